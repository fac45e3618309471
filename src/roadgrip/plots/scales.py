"""The colour scales of the friction figures, defined once, and how cells without data look.

The map command's heat map (:func:`roadgrip.plots.maps.grid_figure`) and the report's map
(:func:`roadgrip.plots.signals.plot_map`) both take their colours from here, so one colour
means one friction value in every figure:

==============  ===========  ==========  ================================================
quantity        colour map   range [-]   reading
==============  ===========  ==========  ================================================
friction        ``RdYlGn``   0 to 1.2    absolute friction (force over load): red is ice
                                         and snow, yellow gravel and wet, green dry
std of friction ``magma_r``  0 to 0.4    pale is certain, dark is uncertain; 0.4 is the
                                         default prior width of a map cell
                                         (:class:`~roadgrip.mapping.FrictionGrid`)
==============  ===========  ==========  ================================================

Values beyond a range are drawn in its end colour (the colour bars say so with an arrow).

A cell without an observation is *no data*, never a colour of the scale: its value is NaN
(drawn transparent) over the hatched grey background of :func:`draw_no_data`, and the
figure carries a "no data" legend entry (:func:`no_data_handle`). A blank or pale cell
would read as friction or as certainty that no measurement supports.
"""

from __future__ import annotations

from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.colors import Colormap, Normalize
from matplotlib.patches import Patch, Rectangle

__all__ = [
    "FRICTION_CMAP",
    "FRICTION_RANGE",
    "NO_DATA_LABEL",
    "STD_CMAP",
    "STD_RANGE",
    "draw_no_data",
    "friction_scale",
    "no_data_handle",
    "std_scale",
]

FRICTION_CMAP = "RdYlGn"
"""Colour map of friction [-]."""
FRICTION_RANGE = (0.0, 1.2)
"""Colour range of friction [-]: from no grip to above dry asphalt's peak."""
STD_CMAP = "magma_r"
"""Colour map of the standard deviation of friction [-]."""
STD_RANGE = (0.0, 0.4)
"""Colour range of the standard deviation of friction [-] (0.4: a map cell's default prior)."""
NO_DATA_LABEL = "no data"
"""Legend text of cells without an observation."""
_NO_DATA_FACE = "#e9ecef"
_NO_DATA_HATCH_COLOUR = "#adb5bd"
_NO_DATA_HATCH = "///"


def _scale(name: str, lo: float, hi: float) -> tuple[Colormap, Normalize]:
    # NaN (no data) transparent: the hatched background shows through
    return colormaps[name].with_extremes(bad=(0.0, 0.0, 0.0, 0.0)), Normalize(lo, hi)


def friction_scale() -> tuple[Colormap, Normalize]:
    """The colour map and norm of friction [-] (:data:`FRICTION_CMAP` over :data:`FRICTION_RANGE`).

    Examples
    --------
    >>> cmap, norm = friction_scale()
    >>> cmap.name, norm.vmin, norm.vmax
    ('RdYlGn', 0.0, 1.2)
    """
    return _scale(FRICTION_CMAP, *FRICTION_RANGE)


def std_scale() -> tuple[Colormap, Normalize]:
    """The colour map and norm of the standard deviation of friction [-]."""
    return _scale(STD_CMAP, *STD_RANGE)


def no_data_handle() -> Patch:
    """A legend handle of the no-data background, labelled :data:`NO_DATA_LABEL`."""
    return Patch(facecolor=_NO_DATA_FACE, edgecolor=_NO_DATA_HATCH_COLOUR, hatch=_NO_DATA_HATCH,
                 label=NO_DATA_LABEL)


def draw_no_data(ax: Axes) -> Rectangle:
    """Fill ``ax``'s background with the hatched grey of cells without data; return the patch.

    Everything drawn later lies above it: cells with data hide it, NaN cells show it.
    """
    patch = Rectangle((0.0, 0.0), 1.0, 1.0, transform=ax.transAxes, facecolor=_NO_DATA_FACE,
                      edgecolor=_NO_DATA_HATCH_COLOUR, hatch=_NO_DATA_HATCH, linewidth=0.0,
                      zorder=-10, label="_no data background")
    ax.add_patch(patch)
    return patch
