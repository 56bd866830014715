"""The markup of the run report's page (:mod:`msd_bench.io.reports.html_report`): small functions, all
escaping.

Every string a function here receives from a run file goes through
:func:`esc` before it is placed in the page, attribute values included; the
only unescaped inserts are this module's own constants and base64 ``data:``
URIs. Values are rendered from their JSON shape (a number, a list of numbers,
a summary object with ``mean`` and ``median``, a nested object), so columns a
newer writer adds show up without a change here.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from typing import Any

CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'"
"""Nothing but inline style and ``data:`` images may load: a link that slipped in makes no request."""

TABLE1_SKIP = frozenset({"per_seed", "fit_by_id_seed"})
"""Table 1 keys left out of the page's table: per-seed lists, in ``table1.csv`` one line each."""

_STYLE = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:12px}
th,td{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top}
th{background:#f2f2f2}td{white-space:nowrap}td.num{text-align:right;font-variant-numeric:tabular-nums}
figure{display:inline-block;margin:.5em;vertical-align:top}figure img{max-width:640px;border:1px solid #ddd}
figcaption{font-size:12px;color:#555}p.note{color:#555}
.kv th{font-weight:normal;color:#555;background:none}div.wide{overflow-x:auto}
"""


def esc(value: object) -> str:
    """``value`` as text that stays text in an element or a quoted attribute."""
    return html.escape(str(value), quote=True)


def page(title: str, sections: Sequence[str]) -> str:
    """The whole document: head with the policy and style, the title, the sections."""
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)}</title><style>{_STYLE}</style></head>\n<body>\n"
            f"<h1>{esc(title)}</h1>\n" + "\n".join(sections) + "\n</body></html>\n")


def section(heading: str, body: str, note: str = "") -> str:
    """A titled part of the page; ``note`` is one escaped sentence under the heading."""
    intro = f"<p class=\"note\">{esc(note)}</p>" if note else ""
    return f"<section><h2>{esc(heading)}</h2>{intro}{body}</section>"


def subsection(heading: str, body: str) -> str:
    return f"<h3>{esc(heading)}</h3>{body}"


def details(summary: str, body: str) -> str:
    """A folded part (long file lists)."""
    return f"<details><summary>{esc(summary)}</summary>{body}</details>"


def figures(items: Sequence[tuple[str, str | None]]) -> str:
    """Each figure inline (``data:`` URI), or its name when it could not be embedded."""
    if not items:
        return ""
    cells = [f"<figure><img src=\"{uri}\" alt=\"{esc(name)}\"><figcaption>{esc(name)}</figcaption></figure>"
             if uri is not None and uri.startswith("data:image/png;base64,")
             else f"<p>{esc(name)}: not embedded (not a PNG, or larger than the limit)</p>"
             for name, uri in items]
    return section("Figures", "".join(cells))


def number(v: float) -> str:
    """A float in four significant digits; non-finite values as JSON would not write them."""
    if not math.isfinite(v):
        return "—"
    return f"{v:.4g}" if abs(v) < 1e6 else f"{v:,.0f}"


def scalar(v: object) -> str | None:
    """The cell text of a scalar or a short list of scalars (escaped); None for anything else."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return esc(f"{v:,}" if abs(v) >= 100_000 else v)
    if isinstance(v, float):
        return esc(number(v))
    if isinstance(v, str):
        return esc(v) if v else "—"
    if isinstance(v, list) and all(isinstance(x, (int, float, str)) and not isinstance(x, bool) for x in v):
        return "[" + ", ".join(scalar(x) or "" for x in v) + "]" if len(v) <= 8 else esc(f"{len(v)} values")
    return None


def _summary(v: Mapping[str, Any]) -> str | None:
    """A metric summary (``mean``, ``sd``, ``median``) as ``mean ± sd (med median)``."""
    if "mean" not in v or "median" not in v:
        return None
    mean, sd, med = (scalar(_short(v.get(k))) for k in ("mean", "sd", "median"))
    return f"{mean} ± {sd} (med {med})"


def _short(v: object) -> object:
    """A summary's number in three significant digits (the page is for reading; the JSON keeps all)."""
    return float(f"{v:.3g}") if isinstance(v, float) and math.isfinite(v) else v


def cells(obj: Mapping[str, Any], skip: frozenset[str] = frozenset()) -> dict[str, str]:
    """An object's columns: scalars as they are, summaries as one cell, nested objects one level flat."""
    out: dict[str, str] = {}
    for key, v in obj.items():
        if key in skip:
            continue
        text = scalar(v)
        if text is not None:
            out[esc(key)] = text
        elif isinstance(v, Mapping):
            for sub, w in v.items():
                inner = scalar(w) if not isinstance(w, Mapping) else _summary(w)
                if inner is not None:
                    out[f"{esc(key)} · {esc(sub)}"] = inner
    return out


def object_table(rows: Sequence[Mapping[str, Any]], skip: frozenset[str] = frozenset()) -> str:
    """A table with a column for every key any row has (first-seen order), a row per object."""
    if not rows:
        return ""
    rendered = [cells(r, skip) for r in rows]
    columns = list(dict.fromkeys(c for r in rendered for c in r))
    head = "".join(f"<th>{c}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{r.get(c, '')}</td>" for c in columns) + "</tr>" for r in rendered)
    return f"<div class=\"wide\"><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>"


def share_text(cell: Mapping[str, Any]) -> str:
    """``k/n`` of a cell with ``n_success`` (or ``successes``) and ``n``."""
    k = cell.get("n_success", cell.get("successes"))
    return f"{k}/{cell.get('n')}"


def share(cell: object) -> float | None:
    """A cell's success share in [0, 1], None when it has no usable counts."""
    if not isinstance(cell, Mapping):
        return None
    k, n = cell.get("n_success", cell.get("successes")), cell.get("n")
    if not isinstance(k, (int, float)) or not isinstance(n, (int, float)) or isinstance(k, bool) or n <= 0:
        return None
    s = float(k) / float(n)
    return min(max(s, 0.0), 1.0) if math.isfinite(s) else None


def heat_colour(s: float | None) -> str:
    """Red (0 %) through yellow to green (100 %); grey without counts."""
    return "#e0e0e0" if s is None else f"hsl({120 * s:.0f},70%,78%)"


def heat_map(scenarios: Sequence[str], rows: Sequence[tuple[str, Mapping[str, Any]]]) -> str:
    """The robustness table: a row per agent kind, a column per scenario, the cell tinted by its share."""
    head = "<th>Agent</th>" + "".join(f"<th><code>{esc(s)}</code></th>" for s in scenarios)
    body = []
    for label, by_scenario in rows:
        tds = []
        for sid in scenarios:
            cell = by_scenario.get(sid)
            s = share(cell)
            sse = cell.get("median_sse") if isinstance(cell, Mapping) else None
            text = "—" if s is None else esc(share_text(cell) if isinstance(cell, Mapping) else "")
            if isinstance(sse, (int, float)) and not isinstance(sse, bool) and s is not None:
                text += f" <small>(SSE {esc(number(float(sse)))} %)</small>"
            tds.append(f"<td class=\"num\" style=\"background:{heat_colour(s)}\">{text}</td>")
        body.append(f"<tr><th>{esc(label)}</th>{''.join(tds)}</tr>")
    return f"<table class=\"heat\"><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def value(v: Any, depth: int = 0) -> str:
    """Any JSON value as nested key/value tables (a configuration, run facts)."""
    text = scalar(v)
    if text is not None and not isinstance(v, list):
        return text
    if isinstance(v, Mapping):
        if not v:
            return "—"
        rows = "".join(f"<tr><th>{esc(k)}</th><td>{value(w, depth + 1)}</td></tr>" for k, w in v.items())
        return f"<table class=\"kv\">{rows}</table>"
    if isinstance(v, (list, tuple)):
        if text is not None and len(v) <= 8:
            return text
        return "<ol>" + "".join(f"<li>{value(w, depth + 1)}</li>" for w in v) + "</ol>" if v else "—"
    return esc(v)
