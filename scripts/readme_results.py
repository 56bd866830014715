"""Rewrite the result tables of the README and docs/*.md from ``docs/results/*.json``; ``--check`` fails
on drift.

A block in README.md looks like::

    <!-- results:table1_default:table1 -->
    ...generated, never edited by hand...
    <!-- /results -->

``NAME`` is a file ``docs/results/NAME.json`` (written by ``scripts/make_results.py``
or a benchmark) and ``VIEW`` says how to render it. ``--check`` exits 1, naming
the first block that differs, when the README and the JSON disagree; the test
suite runs it.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.app.efficiency import reaches  # noqa: E402
from msd_bench.app.rig_cost import ACCOUNTING, ACCOUNTING_TEXT  # noqa: E402
from msd_bench.core.evaluation.risk_table import RISK_HEADERS, RISK_NOTE, compact, summary_of  # noqa: E402
from msd_bench.core.evaluation.stats import wilson  # noqa: E402

BLOCK = re.compile(r"(<!-- results:(?P<name>[\w.-]+):(?P<view>[\w-]+) -->\n)(?P<body>.*?)(<!-- /results -->)",
                   re.DOTALL)


def _pct(v: float | None, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def _rate(k: int, n: int) -> str:
    lo, hi = wilson(k, n)
    return f"{k}/{n} ({100 * k / n:.0f} %; {100 * lo:.0f}–{100 * hi:.0f} %)"


def _source(doc: dict[str, Any], name: str) -> str:
    m = doc.get("machine", {})
    return (f"_Generated from `docs/results/{name}.json`: `{doc['command']}` at commit "
            f"`{str(doc['commit'])[:10]}` on {m.get('cpu', '?')} ({m.get('cores', '?')} cores)"
            + (f", {doc['seconds']} s._" if "seconds" in doc else "._"))


def view_table1(doc: dict[str, Any], name: str) -> str:
    """Table 1 over seeds: fit, identification samples, success with its interval, median SSE."""
    lines = ["| Agent | Fit sim (%) | Id. samples | Real plant steps in training (all seeds) | Success "
             "| SSE median (%) | " + " | ".join(RISK_HEADERS) + " |",
             "|---|---|---|---|---|---|" + "---|" * len(RISK_HEADERS)]
    for a in doc["table1"]["agents"]:
        lines.append(
            f"| {a['label']} | {_pct(a['fit_sim_percent'])} | {a['identification_samples'] or '—'} | "
            f"{a['real_interactions'] or 0:,} | {_rate(a['n_success'], a['n'])} | "
            f"{_pct(a['summary']['sse']['median'])} | " + " | ".join(compact(a.get("risk"))) + " |")
    note = "Success cells: successes/n (rate; Wilson 95 % interval). " + RISK_NOTE
    return "\n".join([*lines, "", note, "", _source(doc, name)]) + "\n"


def view_robustness(doc: dict[str, Any], name: str) -> str:
    """Each agent kind's fixed tables under every scenario: successes/n with the interval (transposed:
    a row per scenario, a column per agent kind, so thirteen scenarios stay readable)."""
    rob = doc["robustness"]
    kinds = [a["kind"] for a in rob["agents"]]
    cells = {a["kind"]: a["cells"] for a in rob["agents"]}
    lines = ["| scenario | " + " | ".join(f"`{k}`" for k in kinds) + " |", "|" + "---|" * (len(kinds) + 1)]
    for sid in rob["scenarios"]:
        row = []
        for k in kinds:
            c = cells[k][sid]
            lo, hi = wilson(c["n_success"], c["n"])
            row.append(f"{c['n_success']}/{c['n']} ({100 * lo:.0f}–{100 * hi:.0f}){_risk_suffix(c)}")
        lines.append(f"| `{sid}` | " + " | ".join(row) + " |")
    note = ("Cells: successes/n (Wilson 95 % interval, %), then, where the runs touched a hard stop or were "
            "aborted, how often (the full risk record of each cell is in the JSON). Columns are agent kinds "
            "(labels in Table 1 above).")
    return "\n".join([*lines, "", note, "", _source(doc, name)]) + "\n"


def _risk_suffix(cell: dict[str, Any]) -> str:
    """`` · N contacts (k runs)`` and `` · m aborted`` for a robustness cell whose runs did so; ''
    for a clean cell and for one written before risk was recorded."""
    risk = summary_of(cell)
    if risk is None:
        return ""
    aborts = sum(int(v) for v in risk.get("aborts", {}).values() if isinstance(v, int))
    said = f" · {risk['contacts']} contacts ({risk['runs_with_contact']} runs)" if risk["contacts"] else ""
    return said + (f" · {aborts} aborted" if aborts else "")


def view_efficiency(doc: dict[str, Any], name: str) -> str:
    """Per method: success with its interval at each real-sample budget, and where it reaches the
    on-plant learner's final rate."""
    methods = doc["efficiency"]["methods"]
    lines = ["| method | points: real samples → successes/n (Wilson 95 %) |", "|---|---|"]
    for m in methods:
        pts = sorted(m["points"], key=lambda p: p["real_samples"])
        text = "; ".join(f"{p['real_samples']:,} → {p['n_success']}/{p['n']} "
                         f"({100 * p['ci95'][0]:.0f}–{100 * p['ci95'][1]:.0f} %)" for p in pts)
        lines.append(f"| {m['label']} | {text} |")
    refs = [m for m in methods if m["name"] in ("plant", "plant+improved")]
    notes = []
    for ref in refs:
        final = max(ref["points"], key=lambda p: p["real_samples"])
        rate = final["n_success"] / final["n"]
        reached = []
        for m in methods:
            at = reaches(m["points"], rate)
            where = f"{at:,}" if at is not None else "not in the sweep"
            reached.append(f"{m['label']}: {where}")
        notes.append(f"- {ref['label']} reaches {100 * rate:.0f} % after {final['real_samples']:,} real "
                     f"steps; that rate is first reached by — " + "; ".join(reached) + ".")
    return "\n".join([*lines, "", *notes, "", _source(doc, name)]) + "\n"


def view_rigs_efficiency(doc: dict[str, Any], name: str) -> str:
    """The curve on rigs: per route and record length, the real samples a rig owner spent (mean over
    the rigs, and their range) and the success pooled over (rig, seed) runs with both intervals; then
    the fewest real samples at which a route first reaches 90 % and 95 %."""
    eff = doc["efficiency"]
    lines = ["| route | record samples | real samples per rig (mean; range) | successes/n (rate) | "
             "bootstrap over rigs 95 % | Wilson 95 % | identification failed on |",
             "|---|---|---|---|---|---|---|"]
    for m in eff["methods"]:
        for p in sorted(m["points"], key=lambda p: p["real_samples"]):
            lo, hi = p["real_samples_range"]
            failed = len(p["identification_failed_rigs"])
            n = p["record_samples"]
            spent = f"{n:,}" if n is not None else f"— ({p['episodes']} episodes)"
            lines.append(
                f"| {m['label']} | {spent} | {p['real_samples']:,} ({lo:,}–{hi:,}) | "
                f"{p['n_success']}/{p['n']} ({100 * p['n_success'] / p['n']:.0f} %) | "
                f"{100 * p['bootstrap95'][0]:.0f}–{100 * p['bootstrap95'][1]:.0f} % | "
                f"{100 * p['wilson95'][0]:.0f}–{100 * p['wilson95'][1]:.0f} % | "
                f"{f'{failed} rigs' if failed else '—'} |")
    notes = []
    for rate in (0.90, 0.95):
        firsts = [(at, m["label"]) for m in eff["methods"] if (at := reaches(m["points"], rate)) is not None]
        said = (f"first reached by {min(firsts)[1]} at {min(firsts)[0]:,} real samples per rig" if firsts
                else "reached by no route of the sweep")
        notes.append(f"- {100 * rate:.0f} % success: {said}.")
    rigs = eff["rigs_run"]
    head = (f"{len(rigs)} {eff['rig_set']} rigs ({rigs[0]}–{rigs[-1]}) of the {eff['family']} family × "
            f"{len(eff['learning_seeds'])} learning seeds; success judged on the {eff['judged_on']}.")
    return "\n".join([head, "", *lines, "", *notes, "", _efficiency_bill(eff), "",
                      _source(doc, name)]) + "\n"


def _efficiency_bill(eff: dict[str, Any]) -> str:
    """What the curve's real samples count, as the JSON names it (an older JSON names none)."""
    if eff.get("accounting") == ACCOUNTING:
        return f"Real samples per rig: {ACCOUNTING_TEXT}."
    return ("Real samples per rig: this JSON predates the one bill of docs/rigs.md (it names none); its "
            "open-loop routes were charged as that bill charges them (their records, settle segments and "
            "the rests before each), a refined route its tries and fresh run without their rests.")


def view_json(doc: dict[str, Any], name: str) -> str:
    """A benchmark's own ``table`` rows (a list of flat objects) as a Markdown table."""
    rows = doc["table"]
    cols = list(rows[0])
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_cell(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def view_fits(doc: dict[str, Any], name: str) -> str:
    """Every model's simulation fit per identification seed: against the truth and the measured record."""
    lines = ["| model | id. seed | sim fit vs truth (%) | sim fit vs measured (%) | one-step (%) |",
             "|---|---|---|---|---|"]
    for a in doc["table1"]["agents"]:
        for e in a["fit_by_id_seed"]:
            truth = e.get("fit_sim_truth_percent")
            lines.append(f"| {a['surrogate']} | {e['id_seed']} | {_pct(truth, 2)} | "
                         f"{_pct(e['fit_sim_percent'], 2)} | {_pct(e['fit_one_step_percent'], 2)} |")
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def view_stoploop(doc: dict[str, Any], name: str) -> str:
    """One line: how many stops of a node at random moments exited 0."""
    return (f"{doc['clean']} of {doc['runs']} SIG{doc['signal']} stops of the plant at random moments "
            f"(start-up included) exited 0 — `{doc['command']}` at commit `{doc['commit']}` on "
            f"{doc['machine']} (`docs/results/{name}.json`).\n")


def view_peers(doc: dict[str, Any], name: str) -> str:
    """Identification methods side by side: simulation fit against the truth, clean and noisy."""
    rows = doc["summary"]
    noises = list(dict.fromkeys(r["noise_std"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    by = {(r["method"], r["noise_std"]): r for r in rows}
    head = [f"sim fit vs truth, σ = {1000 * n:g} mm (mean; min)" for n in noises]
    lines = ["| method | " + " | ".join(head) + " | one-step fit (clean) | fit time (s) |",
             "|" + "---|" * (len(noises) + 3)]
    for m in methods:
        cells = []
        for n in noises:
            r = by.get((m, n))
            if r is None or r["sim_fit_truth_mean"] is None:
                cells.append("diverged")
            else:
                extra = f", {r['diverged']} diverged" if r["diverged"] else ""
                cells.append(f"{r['sim_fit_truth_mean']:.2f}; {r['sim_fit_truth_min']:.2f}{extra}")
        clean = by.get((m, noises[0]))
        one = f"{clean['one_step_fit_mean']:.2f}" if clean else "—"
        secs = f"{clean['fit_seconds_mean']:.2f}" if clean else "—"
        lines.append(f"| {m} | " + " | ".join(cells) + f" | {one} | {secs} |")
    naive = [r for r in doc.get("naive_one_step", []) if r.get("noise_std") == 0.0]
    note = ""
    if naive:
        last = [r["last_sample"] for r in naive]
        const = [r["constant_velocity"] for r in naive]
        note = (f"One-step fit of predictors that know nothing of the plant, on the same clean validation "
                f"records ({len(naive)} identification seeds): repeat the last sample {min(last):.2f}–"
                f"{max(last):.2f} %, constant velocity {min(const):.2f}–{max(const):.2f} %. One-step fit "
                f"is no measure of quality here; the simulation fit is.")
    m = doc.get("machine", {})
    src = (f"_Generated from `docs/results/{name}.json`: `{doc.get('command', '?')}` at commit "
           f"`{str(doc.get('git_commit', '?'))[:10]}` on {m.get('processor', '?')} "
           f"({m.get('cpus', '?')} cores)._")
    return "\n".join([*lines, "", note, "", src]) + "\n"


PERFORMANCE_FLOORS: tuple[tuple[str, str, str | None, float | None, str], ...] = (
    ("bench_bench", "seconds", "<=", 90.0, "`bench.py` default run, seconds"),
    ("bench_bench", "bench_over_inprocess", "<=", 4.0, "`bench.py` over the same kinds in-process"),
    ("bench_bench", "round_trip_bound_s", None, None,
     "`bench.py`'s closed-loop round trips (validation runs; Dyna-Q's real steps if asked for) at bare "
     "ping-pong speed, seconds"),
    ("bench_lockstep", "lockstep_over_pingpong", ">=", 0.8, "lock-step steps over bare rclpy ping-pong"),
    ("bench_lockstep", "via_ros_over_pingpong", ">=", 0.7, "`--via-ros` training steps over ping-pong"),
    ("bench_lockstep", "lockstep_over_pingpong_events", None, None,
     "lock-step steps over a ping-pong on the events executor (the executor our nodes use)"),
    ("bench_training", "over_minimal_loop", "<=", 1.5, "paper-sized Q-learning over a minimal compiled loop"),
    ("bench_training", "speedup_vs_python", None, None, "paper-sized Q-learning, speed-up over plain Python"),
    ("bench_training", "batch64_agent_steps_per_s", ">=", 1e7, "batched training, agent-steps/s"),
    ("bench_plant_rate", "plant_rate_error_percent_worst", "<=", 0.1, "real-time plant mean-rate error, %"),
    ("bench_plant_rate", "p99_over_bare_timer_quiet", "<=", 1.1,
     "plant p99 inter-arrival over a bare timer, quiet"),
    ("bench_plant_rate", "p99_over_bare_timer_loaded", "<=", 1.1,
     "plant p99 inter-arrival over a bare timer, loaded"),
)
"""Issue-10 floors: (benchmark, JSON key, comparison, floor, what it is); ``None`` = reported only."""


def _holds(value: float, op: str | None, floor: float | None) -> str:
    if op is None or floor is None:
        return "—"
    ok = value <= floor if op == "<=" else value >= floor
    return "yes" if ok else "**no**"


def view_performance(doc: dict[str, Any], name: str) -> str:
    """Every speed floor beside the figure its benchmark measured (ratios to same-run baselines)."""
    lines = ["| figure | measured | floor | holds |", "|---|---|---|---|"]
    for bench, key, op, floor, what in PERFORMANCE_FLOORS:
        value = doc["benchmarks"].get(bench, {}).get(key)
        if value is None:
            lines.append(f"| {what} | not measured | {op or ''} {_cell(floor)} | {'**no**' if op else '—'} |")
            continue
        shown = f"{value:,.0f}" if abs(value) >= 1000 else _cell(float(value))
        limit = "—" if floor is None else (f"{op} {floor:,.0f}" if floor >= 1000 else f"{op} {floor:g}")
        lines.append(f"| {what} | {shown} | {limit} | {_holds(float(value), op, floor)} |")
    m = doc.get("machine", {})
    commands = "; ".join(f"`{c}`" for c in doc["commands"])
    src = (f"_Generated from `docs/results/{name}.json`: {commands} at commit "
           f"`{str(doc.get('commit', '?'))[:10]}` on {m.get('cpu', '?')} ({m.get('cores', '?')} cores), "
           f"1-minute load average {doc.get('loadavg_1min_before', '?')} at the start._")
    return "\n".join([*lines, "", src]) + "\n"


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.2f}"
    return "—" if v is None else str(v)


ROBUST_FLOORS: dict[int, dict[str, int]] = {
    192: {"nominal": 180, "noise=0.005": 173, "delay=1": 173},
    20: {"nominal": 17, "noise=0.005": 16, "delay=1": 16},
}
"""Issue 7's floors for the robust agent on the PLM and the improved NLARX, by runs per cell: 3
identification seeds x 64 learning seeds (the held-out table), 20 seeds (the check run)."""
FLOOR_SURROGATES = ("plm", "nlarx-improved")


def _yes(holds: bool) -> str:
    return "yes" if holds else "**no**"


def _robust_floor_rows(cells: dict[str, dict[str, Any]], base: dict[str, dict[str, Any]] | None,
                       kind: str) -> list[str]:
    """One row per scenario: a count floor where the issue sets one, else the interval rule against
    the improved agent (the robust interval overlaps the improved one or lies above it)."""
    rows = []
    for sid, c in cells.items():
        k, n = c["n_success"], c["n"]
        floor = ROBUST_FLOORS.get(n, {}).get(sid)
        if floor is not None:
            rows.append(f"| `{kind}` | `{sid}` | {_rate(k, n)} | ≥ {floor}/{n} | {_yes(k >= floor)} |")
        elif base is not None and sid in base:
            b = base[sid]
            lo_b, hi_b = wilson(b["n_success"], b["n"])
            hi = wilson(k, n)[1]
            rule = f"interval reaches improved's ({100 * lo_b:.0f}–{100 * hi_b:.0f} %)"
            rows.append(f"| `{kind}` | `{sid}` | {_rate(k, n)} | {rule} | {_yes(hi >= lo_b)} |")
    return rows


def view_robust_floors(doc: dict[str, Any], name: str) -> str:
    """The robust agent against every floor of issue 7, on the PLM and the improved NLARX."""
    agents = {a["kind"]: a["cells"] for a in doc["robustness"]["agents"]}
    lines = ["| agent kind | scenario | success | floor | holds |", "|---|---|---|---|---|"]
    for m in FLOOR_SURROGATES:
        if f"{m}+robust" in agents:
            lines += _robust_floor_rows(agents[f"{m}+robust"], agents.get(f"{m}+improved"), f"{m}+robust")
    note = ("Success: successes/n (rate; Wilson 95 % interval). Count floors where set; elsewhere the "
            "robust agent's interval must overlap the improved agent's or lie above it.")
    return "\n".join([*lines, "", note, "", _source(doc, name)]) + "\n"


def _fuzz_runs(doc: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The runs of a fuzz_long document: one run (its own output) or several by file."""
    runs: dict[str, dict[str, Any]] = doc.get("runs", {"all": doc})
    return runs


def view_fuzzlong(doc: dict[str, Any], name: str) -> str:
    """``benchmarks/fuzz_long.py`` counts: per property its random cases and outcome, per run its source."""
    lines = ["| property | random cases | outcome |", "|---|---|---|"]
    sources = []
    for run in _fuzz_runs(doc).values():
        for node, t in run["tests"].items():
            if t["examples"] is not None:
                prop = node.removeprefix("tests/fuzz/")
                lines.append(f"| `{prop}` | {t['examples']:,} | {t['outcome']} |")
        m = run.get("machine", {})
        where = (f" at commit `{str(run['commit'])[:10]}` on {m.get('cpu', '?')} "
                 f"({m.get('cores', '?')} cores), 1-minute load {run.get('loadavg_1min_before', '?')} "
                 "at the start" if "commit" in run else "")
        sources.append(f"`{run['command']}`{where}, {run['wall_seconds']} s")
    total = sum(r["total_examples"] for r in _fuzz_runs(doc).values())
    lines += ["", f"{total:,} random cases in all. _Generated from `docs/results/{name}.json`: "
              + "; ".join(sources) + "._"]
    return "\n".join(lines) + "\n"


def _mm(metres: float) -> str:
    return f"{1000 * metres:.0f} mm"


def _span(values: list[float], fmt: Callable[[float], str]) -> str:
    """``a`` or ``a–b``: a range over identification seeds or cells, one figure when they agree."""
    lo, hi = fmt(min(values)), fmt(max(values))
    return lo if lo == hi else f"{lo.split(' ')[0]}–{hi}"


def _design_rows(doc: dict[str, Any]) -> list[str]:
    """``nominal`` (1 m), the other set-points from the lowest, then the rest in the suite's order."""
    sids: list[str] = doc["scenarios"]
    points = sorted((s for s in sids if s.startswith("setpoint=")), key=lambda s: float(s.split("=")[1]))
    rest = [s for s in sids if s != "nominal" and s not in points]
    return [s for s in sids if s == "nominal"] + points + rest


def _design_successes(doc: dict[str, Any]) -> list[str]:
    """Nominal successes at the six set-points per kind, and every cell that lost a run."""
    cells, kinds = doc["cells"], doc["kinds"]
    points = [s for s in cells if s == "nominal" or s.startswith("setpoint=")]
    per_kind = ", ".join(f"`{k}` {sum(cells[s][k]['n_success'] for s in points)}/"
                         f"{sum(cells[s][k]['n'] for s in points)}" for k in kinds)
    out = [f"- Nominal successes over the {len(points)} set-points, per kind: {per_kind}."]
    lost = [f"`{k}` `{s}` {cells[s][k]['n_success']}/{cells[s][k]['n']}" for s in cells for k in kinds
            if cells[s][k]["n_success"] < cells[s][k]["n"]]
    out.append("- Cells that lost a run: " + "; ".join(lost) + "." if lost else
               "- Every run of every cell succeeds (SSE < 5 %).")
    return out


def _design_mae(doc: dict[str, Any]) -> list[str]:
    """Median MAE at 1 m best first, at ±1.5 m, under the loads and drift; the worst median SSE."""
    cells, kinds = doc["cells"], doc["kinds"]
    ranked = sorted(kinds, key=lambda k: cells["nominal"][k]["median_mae"])
    out = ["- Median MAE at 1 m, lowest first: "
           + ", ".join(f"`{k}` {_mm(cells['nominal'][k]['median_mae'])}" for k in ranked) + "."]
    groups = (("at ±0.5 m", ("setpoint=-0.5", "setpoint=0.5")),
              ("at ±1.5 m", ("setpoint=-1.5", "setpoint=1.5")),
              ("under the loads and the parameter drift",
               tuple(s for s in cells if s.startswith(("disturbance=", "mass=")))))
    for label, sids in groups:
        present = [s for s in sids if s in cells]
        if present:
            out.append(f"- Median MAE {label} ({', '.join(f'`{s}`' for s in present)}): " + ", ".join(
                f"`{k}` {_span([cells[s][k]['median_mae'] for s in present], _mm)}" for k in kinds) + ".")
    worst_sid, worst_kind = max(((s, k) for s in cells for k in kinds),
                                key=lambda sk: cells[sk[0]][sk[1]]["median_sse"])
    out.append(f"- Largest median SSE of any cell: `{worst_kind}` under `{worst_sid}`, "
               f"{cells[worst_sid][worst_kind]['median_sse']:.2f} %.")
    return out


def _finite(per_seed: list[dict[str, Any]], key: str, absent: str) -> str:
    """A range of a PID fact that ``pid.loop_facts`` stores as -1 when it does not exist (an infinite
    gain margin, no -3 dB point below Nyquist): the real values' range and on how many seeds it was
    ``absent``, so a sentinel is never printed as a number."""
    values = [float(d[key]) for d in per_seed]
    real = [v for v in values if v != -1.0]
    if not real:
        return absent
    text = _span(real, lambda v: f"{v:.2f}")
    missing = len(values) - len(real)
    return f"{text} ({absent} on {missing} of {len(values)} seeds)" if missing else text


def _design_facts(doc: dict[str, Any]) -> list[str]:
    """What the constants gave at 1 m, as ranges over the identification seeds."""
    out = []
    for kind, per_seed in doc.get("designs", {}).items():
        def span(key: str, fmt: str, per_seed: list[dict[str, Any]] = per_seed) -> str:
            return _span([float(d[key]) for d in per_seed], lambda v: format(v, fmt))
        first = per_seed[0]
        if first["design"] in ("pid", "pid-continuous"):
            out.append(f"- `{kind}` at 1 m: phase margin {span('phase_margin', '.1f')}° at crossover "
                       f"{span('crossover', '.2f')} rad/s (targets {first['target_phase_margin']:g}°, "
                       f"{first['target_crossover']:g} rad/s), gain margin "
                       f"{_finite(per_seed, 'gain_margin', 'infinite')}, closed-loop bandwidth "
                       f"{_finite(per_seed, 'bandwidth', 'none below Nyquist')} rad/s.")
        elif first["design"] == "lqr":
            radius = span("closed_loop_pole_radius", ".4f")
            out.append(f"- `{kind}` at 1 m: closed-loop pole radius {radius}.")
        elif first["design"] == "mpc":
            blocks = " + ".join(str(b) for b in first["blocks"])
            out.append(f"- `{kind}` at 1 m: {first['plans']} plans per sample over a "
                       f"{first['horizon_s']:g} s horizon (blocks {blocks}, tail {first['tail']}).")
    return out


def view_baselines_design(doc: dict[str, Any], name: str) -> str:
    """``scripts/baselines_check.py --out``: per scenario per kind successes/n and median MAE, then the
    sentences the page draws from them and the designs' tuning facts (evidence for the constants)."""
    kinds, cells = doc["kinds"], doc["cells"]
    lines = ["| scenario | " + " | ".join(f"`{k}`" for k in kinds) + " |", "|" + "---|" * (len(kinds) + 1)]
    for sid in _design_rows(doc):
        row = [f"{cells[sid][k]['n_success']}/{cells[sid][k]['n']}, {_mm(cells[sid][k]['median_mae'])}"
               for k in kinds]
        lines.append(f"| `{sid}` | " + " | ".join(row) + " |")
    seeds = ", ".join(str(s) for s in doc["id_seeds"])
    note = (f"Design identification seeds {seeds} (evidence for the constants; never reported as results), "
            f"{doc['draws']} noise draws per id seed in the noisy cells. Cells: successes/runs, median MAE "
            "over the 30 s run.")
    bullets = [*_design_successes(doc), *_design_mae(doc), *_design_facts(doc)]
    return "\n".join([*lines, "", note, "", *bullets, "", _source(doc, name)]) + "\n"


def _floor_holds(figures: dict[str, float], floor: dict[str, float]) -> str:
    ok = figures["mean_ms"] <= floor["mean_ms"] and figures["p99_ms"] <= floor["p99_ms"]
    return "yes" if ok else "**no**"


def view_bench_mpc(doc: dict[str, Any], name: str) -> str:
    """``benchmarks/bench_mpc.py --out``: per-step time of the MPC's ``act`` in wall-clock and thread CPU,
    each against the floor, with the load the machine carried (wall-clock includes preemption)."""
    floor = doc["floor"]
    lines = [f"| clock | mean (ms) | p50 (ms) | p99 (ms) | max (ms) | within {floor['mean_ms']:g} ms mean / "
             f"{floor['p99_ms']:g} ms p99 |", "|---|---|---|---|---|---|"]
    for label, key in (("wall-clock", "wall"), ("thread CPU", "thread_cpu")):
        f = doc[key]
        lines.append(f"| {label} | {f['mean_ms']:.2f} | {f['p50_ms']:.2f} | {f['p99_ms']:.2f} | "
                     f"{f['max_ms']:.2f} | {_floor_holds(f, floor)} |")
    cores = doc.get("machine", {}).get("cores") or 1
    load = float(doc["load1_at_start"])
    state = ("loaded: other jobs shared the cores, so the wall-clock figures include their preemption"
             if load >= 0.5 * cores else "quiet")
    margin = ", ".join(f"{label} {floor['p99_ms'] / doc[key]['p99_ms']:.1f}×"
                       for label, key in (("wall-clock", "wall"), ("thread CPU", "thread_cpu")))
    note = (f"1-minute load average {load:.2f} on {cores} cores at the start ({state}). p99 under the "
            f"{floor['p99_ms']:g} ms floor by: {margin}. Model `{doc['model']}`, {doc['steps']:,} steps at "
            f"set-points {', '.join(f'{s:g}' for s in doc['setpoints'])} m, blocks "
            f"{' + '.join(str(b) for b in doc['blocks'])}, tail {doc['tail']}, {doc['threads']} numba "
            "thread(s).")
    return "\n".join([*lines, "", note, "", _source(doc, name)]) + "\n"


def view_supervisor_check(doc: dict[str, Any], name: str) -> str:
    """``scripts/supervisor_check.py --out``: per place and adversary, contacts without the supervisor
    beside contacts, exits beyond the margin and peak |x| with it."""
    lim = doc["limits"]
    rows = ["| where | adversary | runs | contacts without | peak \\|x\\| without | contacts with | "
            "exits beyond margin with | peak \\|x\\| with | override share with |",
            "|---|---|---|---|---|---|---|---|---|"]
    places = [("plant", doc["plant"])] + [(f"rig ({rig})", cells) for rig, cells in doc["rig"].items()]
    for where, cells in places:
        for adv, c in cells.items():
            u, s = c["unsupervised"], c["supervised"]
            rows.append(f"| {where} | {adv} | {u['runs']} | {u['contacts']} | {u['peak_x']:.3f} m | "
                        f"{s['contacts']} | {s['exits_beyond_margin']} | {s['peak_x']:.3f} m | "
                        f"{100 * s['override_share']:.1f} % |")
    return ("\n".join(rows) + f"\n\nEnvelope ±{lim['envelope']:.3g} m, margin {lim['margin']:.3g} m, "
            f"stop at ±2.5 m. " + _source(doc, name) + "\n")


def view_supervisor_population(doc: dict[str, Any], name: str) -> str:
    """``supervisor_check.py population --out``: per adversary on the held-out rigs, contacts without
    the supervisor beside contacts, exits beyond the margin and peak |x| with it, and the rigs it
    failed on."""
    rows = ["| adversary | runs | contacts without (runs) | contacts with | exits beyond margin with | "
            "peak \\|x\\| with | override share with | rigs with a contact or exit, with |",
            "|---|---|---|---|---|---|---|---|"]
    for adv, c in doc["adversaries"].items():
        u, s = c["unsupervised"], c["supervised"]
        failed = ", ".join(str(r) for r in s["rigs_with_contact_or_exit"]) or "none"
        rows.append(f"| {adv} | {u['runs']} | {u['contacts']} ({u['runs_with_contact']}) | {s['contacts']} | "
                    f"{s['exits_beyond_margin']} | {s['peak_x']:.3f} m | {100 * s['override_share']:.1f} % | "
                    f"{failed} |")
    seeds, lim, mass = doc["rig_seeds"], doc["limits"], doc["population"]["mass_range"]
    note = (f"Held-out rigs {seeds[0]}–{seeds[-1]} ({len(seeds)} rigs, masses "
            f"{mass[0]:.2f}–{mass[1]:.2f} kg, each with its own imperfections); the random adversary over "
            f"{doc['random_seeds']} seeds spread over them. The supervisor is told the nominal plant only: "
            f"envelope ±{lim['envelope']:.3g} m, margin {lim['margin']:.3g} m, stop at ±2.5 m.")
    return "\n".join([*rows, "", note, "", _source(doc, name)]) + "\n"


def view_supervisor_good_kinds(doc: dict[str, Any], name: str) -> str:
    """``supervisor_check.py good-kinds --out``: per good kind, Table 1's nominal runs and every
    scenario of the robustness suite with the supervisor off and on (paired), the runs lost, and
    the good nominal runs it overrode."""
    rows = ["| kind | nominal: off → on | lost | good nominal runs overridden | all scenarios: off → on | "
            "lost | good runs overridden | contacts off → on |",
            "|---|---|---|---|---|---|---|---|"]
    for kind in doc["kinds"]:
        t, n = doc["totals"][kind]["all_scenarios"], doc["totals"][kind]["nominal"]
        contacts = [sum((c[side] or {}).get("contacts", 0) for c in doc["cells"][kind].values())
                    for side in ("risk_off", "risk_on")]
        rows.append(f"| {kind} | {n['success_off']}/{n['n']} → {n['success_on']}/{n['n']} | {n['lost']} | "
                    f"{n['good_runs_overridden']}/{n['good_runs']} | {t['success_off']}/{t['n']} → "
                    f"{t['success_on']}/{t['n']} | {t['lost']} | "
                    f"{t['good_runs_overridden']}/{t['good_runs']} | {contacts[0]} → {contacts[1]} |")
    run = doc["run"]
    note = (f"{run['seeds']} learning seeds × {run['id_seeds']} identification seeds "
            f"({run['preset']} preset, {run['validation_steps']} steps); a deterministic baseline has one "
            f"nominal run per identified model. Lost: a run that succeeds with the supervisor off and fails "
            f"with it on, same seed and noise. Scenarios: {len(doc['scenarios'])} (the robustness suite, "
            f"nominal included).")
    return "\n".join([*rows, "", note, "", _source(doc, name)]) + "\n"


def _sweep_hours(per_rig: float, rigs: int, machines: int, speedup: float) -> str:
    """Time for ``rigs`` rigs on ``machines`` 2-core machines at the measured 2-worker speed-up."""
    seconds = rigs * per_rig / (machines * speedup)
    return f"{seconds / 3600:.1f} h" if seconds >= 3600 else f"{seconds / 60:.0f} min"


def view_bench_executor(doc: dict[str, Any], name: str) -> str:
    """``benchmarks/bench_executor.py --out``: 1 vs 2 workers of a local Ray cluster, the cost of one
    task by stage, and what 1,000 rigs x 16 seeds would take on N such machines."""
    one, two = doc["runs"]
    lines = [_source(doc, name), "", "| workers | tasks (one per rig, then the report) | wall time | "
             "1-min load at start |",
             "|---|---|---|---|"]
    lines += [f"| {r['workers']} | {r['tasks']} | {r['seconds']:.0f} s | {r['load1_at_start']:.2f} |"
              for r in (one, two)]
    holds = "holds" if doc["within_floor"] else "does not hold"
    lines += ["", f"Speed-up on 2 workers: **{doc['speedup']:.2f}x** (floor {doc['floor']}x: {holds}); "
              f"same result on both: {'yes' if doc['same_result'] else 'NO'}."]
    task = doc.get("per_task")
    if task:
        med = task["median_seconds"]
        k, s = task["kinds"], task["learning_seeds"]
        per_rig = med["play"] + med["identify"] + 16 / s * (med["train"] + med["validate"])
        lines += ["", f"One task (one rig, {k} kinds x {s} learning seed(s)), median on 1 worker: "
                  f"playing the plan {med['play']:.2f} s, identification {med['identify']:.2f} s, training "
                  f"{med['train']:.2f} s, validation {med['validate']:.2f} s ({med['total']:.2f} s in all).",
                  "", f"At 16 learning seeds the training and validation grow 16/{s}-fold and the rest "
                  f"stays: about {per_rig:.1f} s per rig for the same {k} kinds. 1,000 rigs x 16 seeds "
                  f"on N machines of 2 workers at the measured speed-up take 1,000 x {per_rig:.1f} s / "
                  f"(N x {doc['speedup']:.2f}):", "", "| machines | time |", "|---|---|"]
        lines += [f"| {n} | {_sweep_hours(per_rig, 1000, n, doc['speedup'])} |" for n in (1, 4, 16, 64)]
    return "\n".join(lines) + "\n"


def view_bench_time(doc: dict[str, Any], name: str) -> str:
    """How long ``make bench`` takes, one sentence from the performance benchmark's bench.py run."""
    b = doc["benchmarks"]["bench_bench"]
    stages = ", ".join(f"{k} {v:.0f} s" for k, v in b["stage_seconds"].items())
    m = doc.get("machine", {})
    return (f"After setup, `make bench` takes about **{b['seconds']:.0f} s** on {m.get('cores', '?')} cores "
            f"({stages}; `benchmarks/bench_bench.py`, commit `{str(doc['commit'])[:10]}`, "
            f"`docs/results/{name}.json`).\n")


def view_headline(doc: dict[str, Any], name: str) -> str:
    """The README's headline: per surrogate, the paper agent's and the robust agent's successes."""
    rows = {a["kind"]: a for a in doc["table1"]["agents"]}
    lines = ["| Surrogate | Fit sim (%) | paper agent | robust agent |", "|---|---|---|---|"]
    for kind, a in rows.items():
        if a["agent"] == "paper" and f"{kind}+robust" in rows:
            r = rows[f"{kind}+robust"]
            lines.append(f"| {a['label'].split(' (')[0]} | {_pct(a['fit_sim_percent'])} | "
                         f"{_rate(a['n_success'], a['n'])} | {_rate(r['n_success'], r['n'])} |")
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def _trim_row(line: str, keep: list[int]) -> str:
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    return "| " + " | ".join(cells[k] for k in keep) + " |"


def view_bench_sample(doc: dict[str, Any], name: str) -> str:
    """What one ``make bench`` printed, trimmed (its fits, Table 1's first rows and columns that matter
    most, where the report is, the stage seconds; progress bars left out) and the files it wrote."""
    printed = [ln.strip() for ln in doc["printed"] if "%|" not in ln and ln.strip()]
    said = [ln for ln in printed if ln.startswith("[bench]")]
    start = next(i for i, ln in enumerate(printed) if ln.startswith("Table 1"))
    end = next((i for i, ln in enumerate(printed) if ln.startswith("Robustness")), len(printed))
    table = [ln for ln in printed[start:end] if ln.startswith("| ")]  # the header, then one row per kind
    head = [c.strip() for c in table[0].strip().strip("|").split("|")]
    keep = [head.index(c) for c in ("Agent", "Fit sim (%)", "SSE (%)", "Success")]
    rows = [_trim_row(ln, keep) for ln in table[:4]]
    fits = [ln for ln in said if ": fit " in ln]
    tail = [ln for ln in said if "report:" in ln or "stage seconds" in ln]
    files = doc["written"]
    tree = [f"{top}/  {len(files[top])} files, e.g. {files[top][0].split('/', 1)[1]}"
            for top in ("excitation", "models", "agents") if files.get(top)]
    tree.append("report/  " + ", ".join(sorted({f.split("/")[1] for f in files.get("report", [])})))
    tree.append(", ".join(files.get(".", [])))
    body = ["```", said[0], *fits, rows[0], "|---|---|---|---|", *rows[1:],
            f"  ... ({len(table) - 1} rows, {len(head)} columns; then the robustness table)", *tail,
            "# written under bags/<run-id>/:", *tree, "```"]
    return "\n".join([*body, "", f"_Generated from `docs/results/{name}.json`: `{doc['command']}` at commit "
                                 f"`{str(doc['commit'])[:10]}` (1-minute load {doc['loadavg_1min_before']} "
                                 f"at the start), {doc['seconds']} s._"]) + "\n"


def view_deeprl(doc: dict[str, Any], name: str) -> str:
    """Deep-RL baselines in Table 1's columns, one row per kind and budget (``deeprl_runs.py table``)."""
    lines = ["| Agent (baseline) | Budget (env. steps per seed) | Learning seeds | Fit sim (%) | Id. samples "
             "| Real plant steps in training (all seeds) | Success | SSE median (%) |",
             "|---|---|---|---|---|---|---|---|"]
    recomputed = over = False
    for r in doc["rows"]:
        mark = "*" if r["fit_from"] == "recomputed" and r["fit_sim_percent"] is not None else ""
        recomputed = recomputed or bool(mark)
        taken = r.get("real_taken", r["real_interactions"])
        dagger = f" (charged {r['real_interactions']:,}) †" if taken != r["real_interactions"] else ""
        over = over or bool(dagger)
        lines.append(
            f"| {r['label']} | {r['steps_per_seed']:,} | {', '.join(str(s) for s in r['seeds'])} | "
            f"{_pct(r['fit_sim_percent'])}{mark} | {r['identification_samples'] or '—'} | "
            f"{taken:,}{dagger} | {_rate(r['n_success'], r['n'])} | {_pct(r['median_sse'])} |")
    notes = ["Baselines, not learners of the paper: Stable-Baselines3 DQN/PPO through `MsdBench-v0`, "
             "hyper-parameters chosen on design seeds (docs/deeprl.md). Success: the nominal unit step on "
             "the true plant, successes/n (rate; Wilson 95 % interval); n is the number of learning seeds, "
             "so a single seed is a data point, not a distribution."]
    if recomputed:
        notes.append("\\* fit of the same identification (same id. seed), recomputed by "
                     "`deeprl_runs.py table` for a run written before runs recorded it.")
    if over:
        notes.append("† run written before training stopped at its budget: SB3 finished its last rollout "
                     "(PPO: 2,048 steps) past it, so the plant gave more steps than the run charged.")
    return "\n".join([*lines, "", *"\n\n".join(notes).split("\n"), "", _source(doc, name)]) + "\n"


def view_deeprl_efficiency(doc: dict[str, Any], name: str) -> str:
    """The on-plant deep-RL runs as points of the efficiency curve, seeds stated (their own documents)."""
    lines = ["| method (learning seeds) | points: real samples per agent → successes/n (Wilson 95 %) |",
             "|---|---|"]
    for m in doc["efficiency_methods"]:
        pts = sorted(m["points"], key=lambda p: p["real_samples"])
        text = "; ".join(f"{p['real_samples']:,} → {p['n_success']}/{p['n']} "
                         f"({100 * p['ci95'][0]:.0f}–{100 * p['ci95'][1]:.0f} %)" for p in pts)
        lines.append(f"| {m['label']} | {text} |")
    fig = doc.get("figure")
    where = (f"Drawn over the curves of `{Path(fig['curves_from']).name}` in `{Path(fig['path']).name}`."
             if fig else "")
    return "\n".join([*lines, "", where, "", _source(doc, name)]) + "\n"
def _rt_fits(side: dict[str, Any]) -> str:
    if not side.get("completed"):
        return f"failed: {side.get('error', '?')}"
    return ", ".join(f"{k} {_pct(v)}" for k, v in sorted(side["fits"].items())) or "—"


def _rt_kind(side: dict[str, Any], kind: str) -> str:
    cell = side.get("kinds", {}).get(kind) if side.get("completed") else None
    return "—" if not cell or not cell["n"] else _rate(cell["n_success"], cell["n"])


def view_rig_realtime(doc: dict[str, Any], name: str) -> str:
    """The real-time subset: per held-out rig, fits on the measured record and nominal successes (judged
    on the measured position) in real time through bench.py and in-process through msd-bench rigs."""
    lines = [_source(doc, name) + f" One-minute load at the start: {doc.get('load_at_start', '?')}.", "",
             f"Size of both runs: `{' '.join(doc['size'])}`.", "",
             "| rig | kind | successes, real time | successes, in-process | supervisor (real time) |",
             "|---|---|---|---|---|"]
    for r in doc["rigs"]:
        rt, ip = r["real_time"], r["in_process"]
        sup = rt.get("supervisor") if rt.get("completed") else None
        shown = "—" if sup is None else ("on" if (sup.get("on") if isinstance(sup, dict) else sup) else "off")
        lines += [f"| {r['rig']} | {k} | {_rt_kind(rt, k)} | {_rt_kind(ip, k)} | {shown} |"
                  for k in doc["agents"]]
    lines += ["", "| rig | parameters | fits, real time (%) | fits, in-process (%) |", "|---|---|---|---|"]
    for r in doc["rigs"]:
        line = r["line"].split(": ", 1)[-1]
        lines.append(f"| {r['rig']} | {line} | {_rt_fits(r['real_time'])} | {_rt_fits(r['in_process'])} |")
    if any("drive_measured" in r["real_time"] for r in doc["rigs"]):
        lines += ["", "| rig | drive measured, real time | told the robust agents, real time | "
                  "drive measured and told, in-process |", "|---|---|---|---|"]
        for r in doc["rigs"]:
            rt, ip = r["real_time"], r["in_process"]
            lines.append(f"| {r['rig']} | {_rt_drive(rt.get('drive_measured'))} | "
                         f"{_rt_told(rt.get('drive_told'))} | {_rt_drive(ip.get('drive'))} |")
    return "\n".join(lines) + "\n"


def _rt_drive(drive: Any) -> str:
    """A measured drive as ``delay 2, lag 31 ms`` (— when the run showed none)."""
    if not isinstance(drive, dict):
        return "—"
    told = drive.get("told_robust_agent")
    extra = f" (told: delay {told})" if told is not None else ""
    return f"delay {drive['delay_samples']}, lag {1000 * drive['lag_s']:.0f} ms{extra}"


def _rt_told(told: Any) -> str:
    """What each robust agent's result.json says its design was told."""
    if not isinstance(told, dict):
        return "—"
    cells = [f"{k}: delay {d['delay_samples']}" for k, d in sorted(told.items())
             if k.endswith("+robust") and isinstance(d, dict)]
    return "; ".join(cells) or "nothing"


def view_greybox_rig_floors(doc: dict[str, Any], name: str) -> str:
    """The greybox-rig held-out check against issue 21's floors, and the rigs that miss."""
    sm, rigs = doc["summary"], doc["rigs"]
    n = sm["rigs"]
    fits = sorted(r["fit_truth"] for r in rigs)
    ge99 = sum(f >= 99.0 for f in fits)
    lag_errs = [abs(r["tau_error"]) / r["tau_true"] for r in rigs
                if r.get("delay_exact") and r["tau_true"] >= 0.004 and r.get("tau_error") is not None]
    fric = sorted(abs(r["friction_error"]) for r in rigs if r.get("friction_error") is not None)

    def met(ok: bool) -> str:
        return "**met**" if ok else "**not met**"

    lines = ["| floor | result |", "|---|---|",
             f"| fit ≥ 99 % on ≥ 98 % of rigs | {met(ge99 >= 0.98 * n)}: {ge99} of {n}, median "
             f"{sm['fit_median']:.2f} % |",
             f"| fit ≥ 97 % on all | {met(sm['fit_min'] >= 97.0)}: minimum {sm['fit_min']:.2f} % |",
             f"| delay exact on ≥ 98 % | {met(sm['delay_exact'] >= 0.98 * n)}: {sm['delay_exact']} of {n} |",
             f"| lag within 25 % on ≥ 98 % | {met(sm['lag_ok'] >= 0.98 * n)}: {sm['lag_ok']} of {n}"
             + (f"; where the delay is right and the true lag is ≥ 4 ms, the largest lag error is "
                f"{100 * max(lag_errs):.1f} %" if lag_errs else "") + " |",
             f"| friction (no floor) | largest error {1000 * fric[-1]:.1f} mN, median "
             f"{1000 * fric[len(fric) // 2]:.2f} mN |" if fric else "| friction (no floor) | — |",
             "", "| rig | delay found/true | lag found/true (ms) | fit (%) | friction (N) | noise (mm) |",
             "|---|---|---|---|---|---|"]
    for f in sm["failures"]:
        imp = f["imperfections"]
        lines.append(f"| {f['rig']} | {f['delay']:.0f}/{f['delay_true']:.0f} | {1000 * f['tau']:.1f}/"
                     f"{1000 * f['tau_true']:.1f} | {f['fit_truth']:.2f} | {imp['friction']:.3f} | "
                     f"{1000 * imp['sensor_noise']:.2f} |")
    if not sm["failures"]:
        lines.append("| — | | | | | |")
    lines += ["", f"_Generated from `docs/results/{name}.json`: `{doc['command']}` ({doc['role']} rigs)._"]
    return "\n".join(lines) + "\n"


def _wilson_pct(lo_hi: list[float]) -> str:
    return f"{100 * lo_hi[0]:.0f}–{100 * lo_hi[1]:.0f} %"


def view_rigs_kinds(doc: dict[str, Any], name: str) -> str:
    """A rig sweep's success per kind (Wilson and bootstrap-over-rigs intervals), the models' fit range
    over the rigs and the time per rig, from its rigs.json."""
    lines = ["| kind | successes / runs | rate | Wilson 95 % | bootstrap over rigs 95 % "
             "| on the measured position | " + " | ".join(RISK_HEADERS) + " |",
             "|---|---|---|---|---|---|" + "---|" * len(RISK_HEADERS)]
    for k in doc["kinds"]:
        lines.append(f"| {k['label']} | {k['successes']} / {k['n']} | {100 * k['rate']:.0f} % | "
                     f"{_wilson_pct(k['wilson95'])} | {_wilson_pct(k['bootstrap95'])} | "
                     f"{k['measured_successes']} / {k['n']} | " + " | ".join(compact(summary_of(k))) + " |")
    fits: dict[str, list[float]] = {}
    for r in doc["rigs"]:
        for model, f in r["fits"].items():
            if f.get("fit_sim_percent") is not None:
                fits.setdefault(model, []).append(f["fit_sim_percent"])
    spans = "; ".join(f"{m} {min(v):.1f} to {max(v):.1f} %" for m, v in fits.items())
    failed = sum(len(r["identification_failed"]) for r in doc["rigs"])
    sec = doc["seconds"]
    lines += ["", f"Simulation fit on the rigs' broad validation record, lowest to highest: {spans}; "
                  f"identifications that failed: {failed}. Time per rig (wall): median "
                  f"{sec['per_rig_median']:.0f} s, "
                  f"longest {sec['per_rig_max']:.0f} s; the rigs' times summed {sec['total'] / 60:.0f} min.",
              "", RISK_NOTE + " Risk is of the nominal runs.",
              "", f"_Generated from `docs/results/{name}.json` ({len(doc['rigs'])} rigs × "
                  f"{len(doc['learning_seeds'])} learning seeds)._"]
    return "\n".join(lines) + "\n"


def view_rigs_beside(doc: dict[str, Any], name: str) -> str:
    """``scripts/rigs_baselines.py``: the learned kinds of a held-out sweep (rows copied unchanged) and the
    classical baselines run on the same rigs, each with both intervals and the risk columns."""
    lines = ["| kind | runs | successes / runs | rate | Wilson 95 % | bootstrap over rigs 95 % "
             "| on the measured position | " + " | ".join(RISK_HEADERS) + " |",
             "|---|---|---|---|---|---|---|" + "---|" * len(RISK_HEADERS)]
    for k in doc["kinds"]:
        runs = "per rig and learning seed" if k["sweep"] == "learned" else "one per rig"
        lines.append(f"| {k['label']} | {runs} | {k['successes']} / {k['n']} | {100 * k['rate']:.0f} % | "
                     f"{_wilson_pct(k['wilson95'])} | {_wilson_pct(k['bootstrap95'])} | "
                     f"{k['measured_successes']} / {k['n']} | " + " | ".join(compact(summary_of(k))) + " |")
    sw = doc["sweeps"]
    bl, ln = sw["baselines"], sw["learned"]
    not_run = {k["label"]: k["not_run"] for k in doc["kinds"] if k.get("not_run")}
    rigs = doc["rigs_run"]
    lines += ["", f"{len(rigs)} held-out rigs ({rigs[0]}–{rigs[-1]}). The learned "
                  f"rows are `{ln['file']}`'s, unchanged ({len(ln['learning_seeds'])} learning seeds); the "
                  f"baselines are designed once per rig from the same records (deterministic), "
                  f"{bl['seconds']['total'] / 60:.0f} min of rig time summed. Baseline runs not made: "
                  + (", ".join(f"{k} {v}" for k, v in not_run.items()) or "none")
                  + f" (designs that failed: {bl['design_failed']}, identifications that failed: "
                  f"{bl['identification_failed']}).",
              "", RISK_NOTE + " Risk is of the nominal runs.", "", _source(doc, name)]
    return "\n".join(lines) + "\n"


RIGS_FLOORS = (("the best kind", None, 0.90), ("PLM (robust agent)", "plm+robust", 0.85),
               ("NLARX improved form (robust agent)", "nlarx-improved+robust", 0.85))
"""Issue 21's floors on a held-out sweep: (what, kind or None for the best, least rate)."""
RIGS_WALL_FLOOR_S = 30 * 60
"""Issue 21: the held-out population run within 30 minutes on this machine."""


def view_rigs_floors(doc: dict[str, Any], name: str) -> str:
    """Issue 21's floors read off a held-out sweep's rigs.json: each floor's rate (both intervals) and
    whether it holds, the sweep's wall time, and the rigs on which every run of every kind failed."""
    return _floors_view(doc, name, RIGS_FLOORS, RIGS_WALL_FLOOR_S, learned_only=False)


STAGE_FLOORS = (("the best learned kind", None, 0.85),
                ("NLARX improved form (robust agent)", "nlarx-improved+robust", 0.80))
"""Issue 38's floors on the stage family's held-out sweep: (what, kind or None for the best learned
kind, least rate); a baseline (``+pid``, ``+lqr``, ``+mpc``) is beside them, never the best learned."""


def view_stage_floors(doc: dict[str, Any], name: str) -> str:
    """Issue 38's floors read off the stage family's held-out sweep, its wall time against two hours."""
    return _floors_view(doc, name, STAGE_FLOORS, FAMILY_WALL_FLOOR_S, learned_only=True)


def view_stage_stalls(doc: dict[str, Any], name: str) -> str:
    """How a sweep's nominal runs fail, per kind: the failed runs that never passed the set-point (their
    overshoot 0: they stopped short, as friction holds a mass commanded from a coarse force alphabet)
    and their steady-state error, against those that passed it."""
    lines = ["| kind | failed runs | stopped short (never passed the set-point) | their median SSE | "
             "passed it and failed | rigs with no design (its rule found none) |",
             "|---|---|---|---|---|---|"]
    labels = {k["kind"]: k["label"] for k in doc["kinds"]}
    for kind in doc["agents"]:
        runs = [o for r in doc["rigs"] for o in r["outcomes"] if o["kind"] == kind and o.get("identified")]
        failed = [o for o in runs if not o["success"] and o.get("sse") is not None]
        short = [o for o in failed if o.get("po") == 0.0]
        median = f"{statistics.median(o['sse'] for o in short):.1f} %" if short else "–"
        undesigned = sum(kind in (r.get("design_failed") or {}) for r in doc["rigs"])
        lines.append(f"| {labels.get(kind, kind)} | {len(failed)} of {len(runs)} | {len(short)} | {median} | "
                     f"{len(failed) - len(short)} | {undesigned} |")
    lines += ["", f"_Generated from `docs/results/{name}.json` (the nominal runs of {len(doc['rigs'])} "
                  f"{doc['rig_set']} rigs; a run whose SSE is undefined, as on a rig with no design, is left "
                  "out of the failed runs)._"]
    return "\n".join(lines) + "\n"


def _is_learned(kind: str) -> bool:
    """A learned kind, not a classical baseline: the design registry's own word (an unknown kind is one
    ConfigError line)."""
    from msd_bench.designs.kinds import is_baseline

    return not is_baseline(kind)


def _floors_view(doc: dict[str, Any], name: str, floors: tuple[tuple[str, str | None, float], ...],
                 wall_floor_s: int, learned_only: bool) -> str:
    """Each floor's rate (both intervals) and whether it holds, the sweep's wall time against
    ``wall_floor_s``, and the rigs on which every run of every kind failed."""
    kinds = {k["kind"]: k for k in doc["kinds"]}
    eligible = [k for k in doc["kinds"] if not learned_only or _is_learned(k["kind"])]
    best = max(eligible, key=lambda k: k["rate"])
    lines = ["| floor | kind | rate | Wilson 95 % | bootstrap over rigs 95 % | floor | holds |",
             "|---|---|---|---|---|---|---|"]
    for what, kind, floor in floors:
        k = best if kind is None else kinds.get(kind)
        if k is None:
            lines.append(f"| {what} | not run | | | | {100 * floor:.0f} % | no |")
            continue
        lines.append(f"| {what} | {k['label']} | {100 * k['rate']:.1f} % ({k['successes']}/{k['n']}) | "
                     f"{_wilson_pct(k['wilson95'])} | {_wilson_pct(k['bootstrap95'])} | "
                     f"{100 * floor:.0f} % | {'yes' if k['rate'] >= floor else '**no**'} |")
    sweep = doc.get("sweep")
    if sweep:
        holds = "holds" if sweep["wall_seconds"] <= wall_floor_s else "**does not hold**"
        lines += ["", f"Wall time of the sweep: {sweep['wall_seconds'] / 60:.1f} min for "
                      f"{sweep['rigs_computed']} rigs on {sweep['workers']} {sweep['executor']} workers of a "
                      f"{sweep['cpus']}-core machine (floor {wall_floor_s // 60} min: {holds})."]
    dead = [r["rig"] for r in doc["rigs"] if not any(o["success"] for o in r["outcomes"])]
    lines += ["", f"Rigs on which no run of any kind succeeded: {', '.join(map(str, dead)) or 'none'} "
                  f"({len(dead)} of {len(doc['rigs'])}).",
              "", f"_Generated from `docs/results/{name}.json` ({len(doc['rigs'])} {doc['rig_set']} rigs × "
                  f"{len(doc['learning_seeds'])} learning seeds)._"]
    return "\n".join(lines) + "\n"


FAMILY_WALL_FLOOR_S = 2 * 3600
"""A family's held-out run may take at most two hours on this machine (issue 38)."""


def view_rigs_worst(doc: dict[str, Any], name: str) -> str:
    """A rig sweep's worst rigs (fewest successes over every kind and seed) with every drawn parameter,
    and each rig's units where the family draws them; the sweep's wall time against the family bar."""
    from msd_bench.io.rigs.rigs_report import worst_table

    units = [w for w in doc["worst"] if "length_unit" in w["parameters"]]
    lines = worst_table(doc)
    if units:
        lines += ["", "Their units against their default-family twins (length, mass, time): " + "; ".join(
            f"rig {w['rig']} ×{w['parameters']['length_unit']:.3g}, ×{w['parameters']['mass_unit']:.3g}, "
            f"×{w['parameters']['time_unit']:.3g}" for w in units) + "."]
    sweep = doc.get("sweep")
    if sweep:
        holds = "holds" if sweep["wall_seconds"] <= FAMILY_WALL_FLOOR_S else "**does not hold**"
        on = f"{sweep['workers']} {sweep['executor']} worker(s) of a {sweep['cpus']}-core machine"
        lines += ["", f"Wall time of the sweep: {sweep['wall_seconds'] / 60:.0f} min for "
                      f"{sweep['rigs_computed']} rigs on {on} (a family's bar: "
                      f"{FAMILY_WALL_FLOOR_S // 3600} h; {holds})."]
    family = (doc.get("population") or {}).get("family", "default")
    from msd_bench.io.rigs.rigs_report import OWN_PLANT, columns

    own = [c.key for c in columns(doc)] == list(OWN_PLANT)
    said = ("each rig a plant of its own, in physical units" if own
            else "the multipliers are against the default plant in the rig's own units")
    lines += ["", f"_Generated from `docs/results/{name}.json` ({len(doc['rigs'])} {doc['rig_set']} rigs "
                  f"of the `{family}` family × {len(doc['learning_seeds'])} learning seeds; {said})._"]
    return "\n".join(lines) + "\n"


def view_identification_speed(doc: dict[str, Any], name: str) -> str:
    """``benchmarks/bench_identification_rig.py --out``: every model kind's identification time (one
    thread, median of the repeats) and fit, now and with the earlier numerics in the same run."""
    new, old = doc["new"], doc["old"]
    rows = ["| kind | now (s) | earlier numerics (s) | fit now (%) | fit earlier (%) |",
            "|---|---|---|---|---|"]
    for kind, k in new["kinds"].items():
        o = old["kinds"][kind]
        bias = f" ({k['bias_sim_fit']:.4f} on its bias records)" if "bias_sim_fit" in k else ""
        fit = f"{k['sim_fit']:.4f}{bias}"
        fit_old = f"{o['sim_fit']:.4f}" + (f" ({o['bias_sim_fit']:.4f})" if "bias_sim_fit" in o else "")
        rows.append(f"| {kind} | {k['median_seconds']:.2f} | {o['median_seconds']:.2f} | {fit} | {fit_old} |")
    records = (f"population rig {doc['rig']}" if doc.get("rig") is not None
               else f"the `{doc['preset']}` plant")
    target = doc["target_seconds"]
    met = "met" if new["total_seconds"] <= target else "**not met**"
    rig_met = "met" if doc["rig_kinds_seconds"] <= target else "**not met**"
    rows += ["", f"Records: the paper plan of identification seed {doc['seed']} on {records}; "
             f"{doc['repeats']} repeats, one thread, 1-min load {doc['load_at_start']['1min']:.2f} at start. "
             f"Every kind: {new['total_seconds']:.2f} s now, {old['total_seconds']:.2f} s with the earlier "
             f"numerics (ratio {doc['ratio_old_over_new']:.2f}); the target of {target:g} s is {met}. The "
             f"kinds `msd-bench rigs` identifies ({', '.join(doc['rig_kinds'])}): "
             f"{doc['rig_kinds_seconds']:.2f} s ({rig_met}). One rig end to end (records, every kind "
             f"identified and scored): {doc['per_rig_seconds']:.2f} s.", "", _source(doc, name)]
    return "\n".join(rows) + "\n"


SILVERBOX_SETS = (("multisine", "multisine"), ("arrow_full", "arrow, full"),
                  ("arrow_no_extrapolation", "arrow w/o extrapolation"))


def _mv_cell(v: float | None) -> str:
    return "diverged" if v is None else f"{v:.2f}"


def _resid_cell(r: dict[str, Any] | None) -> str:
    if r is None:
        return "—"
    white = "pass" if r["whiteness_pass"] else f"fail ({r['auto_outside']}/{r['lags']})"
    indep = "pass" if r["independence_pass"] else f"fail ({r['cross_outside']}/{2 * r['lags'] + 1})"
    return f"{white} / {indep}"


def _integrator_note(row: dict[str, Any]) -> str:
    """A grey-box kind's chosen kernel, e.g. ``; rk4 chosen at omega dt 0.70``."""
    choice = row.get("integrator_choice")
    if not isinstance(choice, dict):
        return ""
    return f"; {choice['chosen']} chosen at ω·dt {choice['omega_dt']:.2f}"


def view_silverbox(doc: dict[str, Any], name: str) -> str:
    """``scripts/silverbox.py``: each kind's free-run RMSE (mV) on the three test sets, its held-out
    validation RMSE and fit time, then the published results on the same protocol."""
    sb = doc["benchmarks"]["silverbox"]
    heads = " | ".join(label for _, label in SILVERBOX_SETS)
    lines = [f"| model | {heads} | validation | fit time (s) | resid: white / independent of input |",
             "|---|---|---|---|---|---|---|"]
    for row in sb["kinds"]:
        if row["status"] != "ok":
            lines.append(f"| {row['label']} (`{row['kind']}`) | {row['status']} | | | | | |")
            continue
        cells = " | ".join(_mv_cell(row["rmse_mv"][key]) for key, _ in SILVERBOX_SETS)
        val = _mv_cell(row["validation_rmse_mv"])
        lines.append(f"| {row['label']} (`{row['kind']}`{_integrator_note(row)}) | {cells} | {val} | "
                     f"{row['fit_seconds']:.1f} | {_resid_cell(row.get('resid_multisine'))} |")
    for pub in sb["published"]:
        cells = " | ".join(f"{pub['rmse_mv'][key]:g}" for key, _ in SILVERBOX_SETS)
        lines.append(f"| published: {pub['method']} ({pub['source']}) | {cells} | | | |")
    pro = sb["protocol"]
    note = (f"RMSE in mV, free-run simulation; the first {pro['window']} samples of each set only set the "
            f"initial state. Fitted on {pro['estimation_samples']:,} samples of the training range "
            f"[{pro['train'][0]}, {pro['train'][1]}), its last {pro['validation_samples']:,} held out "
            "(validation column); "
            "no test set chose anything. resid: `msd-bench resid` on the multisine test set (a grey-box's "
            "simulation residuals, an ARX-type model's one-step ones; lags outside the 99 % band).")
    m = doc.get("machine", {})
    src = (f"_Generated from `docs/results/{name}.json`: `{'; '.join(doc['commands'])}` at commit "
           f"`{str(doc.get('commit', '?'))[:10]}` on {m.get('cpu', '?')} ({m.get('cores', '?')} cores)._")
    return "\n".join([*lines, "", note, "", src]) + "\n"


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def view_coverage(doc: dict[str, Any], name: str) -> str:
    """Each test tier's size, wall time and line coverage of the package under coverage.py, then
    the full suite's (the tiers' union) and how far the default tier falls short of it."""
    lines = ["| tier | marker expression | tests (failed, skipped) | wall time under coverage | "
             "line coverage |", "|---|---|---|---|---|"]
    for tier, t in doc["tiers"].items():
        failed = t["failures"] + t["errors"]
        lines.append(f"| {tier} | `{t['marker']}` | {t['tests']} ({failed}, {t['skipped']}) | "
                     f"{_minutes(t['seconds'])} | {t['line_percent']:.1f} % |")
    full, default = doc["full"], doc["tiers"]["default"]["line_percent"]
    missing = doc.get("missing", [])
    union = "every tier" if not missing else "every tier but " + ", ".join(missing) + ": not measured"
    lines.append(f"| **full suite** ({union}) | — | {sum(t['tests'] for t in doc['tiers'].values())} | "
                 f"{_minutes(sum(t['seconds'] for t in doc['tiers'].values()))} | "
                 f"{full['line_percent']:.1f} % |")
    note = (f"Lines of `{doc['package']}`: {full['statements']:,} statements, {full['missed']:,} "
            f"never run by any tier. The default tier covers {default:.1f} %, "
            f"{full['line_percent'] - default:.1f} points below the "
            f"{'full suite' if not missing else 'union of the measured tiers'}. Subprocesses (node "
            "processes, bench.py, the commands) are measured; "
            "numba-compiled loops and processes killed by SIGKILL are not, in either number.")
    return "\n".join([*lines, "", note, "", _source(doc, name)]) + "\n"


def _ceilings(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The ceiling rows of a rigs.json run with ``--ceiling`` (its ``ceiling`` facts name them)."""
    names = [c["kind"] for c in doc.get("ceiling", [])]
    return [k for k in doc["kinds"] if k["kind"] in names]


def _rate_cells(k: dict[str, Any]) -> str:
    return (f"{100 * k['rate']:.1f} % ({k['successes']}/{k['n']}) | {_wilson_pct(k['wilson95'])} | "
            f"{_wilson_pct(k['bootstrap95'])}")


def view_rigs_ceiling(doc: dict[str, Any], name: str) -> str:
    """A ``--ceiling`` sweep: each ceiling row, then every robust kind's open-loop success beside the
    higher ceiling and the gap between them (what refinement has to close)."""
    ceilings = _ceilings(doc)
    top = max(ceilings, key=lambda k: k["rate"])
    lines = ["| row | trained on | rate | Wilson 95 % | bootstrap over rigs 95 % "
             "| gap to the higher ceiling (points) |", "|---|---|---|---|---|---|"]
    for k in ceilings:
        lines.append(f"| {k['label']} | the rig's truth (ceiling) | {_rate_cells(k)} | |")
    for k in doc["kinds"]:
        if k["kind"].endswith("+robust") and k not in ceilings:
            lines.append(f"| {k['label']} | its open-loop records | {_rate_cells(k)} | "
                         f"{100 * (top['rate'] - k['rate']):+.1f} |")
    routes = "; ".join(f"{c['kind']}: {c['model']}" for c in doc["ceiling"])
    rigs = doc["rigs_run"]
    lines += ["", f"The ceilings ({routes}). {len(rigs)} {doc['rig_set']} rigs ({rigs[0]}–{rigs[-1]}) × "
                  f"{len(doc['learning_seeds'])} learning seeds, the open-loop rows from the same sweep.",
              "", f"_Generated from `docs/results/{name}.json`._"]
    return "\n".join(lines) + "\n"


def view_rigs_refine(doc: dict[str, Any], name: str) -> str:
    """A ``--refine`` sweep: per refined kind its open-loop row, the refined row (a fresh validation of
    the kept policy), the ceiling and whether half the gap closed; then per round the tries, their true
    successes, aborts, overridden samples, stop contacts and how often the round was kept."""
    kinds = {k["kind"]: k for k in doc["kinds"]}
    ceilings = _ceilings(doc)
    top = max(ceilings, key=lambda k: k["rate"]) if ceilings else None
    lines = ["| kind | open loop | refined | bootstrap over rigs 95 % (refined) | ceiling | half the gap "
             "closed | real samples per run (median) | stop contacts (refined) |",
             "|---|---|---|---|---|---|---|---|"]
    rounds = ["", "| refined kind | round | tries | true successes | aborts | overridden samples "
                  "| stop contacts | kept |", "|---|---|---|---|---|---|---|---|"]
    for k in doc["kinds"]:
        ref = k.get("refine")
        if ref is None:
            continue
        base = kinds[k["kind"].removesuffix("+refined")]
        half = "—"
        if top is not None:
            need = base["rate"] + (top["rate"] - base["rate"]) / 2
            half = f"{'yes' if k['rate'] >= need else '**no**'} (needs {100 * need:.1f} %)"
        ceiling = f"{100 * top['rate']:.1f} %" if top is not None else "not run"
        contacts = compact(summary_of(k))[0]
        lines.append(f"| {base['label']} | {100 * base['rate']:.1f} % ({base['successes']}/{base['n']}) | "
                     f"{100 * k['rate']:.1f} % ({k['successes']}/{k['n']}) | {_wilson_pct(k['bootstrap95'])} "
                     f"| {ceiling} | {half} | {ref['real_samples_per_run']['median']:,.0f} | {contacts} |")
        for r in ref["rounds"]:
            rounds.append(f"| {base['label']} | {r['round']} | {r['tries']} | {r['successes']} | "
                          f"{r['aborts']} | {r['overridden_samples']} | {r['contacts']} | {r['kept']} |")
    cfg = doc.get("run_config", {})
    rigs = doc["rigs_run"]
    refined = [k for k in doc["kinds"] if "refine" in k]
    if refined and top is not None:
        best = max(refined, key=lambda k: k["rate"])
        floor = min(0.97, top["rate"] - 0.01)
        lines += ["", f"The best refined kind: {best['label']}, {100 * best['rate']:.1f} % "
                      f"(bootstrap {_wilson_pct(best['bootstrap95'])}); its floor, 97 % or the ceiling less "
                      f"one point if lower: {100 * floor:.1f} % — "
                      f"{'holds' if best['rate'] >= floor else '**does not hold**'}."]
    note = (f"{len(rigs)} {doc['rig_set']} rigs ({rigs[0]}–{rigs[-1]}) × {len(doc['learning_seeds'])} "
            f"learning seeds; up to {cfg.get('refine', '?')} rounds, each closed-loop record weighted "
            f"{cfg.get('refine_weight', '?')}. Every try and the fresh run behind the supervisor; the "
            "ceiling is the higher of the sweep's own ceiling rows. Round 0 is the open-loop policy's try; "
            "the true successes of the tries are shown, never read by the choice (the measured record is).")
    lines += [*rounds, "", note, "", _refine_bill(refined),
              "", f"_Generated from `docs/results/{name}.json`._"]
    return "\n".join(lines) + "\n"


def _refine_bill(refined: list[dict[str, Any]]) -> str:
    """What a refined run's real samples count, as the JSON names it (an older JSON names none)."""
    named = {k["refine"]["real_samples_per_run"].get("accounting") for k in refined}
    if named == {ACCOUNTING}:
        return f"Real samples per run: {ACCOUNTING_TEXT}."
    return ("Real samples per run as this JSON counted them, before the one bill of docs/rigs.md "
            "§Refinement: every record of the plan played on the rig (the bias records too), every try "
            "and the fresh run, without the rests before them.")



def _pair_rate(r: dict[str, Any]) -> str:
    lo, hi = r["wilson95"]
    return f"{r['successes']}/{r['n']} ({r['percent']:.0f} %; {lo:.0f}–{hi:.0f} %)"


def _sweep_said(run: dict[str, Any]) -> str:
    return f"`{run['command']}` ({run['wall_seconds'] / 60:.0f} min wall, {run['workers']} worker(s))"


def _reproduces(doc: dict[str, Any]) -> str:
    r = doc.get("twin_reproduces")
    if r is None:
        return ""
    return (f" The default-family sweep against `{r['reference']}`: {r['equal_success']} of {r['runs']} "
            f"successes and {r['equal_sse']} of {r['runs']} SSEs equal.")


def view_family_twins(doc: dict[str, Any], name: str) -> str:
    """``scripts/family_twins.py``: a family's rigs paired with their default-family twins, run by run
    (same rig, kind and learning seed): how many agree, each side's success, the rigs where they part."""
    lines = [f"| kind | runs equal to the twin's | parted: only `{doc['family']}` / only twin succeeds "
             f"| McNemar p | `{doc['family']}` family success | default-family twins' success |",
             "|---|---|---|---|---|---|"]
    for kind, k in doc["kinds"].items():
        lines.append(f"| `{kind}` | {k['equal']} / {k['pairs']} | {k['only_family']} / {k['only_twin']} "
                     f"| {k['mcnemar_p']:.2f} | {_pair_rate(k['family'])} | {_pair_rate(k['twin'])} |")
    rigs, parted, runs = doc["rigs_run"], doc["rigs_parted"], doc["runs"]
    named = ", ".join(str(r) for r in parted[:12]) + (", …" if len(parted) > 12 else "")
    lines += ["", f"**{doc['equal']} of {doc['pairs']}** runs equal their twins' outcome, on {len(rigs)} "
                  f"held-out rigs ({rigs[0]}–{rigs[-1]}) × {len(doc['learning_seeds'])} learning seeds; "
                  f"{len(parted)} rigs have a run that parts" + (f" ({named})" if parted else "")
                  + f". Both sweeps at commit `{str(doc['runs_commit'])[:10]}`, beside each other: "
                  f"{_sweep_said(runs['family'])} and {_sweep_said(runs['twin'])}." + _reproduces(doc),
              "", _source(doc, name)]
    return "\n".join(lines) + "\n"


VIEWS: dict[str, Callable[[dict[str, Any], str], str]] = {
    "table1": view_table1, "robustness": view_robustness, "table": view_json, "efficiency": view_efficiency,
    "peers": view_peers, "fits": view_fits, "stoploop": view_stoploop, "performance": view_performance,
    "robust_floors": view_robust_floors, "fuzzlong": view_fuzzlong,
    "baselines_design": view_baselines_design, "bench_mpc": view_bench_mpc,
    "supervisor_check": view_supervisor_check, "supervisor_population": view_supervisor_population,
    "supervisor_good_kinds": view_supervisor_good_kinds, "bench_executor": view_bench_executor,
    "bench_time": view_bench_time, "headline": view_headline, "bench_sample": view_bench_sample,
    "deeprl": view_deeprl, "deeprl_efficiency": view_deeprl_efficiency, "rig_realtime": view_rig_realtime,
    "greybox_rig_floors": view_greybox_rig_floors,
    "rigs_kinds": view_rigs_kinds, "rigs_worst": view_rigs_worst, "rigs_floors": view_rigs_floors,
    "stage_floors": view_stage_floors, "stage_stalls": view_stage_stalls,
    "rigs_beside": view_rigs_beside,
    "rigs_ceiling": view_rigs_ceiling, "rigs_refine": view_rigs_refine,
    "identification_speed": view_identification_speed, "silverbox": view_silverbox,
    "coverage": view_coverage, "rigs_efficiency": view_rigs_efficiency,
    "family_twins": view_family_twins}


def render(readme: str, results_dir: Path) -> str:
    """The README with every block regenerated from its JSON file."""
    def block(m: re.Match[str]) -> str:
        name, view = m["name"], m["view"]
        path = results_dir / f"{name}.json"
        if not path.is_file():
            raise SystemExit(f"readme_results: error: block {name}:{view} needs missing {path}")
        if view not in VIEWS:
            raise SystemExit(f"readme_results: error: unknown view {view!r}; choose from {', '.join(VIEWS)}")
        return m.group(1) + VIEWS[view](json.loads(path.read_text()), name) + m.group(5)

    return BLOCK.sub(block, readme)


def documents(readme: Path | None) -> list[Path]:
    """The pages to render: ``--readme`` alone if given, else README.md and every docs/*.md with a block."""
    if readme is not None:
        return [readme]
    docs = sorted(p for p in (REPO / "docs").glob("*.md") if BLOCK.search(p.read_text()))
    return [REPO / "README.md", *docs]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--check", action="store_true", help="exit 1 if a page differs from the JSON")
    p.add_argument("--readme", type=Path, default=None,
                   help="one page to render (default: README.md and every docs/*.md with a block)")
    p.add_argument("--results", type=Path, default=REPO / "docs" / "results")
    args = p.parse_args(argv)
    pages = documents(args.readme)
    blocks = 0
    for page in pages:
        text = page.read_text()
        new = render(text, args.results)
        blocks += len(BLOCK.findall(new))
        if not args.check:
            if new != text:
                page.write_text(new)
            continue
        if new != text:
            first = next(m for m, n in zip(BLOCK.finditer(text), BLOCK.finditer(new), strict=False)
                         if m.group(0) != n.group(0))
            print(f"readme_results: {page.name} block {first['name']}:{first['view']} differs from "
                  f"docs/results/{first['name']}.json; run python scripts/readme_results.py", file=sys.stderr)
            return 1
    verb = "agree with" if args.check else "rendered from"
    print(f"readme_results: {blocks} blocks in {len(pages)} pages {verb} docs/results")
    return 0


if __name__ == "__main__":
    sys.exit(main())
