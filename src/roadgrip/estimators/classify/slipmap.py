r"""Nonlinear friction-state classification on the slip-acceleration maps (paper 002, Sec. V).

Given the friction-independent slips (:mod:`roadgrip.inference.kinematic`),
reference accelerations follow from a *mid-friction* Magic Formula tire
(longitudinal and lateral curves, computed independently: zero lateral slip
for the longitudinal one and vice versa)::

    ax_ref = g s_x mu_mid,x(kappa)
    ay_ref = g (lr / L mu_mid,y(alpha_f) cos(delta) + lf / L mu_mid,y(alpha_r))

``kappa`` is the mean slip of the driven wheels when accelerating (``ax >= 0``)
and of all measured wheels when braking; ``s_x`` is the share of the weight
they carry (driven axle with longitudinal load transfer ``h ax / (g L)``
when accelerating, 1 when braking). A measured acceleration above the
reference (in magnitude) is high-friction evidence, below it low-friction
evidence, with the reliability weight (eq. 9)::

    W_i = 1 - exp(-(a_i - a_i,ref)^2 / sigma_i^2),    i = x, y

Exclusions (the paper's Fig. 8-9): a channel gets ``W = 0`` in its
low-slip-low-acceleration box (``|slip| < slip_min`` and ``|a| < accel_min``)
and in the quadrants where acceleration and slip disagree in sign (noise and
estimation error: the 2nd/4th quadrants of the longitudinal map and, with
roadgrip's slip-angle sign, the same for the lateral map).

Probabilities per channel (eq. 10-15): ``p^H = W`` above the reference, else 0;
``p^L = W`` below it, else 0; ``p^O = 1 - W``; each of ``p^H, p^L, p^O`` is the
mean over the two channels. Recursive estimate (eq. 16) with ``v^H = 1``,
``v^L = 0``::

    F(k) = p^O F(k-1) + p^H v^H + p^L v^L

followed by a first-order low-pass filter (time constant ``lowpass_tau_s``).
``grip_index`` is the filtered ``F``. ``grip_class`` is 'unknown' until the
accumulated weight ``sum W`` (both channels) reaches ``info_min``, then
'high'/'low' by the filtered ``F`` with a hysteresis band of ``hysteresis``
around 1/2. A sample is ``excited`` when some channel is outside its
exclusions with ``W >= w_excited``.

Calibration (:func:`calibrate_section`, used by ``roadgrip calibrate``) picks
the mid-friction curves' peak and slope per channel that best separate the
labelled high and low samples.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, NamedTuple

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateRequest, EstimateResult, conform, timed
from roadgrip.inference.kinematic import (
    LATERAL_ACCELERATION_SOURCES,
    KinematicClassifier,
    KinematicConfig,
    KinematicInput,
    KinematicOutput,
    drive_lateral_acceleration,
    estimate_kinematics,
    select_lateral_acceleration,
)
from roadgrip.tire import SURFACES, MagicFormula
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "SlipMapClassifier",
    "SlipMapConfig",
    "SlipMapEvidence",
    "SlipMapOutput",
    "SlipMapState",
    "calibrate_section",
    "default_config",
    "evidence",
    "run_cli",
    "slipmap_batch",
    "slipmap_init",
    "slipmap_step",
]

SWITCH_PENALTY = 0.01
"""Calibration score penalty per class switch beyond the first (fraction of time)."""

_DRIVEN = {"fwd": (1.0, 1.0, 0.0, 0.0), "rwd": (0.0, 0.0, 1.0, 1.0), "awd": (1.0, 1.0, 1.0, 1.0)}


@dataclass(frozen=True)
class SlipMapConfig:
    """Settings of the slip-acceleration classifier.

    Attributes
    ----------
    long_curve, lat_curve : MagicFormula
        Mid-friction reference curves, ``mu`` against slip ratio / slip angle.
    sigma_x, sigma_y : float
        Reliability scales of eq. 9 [m/s²] (paper: 3 and 2).
    slip_min_long, slip_min_lat : float
        Slip bounds of the low-excitation boxes [-] and [rad].
    accel_min : float
        Acceleration bound of the low-excitation boxes [m/s²].
    lowpass_tau_s : float
        Time constant of the output low-pass filter [s].
    hysteresis : float
        Half-width of the class hysteresis band around 0.5 [-].
    info_min : float
        Accumulated weight before a class is claimed [-].
    w_excited : float
        Weight at which a sample counts as excited [-].
    min_speed : float
        Below this speed [m/s] both weights are 0 (slips near standstill carry no information).
    prefilter_tau_s : float
        Time constant [s] of a first-order low-pass applied to the slips and
        accelerations before the maps (0 = none): the noise of a low-rate
        inertial sensor otherwise scatters the samples across the reference curve.
    lateral_acceleration : {'auto', 'imu', 'kinematic'}
        Lateral acceleration placed on the lateral map: the accelerometer's, or
        the kinematic ``r vx + dvy/dt``; ``'auto'`` takes the kinematic one when
        the velocity comes from a pose
        (:func:`roadgrip.inference.kinematic.select_lateral_acceleration`).
    """

    long_curve: MagicFormula
    lat_curve: MagicFormula
    sigma_x: float = 3.0
    sigma_y: float = 2.0
    slip_min_long: float = 0.01
    slip_min_lat: float = 0.01
    accel_min: float = 1.0
    lowpass_tau_s: float = 0.5
    hysteresis: float = 0.1
    info_min: float = 3.0
    w_excited: float = 0.1
    min_speed: float = 0.5
    prefilter_tau_s: float = 0.0
    lateral_acceleration: str = "auto"

    def __post_init__(self) -> None:
        if self.lateral_acceleration not in LATERAL_ACCELERATION_SOURCES:
            raise ValueError(
                f"lateral_acceleration must be one of {LATERAL_ACCELERATION_SOURCES}, "
                f"got {self.lateral_acceleration!r}"
            )
        for name in ("sigma_x", "sigma_y", "lowpass_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive, got {v!r}")
        for name in ("slip_min_long", "slip_min_lat", "accel_min", "info_min", "min_speed",
                     "prefilter_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {v!r}")
        if not 0.0 <= self.hysteresis < 0.5:
            raise ValueError(f"hysteresis must lie in [0, 0.5), got {self.hysteresis!r}")
        if not 0.0 < self.w_excited < 1.0:
            raise ValueError(f"w_excited must lie in (0, 1), got {self.w_excited!r}")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["long_curve"] = {k: float(self.long_curve.to_dict()[k]) for k in "BCDE"}
        d["lat_curve"] = {k: float(self.lat_curve.to_dict()[k]) for k in "BCDE"}
        for k, v in d.items():
            if isinstance(v, np.generic):
                d[k] = v.item()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SlipMapConfig:
        d = dict(d)
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown slipmap setting(s) {sorted(unknown)}")
        for k in ("long_curve", "lat_curve"):
            if k not in d:
                raise ValueError(f"slipmap calibration lacks {k!r}")
            d[k] = MagicFormula(**{c: float(d[k][c]) for c in "BCDE"})
        return cls(**d)


def default_config(mu_mid: float = 0.8) -> SlipMapConfig:
    """Mid-friction curves: the dry-asphalt shapes scaled to peak ``mu_mid``.

    The default 0.8 lies halfway between dry asphalt (1.0) and gravel (0.6),
    the two surfaces of the paper's test; the slopes are scaled alike.
    """
    dry = SURFACES["dry_asphalt"]
    return SlipMapConfig(
        long_curve=replace(dry.longitudinal, D=mu_mid),
        lat_curve=replace(dry.lateral, D=mu_mid),
    )


class SlipMapEvidence(NamedTuple):
    """Per-sample evidence (arrays, shape (T,)).

    Attributes
    ----------
    ax_ref, ay_ref : reference accelerations [m/s²]
    w_x, w_y : reliability weights after exclusions (eq. 9)
    p_high, p_low, p_old : eq. 10-15 (channel means)
    kappa : slip used on the longitudinal map [-]
    """

    ax_ref: NDArray[np.float64]
    ay_ref: NDArray[np.float64]
    w_x: NDArray[np.float64]
    w_y: NDArray[np.float64]
    p_high: NDArray[np.float64]
    p_low: NDArray[np.float64]
    p_old: NDArray[np.float64]
    kappa: NDArray[np.float64]


def evidence(
    kappa: NDArray, alpha_f: NDArray, alpha_r: NDArray, ax: NDArray, ay: NDArray,
    steer: NDArray, wheels_valid: NDArray, params: VehicleParams, config: SlipMapConfig,
    vx: NDArray | None = None,
) -> SlipMapEvidence:
    """Reference accelerations, weights and probabilities (eq. 9-15), vectorised.

    Parameters
    ----------
    kappa : ndarray, shape (T, 4)
        Wheel slips ``fl, fr, rl, rr`` [-].
    alpha_f, alpha_r, steer : ndarray, shape (T,)
        Axle slip angles and road-wheel angle [rad].
    ax, ay : ndarray, shape (T,)
        Accelerations [m/s²].
    wheels_valid : ndarray of bool, shape (T, 4)
        Which wheel speeds are measured.
    params : VehicleParams
    config : SlipMapConfig
    vx : ndarray, shape (T,), optional
        Speed [m/s]; samples slower than ``config.min_speed`` get zero weights.
    """
    kappa = np.asarray(kappa, float)
    valid = np.asarray(wheels_valid, bool)
    ax = np.asarray(ax, float)
    ay = np.asarray(ay, float)
    L = params.lf + params.lr
    driven = np.array(_DRIVEN[params.drive], bool) & valid
    allw = valid
    n_dr = driven.sum(-1)
    n_all = allw.sum(-1)
    k_dr = np.where(n_dr > 0, (kappa * driven).sum(-1) / np.maximum(n_dr, 1), 0.0)
    k_all = np.where(n_all > 0, (kappa * allw).sum(-1) / np.maximum(n_all, 1), 0.0)
    accel = ax >= 0.0
    k_eff = np.where(accel, k_dr, k_all)
    transfer = params.cg_height * ax / (GRAVITY * L)
    if params.drive == "fwd":
        share_dr = params.lr / L - transfer
    elif params.drive == "rwd":
        share_dr = params.lf / L + transfer
    else:
        share_dr = np.ones_like(ax)
    share = np.where(accel, np.clip(share_dr, 0.05, 1.0), 1.0)
    ax_ref = GRAVITY * share * config.long_curve.mu(k_eff)
    ay_ref = GRAVITY * (params.lr / L * config.lat_curve.mu(alpha_f) * np.cos(steer)
                        + params.lf / L * config.lat_curve.mu(alpha_r))
    phi_lat = np.asarray(alpha_f) * np.cos(steer) + np.asarray(alpha_r)
    wx = 1.0 - np.exp(-((ax - ax_ref) ** 2) / config.sigma_x**2)
    wy = 1.0 - np.exp(-((ay - ay_ref) ** 2) / config.sigma_y**2)
    # exclusions: low-slip-low-acceleration box, disagreeing quadrants, no slip information
    box_x = (np.abs(k_eff) < config.slip_min_long) & (np.abs(ax) < config.accel_min)
    box_y = (np.abs(phi_lat) < 2.0 * config.slip_min_lat) & (np.abs(ay) < config.accel_min)
    quad_x = k_eff * ax < 0.0
    quad_y = phi_lat * ay < 0.0
    no_x = np.where(accel, n_dr == 0, n_all == 0)
    slow = np.zeros(ax.shape, bool) if vx is None else np.abs(np.asarray(vx, float)) < config.min_speed
    wx = np.where(box_x | quad_x | no_x | slow, 0.0, wx)
    wy = np.where(box_y | quad_y | slow, 0.0, wy)
    above_x = np.abs(ax) > np.abs(ax_ref)
    above_y = np.abs(ay) > np.abs(ay_ref)
    p_high = 0.5 * (np.where(above_x, wx, 0.0) + np.where(above_y, wy, 0.0))
    p_low = 0.5 * (np.where(above_x, 0.0, wx) + np.where(above_y, 0.0, wy))
    p_old = 0.5 * ((1.0 - wx) + (1.0 - wy))
    return SlipMapEvidence(ax_ref, ay_ref, wx, wy, p_high, p_low, p_old, k_eff)


@numba.njit(cache=True)
def _prefilter(x, t, tau, dt0, state):  # pragma: no cover - compiled
    """First-order low-pass of the columns of ``x`` (T, m), in place on ``state`` (m,)."""
    n, m = x.shape
    out = np.empty((n, m))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        k = 1.0 if tau <= 0.0 else 1.0 - np.exp(-dt / tau)
        for j in range(m):
            state[j] += k * (x[i, j] - state[j])
            out[i, j] = state[j]
    return out


def _pack(kin: KinematicOutput, ax, ay) -> NDArray[np.float64]:
    """Prefilter inputs as columns ``kappa_fl..rr, alpha_f, alpha_r, ax, ay``, shape (T, 8)."""
    return np.ascontiguousarray(np.column_stack([
        np.atleast_2d(kin.kappa), np.atleast_1d(kin.alpha_f), np.atleast_1d(kin.alpha_r),
        np.atleast_1d(ax), np.atleast_1d(ay),
    ]), dtype=float)


def _unpack(kin: KinematicOutput, y: NDArray) -> tuple[KinematicOutput, NDArray, NDArray]:
    return kin._replace(kappa=y[:, :4], alpha_f=y[:, 4], alpha_r=y[:, 5]), y[:, 6], y[:, 7]


class SlipMapState(NamedTuple):
    """Recursion state: ``F`` (eq. 16), its low-passed value, accumulated weight, class."""

    f: float
    f_lp: float
    info: float
    high: bool


class SlipMapOutput(NamedTuple):
    """Per-sample output (scalars from :meth:`SlipMapClassifier.step`, arrays from a batch)."""

    grip_class: Any
    grip_index: Any
    excited: Any
    w_x: Any
    w_y: Any


def slipmap_init() -> SlipMapState:
    """Agnostic start: ``F = 1/2``, no information."""
    return SlipMapState(0.5, 0.5, 0.0, True)


@numba.njit(cache=True)
def _recur(st, dt, p_high, p_low, p_old, w_sum, tau, hyst):  # pragma: no cover - compiled
    """Eq. 16, low-pass, information and hysteresis class, in place on ``st``."""
    st[0] = p_old * st[0] + p_high
    k = 1.0 - np.exp(-dt / tau)
    st[1] = st[1] + k * (st[0] - st[1])
    st[2] = st[2] + w_sum
    if st[1] > 0.5 + hyst:
        st[3] = 1.0
    elif st[1] < 0.5 - hyst:
        st[3] = 0.0


@numba.njit(cache=True)
def _recur_batch(st, t, p_high, p_low, p_old, w_sum, tau, hyst, dt0):  # pragma: no cover
    n = t.shape[0]
    out = np.empty((n, 4))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        _recur(st, dt, p_high[i], p_low[i], p_old[i], w_sum[i], tau, hyst)
        out[i] = st
    return out


def _classes(high: NDArray, info: NDArray, info_min: float) -> NDArray[np.str_]:
    return np.where(info >= info_min, np.where(high, "high", "low"), "unknown")


def slipmap_step(
    state: SlipMapState, dt: float, ev: SlipMapEvidence, config: SlipMapConfig
) -> tuple[SlipMapState, SlipMapOutput]:
    """One recursion step (pure) from one sample's evidence (fields of shape () or (1,))."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive and finite, got {dt}")
    st = np.array([state.f, state.f_lp, state.info, float(state.high)])
    wx, wy = float(np.ravel(ev.w_x)[0]), float(np.ravel(ev.w_y)[0])
    _recur(st, dt, float(np.ravel(ev.p_high)[0]), float(np.ravel(ev.p_low)[0]),
           float(np.ravel(ev.p_old)[0]), wx + wy, config.lowpass_tau_s, config.hysteresis)
    new = SlipMapState(float(st[0]), float(st[1]), float(st[2]), bool(st[3] > 0.5))
    cls = str(_classes(np.array(new.high), np.array(new.info), config.info_min))
    excited = max(wx, wy) >= config.w_excited
    return new, SlipMapOutput(cls, float(np.clip(new.f_lp, 0, 1)), bool(excited), wx, wy)


def slipmap_batch(
    t: NDArray, ev: SlipMapEvidence, config: SlipMapConfig,
    state: SlipMapState | None = None, dt0: float | None = None,
) -> tuple[SlipMapState, SlipMapOutput]:
    """The recursion over whole arrays (compiled; equals :func:`slipmap_step` repeated)."""
    t = np.ascontiguousarray(t, float)
    n = t.shape[0]
    if n > 1 and (np.diff(t) <= 0).any():
        raise ValueError("t must be strictly increasing")
    for name in ("p_high", "p_low", "p_old", "w_x", "w_y"):
        a = getattr(ev, name)
        if np.shape(a) != (n,) or not np.isfinite(a).all():
            raise ValueError(f"evidence {name} must be finite with shape ({n},)")
    if dt0 is None:
        dt0 = float(t[1] - t[0]) if n > 1 else 0.01
    s = state or slipmap_init()
    st = np.array([s.f, s.f_lp, s.info, float(s.high)])
    out = _recur_batch(st, t, ev.p_high, ev.p_low, ev.p_old, ev.w_x + ev.w_y,
                       config.lowpass_tau_s, config.hysteresis, float(dt0))
    cls = _classes(out[:, 3] > 0.5, out[:, 2], config.info_min)
    excited = np.maximum(ev.w_x, ev.w_y) >= config.w_excited
    res = SlipMapOutput(cls, np.clip(out[:, 1], 0.0, 1.0), excited, ev.w_x, ev.w_y)
    return SlipMapState(float(st[0]), float(st[1]), float(st[2]), bool(st[3] > 0.5)), res


def _evidence_from_kin(kin: KinematicOutput, ax, ay, steer, params, config) -> SlipMapEvidence:
    return evidence(np.atleast_2d(kin.kappa), np.atleast_1d(kin.alpha_f), np.atleast_1d(kin.alpha_r),
                    np.atleast_1d(ax), np.atleast_1d(ay), np.atleast_1d(steer),
                    np.atleast_2d(kin.wheels_valid), params, config, np.atleast_1d(kin.vx))


class SlipMapClassifier(KinematicClassifier):
    """Online slip-map classifier: kinematic stage + evidence + recursion.

    Parameters
    ----------
    params : VehicleParams
    config : SlipMapConfig, optional
        Default :func:`default_config`.
    kinematic : KinematicConfig
    aid : {'wheels', 'pose'}
        Velocity aid of the kinematic stage for :meth:`step`.
    """

    default_config = staticmethod(default_config)

    def __init__(
        self, params: VehicleParams, config: SlipMapConfig | None = None,
        kinematic: KinematicConfig = KinematicConfig(), aid: str = "wheels",
    ) -> None:
        super().__init__(params, config, kinematic, aid)
        self.state_ = slipmap_init()
        self.prefilter_ = np.zeros(8)

    def step(self, sample: KinematicInput) -> SlipMapOutput:
        kin, dt, ay_kin = self._advance(sample)
        ay = select_lateral_acceleration(self.config.lateral_acceleration, self.kinematic.aid,
                                         float(sample.ay), ay_kin)
        y = _prefilter(_pack(kin, sample.ax, ay), np.array([float(sample.t)]),
                       self.config.prefilter_tau_s, dt, self.prefilter_)
        kin_f, ax_f, ay_f = _unpack(kin, y)
        ev = _evidence_from_kin(kin_f, ax_f, ay_f, sample.steer, self.params, self.config)
        self.state_, out = slipmap_step(self.state_, dt, ev, self.config)
        return out

    def run(self, drive: Drive) -> pd.DataFrame:
        return _run_table(drive, self.config, self.kinematic.config)


def _filtered_evidence(
    drive: Drive, kin: KinematicOutput, config: SlipMapConfig, dt0: float | None = 0.01,
    kin_cfg: KinematicConfig = KinematicConfig(),
) -> SlipMapEvidence:
    """Evidence of a whole drive after the prefilter (equals the online object's)."""
    t = drive.t
    if dt0 is None:
        dt0 = float(t[1] - t[0]) if drive.n > 1 else 0.01
    ay = drive_lateral_acceleration(drive, kin, config.lateral_acceleration, kin_cfg)
    y = _prefilter(_pack(kin, drive.col("ax"), ay), t, config.prefilter_tau_s,
                   float(dt0), np.zeros(8))
    kin_f, ax_f, ay_f = _unpack(kin, y)
    return _evidence_from_kin(kin_f, ax_f, ay_f, drive.col("steer"), drive.vehicle, config)


def _run_table(drive: Drive, config: SlipMapConfig, kin_cfg: KinematicConfig,
               dt0: float | None = 0.01) -> pd.DataFrame:
    kin = estimate_kinematics(drive, kin_cfg)
    ev = _filtered_evidence(drive, kin, config, dt0, kin_cfg)
    _, out = slipmap_batch(drive.t, ev, config, dt0=dt0)
    return pd.DataFrame({
        "t": drive.t,
        "grip_class": out.grip_class,
        "grip_index": out.grip_index,
        "excited": out.excited,
        "theta_long": np.nan,
        "theta_lat": np.nan,
        "w_x": ev.w_x,
        "w_y": ev.w_y,
        "p_high": ev.p_high,
        "p_low": ev.p_low,
        "ax_ref": ev.ax_ref,
        "ay_ref": ev.ay_ref,
        "kappa_used": ev.kappa,
        "ay_used": drive_lateral_acceleration(drive, kin, config.lateral_acceleration, kin_cfg),
        "alpha_f_hat": kin.alpha_f,
        "alpha_r_hat": kin.alpha_r,
        "vx_hat": kin.vx,
        "beta_hat": kin.beta,
    })


def calibrate_section(
    data: list[tuple[Drive, str, KinematicOutput]], base: SlipMapConfig | None = None,
    kinematic: KinematicConfig = KinematicConfig(),
) -> dict[str, Any]:
    """Choose each channel's mid-friction curve from labelled drives.

    For each channel a grid of peaks ``D`` (0.1-1.5 times the base peak) and
    slopes ``B`` (0.25-2 times the base) is searched for the curve whose
    per-sample decision ``|a| > |a_ref| -> high`` has the best balanced
    accuracy on the labelled samples outside the exclusions, each sample
    weighted by its eq. 9 reliability.

    Then the prefilter (0, 0.5 or 1 s), the output low-pass time constant
    (0.5-4 s) and the hysteresis (0.1-0.3) are chosen by running the
    classifier over each labelled drive and scoring the fraction of its moving
    time after the settling period
    (:data:`roadgrip.estimators.brls.CALIBRATION_SETTLING_S`, counted from the
    first moving sample, :func:`roadgrip.estimators.brls.settled`) spent in the
    labelled class, minus ``SWITCH_PENALTY`` per class switch beyond the first.

    The lateral acceleration is ``base.lateral_acceleration``'s.

    Returns
    -------
    dict
        ``{'config': SlipMapConfig.to_dict(), 'fit': {...}}`` with the balanced
        accuracies and the final score in ``'fit'``.
    """
    base = base or default_config()
    fit: dict[str, float] = {}
    ays = [drive_lateral_acceleration(drive, kin, base.lateral_acceleration, kinematic)
           for drive, _, kin in data]
    curves = {"long_curve": base.long_curve, "lat_curve": base.lat_curve}
    for chan, key in (("x", "long_curve"), ("y", "lat_curve")):
        c0 = curves[key]
        best = (-1.0, c0)
        for dscale in np.geomspace(0.1, 1.5, 25):
            for bscale in np.geomspace(0.25, 2.0, 10):
                cur = replace(c0, D=c0.D * dscale, B=c0.B * bscale)
                cfg = replace(base, **{key: cur})
                acc_hi, acc_lo, n_hi, n_lo = 0.0, 0.0, 0.0, 0.0
                for (drive, lab, kin), ay in zip(data, ays, strict=True):
                    ev = _evidence_from_kin(kin, drive.col("ax"), ay,
                                            drive.col("steer"), drive.vehicle, cfg)
                    w = ev.w_x if chan == "x" else ev.w_y
                    a = drive.col("ax") if chan == "x" else ay
                    ref = ev.ax_ref if chan == "x" else ev.ay_ref
                    above = np.abs(a) > np.abs(ref)
                    if lab == "high":
                        acc_hi += float((w * above).sum())
                        n_hi += float(w.sum())
                    else:
                        acc_lo += float((w * ~above).sum())
                        n_lo += float(w.sum())
                if n_hi < 1.0 or n_lo < 1.0:
                    continue
                bal = 0.5 * (acc_hi / n_hi + acc_lo / n_lo)
                if bal > best[0]:
                    best = (bal, cur)
        curves[key] = best[1]
        fit[f"balanced_accuracy_{'long' if chan == 'x' else 'lat'}"] = float(best[0])
    cfg = replace(base, **curves)
    # prefilter and output dynamics, scored on the full recursion over the settled
    # moving samples (as the bRLS calibration)
    from roadgrip.estimators.brls import settled

    masks = [settled(drive.t, np.abs(kin.vx) >= cfg.min_speed) for drive, _lab, kin in data]
    best = None
    for pf in (0.0, 0.5, 1.0):
        cpf = replace(cfg, prefilter_tau_s=pf)
        evs = [(drive, lab, _filtered_evidence(drive, kin, cpf, kin_cfg=kinematic))
               for drive, lab, kin in data]
        for tau in (0.5, 1.0, 2.0, 4.0):
            for hyst in (0.1, 0.2, 0.3):
                c = replace(cpf, lowpass_tau_s=tau, hysteresis=hyst)
                accs, extra = [], 0
                for (drive, lab, ev), judged in zip(evs, masks, strict=True):
                    _, out = slipmap_batch(drive.t, ev, c, dt0=0.01)
                    cls = out.grip_class
                    accs.append(float((cls[judged] == lab).mean()))
                    known = cls[cls != "unknown"]
                    extra += max(int(np.sum(known[1:] != known[:-1])) - 1, 0)
                key = float(np.mean(accs)) - SWITCH_PENALTY * extra
                if best is None or key > best[0] + 1e-9:
                    best = (key, c, float(np.mean(accs)), extra)
    fit["fraction_in_labelled_class"] = best[2]
    fit["extra_switches"] = best[3]
    return {"config": best[1].to_dict(), "fit": fit}


def config_from_calibration(section: dict[str, Any]) -> SlipMapConfig:
    """The :class:`SlipMapConfig` stored in a calibration file's ``slipmap`` section."""
    if "config" not in section:
        raise ValueError("calibration file has no slipmap configuration (section 'slipmap.config')")
    return SlipMapConfig.from_dict(section["config"])


def run_cli(drive: Drive, request: EstimateRequest) -> EstimateResult:
    """``roadgrip estimate DRIVE --method slipmap [--calibration FILE] [--plot FILE]``."""
    from roadgrip.estimators.brls import DEFAULT_FRICTION, load_calibration, summary_meta

    request.reject("slipmap", "particles", "basis", "curves_path", "curve_times")
    if request.options:
        raise ValueError(f"option(s) {sorted(request.options)} do not apply to slipmap")
    friction = dict(DEFAULT_FRICTION)
    if request.calibration:
        cal = load_calibration(request.calibration)
        config, friction = config_from_calibration(cal.slipmap), cal.friction
        note = str(request.calibration)
    else:
        config, note = default_config(), "uncalibrated defaults (mid friction 0.8, dry-asphalt shapes)"
    meta: dict[str, Any] = {}
    with timed(meta, drive.n, drive.duration):
        table = _run_table(drive, config, KinematicConfig())
    meta["summary"] = summary_meta(table, friction)
    cls = table["grip_class"].to_numpy()
    meta["diagnostics"] = {
        "calibration": note,
        "excited_fraction": float(table["excited"].mean()),
        "class_changes": int(np.sum(cls[1:] != cls[:-1])),
    }
    meta["config"] = config.to_dict()
    if request.plot_path:
        from roadgrip.plots.classification import plot_classification

        plot_classification(drive, table, request.plot_path, method="slipmap")
    return EstimateResult("slipmap", conform(table), meta)
