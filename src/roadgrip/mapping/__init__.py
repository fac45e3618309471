r"""Friction grid: fuse position-stamped friction observations into 2-D cells.

Each observation is a friction value ``mu_i`` with variance ``v_i`` at a
position ``(x_i, y_i)``. A cell accumulates, with weights ``w_i = 1 / v_i``
(times an optional forgetting factor),

``S0 = sum w``,  ``S1 = sum w mu``,  ``S2 = sum w mu²``,  ``SB = sum w b``,  ``n = sum 1``

(``b_i >= 0`` is an optional systematic error of each observation: a part of its
error that is shared with its neighbours in time and does not average out)

so fusion is a sum: grids from several drives merge by adding their sums
(associative and commutative, no observation lost). A grid stores only the cells
that hold observations, as a table sorted by cell key (:mod:`roadgrip.mapping.cells`,
48 bytes a cell), so its memory follows the observed cells, not the extent of the map;
fusing sorts the observations' keys and sums equal ones. The cell posterior combines a
Gaussian prior ``N(prior_mean, prior_std²)`` with the data:

``precision = 1 / prior_std² + S0 / b``,
``mean = (prior_mean / prior_std² + S1 / b) / precision``,  ``var = 1 / precision``

plus the systematic part ``(SB / b / precision)²`` added to ``var``, and
where ``b >= 1`` is the Birge ratio ``chi² / (n - 1)`` with
``chi² = S2 - S1² / S0`` (the scatter of the observations about their mean in
units of their claimed variances), applied when ``overdispersion=True``: if the
observations in a cell disagree more than their variances allow (correlated
errors, model mismatch), the cell's uncertainty is inflated accordingly
instead of shrinking as ``1 / sqrt(n)``. Cells without observations report the
prior: a wide band, never a confident number.

What a cell's number answers is the friction where cars drive inside it, and the
observations of a cell come only from where a car was excited in it. A cell on the edge
between two surfaces may hold observations from one side only. Its standard deviation
therefore adds the sub-cell spread ``R / sqrt(12)`` in quadrature (the standard
deviation of a value anywhere in a range ``R``), with ``R`` the range of the posterior
means over the cell and its adjacent cells that hold at least
:data:`~roadgrip.mapping.cells.SPREAD_MIN_OBS` observations (eight squares, six
hexagons). Inside one surface ``R`` is the noise of the neighbours' means, so
the term is conservative there. The mean is the cell's own.

Forgetting (optional, for changing conditions): with a time constant ``tau``
[s], an observation at time ``t`` enters with weight ``exp(-(t_ref - t) / tau)``
relative to the grid's reference time ``t_ref`` (the latest observation);
moving ``t_ref`` forward scales all sums by the same factor, so merging stays
associative.

Only excited observations count: :func:`observations_from_estimates` keeps the
samples flagged ``excited`` (per axle where the estimator reports axles
separately) and places front- and rear-axle observations at the axle positions
(``x_front, y_front``, ``x_rear, y_rear``) where the estimates carry them.

The peak friction of a surface is at least the friction a tire used on it.
Where the estimates carry the axle forces (``Fyf, Fyr`` with ``Fyf_std,
Fyr_std`` and the loads ``Fzf, Fzr``, as the cascade's do) and a cell size is
given, an observation is dropped when it lies below the friction demonstrably
used in its cell during the same drive: the largest lower confidence bound
``(|Fy| - 2 std(Fy)) / Fz`` over the samples of either axle in that cell. Such
an observation cannot be the peak; it is the force of a tire that was not
saturated, read as saturated because its slip angle was overestimated. The
bound needs no slip angle, only the accelerations that give the forces.

Cells are aligned to multiples of the cell size (cell ``(i, j)`` covers
``[i c, (i+1) c) x [j c, (j+1) c)``), so grids of the same cell size always
share cell boundaries. Drives with GNSS positions (``lat, lon``) map on H3 hexagons
(:mod:`roadgrip.mapping.hexgrid`) or on square cells of a local metric frame
(:mod:`roadgrip.mapping.geo`, which also writes GeoJSON and GeoParquet files); many
drives make one map on Dask (:mod:`roadgrip.mapping.fleet`).
"""

from roadgrip.mapping.estimates import (
    GridSummary,
    compare_grids,
    grid_from_estimates,
    grip_used_bound,
    observations_from_estimates,
)
from roadgrip.mapping.grid import FrictionGrid, Observations, empty_grid, fuse, merge
from roadgrip.mapping.hexgrid import HexGrid, empty_hexgrid, fuse_hex, merge_hex

__all__ = [
    "FrictionGrid",
    "GridSummary",
    "HexGrid",
    "Observations",
    "compare_grids",
    "empty_grid",
    "empty_hexgrid",
    "fuse",
    "fuse_hex",
    "grid_from_estimates",
    "grip_used_bound",
    "merge",
    "merge_hex",
    "observations_from_estimates",
]
