"""Identification from any record (issue 32): model files carry their rate and limits, a kind
fails alone, and ``msd-bench identify`` reads CSV, NPZ and MAT records and rejects bad ones in
one line."""

from __future__ import annotations

import json
import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from msd_bench.cli import main
from msd_bench.core.errors import IdentificationError, InvalidInputError
from msd_bench.core.identification import model_kinds
from msd_bench.core.identification.model_kinds import MODEL_KINDS, FitRequest
from msd_bench.core.physics import plant
from msd_bench.gym.backends import model_backend
from msd_bench.io.storage import artifacts

TS = 1 / 610.3515625  # the Silverbox's rate: nothing like the bench's 100 Hz
N = 1200


def _record(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A small hardening-spring-like circuit record in volts: u random, y a damped response."""
    rng = np.random.default_rng(seed)
    u = 0.1 * rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(2, N):
        y[k] = 1.6 * y[k - 1] - 0.7 * y[k - 2] + 0.05 * u[k - 1] - 0.2 * y[k - 1] ** 3
    return u, y


@pytest.fixture(scope="module")
def npz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    u, y = _record()
    path = tmp_path_factory.mktemp("rec") / "rec.npz"
    np.savez(path, V1=u, V2=y, flags=np.zeros(N, dtype=np.uint8))  # a member type the reader skips
    return path


def _identify(src: list[str], out: Path, models: str = "glm", *extra: str) -> int:
    return main(["identify", *src, "--ts", repr(TS), "--train", "0:900", "--validation", "900:1200",
                 "--models", models, "--units", "V,V", "--out", str(out), *extra])


def test_a_model_identified_at_610_hz_loads_back_at_610_hz(npz, tmp_path, capsys):
    assert _identify(["--npz", str(npz), "--u", "V1", "--y", "V2"], tmp_path) == 0
    doc = json.loads((tmp_path / "glm.json").read_text())
    u, y = _record()
    assert doc["dt"] == TS and doc["units"] == {"input": "V", "output": "V"}
    assert doc["force_limit"] == 2 * np.max(np.abs(u))
    assert doc["stroke"] == pytest.approx(4 * np.max(np.abs(y)))
    assert 1 / artifacts.load_model(tmp_path / "glm.json").dt == pytest.approx(610.3515625)
    out = capsys.readouterr().out
    assert "glm: written to" in out and "glm: fit" in out


def test_a_rate_mismatch_is_refused_in_one_line(npz, tmp_path):
    assert _identify(["--npz", str(npz), "--u", "V1", "--y", "V2"], tmp_path) == 0
    with pytest.raises(InvalidInputError) as err:
        model_backend(str(tmp_path / "glm.json"), "default")
    assert "610.352 Hz" in str(err.value) and "100 Hz" in str(err.value) and "\n" not in str(err.value)


def test_an_older_file_without_dt_loads_at_0_01_s_with_one_warning(npz, tmp_path, caplog):
    assert _identify(["--npz", str(npz), "--u", "V1", "--y", "V2"], tmp_path) == 0
    doc = json.loads((tmp_path / "glm.json").read_text())
    del doc["dt"]
    (tmp_path / "old.json").write_text(json.dumps(doc))
    with caplog.at_level(logging.WARNING):
        model = artifacts.load_model(tmp_path / "old.json")
    assert model.dt == plant.DT == FitRequest.dt
    assert len(caplog.records) == 1 and "no sample time recorded" in caplog.records[0].getMessage()


def test_csv_and_mat_give_the_npz_model(npz, tmp_path):
    u, y = _record()
    with (tmp_path / "rec.csv").open("w") as f:
        rows = (f"{k * TS!r},{float(a)!r},{float(b)!r}\n" for k, (a, b) in enumerate(zip(u, y, strict=True)))
        f.write("t,force,pos\n" + "".join(rows))
    scipy.io.savemat(tmp_path / "rec.mat", {"u": u[:, None], "y": y[None, :]})  # MATLAB's column and row
    params = []
    for fmt, src in (("npz", ["--npz", str(npz), "--u", "V1", "--y", "V2"]),
                     ("csv", ["--csv", str(tmp_path / "rec.csv"), "--u", "force", "--y", "pos"]),
                     ("mat", ["--mat", str(tmp_path / "rec.mat"), "--u", "u", "--y", "y"])):
        assert _identify(src, tmp_path / fmt) == 0
        params.append(artifacts.load_model(tmp_path / fmt / "glm.json").params)
    assert np.array_equal(params[0], params[1]) and np.array_equal(params[0], params[2])


def test_a_kind_forced_to_fail_leaves_the_others_written_and_named(npz, tmp_path, monkeypatch, capsys):
    def boom(req: FitRequest):
        raise IdentificationError("model produced a non-finite position")

    monkeypatch.setitem(MODEL_KINDS, "greybox", replace(MODEL_KINDS["greybox"], fit=boom))
    assert model_kinds.model_kind("greybox").fit is boom
    rc = _identify(["--npz", str(npz), "--u", "V1", "--y", "V2"], tmp_path, "greybox,glm")
    assert rc == 1  # only after glm and fits.json are written
    fits = json.loads((tmp_path / "fits.json").read_text())
    assert fits["failed"] == {"greybox": "model produced a non-finite position"}
    assert (tmp_path / "glm.json").is_file() and "glm" in fits and not (tmp_path / "greybox.json").exists()
    assert "greybox: FAILED: model produced a non-finite position" in capsys.readouterr().out


SPAN = ["--ts", repr(TS), "--validation", "900:1000"]


@pytest.mark.parametrize(("args", "says"), [
    (["--npz", "/nonexistent.npz", "--u", "V1", "--y", "V2", "--train", "0:900"], "no such file"),
    (["--npz", "{npz}", "--u", "V9", "--y", "V2", "--train", "0:900"],
     "no column 'V9'; it has V1, V2, flags"),
    (["--csv", "{bad_csv}", "--u", "a", "--y", "b", "--train", "0:9"],
     "column 'a' has 1 non-finite sample(s), the first at index 1"),
    (["--mat", "{npz}", "--u", "u", "--y", "y", "--train", "0:900"], "not a readable MAT file"),
    (["--npz", "{npz}", "--u", "V1", "--y", "V2", "--train", "0:5000"], "--train 0:5000 is out of bounds"),
    (["--npz", "{npz}", "--u", "V1", "--y", "V2", "--train", "0:900", "--models", "nope"],
     "unknown model kind 'nope'"),
    (["--npz", "{npz}", "--u", "V1", "--train", "0:900"], "--npz needs --y"),
])
def test_each_bad_input_is_one_line(npz, tmp_path, capsys, args, says):
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("a,b\n" + "".join(f"{v},{k}\n" for k, v in enumerate(["1", "nan"] + ["0"] * 10)))
    args = [a.format(npz=npz, bad_csv=bad_csv) for a in args]
    assert main(["identify", *args, *SPAN, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "out" / "fits.json").exists()  # nothing fitted from a bad input


@pytest.fixture(scope="module")
def fast_records():
    """The paper's plan, short, on a plant sampled at 200 Hz with a 8 N actuator: not the defaults."""
    from msd_bench.app.pipeline import records_from_plan
    from msd_bench.app.plan import paper_plan

    return records_from_plan(plant.PlantParams(dt=0.005, F=8.0), paper_plan(0, 1500, 600), None)


@pytest.mark.parametrize("kind", list(MODEL_KINDS))
def test_every_kind_records_its_rate_force_limit_stroke_and_units(kind, fast_records, tmp_path):
    req = FitRequest(fast_records, 0, 4.0, 8.0, nlarx_scale=0.002, dt=0.005, units=("V", "mm"))
    model = model_kinds.fit_model(kind, req)
    path = artifacts.save_model(model, tmp_path / f"{kind}.json", artifacts.Provenance((), {}, 0))
    doc = json.loads(path.read_text())
    assert (doc["dt"], doc["force_limit"], doc["stroke"]) == (0.005, 8.0, 4.0)
    assert doc["units"] == {"input": "V", "output": "mm"}
    back = artifacts.load_model(path)
    assert (back.dt, back.force_limit) == (0.005, 8.0)


def test_a_fit_at_another_rate_than_requested_is_refused(fast_records):
    with pytest.raises(IdentificationError, match=r"fitted at dt 0\.005 s"):
        model_kinds.fit_model("glm", FitRequest(fast_records, 0, 4.0, 8.0, dt=0.01))


def test_a_second_run_into_the_same_directory_overwrites_nothing(npz, tmp_path, capsys):
    src = ["--npz", str(npz), "--u", "V1", "--y", "V2"]
    assert _identify(src, tmp_path) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    capsys.readouterr()
    assert _identify(src, tmp_path) == 2  # refused before any fit, not recorded as the kind's failure
    assert "glm.json: already exists; refusing to overwrite" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


SILVERBOX_RIG = ("/**:\n  ros__parameters:\n    rate: 610.3515625\n    stroke: 1.0\n    force_limit: 0.5\n"
                 "    position_unit: V\n    force_unit: V\n    decision_period: 0.0016384\n")
"""A Silverbox-like circuit as a rig description (volts, 610 Hz)."""


def test_a_rig_description_gives_identify_its_rate_limits_and_units(npz, tmp_path, capsys):
    """identify --rig FILE: --ts, --stroke, --force and --units from the description (issue 37)."""
    rig = tmp_path / "rig.yaml"
    rig.write_text(SILVERBOX_RIG)
    out = tmp_path / "out"
    assert main(["identify", "--npz", str(npz), "--u", "V1", "--y", "V2", "--train", "0:900",
                 "--validation", "900:1200", "--models", "glm", "--rig", str(rig), "--out", str(out)]) == 0
    doc = json.loads((out / "glm.json").read_text())
    assert doc["dt"] == TS and doc["units"] == {"input": "V", "output": "V"}
    assert (doc["force_limit"], doc["stroke"]) == (0.5, 1.0)


def test_a_record_at_another_rate_than_the_rigs_is_one_line(npz, tmp_path, capsys):
    """Its model would be refused on the rig, so it is not made: one line, nothing written."""
    rig = tmp_path / "rig.yaml"
    rig.write_text(SILVERBOX_RIG.replace("rate: 610.3515625", "rate: 1000.0").replace("0.0016384", "0.001"))
    out = tmp_path / "out"
    assert _identify(["--npz", str(npz), "--u", "V1", "--y", "V2"], out, "glm", "--rig", str(rig)) == 2
    err = capsys.readouterr().err
    assert "is not the sample time of the rig of" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
