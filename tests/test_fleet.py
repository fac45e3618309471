"""Fleet maps on Dask: equal to the sequential merge, independent of order and partitioning, no observation lost."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roadgrip import mapping as M
from roadgrip.mapping.fleet import (
    FleetConfig,
    FleetPart,
    drive_part,
    fleet_map,
    merge_parts,
    sequential_fleet_map,
)

N_DRIVES = 4
DURATION = 20.0  # [s] of the f1tenth-patches scenario per drive
HOUR = 3600.0


@functools.cache
def _drives():
    from roadgrip.sim.scenarios import simulate_scenario

    return tuple(simulate_scenario("f1tenth-patches", seed, duration=DURATION) for seed in range(N_DRIVES))


@functools.cache
def _parts(tau: float = 86_400.0) -> tuple[FleetPart, ...]:
    cfg = FleetConfig(tau=tau)
    return tuple(drive_part(d, cfg, start_time=i * HOUR) for i, d in enumerate(_drives()))


def _same(a: M.FrictionGrid | M.HexGrid, b: M.FrictionGrid | M.HexGrid) -> None:
    np.testing.assert_array_equal(a.cells.key, b.cells.key)
    np.testing.assert_array_equal(a.cells.n_obs, b.cells.n_obs)
    for f in ("s0", "s1", "s2", "sb"):
        np.testing.assert_allclose(getattr(a.cells, f), getattr(b.cells, f), rtol=1e-12, atol=0)
    assert a.t_ref == b.t_ref


def test_local_cluster_of_two_workers_gives_the_sequential_merge():
    pytest.importorskip("distributed")
    drives = list(_drives())
    starts = {i: (N_DRIVES - i) * HOUR for i in range(N_DRIVES)}  # the drives' table keeps their order
    seq = sequential_fleet_map(drives, FleetConfig(), starts)
    par = fleet_map(drives, FleetConfig(), n_workers=2, processes=False, start_times=starts)
    _same(par.map, seq.map)
    # the same cluster, the drives split into 1 or 3 tasks: the same map
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cl, \
            Client(cl) as client:
        for k in (1, 3):
            _same(fleet_map(drives, FleetConfig(), client=client, partitions=k, start_times=starts).map, seq.map)
    # no observation lost: the map's counts are the drives' observations
    n = [len(M.observations_from_estimates(_table(d), 0.5).mu) for d in drives]
    assert list(par.drives["observations"]) == n
    assert int(par.map.cells.n_obs.sum()) == sum(n) > 500
    assert list(par.drives["start_time"]) == [starts[i] for i in range(N_DRIVES)]
    assert isinstance(par.map, M.FrictionGrid) and set(par.drives["cells"]) == {"square"}


@functools.cache
def _table_cached(i: int):
    from roadgrip.estimators import run_estimator

    return run_estimator("cascade", _drives()[i]).table


def _table(drive):
    return _table_cached(next(i for i, d in enumerate(_drives()) if d is drive))


@settings(max_examples=25, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.permutations(range(N_DRIVES)), st.lists(st.integers(1, N_DRIVES - 1), max_size=3, unique=True),
       st.randoms())
def test_fleet_map_independent_of_order_and_partitioning(order, cuts, rnd):
    """Drives in any order, cut into any partitions merged in any tree: the sequential map to 1e-12."""
    parts = _parts()
    reference = merge_parts(list(parts))
    shuffled = [parts[i] for i in order]
    edges = [0, *sorted(cuts), N_DRIVES]
    groups = [merge_parts(shuffled[a:b]) for a, b in itertools.pairwise(edges)]
    while len(groups) > 1:
        i = rnd.randrange(len(groups) - 1)
        groups[i:i + 2] = [merge_parts([groups[i], groups[i + 1]])]
    _same(groups[0].map, reference.map)
    assert sorted(groups[0].drives["start_time"]) == sorted(reference.drives["start_time"])
    assert int(groups[0].map.cells.n_obs.sum()) == int(reference.drives["observations"].sum())


def test_age_decay_weights_a_drive_by_exp_minus_its_age_over_tau():
    """The same drive an hour and a day later: the older one weighs exp(-dt / tau) of the newer."""
    tau = 6 * HOUR
    d = _drives()[0]
    cfg = FleetConfig(tau=tau)
    old = drive_part(d, cfg, start_time=0.0)
    new = drive_part(d, cfg, start_time=24 * HOUR)
    both = merge_parts([new, old]).map
    f = np.exp(-24 * HOUR / tau)
    np.testing.assert_allclose(both.cells.s0, new.map.cells.s0 * (1 + f), rtol=1e-12)
    np.testing.assert_array_equal(both.cells.n_obs, 2 * new.map.cells.n_obs)
    # without decay both count fully: the posterior mean is that of one copy
    flat = FleetConfig(tau=float("inf"))
    one = drive_part(d, flat, 0.0).map
    m2 = merge_parts([drive_part(d, flat, 0.0), drive_part(d, flat, 24 * HOUR)]).map
    np.testing.assert_allclose(m2.cells.s0, 2 * one.cells.s0, rtol=1e-12)


def _with_gnss(drive, origin=(48.137, 11.575)):
    from roadgrip.mapping.geo import from_local

    lat, lon = from_local(drive.col("x"), drive.col("y"), origin)
    return drive.with_data(drive.data.assign(lat=lat, lon=lon))


def test_gnss_drives_map_on_h3_hexagons_at_their_observations():
    pytest.importorskip("h3")
    from roadgrip.mapping.geo import geo_observations, to_local

    d = _with_gnss(_drives()[1])
    part = drive_part(d, FleetConfig(h3_resolution=15))
    assert isinstance(part.map, M.HexGrid) and part.drives["cells"].iloc[0] == "h3"
    table = _table_cached(1)
    obs, lat, lon = geo_observations(table, d.t, d.col("lat"), d.col("lon"), 0.5)
    assert len(obs.mu) == len(M.observations_from_estimates(table, 0.5).mu)  # every one has a fix
    # the observations land where the pose put them (the GNSS track was made from it)
    x, y = to_local(lat, lon, (48.137, 11.575))
    np.testing.assert_allclose(x, obs.x, atol=1e-6)
    np.testing.assert_allclose(y, obs.y, atol=1e-6)
    assert int(part.map.cells.n_obs.sum()) == len(obs.mu) == part.drives["observations"].iloc[0]
    with pytest.raises(ValueError, match="cannot share a map"):
        merge_parts([part, _parts()[0]])


def test_fleet_options_are_checked():
    with pytest.raises(ValueError, match="tau must be positive"):
        FleetConfig(tau=0.0)
    with pytest.raises(ValueError, match="h3_resolution"):
        FleetConfig(h3_resolution=16)
    with pytest.raises(ValueError, match="no drives"):
        fleet_map([])


def test_square_cells_of_gnss_drives_in_a_given_frame_equal_the_pose_grid():
    """GNSS made from the pose about ORIGIN, square cells about ORIGIN: the pose's cells, in WGS84."""
    origin = (48.137, 11.575)
    d = _drives()[2]
    part = drive_part(_with_gnss(d, origin), FleetConfig(cells="square", origin=origin), start_time=0.0)
    ref = drive_part(d, FleetConfig(cells="square"), start_time=0.0)
    assert part.map.origin == origin and ref.map.origin is None
    np.testing.assert_array_equal(part.map.cells.key, ref.map.cells.key)
    np.testing.assert_array_equal(part.map.cells.n_obs, ref.map.cells.n_obs)
    np.testing.assert_allclose(part.map.cell_posterior()[0], ref.map.cell_posterior()[0], rtol=1e-12)
    with pytest.raises(ValueError, match="origin must be"):
        FleetConfig(origin=(91.0, 0.0))


def test_a_refused_drive_adds_nothing_and_says_why(tmp_path):
    """A drive the reader refuses (a file cut short) leaves the others' map as it is and
    names the reason in its row; a fleet of refused drives only is refused."""
    pytest.importorskip("distributed")
    drives = list(_drives())[:2]
    paths = []
    for i, d in enumerate(drives):
        paths.append(tmp_path / f"d{i}.parquet")
        d.save(paths[-1])
    bad = tmp_path / "cut.parquet"
    bad.write_bytes(paths[0].read_bytes()[:200])
    starts = {0: 0.0, 1: HOUR, 2: 2 * HOUR}
    good = sequential_fleet_map(paths, FleetConfig(), {0: starts[0], 1: starts[2]})
    for build in (lambda s: sequential_fleet_map(s, FleetConfig(), starts),
                  lambda s: fleet_map(s, FleetConfig(), n_workers=2, processes=False, start_times=starts)):
        part = build([paths[0], bad, paths[1]])
        _same(part.map, good.map)
        assert list(part.drives["source"]) == [str(paths[0]), str(bad), str(paths[1])]
        assert list(part.drives["refused"] == "") == [True, False, True]
        assert part.drives["refused"].iloc[1] and "\n" not in part.drives["refused"].iloc[1]
        assert int(part.drives["observations"].iloc[1]) == 0
    with pytest.raises(ValueError, match=r"no drive could be mapped: all 2 were refused; the first, .*cut\.parquet"):
        sequential_fleet_map([bad, bad], FleetConfig())
