"""Interactive friction-map page (Folium / Leaflet), written beside the PNG heat map.

One polygon per observed cell, coloured by the posterior mean friction, with a
tooltip of ``mu_mean``, ``mu_std`` and ``n_obs``, over the driven path the grid keeps. Maps in WGS84 (H3 maps, grids with a
GNSS origin) are drawn in Web Mercator, over OpenStreetMap tiles when ``basemap`` is set;
maps in a local frame are drawn in metres (Leaflet's ``CRS.Simple``, x east, y north).
Leaflet's script and style are inlined from the ``xstatic-leaflet`` package, and no other
asset is fetched, so the page opens offline (the basemap tiles excepted).
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import Normalize, to_hex

from roadgrip.mapping import FrictionGrid, HexGrid

__all__ = ["write_map_page"]


def _leaflet_assets() -> str:
    """Leaflet's CSS and JS as inline ``<style>`` and ``<script>`` elements."""
    import xstatic.pkg.leaflet as xl

    base = Path(xl.BASE_DIR)
    css = (base / "leaflet.css").read_text(encoding="utf-8")
    js = (base / "leaflet.js").read_text(encoding="utf-8").replace("</script", "<\\/script")
    return f"<style>{css}</style>\n<script>{js}</script>"


def _legend(lo: float, hi: float, cmap: str) -> str:
    stops = ", ".join(to_hex(colormaps[cmap](v)) for v in np.linspace(0, 1, 6))
    return (
        '<div id="mu-legend" style="position: fixed; bottom: 64px; left: 12px; z-index: 1000; '
        'background: white; padding: 6px 10px; font: 12px sans-serif; border: 1px solid #888;">'
        f'friction coefficient mu [-]<div style="width: 180px; height: 12px; background: '
        f'linear-gradient(to right, {stops});"></div>'
        f'<span>{lo:.2f}</span><span style="float: right;">{hi:.2f}</span></div>'
    )


def _add_path(m, grid: FrictionGrid | HexGrid) -> None:
    """The driven path a grid keeps (rows of NaN separate drives), as grey lines."""
    import folium

    path = getattr(grid, "path", np.zeros((0, 2)))
    if not path.size:
        return
    x, y = path[:, 0], path[:, 1]
    if grid.origin is not None:
        from roadgrip.mapping.geo import from_local

        y, x = from_local(x, y, grid.origin)
    gap = ~(np.isfinite(x) & np.isfinite(y))
    for seg in np.split(np.arange(len(x)), np.flatnonzero(gap)):
        seg = seg[~gap[seg]]
        if len(seg) > 1:
            folium.PolyLine(np.column_stack([y[seg], x[seg]]).tolist(), color="#777777", weight=1,
                            opacity=0.7).add_to(m)


def write_map_page(
    grid: FrictionGrid | HexGrid,
    path: str | Path,
    *,
    title: str | None = None,
    png: str | Path | None = None,
    min_obs: int = 1,
    basemap: bool = True,
) -> Path:
    """Write the interactive map page (HTML).

    Parameters
    ----------
    grid : FrictionGrid or HexGrid
    path : str or Path
        Output ``.html``.
    title : str, optional
        Page title.
    png : str or Path, optional
        The static heat map written beside it, linked from the page.
    min_obs : int
        Cells drawn (at least this many observations).
    basemap : bool
        OpenStreetMap tiles under a WGS84 map (fetched by the browser).

    Returns
    -------
    Path
        ``path``.
    """
    import folium

    from roadgrip.mapping.geo import map_frame

    path = Path(path)
    frame = map_frame(grid, min_obs)
    geographic = frame.crs is not None
    cmap = "viridis"
    if len(frame):
        lo, hi = float(frame["mu_mean"].min()), float(frame["mu_mean"].max())
        x0, y0, x1, y1 = (float(v) for v in frame.total_bounds)
    else:
        lo, hi = grid.prior_mean - 0.15, grid.prior_mean + 0.15
        x0, y0, x1, y1 = (0.0, 0.0, 1.0, 1.0)
    if hi - lo < 0.3:
        mid = 0.5 * (lo + hi)
        lo, hi = max(mid - 0.15, 0.0), mid + 0.15
    norm = Normalize(lo, hi)
    frame = frame.assign(fill=[to_hex(colormaps[cmap](norm(v))) for v in frame["mu_mean"]],
                         mu_mean=frame["mu_mean"].round(3), mu_std=frame["mu_std"].round(3))
    if not geographic:
        frame = frame.set_crs(None, allow_override=True)
    centre = [0.5 * (y0 + y1), 0.5 * (x0 + x1)]
    m = folium.Map(location=centre, tiles=None, crs="EPSG3857" if geographic else "Simple", zoom_start=1,
                   control_scale=geographic, prefer_canvas=False)
    m.default_js, m.default_css = [], []  # Leaflet is inlined below; nothing is fetched
    m.get_root().header.add_child(folium.Element(_leaflet_assets()))
    if geographic and basemap:
        folium.TileLayer("OpenStreetMap").add_to(m)
    keep = [c for c in ("h3", "ix", "iy", "mu_mean", "mu_std", "n_obs", "fill") if c in frame.columns]
    folium.GeoJson(
        frame[[*keep, "geometry"]].__geo_interface__,
        name="friction",
        style_function=lambda f: {"fillColor": f["properties"]["fill"], "color": f["properties"]["fill"],
                                  "weight": 0.5, "fillOpacity": 0.8},
        tooltip=folium.GeoJsonTooltip(fields=["mu_mean", "mu_std", "n_obs"],
                                      aliases=["mu mean [-]", "mu std [-]", "observations"]),
    ).add_to(m)
    _add_path(m, grid)
    m.fit_bounds([[y0, x0], [y1, x1]])
    head = html.escape(title or f"friction map: {len(frame)} cells")
    link = f' &middot; <a href="{html.escape(Path(png).name)}">static map (PNG)</a>' if png else ""
    m.get_root().html.add_child(folium.Element(
        f'<div id="map-title" style="position: fixed; top: 10px; left: 60px; z-index: 1000; background: white; '
        f'padding: 4px 8px; font: 14px sans-serif; border: 1px solid #888;">{head}{link}</div>'
        + _legend(lo, hi, cmap)))
    m.get_root().title = head
    m.save(str(path))
    return path
