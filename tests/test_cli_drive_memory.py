"""A drive too large to read whole is known before it is read: ``roadgrip info`` reads a
Parquet drive in chunks and refuses a CSV in one line, ``roadgrip estimate`` names
``--stream``; a small drive is never refused."""

from __future__ import annotations

import gzip
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import roadgrip.cli.drive_memory as dm
from roadgrip.cli import app
from roadgrip.cli.options import GIB, MEMORY_FRACTION, available_memory, cgroup_free
from roadgrip.drive import Drive
from roadgrip.vehicle import PRESETS

N = 2000


def _frame(n: int = N) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.01
    vx = np.full(n, 15.0)
    r = 0.2 * np.sin(t)
    return pd.DataFrame({"t": t, "ax": rng.normal(0, 0.1, n), "ay": vx * r, "yaw_rate": r,
                         "steer": 0.02 * np.sin(t), "vx": vx})


@pytest.fixture(scope="module")
def drive():
    return Drive.from_frame(_frame(), PRESETS["sedan"], source="memory-test")


@pytest.fixture
def parquet(drive, tmp_path):
    p = tmp_path / "drive.parquet"
    drive.save(p)
    return p


@pytest.fixture
def csv(drive, tmp_path):
    p = tmp_path / "drive.csv"
    drive.save(p)
    return p


@pytest.fixture
def unread(monkeypatch):
    """Reading a drive whole fails the test (the check must come before it)."""
    def fail(*args, **kwargs):
        raise AssertionError("the drive was read whole")

    import roadgrip.cli.estimate as estimate
    import roadgrip.cli.info as info
    import roadgrip.io

    for module in (estimate, info, roadgrip.io):
        monkeypatch.setattr(module, "load_drive" if module is not roadgrip.io else "read_drive", fail)


def _budget(monkeypatch, available: float) -> None:
    monkeypatch.setattr(dm, "available_memory", lambda: available)


@pytest.fixture
def invoke(monkeypatch):
    """``roadgrip ARGS`` in this process (typer's runner), 200 columns wide."""
    from roadgrip.cli import _common

    monkeypatch.setattr(_common.console, "width", 200)
    return lambda *args: CliRunner().invoke(app, list(args))


def test_a_parquet_drive_is_sized_from_its_footer(parquet):
    size = dm.drive_size(parquet)
    assert (size.kind, size.rows, size.columns) == ("parquet", N, 6)
    read = (dm.READ_BYTES[0] * 6 + dm.READ_BYTES[1]) * N
    run = (dm.RUN_BYTES["cascade"][0] * 6 + dm.RUN_BYTES["cascade"][1]) * N
    assert dm.memory_needed(size) == pytest.approx(read)
    assert dm.memory_needed(size, "cascade") == pytest.approx(max(read, run))
    assert "drive.parquet (2000 rows x 6 columns" in size.describe()


def test_a_csv_drive_is_sized_from_its_text(csv):
    size = dm.drive_size(csv)
    assert (size.kind, size.columns, size.text_bytes) == ("csv", 6, csv.stat().st_size)
    assert 0.7 * N <= size.rows <= 1.3 * N  # from the mean line length
    assert dm.memory_needed(size) == pytest.approx(dm.CSV_BYTES_PER_BYTE * size.text_bytes)


def test_a_gzip_csv_is_sized_by_its_uncompressed_text(csv, tmp_path):
    gz = tmp_path / "drive.csv.gz"
    gz.write_bytes(gzip.compress(csv.read_bytes()))
    size = dm.drive_size(gz)
    assert size.file_bytes < size.text_bytes == csv.stat().st_size
    assert size.columns == 6 and 0.7 * N <= size.rows <= 1.3 * N


def test_other_inputs_are_not_sized(parquet, tmp_path):
    assert dm.drive_size(tmp_path) is None  # a folder (a data set)
    assert dm.drive_size(parquet, "rosbag") is None
    broken = tmp_path / "broken.parquet"
    broken.write_bytes(b"not parquet")
    assert dm.drive_size(broken) is None  # the reader says why


def test_estimate_names_stream_for_a_parquet_whose_rows_do_not_fit(parquet, tmp_path, monkeypatch, unread, invoke):
    need = dm.memory_needed(dm.drive_size(parquet), "cascade")
    _budget(monkeypatch, need / 2)
    res = invoke("estimate", str(parquet), "--method", "cascade", "-o", str(tmp_path / "e.parquet"))
    assert isinstance(res.exception, ValueError), res.output
    msg = str(res.exception)
    assert "\n" not in msg
    assert "drive.parquet (2000 rows x 6 columns" in msg and "for cascade" in msg
    assert f"{need / GIB:.1f} GiB" in msg and "use --stream" in msg
    assert not (tmp_path / "e.parquet").exists()


def test_estimate_on_a_csv_that_does_not_fit_says_to_convert_and_stream(csv, tmp_path, monkeypatch, unread, invoke):
    _budget(monkeypatch, 1e5)
    res = invoke("estimate", str(csv), "--method", "brls", "-o", str(tmp_path / "e.parquet"))
    msg = str(res.exception)
    assert isinstance(res.exception, ValueError) and "drive.csv (" in msg
    assert "convert it to Parquet and use --stream" in msg


def test_info_reads_a_parquet_that_does_not_fit_in_chunks(parquet, monkeypatch, unread, invoke):
    _budget(monkeypatch, dm.memory_needed(dm.drive_size(parquet)) / 2)
    res = invoke("info", str(parquet))
    assert res.exit_code == 0, res.output
    assert "read in chunks" in res.output and f"of {N} rows" in res.output


def test_info_refuses_a_csv_that_does_not_fit_saying_what_to_do(csv, monkeypatch, unread, invoke):
    _budget(monkeypatch, 1e5)
    res = invoke("info", str(csv))
    msg = str(res.exception)
    assert isinstance(res.exception, ValueError) and "\n" not in msg
    assert msg.startswith("drive.csv (") and "GiB read whole" in msg
    assert "convert it to Parquet, which `roadgrip info` reads in chunks" in msg


def test_a_small_drive_is_never_refused(parquet, csv, tmp_path, monkeypatch, invoke):
    """Only the drive's own memory is counted, not the imports: 64 MB available still
    read a 2000-row drive whole, and the commands run."""
    for path in (parquet, csv):
        for method in (None, *dm.RUN_BYTES):
            assert dm.check_whole_read(path, method=method, available=64e6).fits
    assert dm.check_whole_read(parquet, method="cascade").fits  # the machine's own memory
    _budget(monkeypatch, 64e6)
    res = invoke("info", str(csv))
    assert res.exit_code == 0, res.output
    assert "read in chunks" not in res.output
    res = invoke("estimate", str(parquet), "--method", "brls", "-o", str(tmp_path / "e.parquet"))
    assert res.exit_code == 0, res.output
    assert (tmp_path / "e.parquet").exists()


def test_the_budget_is_a_fraction_of_the_available_memory(parquet):
    need = dm.memory_needed(dm.drive_size(parquet))
    assert dm.check_whole_read(parquet, available=need / MEMORY_FRACTION).fits
    assert not dm.check_whole_read(parquet, available=0.99 * need / MEMORY_FRACTION).fits


def test_cgroup_limit_less_its_working_set(tmp_path):
    def files(limit: str, usage: int, inactive: int) -> tuple:
        (tmp_path / "max").write_text(limit + "\n")
        (tmp_path / "current").write_text(f"{usage}\n")
        (tmp_path / "stat").write_text(f"anon 1\ninactive_file {inactive}\nactive_file 5\n")
        return ((str(tmp_path / "max"), str(tmp_path / "current"), str(tmp_path / "stat"), "inactive_file"),)

    assert cgroup_free(files("1000", 600, 100)) == 500.0  # page cache that can go is not used
    assert cgroup_free(files("1000", 1200, 0)) == 0.0
    assert cgroup_free(files("max", 600, 100)) is None
    assert cgroup_free(files(str(2**63 - 4096), 600, 100)) is None  # cgroup v1 without a limit
    assert cgroup_free(((str(tmp_path / "none"), "", "", ""),)) is None


def test_an_address_space_limit_bounds_the_available_memory():
    code = ("import resource\n"
            "soft, hard = resource.getrlimit(resource.RLIMIT_AS)\n"
            "resource.setrlimit(resource.RLIMIT_AS, (3 << 30, hard))\n"
            "from roadgrip.cli.options import address_space_free, available_memory\n"
            "print(address_space_free(), available_memory())\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    free, avail = map(float, res.stdout.split())
    assert 0 < free < 3 * GIB and avail <= free
    assert available_memory() > 0
