"""The figures say what the data say: axes that hold the curves, legends for every mark,
standstill left out of slip angles, titles that fit, no-data cells drawn as no data, and one
friction colour scale for every map.

Figures are caught where their writer closes them, so each test reads the Figure and Axes
objects that were written (limits, legend entries, plotted data, colour map and norm).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, conform
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS

LONG_SOURCE = "/data/" + "/".join(f"campaign_{k:02d}_recordings_of_the_test_track" for k in range(6)) + \
    "/car_1_Datarecording_09_09_2024_14_12_45.csv"
"""A source path far wider than any figure."""


@pytest.fixture
def written(monkeypatch):
    """The figures that writers close, in order (kept open; closed after the test)."""
    figs: list = []
    monkeypatch.setattr(plt, "close", figs.append)
    yield figs
    monkeypatch.undo()
    for f in figs:
        plt.close(f)


def _legend_texts(fig) -> set[str]:
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    return {t.get_text() for lg in legends if lg is not None for t in lg.get_texts()}


def _inside(fig, artist) -> bool:
    fig.canvas.draw()
    box = artist.get_window_extent(fig.canvas.get_renderer())
    return box.x0 >= fig.bbox.x0 - 0.5 and box.x1 <= fig.bbox.x1 + 0.5


# -- GP-SSM curves (paper 000, Fig. 1) ------------------------------------------------------
STOP_S = 5.0
"""The drive stands still for its first seconds, steered to -18 deg."""
STEER_AT_REST = np.radians(-18.0)


def _gpssm_run(min_speed: float = 0.5):
    """A dry drive that stands still (front slip = steering) then slaloms, with its GP-SSM output."""
    t = np.arange(0.0, 20.0 + 1e-9, 0.1)
    moving = t >= STOP_S
    vx = np.where(moving, 10.0, 0.0)
    steer = np.where(moving, 0.03 * np.sin(t), STEER_AT_REST)
    df = pd.DataFrame({"t": t, "vx": vx, "steer": steer, "yaw_rate": 0.1 * np.sin(t) * moving,
                       "ay": 3.0 * np.sin(t) * moving})
    drive = Drive.from_frame(df, PRESETS["sedan"], source=LONG_SOURCE)
    table = pd.DataFrame({"t": t, "alpha_f": np.where(moving, 0.04 * np.sin(t), STEER_AT_REST),
                          "alpha_r": np.where(moving, 0.03 * np.sin(t), 0.0)})
    grid = np.linspace(-0.35, 0.35, 141)
    dry = SURFACES["dry_asphalt"].lateral  # peak friction 1.0
    curves = pd.concat([
        pd.DataFrame({"t": tc, "axle": axle, "alpha": grid, "mu_mean": dry.mu(grid) * 0.98,
                      "mu_lower": dry.mu(grid) - 0.08, "mu_upper": dry.mu(grid) + 0.08,
                      "mu_prior": 0.05 * np.tanh(grid / 0.02), "mu_true": dry.mu(grid)})
        for tc in (10.0, 20.0) for axle in ("front", "rear")
    ])
    meta = {"config": {"min_speed": min_speed, "vx_source": "auto"}}
    return drive, EstimateResult("gpssm", conform(table), meta, curves)


def _gpssm_figure(written, tmp_path, min_speed: float = 0.5):
    from roadgrip.plots.gpssm import plot_result

    drive, res = _gpssm_run(min_speed)
    plot_result(drive, res, tmp_path / "fig1.png")
    assert (tmp_path / "fig1.png").stat().st_size > 10_000
    return written[-1], res


def _curve_axes(fig):
    return [ax for ax in fig.axes if ax.get_ylabel().endswith("friction mu [-]") or
            any(ln.get_label() == "posterior mean" for ln in ax.get_lines())]


def test_gpssm_friction_axis_holds_a_dry_curve_its_band_and_truth(written, tmp_path):
    fig, res = _gpssm_figure(written, tmp_path)
    c = res.curves
    lo = float(np.nanmin(c[["mu_lower", "mu_true"]].to_numpy()))
    hi = float(np.nanmax(c[["mu_upper", "mu_true"]].to_numpy()))
    axes = _curve_axes(fig)
    assert len(axes) == 4  # 2 snapshots x 2 axles
    for ax in axes:
        y0, y1 = ax.get_ylim()
        assert y0 < lo and y1 > hi  # nothing drawn leaves the axes (was fixed at +-0.6)
        assert (y1 - y0) < 1.3 * (hi - lo)  # and the margin is a margin, not a zoom-out
        for ln in ax.get_lines():
            y = np.asarray(ln.get_ydata(), float)
            if ln.get_label() in ("posterior mean", "truth"):
                assert np.nanmax(y) < y1 and np.nanmin(y) > y0


def test_gpssm_every_mark_has_a_legend_entry(written, tmp_path):
    fig, _ = _gpssm_figure(written, tmp_path)
    texts = _legend_texts(fig)
    green = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_color() == "g"]
    assert green, "the visited-range lines are drawn"
    assert {ln.get_label() for ln in green if not ln.get_label().startswith("_")} <= texts
    assert "range of visited slip angles" in texts
    assert {"posterior mean", "95 % band", "truth", "prior"} <= texts


def test_gpssm_visited_slip_angles_leave_out_standstill(written, tmp_path):
    fig, res = _gpssm_figure(written, tmp_path)
    t = res.table["t"].to_numpy()
    moving = t >= STOP_S
    hist_axes = [ax for ax in fig.axes if ax.get_xlabel() == "slip angle alpha [deg]" and ax.patches]
    last = hist_axes[-1]  # the snapshot at the end: every moving sample visited
    bars = [p for p in last.patches if p.get_height() > 0]
    left = min(p.get_x() for p in bars)
    assert left > -5.0, "the -18 deg of the standing car is not a visited slip angle"
    assert sum(p.get_height() for p in bars) == 2 * moving.sum()  # front and rear, moving only
    lines = [ln.get_xdata()[0] for ax in fig.axes for ln in ax.get_lines() if ln.get_color() == "g"]
    assert min(lines) > -5.0


def test_gpssm_standstill_threshold_is_the_runs(written, tmp_path):
    """A run whose ``min_speed`` lies above every speed of the drive visited no slip angle."""
    fig, _ = _gpssm_figure(written, tmp_path, min_speed=12.0)
    assert not [p for ax in fig.axes for p in ax.patches if p.get_height() > 0 and p.get_width() < 5]
    assert not [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_color() == "g"]


def test_gpssm_title_fits_a_long_source(written, tmp_path):
    fig, _ = _gpssm_figure(written, tmp_path)
    title = fig.get_suptitle()
    assert title.endswith(".csv") and title.startswith("/data/")
    assert _inside(fig, fig._suptitle)


# -- Kalman cascade ---------------------------------------------------------------------------
def _cascade_run(v_min: float | None = None):
    """Starts from rest: at walking pace the estimated slip angles reach +-75 deg."""
    t = np.arange(0.0, 30.0, 0.05)
    vx = np.minimum(t, 8.0)  # 1 m/s^2 from rest
    slow = vx < 1.0  # below every threshold tested
    alpha = np.where(slow, np.radians(75.0) * np.sign(np.sin(5 * t)), 0.05 * np.sin(t))
    mu = np.full(len(t), 0.8)
    table = pd.DataFrame({
        "t": t, "vx": vx, "vy": 0.1 * np.sin(t), "Fyf": 2000 * np.sin(t), "Fyr": 1800 * np.sin(t),
        "Fyf_std": np.full(len(t), 100.0), "Fyr_std": np.full(len(t), 100.0),
        "alpha_f": alpha, "alpha_r": 0.7 * alpha, "mu_front": mu, "mu_rear": mu,
        "mu_front_lower": mu - 0.2, "mu_front_upper": mu + 0.2, "mu_rear_lower": mu - 0.2,
        "mu_rear_upper": mu + 0.2,
    })
    df = pd.DataFrame({"t": t, "vx": vx, "steer": 0.02 * np.sin(t), "yaw_rate": 0.1 * np.sin(t),
                       "ay": 2.0 * np.sin(t), "alpha_f_true": alpha, "alpha_r_true": 0.7 * alpha})
    drive = Drive.from_frame(df, PRESETS["sedan"], source=LONG_SOURCE)
    meta = {} if v_min is None else {"config": {"v_min": v_min}}
    return drive, EstimateResult("cascade", conform(table), meta)


def _cascade_figure(written, tmp_path, v_min=None):
    from roadgrip.plots.cascade import plot_result

    drive, res = _cascade_run(v_min)
    plot_result(drive, res, tmp_path / "cascade.png")
    return written[-1], res


def _slip_lines(fig):
    ax = next(a for a in fig.axes if a.get_ylabel() == "slip angle [deg]")
    return ax, {ln.get_label(): np.asarray(ln.get_ydata(), float) for ln in ax.get_lines()}


@pytest.mark.parametrize("v_min", [None, 2.0])
def test_cascade_slip_angles_are_hidden_below_the_runs_v_min(written, tmp_path, v_min):
    from roadgrip.estimators import get

    fig, res = _cascade_figure(written, tmp_path, v_min)
    threshold = get("cascade").Config.v_min if v_min is None else v_min
    vx = res.table["vx"].to_numpy()
    ax, lines = _slip_lines(fig)
    assert {"alpha_f", "alpha_r", "alpha_f_true", "alpha_r_true"} <= set(lines)
    for y in (lines["alpha_f"], lines["alpha_r"], lines["alpha_f_true"], lines["alpha_r_true"]):
        assert np.isnan(y[vx < threshold]).all()
        assert np.isfinite(y[vx >= threshold]).all()
    assert any(f"vx < {threshold:g} m/s" in s for s in _legend_texts(fig))
    assert max(np.abs(ax.get_ylim())) < 20.0  # the axis holds the moving car's few degrees, not 75


def test_cascade_title_fits(written, tmp_path):
    fig, _ = _cascade_figure(written, tmp_path)
    assert fig.get_suptitle().startswith("Kalman cascade") and fig.get_suptitle().endswith(".csv")
    assert _inside(fig, fig._suptitle)


# -- friction maps ------------------------------------------------------------------------------
def _grid():
    """Observations on one side of an oval; the path around it passes unobserved cells."""
    from roadgrip.mapping import empty_grid, fuse

    th = np.linspace(0, 2 * np.pi, 400)
    x, y = 5 * np.cos(th), 3 * np.sin(th)
    sel = np.cos(th) > 0.8
    return fuse(empty_grid(0.5), x[sel], y[sel], 0.9 + 0.1 * np.sin(th[sel]), np.full(sel.sum(), 0.01),
                path=np.c_[x, y])


def _images(fig):
    return [im for ax in fig.axes for im in ax.images]


def test_map_draws_cells_without_data_as_no_data_in_both_panels(written, tmp_path):
    from roadgrip.plots.maps import plot_grid

    g = _grid()
    plot_grid(g, tmp_path / "map.png")
    fig = written[-1]
    mean_img, std_img = _images(fig)
    visited = g.n_obs >= 1
    assert (~visited).any()
    for im in (mean_img, std_img):
        a = np.ma.masked_invalid(im.get_array())
        assert a.mask[~visited].all(), "a cell without data takes no colour of the scale"
        assert not a.mask[visited].any()
        ax = im.axes
        # the axes show the whole driven path (beyond the observed cells' bounding box) ...
        assert ax.get_xlim()[0] <= g.path[:, 0].min() and ax.get_xlim()[1] >= g.path[:, 0].max()
        assert ax.get_ylim()[0] <= g.path[:, 1].min() and ax.get_ylim()[1] >= g.path[:, 1].max()
        # ... over a hatched background that stands for no data
        assert any(p.get_hatch() for p in ax.patches)
    assert "no data" in _legend_texts(fig)


def test_report_map_draws_cells_without_data_as_no_data():
    from roadgrip.plots.signals import plot_map

    cells = pd.DataFrame({"x": [0.25, 0.75, 1.25], "y": [0.25, 0.25, 0.25], "mu_mean": [0.3, 0.9, 0.7],
                          "mu_std": [0.05, 0.05, 0.4], "n_obs": [12, 40, 0]})
    fig = plot_map(cells, 0.5, (np.array([-2.0, 3.0]), np.array([-1.0, 2.0])))
    for im in _images(fig):
        a = np.ma.masked_invalid(im.get_array())
        assert a.mask[0, 2] and not a.mask[0, :2].any()  # the unobserved cell, in both panels
        assert im.axes.get_xlim()[0] <= -2.0 and im.axes.get_ylim()[1] >= 2.0
        assert any(p.get_hatch() for p in im.axes.patches)
    assert "no data" in _legend_texts(fig)
    plt.close(fig)


def test_map_command_and_report_use_one_friction_scale(written, tmp_path):
    from roadgrip.plots.maps import plot_grid
    from roadgrip.plots.signals import plot_map

    g = _grid()
    plot_grid(g, tmp_path / "map.png")
    command = _images(written[-1])
    report = _images(plot_map(g.cells_frame(), g.cell, (g.path[:, 0], g.path[:, 1])))
    assert len(command) == len(report) == 2
    for a, b in zip(command, report, strict=True):  # mean, then std
        assert a.get_cmap().name == b.get_cmap().name
        assert (a.norm.vmin, a.norm.vmax) == (b.norm.vmin, b.norm.vmax)
        # one value, one colour, in both figures
        assert np.allclose(a.to_rgba(np.array([0.25, 0.9])), b.to_rgba(np.array([0.25, 0.9])))
    from roadgrip.plots.scales import FRICTION_CMAP, FRICTION_RANGE, STD_CMAP, STD_RANGE

    assert (command[0].get_cmap().name, (command[0].norm.vmin, command[0].norm.vmax)) == (
        FRICTION_CMAP, FRICTION_RANGE) and FRICTION_RANGE == (0.0, 1.2)  # fixed, not the data's range
    assert (command[1].get_cmap().name, (command[1].norm.vmin, command[1].norm.vmax)) == (STD_CMAP, STD_RANGE)
