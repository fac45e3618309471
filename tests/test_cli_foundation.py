"""`roadgrip info` on files and data sets; one-line errors with exit status 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.vehicle import PRESETS

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / ".." / "shared" / "data"


def _roadgrip(*args: str) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent / "roadgrip"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-c", "from roadgrip.cli import main; main()"]
    env = {"COLUMNS": "200", "PATH": "/usr/bin:/bin", "TERM": "dumb"}
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=120, env=env)


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory):
    rng = np.random.default_rng(0)
    n = 400
    t = np.arange(n) * 0.02
    vx = np.full(n, 15.0)
    r = 0.2 * np.sin(t)
    df = pd.DataFrame({"t": t, "ax": rng.normal(0, 0.1, n), "ay": vx * r, "yaw_rate": r,
                       "steer": 0.02 * np.sin(t), "vx": vx, "wiper_state": rng.integers(0, 3, n)})
    p = tmp_path_factory.mktemp("cli") / "drive.parquet"
    Drive.from_frame(df, PRESETS["sedan"], source="cli-test").save(p)
    return p


def test_info_on_canonical_file(drive_file):
    res = _roadgrip("info", str(drive_file))
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "7.98 s" in out  # duration
    assert "50.00 Hz" in out
    assert "wiper_state" in out  # extra columns listed
    assert "nonlinear tire excitation" in out
    assert "sedan" in out


def test_info_vehicle_override(drive_file):
    res = _roadgrip("info", str(drive_file), "--vehicle", "suv")
    assert res.returncode == 0, res.stderr
    assert "suv" in res.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["info", "/nonexistent/drive.parquet"], "no such file or folder"),
        (["info", "{empty}"], "is empty"),
        (["info", "{plain}"], "no roadgrip metadata: pass the vehicle"),
        (["info", "{plain}", "--format", "hdf5"], "unknown format 'hdf5'"),
        (["info", "{plain}", "--format", "rosbag"], "not a readable ROS bag"),
        (["info", "{plain}", "--vehicle", "tractor"], "unknown vehicle 'tractor'"),
        (["info", "{nan}", "--vehicle", "sedan"], "column 'ay' has 1 NaN/inf value(s)"),
    ],
)
def test_bad_input_gives_one_error_line(tmp_path, monkeypatch, capsys, args, message):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    plain = tmp_path / "plain.csv"
    plain.write_text("t,ay\n0,0.1\n0.01,0.2\n")
    nan = tmp_path / "nan.csv"
    nan.write_text("t,ay\n0,0.1\n0.01,\n")
    args = [a.format(empty=empty, plain=plain, nan=nan) for a in args]
    # in-process through the console entry point (the subprocess path is tested below)
    from roadgrip.cli import main

    monkeypatch.setattr(sys, "argv", ["roadgrip", *args])
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ")
    assert message in lines[0]


def test_error_from_the_installed_command(tmp_path):
    long_path = tmp_path / ("a-very-long-folder-name-" * 6) / "drive.parquet"
    res = _roadgrip("info", str(long_path))
    assert res.returncode == 2
    assert res.stderr.strip() == f"error: no such file or folder: {long_path}"  # one line, unwrapped
    assert "Traceback" not in res.stderr + res.stdout


@pytest.mark.realdata
@pytest.mark.skipif(not DATA.is_dir(), reason=f"shared data not found at {DATA}")
def test_info_on_real_data_sets():
    dart = sorted((DATA / "dart").glob("*/*.csv"))[0]
    res = _roadgrip("info", str(dart))
    assert res.returncode == 0, res.stderr
    assert "jetracer" in res.stdout and "dart" in res.stdout and "steer_cmd" in res.stdout
    res = _roadgrip("info", str(DATA / "frictionmaps" / "DS3"))
    assert res.returncode == 0, res.stderr
    assert "f1tenth" in res.stdout and "50.00 Hz" in res.stdout and "pose_jump" in res.stdout
    res = _roadgrip("info", str(DATA / "frictionmaps"))  # the parent folder is ambiguous
    assert res.returncode == 2
    assert res.stderr.startswith("error: cannot tell the format of folder")


# -- roadgrip estimate on a test-only estimator ------------------------------------------
@pytest.fixture()
def flat_estimator():
    """A registered estimator with a ``curve_times`` option (constant band, flat curves)."""
    from dataclasses import dataclass

    from roadgrip import estimators
    from roadgrip.estimators.protocol import (
        DriveInfo,
        Estimator,
        EstimatorConfig,
        Prepared,
        run_by_stepping,
    )

    @dataclass(frozen=True)
    class FlatConfig(EstimatorConfig):
        method = "flat"
        level: float = 0.6
        curve_times: tuple[float, ...] = ()

    def step(state, t):
        row = {"t": float(t), "mu_front": state, "mu_rear": state, "mu_front_lower": state - 0.1,
               "mu_front_upper": state + 0.1, "mu_rear_lower": state - 0.1, "mu_rear_upper": state + 0.1}
        return state, row

    def run(drive, config=None, seed=0, progress=None):
        config = config or FlatConfig()
        res = run_by_stepping(FLAT, drive, config, seed, progress)
        alpha = np.linspace(-0.1, 0.1, 5)
        curves = pd.DataFrame([{"t": t, "axle": a, "alpha": x, "mu_mean": config.level, "mu_lower": 0.5,
                                "mu_upper": 0.7, "mu_prior": 0.6}
                               for t in config.curve_times for a in ("front", "rear") for x in alpha])
        return type(res)(res.method, res.table, res.meta, curves if len(curves) else None)

    FLAT = Estimator("flat", "-", "flat (test only)", FlatConfig,
                     lambda d, c: Prepared(DriveInfo.from_drive(d), d.t),
                     lambda info, c, seed: c.level, step, run, lambda c: (c.level - 0.1, c.level + 0.1))
    estimators.register(FLAT)
    yield FLAT
    estimators.unregister("flat")


def test_estimate_writes_estimates_and_curves(drive_file, tmp_path, flat_estimator):
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.estimators import EstimateResult

    out, curves = tmp_path / "est.parquet", tmp_path / "curves.parquet"
    r = CliRunner().invoke(app, ["estimate", str(drive_file), "--method", "flat", "-o", str(out),
                                 "--curves", str(curves), "--curve-times", "1,2.5"])
    assert r.exit_code == 0, r.output
    assert "flat: run summary" in r.output and "peak friction front" in r.output
    res = EstimateResult.read_parquet(out)
    assert len(res.table) == 400 and res.table["mu_front"].eq(0.6).all()
    assert sorted(pd.read_parquet(curves)["t"].unique()) == [1.0, 2.5]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--particles", "5"], "'particles' do not apply to flat"),
        (["--linalg", "fast"], "'linalg' do not apply to flat"),
        (["--curve-times", "1,x"], "--curve-times must be comma-separated seconds"),
        (["--plot", "{tmp}/f.png"], "no figure for method 'flat'"),
    ],
)
def test_estimate_rejects_options_by_name(drive_file, tmp_path, flat_estimator, extra, message):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    extra = [a.format(tmp=tmp_path) for a in extra]
    r = CliRunner().invoke(app, ["estimate", str(drive_file), "--method", "flat", "-o",
                                 str(tmp_path / "e.parquet"), *extra])
    assert r.exit_code != 0
    assert message in str(r.exception)


def test_estimate_rejects_an_unknown_method(drive_file, tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    r = CliRunner().invoke(app, ["estimate", str(drive_file), "--method", "nonexistent", "-o",
                                 str(tmp_path / "e.parquet")])
    assert r.exit_code != 0 and "unknown method 'nonexistent'" in str(r.exception)


def test_bench_and_demo_commands_print_the_table_and_write_files(tmp_path, monkeypatch):
    from dataclasses import replace

    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.evaluate import cases, suite  # noqa: F401  (suite binds the real settings before the patch)

    tiny = replace(cases.DEMO, name="tiny", scenarios=("dry-gravel-dry",), multibody=(),
                   real_data=False, durations={"dry-gravel-dry": 20.0})
    monkeypatch.setattr(cases, "QUICK", tiny)
    monkeypatch.setattr(cases, "DEMO", tiny)
    r = CliRunner().invoke(app, ["bench", "--quick", "-o", str(tmp_path / "bench")])
    assert r.exit_code == 0, r.output
    assert "roadgrip benchmark (seed 0, tiny)" in r.output and "dry-gravel-dry / brls" in r.output
    assert (tmp_path / "bench" / "bench.md").is_file() and (tmp_path / "bench" / "bench.csv").is_file()
    r = CliRunner().invoke(app, ["demo", "--out", str(tmp_path / "demo")])
    assert r.exit_code == 0, r.output
    assert "roadgrip demo benchmark (seed 0)" in r.output and "report written to" in r.output
    assert (tmp_path / "demo" / "index.html").is_file()


def test_run_summary_calls_a_band_a_lower_bound_only_for_methods_that_flag_the_peak():
    from rich.console import Console

    from roadgrip.cli.summary import summary_table
    from roadgrip.estimators.base import EstimateResult

    tab = pd.DataFrame({"t": [0.0, 1.0], "mu_front": [0.8, 0.84], "mu_front_lower": [0.6, 0.8],
                        "mu_front_upper": [1.0, 0.88], "peak_observed_front": [False, False]})

    def text(method):
        console = Console(record=True, width=200)
        console.print(summary_table(EstimateResult(method, tab, {})))
        return console.export_text()

    assert "lower bound" not in text("cascade")  # its band is the friction itself
    assert "peak not observed: lower bound" in text("gpssm")
