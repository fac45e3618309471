"""Friction fields: which surface lies under the vehicle, over time or position.

A *surface* here is a set of four friction curves (front and rear axle, lateral
and longitudinal) with a peak friction, :class:`SurfaceTires`. A *friction field*
says which surface label applies at time ``t`` and position ``(x, y)``:

=========================  ====================================================
field                      surface label
=========================  ====================================================
:class:`ConstantFriction`  one label everywhere
:class:`PiecewiseTime`     ``labels[i]`` for ``times[i] <= t < times[i+1]``
:class:`PatchFriction`     the last rectangle containing ``(x, y)``, else the base
=========================  ====================================================

Each field is encoded into flat arrays (:meth:`encode`) that the compiled
integrator evaluates at the start of every internal step, and also evaluates
itself in numpy (:meth:`labels_at`) for tests and truth columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.tire import (
    SURFACES,
    BrushTire,
    FrictionModel,
    MagicFormula,
    model_from_dict,
)
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "FIELD_CONSTANT",
    "FIELD_PATCHES",
    "FIELD_TIME",
    "ConstantFriction",
    "FrictionField",
    "Patch",
    "PatchFriction",
    "PiecewiseTime",
    "SurfaceTires",
    "TireKind",
    "TireRole",
    "brush_surface",
    "encode_tire",
    "field_from_dict",
    "mu_at",
    "surface_from_preset",
    "tire_table",
]

FIELD_CONSTANT = 0
FIELD_TIME = 1
FIELD_PATCHES = 2


class TireKind:
    """Codes of the friction-curve families understood by the compiled kernels."""

    MAGIC_FORMULA = 0
    BRUSH = 1
    SIZE = 5  # one encoded row: [kind, p0, p1, p2, p3]


class TireRole:
    """Index layout of the four curves of a surface in :func:`tire_table`."""

    FRONT_LAT = 0
    REAR_LAT = 1
    FRONT_LONG = 2
    REAR_LONG = 3
    SIZE = 4


def encode_tire(model: FrictionModel) -> NDArray[np.float64]:
    """``[kind, p0, p1, p2, p3]`` row of a Magic Formula or brush curve.

    Raises
    ------
    ValueError
        For a curve family the compiled kernels do not implement.
    """
    if isinstance(model, MagicFormula):
        return np.array([TireKind.MAGIC_FORMULA, model.B, model.C, model.D, model.E])
    if isinstance(model, BrushTire):
        return np.array([TireKind.BRUSH, model.mu_peak, model.stiffness, 0.0, 0.0])
    raise ValueError(
        f"the simulator supports Magic Formula and brush curves, got {type(model).__name__}"
    )


@dataclass(frozen=True)
class SurfaceTires:
    """The true friction curves of one surface.

    Attributes
    ----------
    label : str
        Surface label written to the ``surface`` column.
    front, rear : FrictionModel
        Lateral ``mu`` against axle slip angle [rad].
    front_long, rear_long : FrictionModel
        Longitudinal ``mu`` against slip ratio [-].
    """

    label: str
    front: FrictionModel
    rear: FrictionModel
    front_long: FrictionModel
    rear_long: FrictionModel

    @property
    def mu(self) -> float:
        """Peak friction [-]: the larger of the two lateral peaks."""
        return float(max(self.front.peak()[1], self.rear.peak()[1]))

    def to_dict(self) -> dict[str, Any]:
        """The ``meta.truth['surfaces'][label]`` entry read by ``Drive.true_tire``."""
        return {
            "front": self.front.to_dict(),
            "rear": self.rear.to_dict(),
            "front_long": self.front_long.to_dict(),
            "rear_long": self.rear_long.to_dict(),
            "mu": self.mu,
        }

    @classmethod
    def from_dict(cls, label: str, d: dict[str, Any]) -> SurfaceTires:
        return cls(
            label,
            model_from_dict(d["front"]),
            model_from_dict(d["rear"]),
            model_from_dict(d["front_long"]),
            model_from_dict(d["rear_long"]),
        )

    def scaled(self, label: str, mu_peak: float) -> SurfaceTires:
        """The same curve shapes with every peak scaled by ``mu_peak / self.mu``."""
        s = mu_peak / self.mu
        return SurfaceTires(
            label,
            self.front.with_peak(self.front.peak()[1] * s),
            self.rear.with_peak(self.rear.peak()[1] * s),
            self.front_long.with_peak(self.front_long.peak()[1] * s),
            self.rear_long.with_peak(self.rear_long.peak()[1] * s),
        )


def surface_from_preset(name: str, label: str | None = None) -> SurfaceTires:
    """Curves of a :data:`roadgrip.tire.SURFACES` preset, same on both axles."""
    try:
        s = SURFACES[name]
    except KeyError:
        raise ValueError(f"unknown surface {name!r}; expected one of {sorted(SURFACES)}") from None
    return SurfaceTires(label or name, s.lateral, s.lateral, s.longitudinal, s.longitudinal)


def brush_surface(
    label: str, mu_peak: float, vehicle: VehicleParams, long_shape: str = "dry_asphalt"
) -> SurfaceTires:
    """Brush lateral curves whose cornering stiffness matches the vehicle's.

    The normalised stiffness of each axle is ``C_alpha / Fz`` with the static
    axle load, so the brush model of paper 003 with the preset's cornering
    stiffness is the exact lateral truth; it does not change with ``mu_peak``.
    The longitudinal curves are the ``long_shape`` preset scaled to ``mu_peak``.
    """
    kf = vehicle.cornering_stiffness_front / vehicle.fz_front
    kr = vehicle.cornering_stiffness_rear / vehicle.fz_rear
    lon = SURFACES[long_shape].longitudinal
    lon = lon.with_peak(lon.peak()[1] * mu_peak / SURFACES[long_shape].mu_peak)
    return SurfaceTires(label, BrushTire(mu_peak, kf), BrushTire(mu_peak, kr), lon, lon)


def tire_table(surfaces: list[SurfaceTires]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Encode surfaces for the compiled kernels.

    Returns
    -------
    table : ndarray, shape (n_surfaces, 4, 5)
        ``table[s, role]`` is the :func:`encode_tire` row of curve ``role``
        (:class:`TireRole`) of surface ``s``.
    peaks : ndarray, shape (n_surfaces, 4)
        Peak ``mu`` of each curve (semi-axes of the friction ellipse).
    """
    table = np.zeros((len(surfaces), TireRole.SIZE, TireKind.SIZE))
    peaks = np.zeros((len(surfaces), TireRole.SIZE))
    for i, s in enumerate(surfaces):
        for role, m in enumerate((s.front, s.rear, s.front_long, s.rear_long)):
            table[i, role] = encode_tire(m)
            peaks[i, role] = m.peak()[1]
    return table, peaks


class FrictionField:
    """Base class: a map from ``(t, x, y)`` to a surface label."""

    labels: tuple[str, ...]

    def encode(self) -> dict[str, Any]:
        """Flat arrays for :func:`roadgrip.sim.engine.surface_index`."""
        raise NotImplementedError

    def labels_at(self, t: ArrayLike, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        """Index into :attr:`labels` at each sample, shape of the broadcast inputs."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        """JSON description (stored as ``meta.truth['friction_field']``)."""
        raise NotImplementedError


def _empty_encoding(mode: int, base: int = 0) -> dict[str, Any]:
    return {
        "mode": mode,
        "times": np.zeros(1),
        "time_idx": np.zeros(1, dtype=np.int64),
        "rects": np.zeros((1, 4)),
        "rect_idx": np.zeros(1, dtype=np.int64),
        "base": base,
        "n_rects": 0,
    }


@dataclass(frozen=True)
class ConstantFriction(FrictionField):
    """One surface everywhere and always."""

    label: str

    @property
    def labels(self) -> tuple[str, ...]:  # type: ignore[override]
        return (self.label,)

    def encode(self) -> dict[str, Any]:
        return _empty_encoding(FIELD_CONSTANT)

    def labels_at(self, t: ArrayLike, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        shape = np.broadcast(np.asarray(t), np.asarray(x), np.asarray(y)).shape
        return np.zeros(shape, dtype=np.int64)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "constant", "surface": self.label}


@dataclass(frozen=True)
class PiecewiseTime(FrictionField):
    """Surface changes at given times.

    Parameters
    ----------
    starts : tuple of float
        Start time of each segment [s], strictly increasing, first one 0.
    segment_labels : tuple of str
        Surface label of each segment.
    """

    starts: tuple[float, ...]
    segment_labels: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.starts) != len(self.segment_labels) or not self.starts:
            raise ValueError("PiecewiseTime needs one start time per segment label")
        if self.starts[0] != 0.0 or np.any(np.diff(self.starts) <= 0):
            raise ValueError(f"segment start times must begin at 0 and increase, got {self.starts}")

    @property
    def labels(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(dict.fromkeys(self.segment_labels))

    def _seg_idx(self) -> NDArray[np.int64]:
        return np.array([self.labels.index(s) for s in self.segment_labels], dtype=np.int64)

    def encode(self) -> dict[str, Any]:
        enc = _empty_encoding(FIELD_TIME)
        enc["times"] = np.asarray(self.starts, dtype=float)
        enc["time_idx"] = self._seg_idx()
        return enc

    def labels_at(self, t: ArrayLike, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        t = np.broadcast_arrays(np.asarray(t, float), np.asarray(x), np.asarray(y))[0]
        seg = np.searchsorted(np.asarray(self.starts), t, side="right") - 1
        return self._seg_idx()[np.clip(seg, 0, None)]

    @property
    def changes(self) -> list[dict[str, Any]]:
        """``[{'t': start, 'from': label, 'to': label}, ...]`` for each change."""
        return [
            {"t": float(t), "from": a, "to": b}
            for t, a, b in zip(self.starts[1:], self.segment_labels[:-1], self.segment_labels[1:], strict=True)
        ]

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "piecewise_time",
            "starts": list(map(float, self.starts)),
            "surfaces": list(self.segment_labels),
        }


@dataclass(frozen=True)
class Patch:
    """An axis-aligned rectangle ``x0 <= x < x1, y0 <= y < y1`` [m] of one surface."""

    x0: float
    x1: float
    y0: float
    y1: float
    label: str

    def __post_init__(self) -> None:
        if not (self.x1 > self.x0 and self.y1 > self.y0):
            raise ValueError(f"patch {self.label!r} needs x1 > x0 and y1 > y0, got {self}")


@dataclass(frozen=True)
class PatchFriction(FrictionField):
    """Rectangular patches over a base surface; later patches win where they overlap."""

    base: str
    patches: tuple[Patch, ...] = field(default_factory=tuple)

    @property
    def labels(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(dict.fromkeys([self.base, *(p.label for p in self.patches)]))

    def encode(self) -> dict[str, Any]:
        enc = _empty_encoding(FIELD_PATCHES, base=0)
        if self.patches:
            enc["rects"] = np.array([[p.x0, p.x1, p.y0, p.y1] for p in self.patches], float)
            enc["rect_idx"] = np.array([self.labels.index(p.label) for p in self.patches], np.int64)
        enc["n_rects"] = len(self.patches)
        return enc

    def labels_at(self, t: ArrayLike, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        _, x, y = np.broadcast_arrays(np.asarray(t, float), np.asarray(x, float), np.asarray(y, float))
        out = np.zeros(x.shape, dtype=np.int64)
        for p in self.patches:
            inside = (x >= p.x0) & (x < p.x1) & (y >= p.y0) & (y < p.y1)
            out[inside] = self.labels.index(p.label)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "patches",
            "base": self.base,
            "patches": [
                {"x0": p.x0, "x1": p.x1, "y0": p.y0, "y1": p.y1, "surface": p.label}
                for p in self.patches
            ],
        }


def field_from_dict(d: dict[str, Any]) -> FrictionField:
    """Rebuild a friction field from :meth:`FrictionField.to_dict` (e.g. ``meta.truth['friction_field']``).

    Raises
    ------
    ValueError
        Unknown ``kind``.
    """
    kind = d.get("kind")
    if kind == "constant":
        return ConstantFriction(d["surface"])
    if kind == "piecewise_time":
        return PiecewiseTime(tuple(float(t) for t in d["starts"]), tuple(d["surfaces"]))
    if kind == "patches":
        return PatchFriction(
            d["base"],
            tuple(Patch(p["x0"], p["x1"], p["y0"], p["y1"], p["surface"]) for p in d["patches"]),
        )
    raise ValueError(f"unknown friction field kind {kind!r}; expected constant, piecewise_time or patches")


def mu_at(field_dict: dict[str, Any], t: ArrayLike, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """True peak friction [-] of a stored friction field at times ``t`` [s] and positions ``(x, y)`` [m].

    ``field_dict`` is ``drive.meta.truth['friction_field']``, which carries the
    peak of each label under ``'mu'``; use it to score a friction map cell by
    cell (evaluate at the cell centres).

    Examples
    --------
    >>> d = {"kind": "patches", "base": "a", "mu": {"a": 0.7, "b": 0.4},
    ...      "patches": [{"x0": 0, "x1": 1, "y0": 0, "y1": 1, "surface": "b"}]}
    >>> mu_at(d, 0.0, [0.5, 2.0], [0.5, 0.5]).tolist()
    [0.4, 0.7]
    """
    if "mu" not in field_dict:
        raise ValueError("friction field has no 'mu' table (peak friction per surface label)")
    field = field_from_dict(field_dict)
    table = np.array([float(field_dict["mu"][label]) for label in field.labels])
    return table[field.labels_at(t, x, y)]
