"""Every command-line option is checked before any work: the message names the option and
its accepted range, and neither the drive is read nor an estimate, simulation, benchmark
or report started."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from roadgrip.cli import app
from roadgrip.drive import Drive
from roadgrip.vehicle import PRESETS


class WorkRan(AssertionError):
    """Raised by the patched readers and runners: the command started work."""


def _work(*args, **kwargs):
    raise WorkRan("work started before the options were checked")


@pytest.fixture()
def no_work(monkeypatch):
    """Reading a drive, simulating, benchmarking and reporting raise :class:`WorkRan`."""
    import roadgrip.evaluate.suite
    import roadgrip.io
    import roadgrip.report
    import roadgrip.sim.scenarios

    monkeypatch.setattr(roadgrip.io, "read_drive", _work)
    monkeypatch.setattr(roadgrip.sim.scenarios, "simulate_scenario", _work)
    monkeypatch.setattr(roadgrip.evaluate.suite, "bench", _work)
    monkeypatch.setattr(roadgrip.report, "write_report", _work)
    monkeypatch.setattr(roadgrip.report, "run_demo", _work)


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory) -> Path:
    n = 500
    t = np.arange(n) * 0.02
    vx = np.full(n, 12.0)
    r = 0.2 * np.sin(t)
    df = pd.DataFrame({"t": t, "ax": np.zeros(n), "ay": vx * r, "yaw_rate": r,
                       "steer": 0.02 * np.sin(t), "vx": vx})
    p = tmp_path_factory.mktemp("opts") / "drive.parquet"
    Drive.from_frame(df, PRESETS["sedan"], source="cli-options-test").save(p)
    return p


def _invoke(args: list[str]) -> str:
    res = CliRunner().invoke(app, args)
    assert res.exit_code != 0, res.output
    # reading, simulating, benchmarking and reporting raise WorkRan here: a refusal comes first
    assert not isinstance(res.exception, WorkRan), f"{args}: {res.exception}"
    return str(res.exception) + res.output


EST = ["estimate", "{drive}", "--method", "gpssm", "-o", "{tmp}/e.parquet"]
# (arguments, texts the message must contain: the option and its accepted range)
CASES = {
    "particles zero": ([*EST, "--particles", "0"], ["--particles", ">= 2", "got 0"]),
    "particles beyond memory": ([*EST, "--particles", "3000000"],
                                ["--particles 3000000", "GiB", "available", "at most"]),
    "basis beyond memory": ([*EST, "--basis", "separable:5000"],
                            ["--basis separable:5000", "GiB", "available"]),
    "basis malformed": ([*EST, "--basis", "radial:7"], ["--basis", "separable:N"]),
    "curve time nan": ([*EST, "--curve-times", "1,nan"], ["--curve-times", "from 0 to", "nan"]),
    "curve time inf": ([*EST, "--curve-times", "inf"], ["--curve-times", "from 0 to", "inf"]),
    "curve time negative": ([*EST, "--curve-times", "-3"], ["--curve-times", "from 0 to"]),
    "seed negative": ([*EST, "--seed", "-1"], ["--seed", "from 0 to 4294967295", "-1"]),
    "seed too large": ([*EST, "--seed", str(2**40)], ["--seed", "from 0 to 4294967295"]),
    "output folder missing": (["estimate", "{drive}", "--method", "brls", "-o", "{tmp}/nowhere/e.parquet"],
                              ["--output", "does not exist"]),
    "output suffix": (["estimate", "{drive}", "--method", "brls", "-o", "{tmp}/e.txt"],
                      ["--output", ".parquet or .pq or .csv"]),
    "curves folder missing": ([*EST, "--curves", "{tmp}/nowhere/c.parquet"], ["--curves", "does not exist"]),
    "plot suffix": ([*EST, "--plot", "{tmp}/f.jpg"], ["--plot", ".png"]),
    "vss folder missing": ([*EST, "--vss", "{tmp}/nowhere/v.jsonl"], ["--vss", "does not exist"]),
    "linalg": ([*EST, "--linalg", "quick"], ["linalg", "exact"]),
    "method": (["estimate", "{drive}", "--method", "kalman", "-o", "{tmp}/e.parquet"],
               ["unknown method 'kalman'", "gpssm"]),
    "option of another method": (["estimate", "{drive}", "--method", "cascade", "-o", "{tmp}/e.parquet",
                                  "--particles", "50"], ["particles", "do not apply to cascade"]),
    "format": (["info", "{drive}", "--format", "hdf5"], ["--format", "hdf5", "canonical"]),
    "vehicle": (["estimate", "{drive}", "--method", "brls", "-o", "{tmp}/e.parquet", "--vehicle", "tractor"],
                ["--vehicle", "tractor"]),
    "calibration file": (["estimate", "{drive}", "--method", "brls", "-o", "{tmp}/e.parquet",
                          "--calibration", "{tmp}/none.yaml"], ["calibration file", "does not exist"]),
    "channels file": (["info", "{drive}", "--channels", "{tmp}/none.yaml"], ["--channels", "no such file"]),
    "drive missing": (["info", "{tmp}/none.parquet"], ["no such file or folder", "none.parquet"]),
    "simulate scenario": (["simulate", "moon-landing", "-o", "{tmp}/s.parquet"],
                          ["SCENARIO", "moon-landing", "snow-slalom"]),
    "simulate engine": (["simulate", "snow-slalom", "--engine", "warp", "-o", "{tmp}/s.parquet"],
                        ["--engine", "multibody"]),
    "simulate vehicle": (["simulate", "snow-slalom", "--engine", "multibody", "--vehicle", "bus",
                          "-o", "{tmp}/s.parquet"], ["--vehicle", "ford-escort"]),
    "simulate duration nan": (["simulate", "snow-slalom", "--duration", "nan", "-o", "{tmp}/s.parquet"],
                              ["--duration", "(0, 86400]"]),
    "simulate duration zero": (["simulate", "snow-slalom", "--duration", "0", "-o", "{tmp}/s.parquet"],
                               ["--duration", "(0, 86400]"]),
    "simulate seed": (["simulate", "snow-slalom", "--seed", "-1", "-o", "{tmp}/s.parquet"],
                      ["--seed", "from 0 to"]),
    "simulate output": (["simulate", "snow-slalom", "-o", "{tmp}/nowhere/s.parquet"],
                        ["--output", "does not exist"]),
    "simulate output suffix": (["simulate", "snow-slalom", "-o", "{tmp}/s.h5"],
                               ["--output", ".parquet or .pq or .csv"]),
    "map cell nan": (["map", "{drive}", "-o", "{tmp}/m.npz", "--cell", "nan"], ["--cell", "0.01 to 1000 m"]),
    "map cell zero": (["map", "{drive}", "-o", "{tmp}/m.npz", "--cell", "0"], ["--cell", "0.01 to 1000 m"]),
    "map output": (["map", "{drive}", "-o", "{tmp}/nowhere/m.npz"], ["--output", "does not exist"]),
    "map csv": (["map", "{drive}", "-o", "{tmp}/m.npz", "--csv", "{tmp}/c.parquet"], ["--csv", ".csv"]),
    "map input": (["map", "{tmp}/none.parquet", "-o", "{tmp}/m.npz"], ["no such file", "none.parquet"]),
    "map show output": (["map", "show", "{tmp}/none.npz", "-o", "{tmp}/m.png"], ["no such file", "none.npz"]),
    "calibrate output": (["calibrate", "{drive}:high", "{drive}:low", "-o", "{tmp}/nowhere/c.yaml"],
                         ["--output", "does not exist"]),
    "calibrate output suffix": (["calibrate", "{drive}:high", "{drive}:low", "-o", "{tmp}/c.json"],
                                ["--output", ".yaml"]),
    "calibrate drive": (["calibrate", "{tmp}/none.parquet:high", "{drive}:low", "-o", "{tmp}/c.yaml"],
                        ["no such file", "none.parquet"]),
    "bench seed": (["bench", "--quick", "--seed", "-5", "-o", "{tmp}/b"], ["--seed", "from 0 to"]),
    "bench output": (["bench", "--quick", "-o", "{tmp}/nowhere/deeper/b"], ["--output", "does not exist"]),
    "report input": (["report", "{tmp}/none.parquet", "-o", "{tmp}/r"], ["no such file", "none.parquet"]),
    "report output": (["report", "{drive}", "-o", "{tmp}/nowhere/deeper/r"], ["--output", "does not exist"]),
    "demo seed": (["demo", "--seed", "-2", "--out", "{tmp}/d"], ["--seed", "from 0 to"]),
    "demo output": (["demo", "--out", "{drive}"], ["--out", "not a folder"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_option_is_refused_before_any_work(case, drive_file, tmp_path, no_work):
    args, texts = CASES[case]
    args = [a.format(drive=drive_file, tmp=tmp_path) for a in args]
    message = _invoke(args)
    for text in texts:
        assert text in message, f"{case}: {text!r} not in {message!r}"
    assert "\n" not in message.strip() or message.count("error") <= 1


def test_memory_estimate_follows_the_gpssm_state():
    """The per-particle estimate against the arrays of the GP-SSM's own initial state
    (measured at two particle counts), for every basis family and linear-algebra mode."""
    from roadgrip.cli.options import gpssm_memory
    from roadgrip.estimators.gpssm import Context, GPSSMConfig, Sample, init_state

    def nbytes(obj) -> int:
        if isinstance(obj, np.ndarray):
            return obj.nbytes
        if isinstance(obj, tuple):
            return sum(nbytes(o) for o in obj)
        return 0

    sample = Sample(*([0.0] * len(Sample._fields)))
    for spec in ("separable-odd:20", "tensor:10x10", "separable:40", "tensor-odd:6x6"):
        for linalg in ("exact", "fast", "direct"):
            sizes = []
            for n in (10, 30):
                cfg = GPSSMConfig(basis=spec, particles=n, linalg=linalg)
                sizes.append(nbytes(init_state(Context(cfg, PRESETS["sedan"]), sample, 0)))
            measured = (sizes[1] - sizes[0]) / 20
            per, _ = gpssm_memory(cfg.basis, 10, linalg, cfg.refactor_every)
            # the estimate carries a 25 % margin over the state for resampling copies
            assert 1.0 <= per / 1.25 / measured < 1.1, (spec, linalg, per, measured)


def test_resource_refusal_names_the_largest_count_that_fits():
    from roadgrip.cli.options import GIB, check_gpssm_resources, gpssm_memory
    from roadgrip.inference.basis import make_basis

    per, fixed = gpssm_memory(make_basis("separable-odd:20"), 1, "exact", 80)
    avail = 4 * GIB
    most = int((0.8 * avail - fixed) // per)
    check_gpssm_resources({"particles": most}, available=avail)  # fits
    with pytest.raises(ValueError, match=f"at most {most} particles"):
        check_gpssm_resources({"particles": most + 1}, available=avail)
    check_gpssm_resources({"particles": 200, "basis": "tensor:10x10"}, available=avail)


def test_output_named_csv_is_written_as_csv(drive_file, tmp_path):
    out, parquet = tmp_path / "e.csv", tmp_path / "e.parquet"
    for path in (out, parquet):
        res = CliRunner().invoke(app, ["estimate", str(drive_file), "--method", "brls", "-o", str(path)])
        assert res.exit_code == 0, res.output
    assert out.read_bytes()[:4] != b"PAR1"
    table = pd.read_csv(out)
    ref = pd.read_parquet(parquet)
    assert list(table.columns) == list(ref.columns) and len(table) == len(ref) == 500
    np.testing.assert_allclose(table["mu_front"].to_numpy(), ref["mu_front"].to_numpy(), rtol=1e-12)


@pytest.fixture(scope="module")
def estimates_file(drive_file, tmp_path_factory) -> Path:
    """The output of `roadgrip estimate` (bRLS) on the test drive."""
    out = tmp_path_factory.mktemp("estimates") / "estimates.parquet"
    res = CliRunner().invoke(app, ["estimate", str(drive_file), "--method", "brls", "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out


@pytest.mark.parametrize("args", [
    ["estimate", "{est}", "--method", "cascade", "-o", "{tmp}/e.parquet"],
    ["estimate", "{est}", "--method", "cascade", "-o", "{tmp}/e.parquet", "--vehicle", "sedan"],
    ["estimate", "{est}", "--method", "brls", "-o", "{tmp}/e.parquet", "--stream"],
    ["info", "{est}"],
    ["calibrate", "{est}:high", "{drive}:low", "-o", "{tmp}/c.yaml"],
], ids=["estimate", "estimate --vehicle", "estimate --stream", "info", "calibrate"])
def test_an_estimates_file_given_as_a_drive_is_called_an_estimates_table(args, estimates_file, drive_file,
                                                                         tmp_path):
    args = [a.format(est=estimates_file, drive=drive_file, tmp=tmp_path) for a in args]
    res = CliRunner().invoke(app, args)
    assert res.exit_code != 0
    message = str(res.exception)
    assert message == ("estimates.parquet is an estimates table (output of `roadgrip estimate --method brls`), "
                       "not a drive: pass the drive it was estimated from"), message
    assert not (tmp_path / "e.parquet").exists() and not (tmp_path / "c.yaml").exists()
