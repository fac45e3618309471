"""The command line imports the heavy libraries only where a command uses them.

Each check runs a command's code in a fresh interpreter (``python -c``) and prints the heavy
top-level packages then in ``sys.modules``; ``benchmarks/bench_startup.py`` times the same
commands. No timing is asserted here.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numba", "llvmlite", "dask", "distributed", "geopandas", "shapely", "matplotlib",
         "asammdf", "rosbags", "scipy")
"""Packages no listing or description of a drive needs (compiled kernels, parallel fleets,
maps, figures, MDF4 files and ROS bags, SciPy)."""

PRELUDE = "import json, sys\n"
REPORT = "print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & set({heavy!r}))))"


def heavy_after(code: str, *heavy: str) -> list[str]:
    """The packages of ``heavy`` (default :data:`HEAVY`) imported after running ``code`` in a
    fresh interpreter."""
    run = PRELUDE + code + "\n" + REPORT.format(heavy=list(heavy or HEAVY))
    res = subprocess.run([sys.executable, "-c", run], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-3000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


def command(*argv: str) -> str:
    """Code running ``roadgrip ARGV`` in-process (its output discarded) up to its exit."""
    return ("import contextlib, io\n"
            f"sys.argv = ['roadgrip', *{list(argv)!r}]\n"
            "from roadgrip.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n"
            "        main()\n"
            "    except SystemExit as exc:\n"
            "        assert not exc.code, exc.code\n")


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory):
    """A simulated drive with a pose (the windowed pose derivative of the sensor delays)
    and a parametric truth (the slip at 80 % of the peak of the excitation)."""
    from roadgrip.sim.scenarios import simulate_scenario

    path = tmp_path_factory.mktemp("startup") / "drive.parquet"
    drive = simulate_scenario("dry-gravel-dry", seed=0, duration=20.0)
    assert {"x", "y", "psi", "alpha_f_true"} <= set(drive.data.columns)
    drive.save(path)
    return path


def test_the_command_line_module_imports_no_heavy_package():
    assert heavy_after("import roadgrip.cli, roadgrip.cli.info, roadgrip.cli.simulate") == []


def test_listing_the_scenarios_imports_no_heavy_package_nor_pandas():
    assert heavy_after(command("scenarios"), *HEAVY, "pandas", "pyarrow") == []


def test_describing_a_drive_imports_no_heavy_package(drive_file):
    assert heavy_after(command("info", str(drive_file))) == []


def test_describing_a_csv_drive_imports_no_heavy_package(drive_file, tmp_path):
    from roadgrip.io import read_drive

    csv = tmp_path / "drive.csv"
    read_drive(drive_file).save(csv)
    assert heavy_after(command("info", str(csv), "--align")) == []


def test_the_help_imports_no_heavy_package_nor_pandas():
    assert heavy_after(command("--help"), *HEAVY, "pandas", "pyarrow") == []


def test_the_simulator_package_still_gives_its_names():
    """``roadgrip.sim`` imports its parts on first use; every public name and submodule is there."""
    code = ("import roadgrip.sim as sim\n"
            "assert 'numba' not in sys.modules and 'pandas' not in sys.modules\n"
            "from roadgrip.sim import SCENARIOS, ConstantFriction, engine, simulate\n"
            "assert engine.__name__ == 'roadgrip.sim.engine' and callable(simulate)\n"
            "assert all(getattr(sim, name) is not None for name in sim.__all__)\n"
            "try:\n"
            "    sim.no_such_name\n"
            "except AttributeError as exc:\n"
            "    assert 'no_such_name' in str(exc)\n"
            "else:\n"
            "    raise AssertionError('no AttributeError')\n")
    assert heavy_after(code, "numba") == ["numba"]  # the runner, once asked for, compiles
