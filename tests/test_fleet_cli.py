"""``roadgrip fleet``: drive globs, options checked before any work, outputs written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from roadgrip import mapping as M
from roadgrip.cli.fleet import _check, expand_drives, write_fleet_outputs
from roadgrip.mapping.fleet import FleetPart


def test_globs_expand_sorted_and_a_pattern_matching_nothing_is_named(tmp_path):
    for name in ("b.parquet", "a.parquet", "c.csv"):
        (tmp_path / name).write_bytes(b"")
    got = expand_drives([str(tmp_path / "*.parquet"), str(tmp_path / "c.csv"), str(tmp_path / "a.parquet")])
    assert [Path(p).name for p in got] == ["a.parquet", "b.parquet", "c.csv"]
    with pytest.raises(ValueError, match=r"no drive matches '.*\*.mf4'"):
        expand_drives([str(tmp_path / "*.mf4")])
    with pytest.raises(ValueError, match=r"no such drive: .*missing\.parquet"):
        expand_drives([str(tmp_path / "missing.parquet")])


@pytest.mark.parametrize(("args", "msg"), [
    (("map.csv", None, None, 0.5, 24.0, 2), r"--output map.csv: a fleet map is .parquet"),
    (("map.parquet", "page.htm", None, 0.5, 24.0, 2), r"--html page.htm: expected .html"),
    (("nowhere/map.parquet", None, None, 0.5, 24.0, 2), r"--output .*nowhere.* does not exist"),
    (("map.parquet", None, None, 0.0, 24.0, 2), r"--cell must be within \[0.01, 1000\] m, got 0.0"),
    (("map.parquet", None, None, 0.5, float("nan"), 2), r"--decay-hours must be > 0"),
    (("map.parquet", None, None, 0.5, 24.0, 0), r"--workers must be within \[1, 256\], got 0"),
])
def test_options_are_refused_before_any_work_with_the_range(tmp_path, monkeypatch, args, msg):
    monkeypatch.chdir(tmp_path)
    out, html, png, *rest = args
    with pytest.raises(ValueError, match=msg):
        _check(Path(out), Path(html) if html else None, Path(png) if png else None, *rest)


def test_outputs_of_a_fleet_part(tmp_path):
    import pandas as pd

    g = M.fuse(M.empty_grid(0.5), [0.1, 3.0, 3.1], [0.2, 1.0, 1.1], [0.5, 0.6, 0.7], [0.01, 0.01, 0.02])
    part = FleetPart(g, pd.DataFrame({"source": ["a"], "observations": [3]}))
    write_fleet_outputs(part, tmp_path / "m.npz", html=tmp_path / "m.html", png=tmp_path / "m.png")
    back = M.FrictionGrid.from_npz(tmp_path / "m.npz")
    np.testing.assert_array_equal(back.cells.n_obs, [1, 2])
    assert (tmp_path / "m.png").stat().st_size > 10_000 and "m.png" in (tmp_path / "m.html").read_text()
    hexes = FleetPart(M.fuse_hex(M.empty_hexgrid(13), [48.1], [11.5], [0.5], [0.01]), part.drives)
    with pytest.raises(ValueError, match=r"an H3 map is written as \.parquet or \.geojson"):
        write_fleet_outputs(hexes, tmp_path / "h.npz")


@pytest.mark.slow
def test_fleet_command_on_simulated_drives(tmp_path):
    """The command end to end: a local cluster of two processes, GeoParquet, page and counts."""
    gpd = pytest.importorskip("geopandas")
    from roadgrip.sim.scenarios import simulate_scenario

    n_obs = 0
    for seed in (0, 1):
        d = simulate_scenario("f1tenth-patches", seed, duration=15.0)
        d.to_parquet(tmp_path / f"drive{seed}.parquet")
        from roadgrip.estimators import run_estimator

        n_obs += len(M.observations_from_estimates(run_estimator("cascade", d).table, 0.5).mu)
    # a file cut short among them: refused by name, the others mapped
    good = (tmp_path / "drive0.parquet").read_bytes()
    (tmp_path / "drive9.parquet").write_bytes(good[: len(good) // 3])
    out = tmp_path / "fleet.parquet"
    proc = subprocess.run([str(Path(sys.executable).parent / "roadgrip"), "fleet", str(tmp_path / "drive*.parquet"),
                           "-o", str(out), "--html", str(tmp_path / "fleet.html")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "3 drives" in proc.stdout and "drives/min" in proc.stdout
    refusal = next(line for line in proc.stdout.splitlines() if "drive9.parquet" in line)
    assert "1 of 3 drives refused" in proc.stdout and refusal.strip().startswith(str(tmp_path / "drive9.parquet:"))
    cells = gpd.read_parquet(out)
    assert cells["n_obs"].sum() == n_obs and cells.crs is None
    assert (tmp_path / "fleet.html").stat().st_size > 100_000


def test_origin_option():
    from roadgrip.cli.fleet import _origin

    assert _origin("48.1, 11.5") == (48.1, 11.5) and _origin(None) is None
    for bad in ("48.1", "x,y", "95,0"):
        with pytest.raises(ValueError, match="--origin must be"):
            _origin(bad)
