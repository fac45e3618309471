"""Vehicle parameters: a frozen, validated dataclass with YAML presets.

Every field carries its SI unit in its docstring. Presets are shipped as YAML
files in ``roadgrip/data/vehicles`` and documented in :data:`PRESET_SOURCES`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import GRAVITY

__all__ = [
    "FIELD_RANGES", "PRESETS", "PRESET_SOURCES", "VehicleParams", "axle_loads", "driven_wheels",
    "load_vehicle", "template_yaml",
]  # fmt: skip

_DRIVEN = {
    "fwd": (True, True, False, False),
    "rwd": (False, False, True, True),
    "awd": (True, True, True, True),
}
_DRIVES = tuple(_DRIVEN)
FIELD_RANGES: dict[str, tuple[float, float, str, str]] = {
    "mass": (0.3, 6.0e4, "kg", "total mass"),
    "yaw_inertia": (1e-4, 1.0e6, "kg m²", "yaw moment of inertia about the CG"),
    "lf": (0.02, 10.0, "m", "distance CG to front axle"),
    "lr": (0.02, 10.0, "m", "distance CG to rear axle"),
    "cg_height": (0.0, 4.0, "m", "CG height above ground (> 0)"),
    "wheel_radius": (0.01, 1.5, "m", "effective rolling radius"),
    "track_width": (0.03, 4.0, "m", "track width"),
    "wheel_inertia": (1e-7, 500.0, "kg m²", "spin inertia of one wheel with its drive line"),
    "cornering_stiffness_front": (1.0, 5.0e6, "N/rad", "front-axle cornering stiffness"),
    "cornering_stiffness_rear": (1.0, 5.0e6, "N/rad", "rear-axle cornering stiffness"),
    "max_steer": (0.0, 1.5, "rad", "largest front road-wheel angle (> 0)"),
    "gear_ratio": (0.01, 1000.0, "-", "motor revolutions per wheel revolution"),
    "roll_gradient": (0.0, 0.05, "rad/(m/s²)", "body roll per lateral acceleration (0 = rigid)"),
    "pitch_gradient": (0.0, 0.05, "rad/(m/s²)", "body pitch per longitudinal acceleration"),
}
"""Physical range of each numeric field: ``(low, high, unit, meaning)``.

From a 1:10 model car (1.6 kg) to a heavy truck (60 t). A bound of 0 is
exclusive except for the body gradients (0: rigid body or unknown), whose upper
bound 0.05 (28 deg/g) is exclusive; other bounds are inclusive.
"""
_ZERO_ALLOWED = ("roll_gradient", "pitch_gradient")
CALIBRATION_KEY = "calibration"
"""Key of a vehicle file's sensor calibration (not a vehicle field)."""
_DYNAMIC_INDEX = (0.1, 10.0)  # yaw_inertia / (mass lf lr)
_STIFFNESS_PER_LOAD = (0.5, 100.0)  # axle cornering stiffness / static axle load [1/rad]


@dataclass(frozen=True)
class VehicleParams:
    """Single-track vehicle parameters (SI units).

    Attributes
    ----------
    name : str
        Label.
    mass : float
        Total mass [kg].
    yaw_inertia : float
        Yaw moment of inertia about the CG [kg m²].
    lf : float
        Distance CG to front axle [m].
    lr : float
        Distance CG to rear axle [m].
    cg_height : float
        CG height above ground [m] (longitudinal load transfer).
    wheel_radius : float
        Effective rolling radius [m].
    track_width : float
        Track width [m].
    wheel_inertia : float
        Spin inertia of one wheel with its drive-line share [kg m²].
    cornering_stiffness_front : float
        Front-axle cornering stiffness (both wheels) [N/rad].
    cornering_stiffness_rear : float
        Rear-axle cornering stiffness (both wheels) [N/rad].
    drive : str
        Driven axles: ``'fwd'``, ``'rwd'`` or ``'awd'``.
    max_steer : float
        Largest front road-wheel angle [rad].
    gear_ratio : float
        Motor revolutions per wheel revolution [-] (1 where no motor speed is used).
    roll_gradient : float
        Body roll per lateral acceleration [rad/(m/s²)] (0.0157 is 8.8 deg/g), >= 0;
        0 for a rigid body or where unknown. A body-fixed accelerometer tilts with
        the body and reads ``a_y (1 + g roll_gradient)``
        (:func:`roadgrip.signals.level_accelerations`).
    pitch_gradient : float
        Body pitch per longitudinal acceleration [rad/(m/s²)] (nose up under
        acceleration, down under braking), >= 0; the accelerometer reads
        ``a_x (1 + g pitch_gradient)``.
    """

    name: str
    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    cg_height: float
    wheel_radius: float
    track_width: float
    wheel_inertia: float = 1.0
    cornering_stiffness_front: float = 1.0e5
    cornering_stiffness_rear: float = 1.0e5
    drive: str = "fwd"
    max_steer: float = 0.6
    gear_ratio: float = 1.0
    roll_gradient: float = 0.0
    pitch_gradient: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.name, bool) or not isinstance(self.name, str | int | float):
            raise ValueError(f"vehicle field 'name' must be a text label, got {self.name!r}")
        object.__setattr__(self, "name", str(self.name))
        for f in fields(self):
            if f.name in ("name", "drive"):
                continue
            value = getattr(self, f.name)
            lo, hi, unit, _ = FIELD_RANGES[f.name]
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"vehicle field {f.name!r} must be a number in {unit}, got {value!r}")
            if f.name in _ZERO_ALLOWED:
                ok = lo <= value < hi
                rng = f"[{lo:g}, {hi:g})"
            else:
                ok = (lo < value if lo == 0 else lo <= value) and value <= hi
                rng = f"({lo:g}, {hi:g}]" if lo == 0 else f"[{lo:g}, {hi:g}]"
            if not (math.isfinite(value) and ok):
                raise ValueError(f"vehicle field {f.name!r} = {value!r} {unit} is outside its "
                                 f"physical range {rng} {unit}")
            object.__setattr__(self, f.name, float(value))
        if not isinstance(self.drive, str) or self.drive not in _DRIVES:
            raise ValueError(f"vehicle field 'drive' must be one of {_DRIVES}, got {self.drive!r}")
        self._check_consistency()

    def _check_consistency(self) -> None:
        """Refuse field combinations no vehicle has (each field alone being in range).

        The yaw inertia over ``m lf lr`` (the dynamic index) lies near 1 for cars
        and trucks (0.4 to 1.2 for the presets); the axle cornering stiffness per
        unit static axle load is 5 to 20 /rad for tires on a road.
        """
        ratio = self.yaw_inertia / (self.mass * self.lf * self.lr)
        if not _DYNAMIC_INDEX[0] <= ratio <= _DYNAMIC_INDEX[1]:
            raise ValueError(
                f"vehicle field 'yaw_inertia' = {self.yaw_inertia!r} kg m² is {ratio:.3g} x "
                f"mass * lf * lr; a vehicle has {_DYNAMIC_INDEX[0]:g} to {_DYNAMIC_INDEX[1]:g} "
                "(check the unit and the other fields)"
            )
        for axle, c, fz in (("front", self.cornering_stiffness_front, self.fz_front),
                            ("rear", self.cornering_stiffness_rear, self.fz_rear)):
            per_load = c / fz
            if not _STIFFNESS_PER_LOAD[0] <= per_load <= _STIFFNESS_PER_LOAD[1]:
                raise ValueError(
                    f"vehicle field 'cornering_stiffness_{axle}' = {c!r} N/rad is {per_load:.3g} /rad "
                    f"per unit of the static axle load {fz:.4g} N; a tire has "
                    f"{_STIFFNESS_PER_LOAD[0]:g} to {_STIFFNESS_PER_LOAD[1]:g} /rad"
                )

    # -- derived quantities ------------------------------------------------------------
    @property
    def wheelbase(self) -> float:
        """``lf + lr`` [m]."""
        return self.lf + self.lr

    @property
    def fz_front(self) -> float:
        """Static front-axle load ``m g lr / l`` [N] (paper 000, eq. 2)."""
        return self.mass * GRAVITY * self.lr / self.wheelbase

    @property
    def fz_rear(self) -> float:
        """Static rear-axle load ``m g lf / l`` [N] (paper 000, eq. 2)."""
        return self.mass * GRAVITY * self.lf / self.wheelbase

    @property
    def understeer_gradient(self) -> float:
        """Linear understeer gradient ``K = m/l (lr/Cf - lf/Cr)`` [rad s²/m]."""
        return (self.mass / self.wheelbase) * (
            self.lr / self.cornering_stiffness_front - self.lf / self.cornering_stiffness_rear
        )

    # -- (de)serialisation -------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> VehicleParams:
        """Build from a mapping; unknown keys and missing required keys are errors.

        Every missing field is reported at once, with its unit and meaning.
        """
        if not isinstance(d, dict):
            raise ValueError(f"vehicle description must be a mapping, got {type(d).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(str(k) for k in set(d) - known)
        if unknown:
            raise ValueError(f"unknown vehicle field(s) {unknown}; known fields: {sorted(known)}")
        required = [
            f.name
            for f in fields(cls)
            if f.default is dataclasses.MISSING and f.name not in d
        ]
        if required:
            what = "; ".join(
                f"{k} [{FIELD_RANGES[k][2]}]: {FIELD_RANGES[k][3]}" if k in FIELD_RANGES
                else f"{k}: a label" for k in required
            )
            raise ValueError(f"missing vehicle field(s) {required} ({what})")
        return cls(**d)

    def to_yaml(self, path: str | Path) -> None:
        Path(path).write_text(yaml.safe_dump(self.to_dict(), sort_keys=False))

    @classmethod
    def from_yaml(cls, path: str | Path) -> VehicleParams:
        """Read a YAML file (UTF-8 with or without byte-order mark, or UTF-16).

        ``name`` defaults to the file's stem. A ``calibration`` mapping (the sensors'
        calibration that ``roadgrip vehicle fit`` writes) is not a vehicle field and is
        left to :func:`roadgrip.io.calibration.read_calibration`.
        """
        try:
            data = yaml.safe_load(_decode(Path(path).read_bytes(), path))
        except FileNotFoundError:
            raise ValueError(f"vehicle file not found: {path}") from None
        except OSError as exc:
            raise ValueError(f"vehicle file {path} cannot be read: {exc.strerror}") from None
        except yaml.YAMLError as exc:
            msg = " ".join(str(exc).split())
            raise ValueError(f"vehicle file {path} is not valid YAML: {msg}") from None
        if isinstance(data, dict) and "name" not in data:
            data = {"name": Path(path).stem, **data}
        if isinstance(data, dict):  # the sensors' calibration (roadgrip vehicle fit): not a field
            data = {k: v for k, v in data.items() if k != CALIBRATION_KEY}
        try:
            return cls.from_dict(data)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"vehicle file {Path(path).name}: {exc}") from None

    def replace(self, **changes: Any) -> VehicleParams:
        return dataclasses.replace(self, **changes)


def _decode(raw: bytes, path: str | Path) -> str:
    """Text of a YAML file: UTF-8 (byte-order mark dropped) or UTF-16 (with or without mark)."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        enc = "utf-16"
    elif len(raw) >= 4 and raw[1] == 0 and raw[3] == 0 and raw[0] != 0:
        enc = "utf-16-le"
    elif len(raw) >= 4 and raw[0] == 0 and raw[2] == 0 and raw[1] != 0:
        enc = "utf-16-be"
    else:
        enc = "utf-8-sig"
    try:
        return raw.decode(enc).lstrip("\ufeff")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ValueError(f"vehicle file {path}:{line}: not UTF-8 or UTF-16 text ({exc.reason})") from None


def template_yaml() -> str:
    """A commented vehicle YAML: every field with its unit, meaning, range and a sedan's value."""
    sedan = PRESETS["sedan"]
    lines = ["# roadgrip vehicle description (SI units). Fields without a default are required;",
             "# `name` defaults to the file's stem. Values are a C-segment sedan's: replace them.",
             "# name: my-car  # label; default: the file name without .yaml"]
    for f in fields(VehicleParams):
        if f.name == "name":
            continue
        value = getattr(sedan, f.name)
        opt = "" if f.default is dataclasses.MISSING else f"; optional, default {f.default!r}"
        if f.name == "drive":
            lines.append(f"drive: {value}  # driven axles: fwd, rwd or awd{opt}")
            continue
        lo, hi, unit, meaning = FIELD_RANGES[f.name]
        lines.append(f"{f.name}: {value!r}  # [{unit}] {meaning}; range {lo:g} to {hi:g}{opt}")
    return "\n".join(lines) + "\n"


PRESET_SOURCES: dict[str, str] = {
    "suv": (
        "Mid-size SUV of the class used in Berntorp's GP-SSM study (paper 000). The paper does "
        "not list its parameters; mass, inertia and axle distances are typical data-sheet "
        "values for a ~2.1 t SUV, the same order as the vehicle of Berntorp et al., 'Models and "
        "methodology for optimal trajectory generation in safety-critical road-vehicle "
        "manoeuvres', Vehicle System Dynamics 52(10), 2014 (m = 2100 kg, Izz = 3900 kg m², "
        "lf = 1.3 m, lr = 1.5 m). Cornering stiffnesses follow from the snow tire (B C D Fz)."
    ),
    "sedan": (
        "C-segment passenger sedan, representative data-sheet values (1.5 t, wheelbase 2.7 m, "
        "inertia from the m a b rule of thumb Izz ~ 0.9 m lf lr), cornering stiffnesses of "
        "dry-road passenger-car tires (about 15/rad per unit load)."
    ),
    "f1tenth": (
        "F1/10 Traxxas-based car of Amine et al. (paper 003, appendix) and ../shared/data "
        "README: m = 3.33 kg, Iz = 0.0687 kg m², lf = 0.112 m, lr = 0.208 m, h = 0.075 m, "
        "tire circumference 0.319 m (radius 0.0508 m), gear ratio 11.85, axle cornering "
        "stiffness 150 N/rad as in the paper's appendix; track width of the F1TENTH chassis."
    ),
    "jetracer": (
        "DART 1:10 JetRacer (Lyons et al., TU Delft 2024; ../shared/data README): m = 1.58 kg, "
        "lf = 0.0805 m, lr = 0.0930 m, Iz = 0.0048 kg m², rear-wheel drive. Wheel radius and "
        "CG height are measured-scale estimates; cornering stiffness is from the authors' "
        "Pacejka-like fit (about 0.84 peak, slope near 6/rad per unit load)."
    ),
    "ford-escort": (
        "CommonRoad vehicle 1 (Ford Escort, multi-body parameters from the US DOT vehicle "
        "dynamics data) as roadgrip.sim.mb_model.vehicle_from_commonroad derives it: total "
        "mass, CG and yaw inertia of the sprung and unsprung masses, the package's CG height, "
        "rolling radius and wheel inertia, mean track, cornering stiffness |p_ky1| Fz."
    ),
    "vw-vanagon": (
        "CommonRoad vehicle 3 (VW Vanagon, multi-body parameters), derived as for ford-escort."
    ),
}


def _preset_dir() -> Any:
    return resources.files("roadgrip") / "data" / "vehicles"


def _load_presets() -> dict[str, VehicleParams]:
    out = {}
    for name in PRESET_SOURCES:
        text = (_preset_dir() / f"{name}.yaml").read_text()
        out[name] = VehicleParams.from_dict(yaml.safe_load(text))
    return out


PRESETS: dict[str, VehicleParams] = _load_presets()
"""Shipped presets by name; see :data:`PRESET_SOURCES`."""


def load_vehicle(spec: str | Path | VehicleParams) -> VehicleParams:
    """A preset name, a YAML path or a :class:`VehicleParams` -> :class:`VehicleParams`.

    Raises
    ------
    ValueError
        Unknown preset, missing file, unknown or invalid fields.
    """
    if isinstance(spec, VehicleParams):
        return spec
    s = str(spec)
    if s in PRESETS:
        return PRESETS[s]
    p = Path(s)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return VehicleParams.from_yaml(p)
    raise ValueError(f"unknown vehicle {s!r}: not a preset ({sorted(PRESETS)}) nor a YAML file")


def driven_wheels(drive: str) -> NDArray[np.bool_]:
    """Which wheels the drive layout drives.

    Parameters
    ----------
    drive : {'fwd', 'rwd', 'awd'}
        ``VehicleParams.drive``.

    Returns
    -------
    ndarray of bool, shape (4,)
        Order ``fl, fr, rl, rr`` (``WHEELS`` of :mod:`roadgrip.signals`); a new array on each call.

    Raises
    ------
    ValueError
        An unknown layout (named in the message).
    """
    try:
        return np.array(_DRIVEN[drive], dtype=bool)
    except (KeyError, TypeError):
        raise ValueError(f"unknown drive layout {drive!r}; known: {sorted(_DRIVEN)}") from None


def axle_loads(params: VehicleParams, ax: ArrayLike = 0.0) -> tuple[NDArray, NDArray]:
    """Axle normal loads with quasi-steady longitudinal load transfer.

    ``F_zf = m g lr / l - m a_x h / l`` and ``F_zr = m g lf / l + m a_x h / l``
    (``l = lf + lr``, ``h`` the CG height), each clipped at zero (a lifted
    axle); ``ax = 0`` gives the static loads ``params.fz_front``,
    ``params.fz_rear``.

    Parameters
    ----------
    params : VehicleParams
        ``mass``, ``lf``, ``lr``, ``cg_height`` are used.
    ax : array_like, shape (...)
        Longitudinal acceleration (specific force) at the CG [m/s²], positive forward.

    Returns
    -------
    fz_front, fz_rear : ndarray, shape (...)
        [N].
    """
    ax = np.asarray(ax, dtype=float)
    dfz = params.mass * ax * params.cg_height / params.wheelbase
    return np.maximum(params.fz_front - dfz, 0.0), np.maximum(params.fz_rear + dfz, 0.0)
