"""The sparse friction grid and H3 maps: memory follows the observed cells; merging is exact and order-free."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roadgrip import mapping as M
from roadgrip.mapping import cells as C
from roadgrip.mapping import hexgrid as H

_SETTINGS = settings(max_examples=40, derandomize=True, deadline=None, database=None,
                     suppress_health_check=[HealthCheck.too_slow])


def _obs(seed: int, n: int, spread: float):
    rng = np.random.default_rng(seed)
    return (rng.uniform(-spread, spread, n), rng.uniform(-spread, spread, n), rng.normal(0.6, 0.1, n),
            rng.uniform(0.01, 0.2, n), rng.uniform(0.0, 100.0, n), rng.uniform(0.0, 0.05, n))


def _same(a: C.CellSums, b: C.CellSums) -> None:
    np.testing.assert_array_equal(a.key, b.key)
    np.testing.assert_array_equal(a.n_obs, b.n_obs)
    for f in ("s0", "s1", "s2", "sb"):
        np.testing.assert_allclose(getattr(a, f), getattr(b, f), rtol=1e-12, atol=1e-300)


def test_square_keys_round_trip_and_sort_by_row_then_column():
    ix = np.array([-(2**31) + 1, -5, 0, 3, 2**31 - 1, 7])
    iy = np.array([0, -2, -2, 9, -(2**31) + 1, 2**31 - 1])
    key = C.square_keys(ix, iy)
    back = C.square_index(key)
    np.testing.assert_array_equal(back[0], ix)
    np.testing.assert_array_equal(back[1], iy)
    order = np.argsort(key)
    np.testing.assert_array_equal(order, np.lexsort((ix, iy)))
    with pytest.raises(ValueError, match="more than 2147483647 cells"):
        C.square_keys([2**31], [0])


def test_memory_follows_the_observed_cells_not_their_spread():
    """1000 observations scattered over 2 x 2 Mm of 0.5 m cells: 1000 rows of 48 bytes (dense: 1.6e13 cells)."""
    x, y, mu, var, _t, b = _obs(0, 1000, 1e6)
    g = M.fuse(M.empty_grid(0.5), x, y, mu, var, sys=b)
    assert g.n_cells == 1000 and g.nbytes == 1000 * C.BYTES_PER_CELL
    m, _s = g.query(x, y)
    w = 1 / var
    p0 = 1 / 0.4**2
    np.testing.assert_allclose(m, (0.7 * p0 + w * mu) / (p0 + w), rtol=1e-12)
    # a second fusion of the same positions adds to the same rows
    g2 = M.fuse(g, x, y, mu, var, sys=b)
    assert g2.n_cells == 1000 and int(g2.cells.n_obs.sum()) == 2000


@_SETTINGS
@given(st.integers(0, 2**16), st.integers(1, 6), st.sampled_from([0.5, 2.0]), st.booleans(), st.randoms())
def test_merge_in_any_order_and_partition_equals_one_fusion(seed, k, cell, forget, rnd):
    """Observations split into k drives, merged in a random order and tree: the one-grid fusion to 1e-12."""
    x, y, mu, var, t, b = _obs(seed, 300, 20.0)
    tau = 50.0 if forget else float("inf")
    whole = M.fuse(M.empty_grid(cell, tau=tau), x, y, mu, var, t=t, sys=b)
    cut = np.sort(rnd.sample(range(1, 300), k - 1)) if k > 1 else []
    parts = [M.fuse(M.empty_grid(cell, tau=tau), *(a[i] for a in (x, y, mu, var)), t=t[i], sys=b[i])
             for i in np.split(np.arange(300), cut)]
    rnd.shuffle(parts)
    while len(parts) > 1:  # a random tree of pairwise merges
        i = rnd.randrange(len(parts) - 1)
        parts[i:i + 2] = [M.merge(parts[i], parts[i + 1])]
    _same(parts[0].cells, whole.cells)
    assert int(parts[0].cells.n_obs.sum()) == 300 and parts[0].t_ref == whole.t_ref


def test_reading_the_dense_format_of_earlier_files(tmp_path):
    x, y, mu, var, _t, b = _obs(1, 50, 3.0)
    g = M.fuse(M.empty_grid(0.5), x, y, mu, var, sys=b)
    old = tmp_path / "old.npz"
    np.savez_compressed(old, cell=0.5, ix0=g.ix0, iy0=g.iy0, s0=g.s0, s1=g.s1, s2=g.s2, sb=g.sb, n_obs=g.n_obs,
                        prior_mean=0.7, prior_std=0.4, tau=np.inf, t_ref=-np.inf, overdispersion=True,
                        path=np.zeros((0, 2)), format="roadgrip-friction-grid-1")
    _same(M.FrictionGrid.from_npz(old).cells, g.cells)
    new = tmp_path / "new.npz"
    g2 = M.fuse(M.empty_grid(0.5, tau=30.0, origin=(48.1, 11.5)), x, y, mu, var, t=np.arange(50.0), sys=b)
    g2.to_npz(new)
    back = M.FrictionGrid.from_npz(new)
    _same(back.cells, g2.cells)
    assert (back.tau, back.t_ref, back.origin) == (30.0, 49.0, (48.1, 11.5))


def test_hexagon_map_is_the_precision_weighted_mean_and_merges_order_free():
    h3 = pytest.importorskip("h3")
    rng = np.random.default_rng(3)
    lat0, lon0 = 48.137, 11.575
    lat = lat0 + rng.normal(0, 2e-4, 200)  # ~ 20 m
    lon = lon0 + rng.normal(0, 3e-4, 200)
    mu, var = rng.normal(0.6, 0.1, 200), rng.uniform(0.01, 0.1, 200)
    g = H.fuse_hex(H.empty_hexgrid(12, overdispersion=False), lat, lon, mu, var)
    cell = h3.latlng_to_cell(lat[0], lon[0], 12)
    same = np.array([h3.latlng_to_cell(a, b, 12) == cell for a, b in zip(lat, lon, strict=True)])
    w = 1 / var[same]
    p0 = 1 / 0.4**2
    m, s = g.query(lat[0], lon[0])
    np.testing.assert_allclose(m, (0.7 * p0 + (w * mu[same]).sum()) / (p0 + w.sum()), rtol=1e-12)
    np.testing.assert_allclose(s, (p0 + w.sum()) ** -0.5, rtol=1e-12)
    frame = g.cells_frame()
    assert frame["n_obs"].sum() == 200 and cell in set(frame["h3"])
    a = H.fuse_hex(H.empty_hexgrid(12, overdispersion=False), lat[:70], lon[:70], mu[:70], var[:70])
    b = H.fuse_hex(H.empty_hexgrid(12, overdispersion=False), lat[70:], lon[70:], mu[70:], var[70:])
    _same(H.merge_hex(b, a).cells, g.cells)
    with pytest.raises(ValueError, match="observation 1 is not usable: lat = 91"):
        H.fuse_hex(g, [48.0, 91.0], [11.0, 11.0], [0.5, 0.5], [0.1, 0.1])
    with pytest.raises(ValueError, match="different resolution"):
        H.merge_hex(g, H.empty_hexgrid(13, overdispersion=False))


def test_figures_of_far_apart_cells_and_hexagons(tmp_path):
    """The PNG of a map whose cells lie 30 km apart (no dense image of 3.6e9 cells) and of an H3 map."""
    pytest.importorskip("h3")
    from roadgrip.plots.maps import plot_grid

    g = M.fuse(M.empty_grid(0.5), [0.0, 30_000.0], [0.0, 30_000.0], [0.5, 0.6], [0.01, 0.01])
    h = H.fuse_hex(H.empty_hexgrid(13), [48.1, 48.2], [11.5, 11.6], [0.5, 0.6], [0.01, 0.01])
    for name, m in (("far.png", g), ("hex.png", h)):
        plot_grid(m, tmp_path / name)
        assert (tmp_path / name).stat().st_size > 10_000


def test_compact_batches_summed_in_a_window_equal_the_sorted_sums():
    """The compiled window pass (compact batch) and the sort by key (scattered batch) give one table."""
    rng = np.random.default_rng(4)
    for spread in (3, 30, 3000):  # 6x6 .. 6000x6000 cells for 2000 observations: window, window, sort
        ix, iy = rng.integers(-spread, spread, 2000), rng.integers(-spread, spread, 2000)
        w, mu, b = rng.uniform(1, 100, 2000), rng.normal(0.6, 0.1, 2000), rng.uniform(0, 0.05, 2000)
        _same(C.cells_from_squares(ix, iy, w, mu, b), C.cells_from_observations(C.square_keys(ix, iy), w, mu, b))


_LAT = st.floats(-90, 90) | st.sampled_from([-90.0, 90.0, 0.0, 1e-300, float("nan"), 91.0, float("inf")])
_LON = st.floats(-180, 180) | st.sampled_from([-180.0, 180.0, 179.9999999, float("nan"), -181.0])


@_SETTINGS
@given(st.lists(st.tuples(_LAT, _LON, st.floats(-1, 3), st.floats(-1, 1)), min_size=1, max_size=6),
       st.integers(0, 15))
def test_hexagon_map_fuses_anywhere_on_the_globe_or_refuses_naming_the_observation(obs, res):
    lat, lon, mu, var = (np.array(v, float) for v in zip(*obs, strict=True))
    try:
        g = H.fuse_hex(H.empty_hexgrid(res), lat, lon, mu, var)
    except ValueError as exc:
        assert "observation" in str(exc), exc
        return
    assert int(g.cells.n_obs.sum()) == len(lat) and g.n_cells <= len(lat)
    m, s = g.cell_posterior()
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(s))
    qm, _ = g.query(lat, lon)
    assert set(np.round(qm, 12)) <= set(np.round(m, 12))


def test_a_cell_between_two_surfaces_widens_by_the_spread_of_its_neighbourhood():
    """Three cells in a row on 0.45 | 0.6 | 0.7: the middle cell's std is its own (prior and
    observations) plus the range 0.25 over sqrt(12); a neighbour with fewer than
    SPREAD_MIN_OBS observations does not count, and the end cells see only the middle one."""
    n = 20
    x = np.repeat([0.5, 1.5, 2.5], n)
    mu = np.repeat([0.45, 0.6, 0.7], n)
    g = M.fuse(M.empty_grid(1.0, overdispersion=False), x, np.full(3 * n, 0.5), mu, np.full(3 * n, 0.01))
    own_m, own_s = C.cell_posterior(g.cells, g.prior_mean, g.prior_std, False)
    m, s = g.cell_posterior()
    np.testing.assert_array_equal(m, own_m)
    r = np.array([own_m[1] - own_m[0], own_m[2] - own_m[0], own_m[2] - own_m[1]])
    np.testing.assert_allclose(s, np.sqrt(own_s**2 + r**2 / 12), rtol=1e-12)
    assert r[1] == pytest.approx(0.25, abs=2e-3)
    # a sparse neighbour (fewer observations than SPREAD_MIN_OBS) above it changes nothing
    k = C.SPREAD_MIN_OBS - 1
    g2 = M.fuse(g, np.full(k, 1.5), np.full(k, 1.5), np.full(k, 1.1), np.full(k, 0.01))
    assert g2.cell_posterior()[1][1] == pytest.approx(s[1], rel=1e-12)
    g3 = M.fuse(g2, [1.5], [1.5], [1.1], [0.01])
    assert g3.cell_posterior()[1][1] > s[1] + 0.02
    # a lone cell: its own posterior
    lone = M.fuse(M.empty_grid(1.0), [0.5] * 3, [0.5] * 3, [0.5] * 3, [0.01] * 3)
    np.testing.assert_allclose(lone.cell_posterior()[1], C.cell_posterior(lone.cells, 0.7, 0.4)[1], rtol=1e-12)


def test_square_neighbours_are_the_eight_around_and_stay_inside_the_index_range():
    key = C.square_keys([0, C.MAX_INDEX], [0, 5])
    nb = C.square_neighbours(key)
    ix, iy = C.square_index(nb[0])
    assert sorted(zip(ix.tolist(), iy.tolist(), strict=True)) == [
        (dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    ix, _ = C.square_index(nb[1])
    assert ix.max() == C.MAX_INDEX and (nb[1] == key[1]).sum() == 3


def test_hexagon_neighbours_share_an_edge():
    h3 = pytest.importorskip("h3")
    lat, lon = np.array([48.137, 48.1372]), np.array([11.575, 11.5753])
    g = H.fuse_hex(H.empty_hexgrid(12), lat, lon, [0.5, 0.6], [0.01, 0.01])
    nb = g.neighbour_keys()
    assert nb.shape == (g.n_cells, 6)
    for k, ring in zip(g.cells.key.tolist(), nb.tolist(), strict=True):
        s = h3.int_to_str(k)
        assert {h3.int_to_str(r) for r in ring} == set(h3.grid_ring(s, 1))
