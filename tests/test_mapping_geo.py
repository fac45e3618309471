"""Map files in GeoJSON / GeoParquet (WGS84 for GNSS grids and H3 maps) and the interactive map page."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip import mapping as M

gpd = pytest.importorskip("geopandas")
geo = pytest.importorskip("roadgrip.mapping.geo")

ORIGIN = (48.137, 11.575)
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _obs(n=400, seed=0):
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-5, 10, n), rng.uniform(-3, 6, n)
    return x, y, 0.5 + 0.03 * x, rng.uniform(0.005, 0.05, n)


def test_gnss_grid_written_in_wgs84_with_cells_of_the_right_size(tmp_path):
    x, y, mu, var = _obs()
    g = M.fuse(M.empty_grid(0.5, origin=ORIGIN), x, y, mu, var)
    for name in ("map.geojson", "map.parquet"):
        geo.write_map(g, tmp_path / name)
        back = gpd.read_file(tmp_path / name) if name.endswith("json") else gpd.read_parquet(tmp_path / name)
        assert back.crs.to_epsg() == 4326 and len(back) == g.n_cells
        cells = g.cells_frame()
        np.testing.assert_allclose(back["mu_mean"], cells["mu_mean"], rtol=1e-12)
        np.testing.assert_allclose(back["mu_std"], cells["mu_std"], rtol=1e-12)
        assert back["n_obs"].sum() == 400
        # back in the local frame: squares of 0.5 m at the cells' places (GeoJSON keeps 7 decimals, 1 cm)
        local = back.to_crs(f"+proj=aeqd +lat_0={ORIGIN[0]} +lon_0={ORIGIN[1]} +datum=WGS84 +units=m")
        tol = 1e-6 if name.endswith("parquet") else 0.02
        np.testing.assert_allclose(local.area, 0.25, rtol=tol * 4)
        np.testing.assert_allclose(local.centroid.x, cells["x"], atol=tol)
        np.testing.assert_allclose(local.centroid.y, cells["y"], atol=tol)
        np.testing.assert_allclose(back["lat"], geo.from_local(cells["x"], cells["y"], ORIGIN)[0], atol=1e-9)
    with pytest.raises(ValueError, match=r"map.shp: a map file is .geojson"):
        geo.write_map(g, tmp_path / "map.shp")


def test_local_grid_written_in_metres_without_crs(tmp_path):
    x, y, mu, var = _obs()
    g = M.fuse(M.empty_grid(0.5), x, y, mu, var)
    geo.write_map(g, tmp_path / "map.parquet")
    back = gpd.read_parquet(tmp_path / "map.parquet")
    assert back.crs is None
    b = back.geometry.bounds
    np.testing.assert_allclose(b["minx"], back["ix"] * 0.5)
    np.testing.assert_allclose(b["maxy"], (back["iy"] + 1) * 0.5)


def test_hexagon_map_polygons_hold_their_cells(tmp_path):
    lat, lon = geo.from_local(*_obs()[:2], ORIGIN)
    _, _, mu, var = _obs()
    h = M.fuse_hex(M.empty_hexgrid(13), lat, lon, mu, var)
    geo.write_map(h, tmp_path / "hex.geojson")
    back = gpd.read_file(tmp_path / "hex.geojson")
    assert len(back) == h.n_cells and back["n_obs"].sum() == 400 and back.crs.to_epsg() == 4326
    pts = gpd.points_from_xy(back["lon"], back["lat"])
    assert all(poly.contains(p) for poly, p in zip(back.geometry, pts, strict=True))
    # every observation lies in the hexagon holding its count
    got = gpd.GeoDataFrame(geometry=gpd.points_from_xy(lon, lat), crs=4326).sjoin(back, predicate="within")
    assert len(got) == 400


def test_grid_from_gnss_equals_the_grid_from_the_pose_it_was_made_from():
    """A GNSS track made from the pose about ORIGIN gives the pose's grid (observations at the axles)."""
    n = 400
    t = np.arange(n) * 0.02
    x = np.linspace(0.013, 8.013, n)
    exc = np.arange(n) % 3 == 0
    tab = pd.DataFrame({"t": t, "x": x, "y": np.zeros(n) + 0.2, "x_front": x + 0.1, "y_front": np.zeros(n) + 0.8,
                        "mu_front_obs": np.where(exc, 0.5 + 0.01 * x, np.nan),
                        "mu_front_obs_std": np.where(exc, 0.1, np.inf), "excited_front": exc})
    lat, lon = geo.from_local(x, np.zeros(n) + 0.2, ORIGIN)
    g = geo.grid_from_estimates_geo(tab, t, lat, lon, 0.5, origin=ORIGIN)
    ref = M.grid_from_estimates(tab, 0.5)
    assert g.origin == ORIGIN and g.n_cells == ref.n_cells
    np.testing.assert_array_equal(g.cells.key, ref.cells.key)
    np.testing.assert_allclose(g.cell_posterior()[0], ref.cell_posterior()[0], rtol=1e-12)
    lat[:10] = np.nan  # no fix at the start: those observations are left out
    assert int(geo.grid_from_estimates_geo(tab, t, lat, lon, 0.5).cells.n_obs.sum()) == exc[10:].sum()


# -- the interactive page -------------------------------------------------------------------
@pytest.fixture(scope="module")
def page(tmp_path_factory):
    from roadgrip.plots.maps_web import write_map_page

    x, y, mu, var = _obs()
    g = M.fuse(M.empty_grid(0.5, origin=ORIGIN), x, y, mu, var)
    out = tmp_path_factory.mktemp("page") / "map.html"
    write_map_page(g, out, png="map.png", basemap=False)
    return out, g


def test_page_is_self_contained_with_one_polygon_per_cell(page):
    out, g = page
    text = out.read_text()
    assert not re.search(r"<script[^>]+src=|<link[^>]+href=\"http", text), "an asset would be fetched"
    assert "Leaflet" in text and "L.map(" in text and "L.geoJson(" in text
    assert text.count('"type": "Polygon"') == g.n_cells
    assert 'href="map.png"' in text and f"friction map: {g.n_cells} cells" in text


def _render(html_path: Path, tmp: Path) -> tuple[Path, str]:
    shot = tmp / "shot.png"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp / 'profile'}", "--enable-logging=stderr", "--v=0",
           f"--screenshot={shot}", "--window-size=1000,700", html_path.resolve().as_uri()]
    return shot, subprocess.run(cmd, capture_output=True, text=True, timeout=120).stderr


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed; the structural check above still runs")
def test_page_renders_the_cells_in_headless_chromium(page, tmp_path):
    from matplotlib.image import imread

    shot, stderr = _render(page[0], tmp_path)
    assert shot.is_file(), stderr[-2000:]
    img = imread(shot)[..., :3]
    errors = [ln for ln in stderr.splitlines() if ("CONSOLE" in ln and ("ERROR" in ln or "Uncaught" in ln))
              or "Failed to load resource" in ln or "net::ERR_" in ln]
    assert errors == []
    # the cells drew (coloured pixels, where an empty map is grey and white), and mu = 0.5 + 0.03 x
    # rises eastwards: viridis' purple (blue over green) in the west, yellow-green in the east
    cells = img.max(axis=2) - img.min(axis=2) > 0.15
    cells[:80], cells[-160:] = False, False  # title, legend and scale
    assert cells.mean() > 0.1, cells.mean()
    cols = np.flatnonzero(cells.any(axis=0))
    west, east = cols[: len(cols) // 5], cols[-len(cols) // 5:]
    b_minus_g = img[..., 2] - img[..., 1]
    assert b_minus_g[:, west][cells[:, west]].mean() > 0.1
    assert b_minus_g[:, east][cells[:, east]].mean() < -0.3


def test_page_draws_the_driven_path_split_between_drives(tmp_path):
    from roadgrip.plots.maps_web import write_map_page

    x, y, mu, var = _obs(50)
    path = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.0], [np.nan, np.nan], [5.0, 5.0], [6.0, 5.0]])
    g = M.fuse(M.empty_grid(0.5), x, y, mu, var, path=path)
    text = write_map_page(g, tmp_path / "p.html").read_text()
    assert text.count("L.polyline(") == 2 and "[0.5, 1.0]" in text  # [lat = y, lng = x] in CRS.Simple
