r"""Friction-state classification with two bistable RLS instances and a state machine.

Paper 002 (Selmanaj, Corno, Savaresi), Sections III-IV. The vehicle behaves as
one equivalent tire (eq. 4)::

    ax = theta_long * phi_long,   phi_long = kappa_fl + kappa_fr + kappa_rl + kappa_rr
    ay = theta_lat  * phi_lat,    phi_lat  = alpha_f cos(delta) + alpha_r

with ``theta_long = C_k / M`` [m/s²] and ``theta_lat = 2 C_alpha / M``
[m/s²/rad] (roadgrip slip-angle sign, so ``theta_lat > 0``; the paper's
opposite sign flips its eq. 8 inequalities for the lateral channel). The slips
come from the friction-independent :mod:`roadgrip.inference.kinematic`
stage. Wheels without a speed sensor contribute zero slip.

Each channel runs bRLS (eq. 6, :mod:`roadgrip.inference.rls`) whose reference
is the stiffness of the *current* friction state (Fig. 5 and 7): unexcited
data pull the estimate to the state's reference, excited data move it towards
the measured stiffness. The state machine (eq. 8, roadgrip sign)::

    high -> low  when  theta_lat < thr_lat  or  theta_long < thr_long
    low -> high  when  theta_lat > thr_lat  or  theta_long > thr_long

Implementation choices the paper leaves open, written down here:

* A channel takes part in eq. 8 only while it is *informed*: the low-passed
  measurement weight ``e = LP(1 - exp(-|phi| / gamma))`` (time constant
  ``excitation_tau_s``) is at least ``excitation_min``. Otherwise an unexcited
  channel, still sitting at the previous state's reference, would flip the
  state straight back after every switch. An informed channel that contradicts
  the switch vetoes it (no chatter when the two channels disagree).
* On a switch, a channel that is not informed is reset to the new state's
  reference (its estimate was the old reference, not data).
* Forgetting is given as a memory time: ``mu = exp(-dt / memory_s)`` per sample.
* ``gamma`` (the excitation scale of each regressor, see
  :mod:`roadgrip.inference.rls` on its form) defaults to the regressor value at
  which the two classes' predicted accelerations differ by twice the
  acceleration noise: ``gamma ln 2 = 2 sigma_a / (theta_high - theta_low)``.
  A sample is **sufficiently excited** for a channel when its measurement
  weight is at least 1/2, i.e. ``|phi| >= gamma ln 2``; the output ``excited``
  flags such samples (:func:`sufficiently_excited` adds a minimum duration).
* Options, off by default (the paper's algorithm): a first-order prefilter
  applied alike to regressor and output (``prefilter_tau_s``), a bound on the
  prediction error (``error_clip``, Huber-type robust RLS), and the rear-axle
  lateral regressor ``2 alpha_r`` (``lateral_regressor='rear'``, independent of
  the steering angle; see :func:`regressors`). Regressors are zeroed below
  ``min_speed``.

Outputs per sample: ``grip_class`` ('unknown' until some channel has been
informed, then the state), ``grip_index`` in [0, 1] (each channel's estimate
placed between its low (0) and high (1) references, weighted by the channels'
information ``e``; the state itself when no channel is informed), ``excited``,
``theta_long``, ``theta_lat``.

Calibration (:func:`calibrate`, ``roadgrip calibrate``) learns per-channel
references, thresholds, gamma, the on/off switch of each channel and the
options above from drives labelled 'high' / 'low', and the slip-map
classifier's reference curves
(:mod:`roadgrip.estimators.slipmap`); :func:`save_calibration` /
:func:`load_calibration` write and read the YAML file.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

import numba
import numpy as np
import pandas as pd
import yaml
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
from roadgrip.tire import SURFACES
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BRLSClassifier",
    "BRLSConfig",
    "BRLSOutput",
    "BRLSState",
    "ChannelCalibration",
    "brls_batch",
    "brls_init",
    "brls_step",
    "calibrate",
    "calibrate_cli",
    "default_config",
    "load_calibration",
    "regressors",
    "rolling_ratio",
    "run_cli",
    "save_calibration",
    "settled",
    "sufficiently_excited",
]

CALIBRATION_VERSION = 1

CALIBRATION_SETTLING_S = 10.0
"""Calibration scores judge each drive from this time after its start, while moving [s]."""

DEFAULT_FRICTION = {
    "high": SURFACES["dry_asphalt"].mu_peak,
    "low": SURFACES["gravel"].mu_peak,
}
"""Peak-friction references of the classes without calibration: dry asphalt and gravel."""

SWITCH_PENALTY = 0.01
"""Score penalty per class switch in :func:`calibrate` (fraction of time)."""

SCORE_TOLERANCE = 0.01
"""Scores within this of the best count as equally good in :func:`calibrate`
(fraction of time); among them the largest margin wins."""


@dataclass(frozen=True)
class ChannelCalibration:
    """References and threshold of one bRLS channel (eq. 6, 8).

    Attributes
    ----------
    ref_high, ref_low : float
        Stiffness reference of the high / low state [m/s² per regressor unit].
    threshold : float
        Eq. 8 threshold, between the references.
    gamma : float
        Regressor excitation scale [regressor unit] (module docstring); 0 = plain RLS.
    enabled : bool
        Whether the channel runs at all (calibration switches off a channel whose
        estimates do not separate the labelled classes).
    """

    ref_high: float
    ref_low: float
    threshold: float
    gamma: float
    enabled: bool = True

    def __post_init__(self) -> None:
        for name in ("ref_high", "ref_low", "threshold", "gamma"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if not self.ref_high > self.ref_low:
            raise ValueError(
                f"ref_high ({self.ref_high}) must exceed ref_low ({self.ref_low})"
            )
        if not self.ref_low <= self.threshold <= self.ref_high:
            raise ValueError(
                f"threshold {self.threshold} must lie between ref_low {self.ref_low} "
                f"and ref_high {self.ref_high}"
            )
        if self.gamma < 0:
            raise ValueError(f"gamma must be >= 0, got {self.gamma}")


@dataclass(frozen=True)
class BRLSConfig:
    """bRLS classifier settings.

    Attributes
    ----------
    long, lat : ChannelCalibration
        Longitudinal (``ax`` vs sum of slips) and lateral (``ay`` vs slip regressor) channels.
    memory_s : float
        Forgetting as a memory time [s]: ``mu = exp(-dt / memory_s)``.
    s0 : float
        Initial ``S`` of both channels.
    s_max : float
        Anti-wind-up bound on ``S``.
    excitation_tau_s : float
        Low-pass time constant of the channel information ``e`` [s].
    excitation_min : float
        ``e`` at which a channel is informed and may switch the state.
    initial_state : {'high', 'low'}
        State before any information.
    theta0_long, theta0_lat : float or None
        Initial estimates; default the initial state's references.
    min_speed : float
        Below this speed [m/s] the regressors are zeroed (no information).
    prefilter_tau_s : float
        Time constant [s] of a first-order low-pass applied alike to each
        channel's regressor and output before bRLS (0 = none). Filtering both
        sides keeps ``y = theta phi`` and removes the noise that a 10 Hz
        inertial sensor leaves at the sample level.
    lateral_regressor : {'axles', 'rear'}
        ``alpha_f cos(delta) + alpha_r`` (eq. 4) or ``2 alpha_r`` (see :func:`regressors`).
    error_clip : float
        Bound on the prediction error ``|eps|`` of eq. 6 [m/s²] (a Huber-type
        robust RLS: a burst of outliers moves the estimate by a bounded amount);
        ``inf`` = the paper's update.
    lateral_acceleration : {'auto', 'imu', 'kinematic'}
        Output of the lateral channel: the accelerometer's ``ay``, or the
        kinematic ``r vx + dvy/dt`` of the upstream stage; ``'auto'`` takes the
        kinematic one when the velocity comes from a pose
        (:func:`roadgrip.inference.kinematic.select_lateral_acceleration`).
    theoretical_slip : bool
        Lateral regressor from the theoretical slips ``tan(alpha) vx / (R omega)``
        instead of the slip angles (see :func:`regressors`).
    """

    long: ChannelCalibration
    lat: ChannelCalibration
    memory_s: float = 0.5
    s0: float = 100.0
    s_max: float = 1.0e4
    excitation_tau_s: float = 0.3
    excitation_min: float = 0.3
    initial_state: str = "high"
    theta0_long: float | None = None
    theta0_lat: float | None = None
    min_speed: float = 0.5
    prefilter_tau_s: float = 0.0
    lateral_regressor: str = "axles"
    error_clip: float = math.inf
    lateral_acceleration: str = "auto"
    theoretical_slip: bool = False

    def __post_init__(self) -> None:
        if self.lateral_acceleration not in LATERAL_ACCELERATION_SOURCES:
            raise ValueError(
                f"lateral_acceleration must be one of {LATERAL_ACCELERATION_SOURCES}, "
                f"got {self.lateral_acceleration!r}"
            )
        if self.lateral_regressor not in ("axles", "rear"):
            raise ValueError(
                f"lateral_regressor must be 'axles' or 'rear', got {self.lateral_regressor!r}"
            )
        if not self.error_clip > 0:
            raise ValueError(f"error_clip must be positive (inf = off), got {self.error_clip!r}")
        if not (math.isfinite(self.prefilter_tau_s) and self.prefilter_tau_s >= 0):
            raise ValueError(f"prefilter_tau_s must be >= 0, got {self.prefilter_tau_s!r}")
        if not (math.isfinite(self.min_speed) and self.min_speed >= 0):
            raise ValueError(f"min_speed must be >= 0, got {self.min_speed!r}")
        for name in ("memory_s", "s0", "s_max", "excitation_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        if not 0.0 < self.excitation_min < 1.0:
            raise ValueError(f"excitation_min must lie in (0, 1), got {self.excitation_min!r}")
        if self.initial_state not in ("high", "low"):
            raise ValueError(f"initial_state must be 'high' or 'low', got {self.initial_state!r}")
        if not (self.long.enabled or self.lat.enabled):
            raise ValueError("both bRLS channels are disabled: nothing to classify with")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> BRLSConfig:
        d = dict(d)
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown bRLS setting(s) {sorted(unknown)}")
        for ch in ("long", "lat"):
            if ch not in d:
                raise ValueError(f"bRLS calibration lacks the {ch!r} channel")
            extra = set(d[ch]) - set(ChannelCalibration.__dataclass_fields__)
            if extra:
                raise ValueError(f"unknown key(s) {sorted(extra)} in bRLS channel {ch!r}")
            d[ch] = ChannelCalibration(**d[ch])
        return cls(**d)


def gamma_from_noise(ref_high: float, ref_low: float, accel_noise: float) -> float:
    """``gamma`` with ``gamma ln 2 = 2 sigma_a / (ref_high - ref_low)`` (module docstring)."""
    return 2.0 * accel_noise / ((ref_high - ref_low) * math.log(2.0))


def default_config(accel_noise: float = 0.3) -> BRLSConfig:
    """Uncalibrated defaults from the tire presets: high = dry asphalt, low = gravel.

    Lateral: ``theta_lat = g B C D / 2`` (axle loads in the static split, the
    normalised cornering stiffness of the surface's lateral Magic Formula);
    longitudinal: ``theta_long = g B C D / 4`` (four equally loaded wheels).
    Thresholds halfway; gamma from ``accel_noise`` [m/s²].
    """
    hi, lo = SURFACES["dry_asphalt"], SURFACES["gravel"]

    def chan(sh: float, sl: float) -> ChannelCalibration:
        return ChannelCalibration(sh, sl, 0.5 * (sh + sl), gamma_from_noise(sh, sl, accel_noise))

    return BRLSConfig(
        long=chan(GRAVITY * hi.longitudinal.slope0() / 4, GRAVITY * lo.longitudinal.slope0() / 4),
        lat=chan(GRAVITY * hi.lateral.slope0() / 2, GRAVITY * lo.lateral.slope0() / 2),
    )


# ---------------------------------------------------------------------------------------
# state layout and compiled kernel


class BRLSState(NamedTuple):
    """Classifier state.

    Attributes
    ----------
    theta_long, theta_lat : float
        Stiffness estimates.
    s_long, s_lat : float
        Their ``S``.
    high : bool
        Friction state of eq. 8.
    informed : bool
        Some channel has been informed since the start.
    e_long, e_lat : float
        Low-passed measurement weights (channel information) in [0, 1].
    filtered : tuple of 4 float
        Prefilter states of ``phi_long, ax, phi_lat, ay``.
    """

    theta_long: float
    s_long: float
    theta_lat: float
    s_lat: float
    high: bool
    informed: bool
    e_long: float
    e_lat: float
    filtered: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)


class BRLSOutput(NamedTuple):
    """Per-sample output (scalars in :meth:`BRLSClassifier.step`, arrays from a batch)."""

    grip_class: Any
    grip_index: Any
    excited: Any
    theta_long: Any
    theta_lat: Any
    w_long: Any
    w_lat: Any


class _P:
    """Index layout of the flat parameter vector handed to the compiled kernel."""

    REF_H, REF_L, THR, GAMMA, ON = 0, 1, 2, 3, 4  # + 5 * channel (0 long, 1 lat)
    MEMORY, S_MAX, TAU_E, E_MIN, PREFILTER, ERROR_CLIP = 10, 11, 12, 13, 14, 15
    SIZE = 16


class _S:
    """Index layout of the flat state vector of the compiled kernel."""

    THETA_LONG, S_LONG, THETA_LAT, S_LAT, HIGH, INFORMED, E_LONG, E_LAT = range(8)
    F_PHI_LONG, F_AX, F_PHI_LAT, F_AY = range(8, 12)
    SIZE = 12


@functools.lru_cache(maxsize=64)
def _param_vector(cfg: BRLSConfig) -> NDArray[np.float64]:
    """The flat parameter vector of the kernel (cached per configuration; read-only)."""
    p = np.zeros(_P.SIZE)
    for c, ch in enumerate((cfg.long, cfg.lat)):
        o = 5 * c
        p[o + _P.REF_H], p[o + _P.REF_L] = ch.ref_high, ch.ref_low
        p[o + _P.THR], p[o + _P.GAMMA], p[o + _P.ON] = ch.threshold, ch.gamma, float(ch.enabled)
    p[_P.MEMORY], p[_P.S_MAX] = cfg.memory_s, cfg.s_max
    p[_P.TAU_E], p[_P.E_MIN] = cfg.excitation_tau_s, cfg.excitation_min
    p[_P.PREFILTER] = cfg.prefilter_tau_s
    p[_P.ERROR_CLIP] = cfg.error_clip
    p.setflags(write=False)
    return p


def _state_vector(s: BRLSState) -> NDArray[np.float64]:
    return np.array([s.theta_long, s.s_long, s.theta_lat, s.s_lat, float(s.high),
                     float(s.informed), s.e_long, s.e_lat, *s.filtered])


def _state_from_vector(v: NDArray[np.float64]) -> BRLSState:
    return BRLSState(float(v[0]), float(v[1]), float(v[2]), float(v[3]), bool(v[4] > 0.5),
                     bool(v[5] > 0.5), float(v[6]), float(v[7]),
                     (float(v[8]), float(v[9]), float(v[10]), float(v[11])))


@numba.njit(cache=True)
def _update(st, dt, phi_long, y_long, phi_lat, y_lat, p):  # pragma: no cover - compiled
    """One classifier update in place on ``st``; returns (index, w_long, w_lat)."""
    mu = np.exp(-dt / p[10])
    ke = 1.0 - np.exp(-dt / p[12])
    kf = 1.0 if p[14] <= 0.0 else 1.0 - np.exp(-dt / p[14])
    e_min = p[13]
    high = st[4] > 0.5
    # identical first-order prefilter on regressor and output (keeps y = theta phi)
    st[8] += kf * (phi_long - st[8])
    st[9] += kf * (y_long - st[9])
    st[10] += kf * (phi_lat - st[10])
    st[11] += kf * (y_lat - st[11])
    w0 = 0.0
    w1 = 0.0
    for c in range(2):
        o = 5 * c
        if p[o + 4] < 0.5:
            continue
        th = st[2 * c]
        s = st[2 * c + 1]
        ph = st[8 + 2 * c]
        g = p[o + 3]
        w = 1.0 if g == 0.0 else 1.0 - np.exp(-abs(ph) / g)
        ref = p[o + 0] if high else p[o + 1]
        eps = st[9 + 2 * c] - ph * th
        if eps > p[15]:
            eps = p[15]
        elif eps < -p[15]:
            eps = -p[15]
        eps_ref = w * eps + (1.0 - w) * ph * (ref - th)
        sp = s * ph
        eta = mu + ph * sp
        th = th + sp / eta * eps_ref
        s = (s - sp * sp / eta) / mu
        if s > p[11]:
            s = p[11]
        st[2 * c] = th
        st[2 * c + 1] = s
        st[6 + c] = st[6 + c] + ke * (w - st[6 + c])
        if c == 0:
            w0 = w
        else:
            w1 = w
    # state machine, eq. 8 (roadgrip sign: larger stiffness = higher grip)
    says_low = False
    says_high = False
    for c in range(2):
        o = 5 * c
        if p[o + 4] > 0.5 and st[6 + c] >= e_min:
            st[5] = 1.0
            if st[2 * c] < p[o + 2]:
                says_low = True
            elif st[2 * c] > p[o + 2]:
                says_high = True
    switch = (high and says_low and not says_high) or ((not high) and says_high and not says_low)
    if switch:
        high = not high
        st[4] = 1.0 if high else 0.0
        for c in range(2):
            o = 5 * c
            if p[o + 4] > 0.5 and st[6 + c] < e_min:
                st[2 * c] = p[o + 0] if high else p[o + 1]
    # grip index: channel estimates between their references, weighted by information
    num = 0.05 * (1.0 if high else 0.0)
    den = 0.05
    for c in range(2):
        o = 5 * c
        if p[o + 4] > 0.5:
            gi = (st[2 * c] - p[o + 1]) / (p[o + 0] - p[o + 1])
            gi = min(max(gi, 0.0), 1.0)
            num += st[6 + c] * gi
            den += st[6 + c]
    idx = num / den
    if st[5] < 0.5:
        idx = 0.5
    return idx, w0, w1


@numba.njit(cache=True)
def _batch(st, t, phi_long, y_long, phi_lat, y_lat, p, dt0):  # pragma: no cover - compiled
    n = t.shape[0]
    out_state = np.empty((n, st.shape[0]))
    idx = np.empty(n)
    wl = np.empty(n)
    wa = np.empty(n)
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        idx[i], wl[i], wa[i] = _update(st, dt, phi_long[i], y_long[i], phi_lat[i], y_lat[i], p)
        out_state[i] = st
    return out_state, idx, wl, wa


def brls_init(config: BRLSConfig) -> BRLSState:
    """State before the first sample: the initial state's references, ``S = s0``."""
    high = config.initial_state == "high"
    tl = config.theta0_long
    ta = config.theta0_lat
    if tl is None:
        tl = config.long.ref_high if high else config.long.ref_low
    if ta is None:
        ta = config.lat.ref_high if high else config.lat.ref_low
    return BRLSState(float(tl), config.s0, float(ta), config.s0, high, False, 0.0, 0.0,
                     (0.0, 0.0, 0.0, 0.0))


def _classes(high: NDArray, informed: NDArray) -> NDArray[np.str_]:
    return np.where(informed, np.where(high, "high", "low"), "unknown")


def brls_step(
    state: BRLSState,
    dt: float,
    phi_long: float,
    ax: float,
    phi_lat: float,
    ay: float,
    config: BRLSConfig,
) -> tuple[BRLSState, BRLSOutput]:
    """One classifier step (pure): both bRLS channels (eq. 6) and the state machine (eq. 8).

    Parameters
    ----------
    state : BRLSState
    dt : float
        Time since the previous sample [s] (> 0).
    phi_long, ax : float
        Sum of the wheel slips [-] and longitudinal acceleration [m/s²].
    phi_lat, ay : float
        ``alpha_f cos(delta) + alpha_r`` [rad] and lateral acceleration [m/s²].
    config : BRLSConfig

    Returns
    -------
    state : BRLSState
    output : BRLSOutput
    """
    vals = (dt, phi_long, ax, phi_lat, ay)
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"non-finite bRLS input (dt, phi_long, ax, phi_lat, ay) = {vals}")
    if dt <= 0:
        raise ValueError(f"dt must be positive, got {dt}")
    st = _state_vector(state)
    idx, wl, wa = _update(st, dt, phi_long, ax, phi_lat, ay, _param_vector(config))
    new = _state_from_vector(st)
    excited = (wl >= 0.5 and config.long.enabled) or (wa >= 0.5 and config.lat.enabled)
    cls = str(_classes(np.array(new.high), np.array(new.informed)))
    return new, BRLSOutput(cls, float(idx), bool(excited), new.theta_long, new.theta_lat, wl, wa)


def brls_batch(
    t: NDArray, phi_long: NDArray, ax: NDArray, phi_lat: NDArray, ay: NDArray,
    config: BRLSConfig, state: BRLSState | None = None, dt0: float | None = None,
) -> tuple[BRLSState, BRLSOutput]:
    """The classifier over whole arrays (compiled loop; equals :func:`brls_step` repeated).

    Parameters
    ----------
    t : ndarray, shape (T,)
        Sample times [s], strictly increasing.
    phi_long, ax, phi_lat, ay : ndarray, shape (T,)
        Regressors and outputs of the two channels.
    config : BRLSConfig
    state : BRLSState, optional
        Start state (default :func:`brls_init`).
    dt0 : float, optional
        Step before the first sample [s]; default the first time step.

    Returns
    -------
    state : BRLSState
        After the last sample.
    output : BRLSOutput
        Arrays of shape (T,).
    """
    arrs = [np.ascontiguousarray(a, dtype=float) for a in (t, phi_long, ax, phi_lat, ay)]
    names = ("t", "phi_long", "ax", "phi_lat", "ay")
    n = arrs[0].shape[0]
    for name, a in zip(names, arrs, strict=True):
        if a.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name} has non-finite values, first at index {np.flatnonzero(~np.isfinite(a))[0]}")
    if n > 1 and (np.diff(arrs[0]) <= 0).any():
        raise ValueError("t must be strictly increasing")
    if dt0 is None:
        dt0 = float(arrs[0][1] - arrs[0][0]) if n > 1 else 0.01
    st = _state_vector(state if state is not None else brls_init(config))
    sv, idx, wl, wa = _batch(st, *arrs, _param_vector(config), float(dt0))
    high, informed = sv[:, _S.HIGH] > 0.5, sv[:, _S.INFORMED] > 0.5
    excited = ((wl >= 0.5) & config.long.enabled) | ((wa >= 0.5) & config.lat.enabled)
    out = BRLSOutput(_classes(high, informed), idx, excited, sv[:, _S.THETA_LONG],
                     sv[:, _S.THETA_LAT], wl, wa)
    return _state_from_vector(st), out


def rolling_ratio(kappa: NDArray) -> NDArray[np.float64]:
    """``vx / (R omega)`` of a wheel from its slip (eq. 2's definition).

    Eq. 2 divides by the larger of the two speeds, so ``vx / (R omega) = 1 - kappa``
    when driving (``kappa >= 0``) and ``1 / (1 + kappa)`` when braking; braking
    slip is bounded at -0.5 (a locking wheel has no rolling speed).
    """
    k = np.clip(np.asarray(kappa, float), -0.5, 1.0)
    return np.where(k >= 0.0, 1.0 - k, 1.0 / (1.0 + k))


def _axle_rolling_ratio(kin: KinematicOutput, axle: slice) -> NDArray[np.float64]:
    """Mean :func:`rolling_ratio` of an axle's measured wheels (1 where none is measured)."""
    kappa = np.asarray(kin.kappa, float)[..., axle]
    valid = np.asarray(kin.wheels_valid, bool)[..., axle]
    n = valid.sum(axis=-1)
    k = np.where(n > 0, (kappa * valid).sum(axis=-1) / np.maximum(n, 1), 0.0)
    return rolling_ratio(k)


def regressors(
    kin: KinematicOutput, steer: NDArray, min_speed: float = 0.0, lateral: str = "axles",
    params: VehicleParams | None = None, theoretical_slip: bool = False,
) -> tuple[NDArray, NDArray]:
    """The two regressors of eq. 4.

    ``phi_long`` is the sum of the wheel slips. ``phi_lat`` is
    ``alpha_f cos(delta) + alpha_r`` (``lateral='axles'``, the paper's), or
    ``2 alpha_r`` (``lateral='rear'``): in quasi-steady cornering the rear axle
    carries ``lf / L`` of the lateral force whatever the front does, so the
    rear slip angle alone is a regressor of ``ay`` that does not depend on the
    steering angle. It is the better choice when the road-wheel angle is only
    known through a fitted steering map. The factor 2 keeps the scale of the
    paper's regressor in symmetric driving. Both are set to 0 (no information)
    where ``|vx| < min_speed`` [m/s]: near standstill the slips are dominated
    by the low-speed regularisation.

    ``theoretical_slip=True`` replaces each axle's slip angle by the brush
    model's theoretical lateral slip ``sigma_y = tan(alpha) vx / (R omega)``
    (Pacejka, *Tire and Vehicle Dynamics*, Sec. 3.2): the tread deflection
    builds up over the contact length at the wheel's rolling speed
    ``R omega``, not at the travel speed, so a spinning wheel (``kappa > 0``)
    needs a larger slip angle for the same lateral force (the combined-slip
    reduction in the linear range). The ratio comes from the axle's measured
    wheels (:func:`rolling_ratio`); an axle without wheel speeds keeps ``tan(alpha)``.
    """
    kappa = np.asarray(kin.kappa, float)
    slow = np.abs(np.asarray(kin.vx, float)) < min_speed
    phi_long = np.where(slow, 0.0, kappa.sum(axis=-1))
    a_f = np.asarray(kin.alpha_f, float)
    a_r = np.asarray(kin.alpha_r, float)
    if theoretical_slip:
        a_f = np.tan(a_f) * _axle_rolling_ratio(kin, slice(0, 2))
        a_r = np.tan(a_r) * _axle_rolling_ratio(kin, slice(2, 4))
    if lateral == "axles":
        lat = a_f * np.cos(steer) + a_r
    elif lateral == "rear":
        lat = 2.0 * a_r
    else:
        raise ValueError(f"lateral regressor must be 'axles' or 'rear', got {lateral!r}")
    phi_lat = np.where(slow, 0.0, lat)
    return phi_long, phi_lat


def sufficiently_excited(
    t: NDArray, phi_long: NDArray, phi_lat: NDArray, config: BRLSConfig,
    min_duration: float = 0.2,
) -> NDArray[np.bool_]:
    """Samples inside a *sufficiently excited manoeuvre*.

    Definition (used by the acceptance tests and the benchmark): a sample is
    sufficiently excited when, for an enabled channel, the measurement weight of
    eq. 6 is at least 1/2, ``|phi| >= gamma ln 2``, and this has held for at
    least ``min_duration`` [s]. With true slips (simulator truth) this marks
    the manoeuvres that carry friction information, independently of the
    estimator's own slip estimates.

    Parameters
    ----------
    t : ndarray, shape (T,)
    phi_long, phi_lat : ndarray, shape (T,)
        Regressors (sum of wheel slips; ``alpha_f cos(delta) + alpha_r``).
    config : BRLSConfig
    min_duration : float
        [s].
    """
    from roadgrip.evaluate.metrics import sustained

    ln2 = math.log(2.0)
    ex = np.zeros(len(t), bool)
    if config.long.enabled:
        ex |= np.abs(phi_long) >= config.long.gamma * ln2
    if config.lat.enabled:
        ex |= np.abs(phi_lat) >= config.lat.gamma * ln2
    return sustained(ex, t, min_duration)


# ---------------------------------------------------------------------------------------
# online object


class BRLSClassifier(KinematicClassifier):
    """Online bRLS friction classifier: kinematic stage + two bRLS channels + state machine.

    Parameters
    ----------
    params : VehicleParams
    config : BRLSConfig, optional
        Default :func:`default_config`.
    kinematic : KinematicConfig, optional
    aid : {'wheels', 'pose'}
        Velocity aid of the kinematic stage for :meth:`step`.

    Examples
    --------
    >>> from roadgrip.vehicle import PRESETS
    >>> clf = BRLSClassifier(PRESETS["sedan"])
    >>> clf.state_.high, clf.state_.informed
    (True, False)
    """

    default_config = staticmethod(default_config)

    def __init__(
        self,
        params: VehicleParams,
        config: BRLSConfig | None = None,
        kinematic: KinematicConfig = KinematicConfig(),
        aid: str = "wheels",
    ) -> None:
        super().__init__(params, config, kinematic, aid)
        self.state_ = brls_init(self.config)

    def step(self, sample: KinematicInput) -> BRLSOutput:
        """Process one sample; returns the classification after it."""
        kin, dt, ay_kin = self._advance(sample)
        phi_long, phi_lat = regressors(kin, np.asarray(sample.steer), self.config.min_speed,
                                       self.config.lateral_regressor,
                                       theoretical_slip=self.config.theoretical_slip)
        ay = select_lateral_acceleration(self.config.lateral_acceleration, self.kinematic.aid,
                                         float(sample.ay), ay_kin)
        self.state_, out = brls_step(self.state_, dt, float(phi_long), float(sample.ax),
                                     float(phi_lat), float(ay), self.config)
        return out

    def run(self, drive: Drive) -> pd.DataFrame:
        """Classify a whole drive (batch; equals stepping with the drive's first step as dt0)."""
        table, _ = _run_table(drive, self.config, self.kinematic.config)
        return table


def _run_table(
    drive: Drive, config: BRLSConfig, kin_cfg: KinematicConfig, dt0: float | None = 0.01
) -> tuple[pd.DataFrame, KinematicOutput]:
    kin = estimate_kinematics(drive, kin_cfg)
    steer = drive.col("steer")
    phi_long, phi_lat = regressors(kin, steer, config.min_speed, config.lateral_regressor,
                                   theoretical_slip=config.theoretical_slip)
    ay = drive_lateral_acceleration(drive, kin, config.lateral_acceleration, kin_cfg)
    _, out = brls_batch(drive.t, phi_long, drive.col("ax"), phi_lat, ay, config, dt0=dt0)
    table = pd.DataFrame({
        "t": drive.t,
        "grip_class": out.grip_class,
        "grip_index": out.grip_index,
        "excited": out.excited,
        "theta_long": out.theta_long,
        "theta_lat": out.theta_lat,
        "phi_long": phi_long,
        "phi_lat": phi_lat,
        "w_long": out.w_long,
        "w_lat": out.w_lat,
        "ay_used": ay,
        "vx_hat": kin.vx,
        "beta_hat": kin.beta,
    })
    return table, kin


# ---------------------------------------------------------------------------------------
# calibration


@dataclass(frozen=True)
class Calibration:
    """Contents of a calibration file.

    Attributes
    ----------
    brls : BRLSConfig
    slipmap : dict
        ``{'config': SlipMapConfig.to_dict(), 'fit': {...}}``.
    vehicle : str
    drives : tuple of dict
        Provenance: source, label, samples.
    diagnostics : dict
    friction : dict
        Peak-friction reference of each class, ``{'high': float, 'low': float}``
        (used for ``meta['summary']``, see :func:`summary_meta`).
    """

    brls: BRLSConfig
    slipmap: dict[str, Any] = field(default_factory=dict)
    vehicle: str = ""
    drives: tuple[dict[str, Any], ...] = ()
    diagnostics: dict[str, Any] = field(default_factory=dict)
    friction: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_FRICTION))


def save_calibration(cal: Calibration, path: str | Path) -> None:
    """Write a calibration YAML file."""
    doc = {
        "roadgrip_calibration": CALIBRATION_VERSION,
        "vehicle": cal.vehicle,
        "drives": [dict(d) for d in cal.drives],
        "brls": cal.brls.to_dict(),
        "slipmap": dict(cal.slipmap),
        "diagnostics": _plain(cal.diagnostics),
        "friction": {k: float(v) for k, v in cal.friction.items()},
    }
    Path(path).write_text(yaml.safe_dump(_plain(doc), sort_keys=False))


def _plain(o: Any) -> Any:
    if isinstance(o, dict):
        return {str(k): _plain(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_plain(v) for v in o]
    if isinstance(o, np.generic):
        return o.item()
    return o


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration YAML file written by :func:`save_calibration`.

    Raises
    ------
    ValueError
        When the file is not a roadgrip calibration or its contents are invalid.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"calibration file {p} does not exist")
    try:
        doc = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"calibration file {p} is not valid YAML: {exc}") from None
    if not isinstance(doc, dict) or "roadgrip_calibration" not in doc:
        raise ValueError(f"{p} is not a roadgrip calibration file (no 'roadgrip_calibration' key)")
    if doc["roadgrip_calibration"] != CALIBRATION_VERSION:
        raise ValueError(f"{p}: unsupported calibration version {doc['roadgrip_calibration']!r}")
    if "brls" not in doc:
        raise ValueError(f"{p}: calibration lacks the 'brls' section")
    return Calibration(
        brls=BRLSConfig.from_dict(doc["brls"]),
        slipmap=dict(doc.get("slipmap") or {}),
        vehicle=str(doc.get("vehicle", "")),
        drives=tuple(doc.get("drives") or ()),
        diagnostics=dict(doc.get("diagnostics") or {}),
        friction=_friction_refs(doc.get("friction") or DEFAULT_FRICTION, str(p)),
    )


def _friction_refs(d: dict[str, Any], where: str) -> dict[str, float]:
    try:
        hi, lo = float(d["high"]), float(d["low"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}: 'friction' must give numbers for 'high' and 'low'") from None
    if not (0.0 < lo < hi):
        raise ValueError(f"{where}: friction references need 0 < low < high, got {lo}, {hi}")
    return {"high": hi, "low": lo}


def _best_threshold(hi: NDArray, lo: NDArray) -> tuple[float, float]:
    """Threshold maximising the balanced accuracy of ``x > thr -> high``; returns (thr, acc)."""
    cand = np.unique(np.quantile(np.r_[hi, lo], np.linspace(0.01, 0.99, 197)))
    acc = np.array([0.5 * ((hi > c).mean() + (lo <= c).mean()) for c in cand])
    k = int(np.argmax(acc))
    # the middle of the plateau of best thresholds
    best = cand[acc >= acc[k] - 1e-12]
    return float(np.median(best)), float(acc[k])


def _lowpass(x: NDArray, dt: float, tau: float) -> NDArray:
    """First-order low-pass at a constant step (the kernel's prefilter, for calibration)."""
    if tau <= 0:
        return x
    from scipy.signal import lfilter

    k = 1.0 - math.exp(-dt / tau)
    return lfilter([k], [1.0, k - 1.0], x)


def _filtered(data: list, tau: float) -> list:
    out = []
    for drive, lab, kin, regs, moving in data:
        dt = float(np.median(np.diff(drive.t))) if drive.n > 1 else 0.01
        f = {k: (_lowpass(v[0], dt, tau), _lowpass(v[1], dt, tau)) for k, v in regs.items()}
        out.append((drive, lab, kin, f, moving))
    return out


def _channel_candidates(
    name: str, data: list, base: BRLSConfig, quantiles: Sequence[float], memory: float
) -> list[ChannelCalibration]:
    """Candidate settings of one channel for one memory (see :func:`calibrate`)."""
    from roadgrip.inference.rls import brls_scalar_batch

    ln2 = math.log(2.0)
    pooled = {}
    for lab in ("high", "low"):
        pooled[lab] = (
            np.concatenate([d[3][name][0][d[4]] for d in data if d[1] == lab]),
            np.concatenate([d[3][name][1][d[4]] for d in data if d[1] == lab]),
        )
    phi_abs = np.abs(np.concatenate([pooled[k][0] for k in pooled]))
    out = []
    if phi_abs.size < 20:
        return out
    gammas = [getattr(base, name).gamma] + [float(np.quantile(phi_abs, q)) / ln2 for q in quantiles]
    for gamma in gammas:
        if not gamma > 0:
            continue
        refs = {}
        for lab, (phi, y) in pooled.items():
            m = np.abs(phi) >= gamma * ln2
            refs[lab] = float(phi[m] @ y[m] / (phi[m] @ phi[m])) if m.sum() >= 10 else float("nan")
        if not (np.isfinite(refs["high"]) and np.isfinite(refs["low"]) and refs["high"] > refs["low"]):
            continue
        est: dict[str, list] = {"high": [], "low": []}
        for drive, lab, _kin, regs, moving in data:
            phi, y = regs[name]
            dt = float(np.median(np.diff(drive.t))) if drive.n > 1 else 0.01
            th, _, _ = brls_scalar_batch(
                np.where(moving, phi, 0.0), y, np.full(drive.n, np.nan),
                0.5 * (refs["high"] + refs["low"]), base.s0, math.exp(-dt / memory), 0.0, base.s_max,
            )
            est[lab].append(th[(np.abs(phi) >= gamma * ln2) & settled(drive.t, moving)])
        hi, lo = np.concatenate(est["high"]), np.concatenate(est["low"])
        mid = 0.5 * (refs["high"] + refs["low"])
        thrs = {mid}
        if hi.size >= 10 and lo.size >= 10:
            thrs.add(_best_threshold(hi, lo)[0])
        # largest margin between the drives: halfway between the lowest median
        # estimate of a high drive and the highest median of a low drive
        med = {lab: [float(np.median(e)) for e in est[lab] if e.size >= 10] for lab in est}
        if med["high"] and med["low"] and min(med["high"]) > max(med["low"]):
            thrs.add(0.5 * (min(med["high"]) + max(med["low"])))
        for thr in sorted(thrs):
            thr = min(max(thr, refs["low"]), refs["high"])
            out.append(ChannelCalibration(refs["high"], refs["low"], thr, gamma, True))
    return out


def settled(t: NDArray, moving: NDArray) -> NDArray[np.bool_]:
    """Moving samples from :data:`CALIBRATION_SETTLING_S` after the vehicle first moves.

    The settling period counts from the first moving sample: before it no
    estimator has information, so a drive that starts at a standstill is not
    judged on its first seconds of motion. All samples when it never moves.
    """
    moving = np.asarray(moving, bool)
    if not moving.any():
        return np.ones(moving.shape, bool)
    t0 = t[int(np.argmax(moving))]
    m = moving & (t >= t0 + CALIBRATION_SETTLING_S)
    return m if m.any() else moving


def _score(cfg: BRLSConfig, data: list) -> tuple[float, int, float]:
    """Calibration score of one configuration over the labelled drives.

    Returns the mean fraction of the settled moving time (:func:`settled`) in
    the labelled class, starting in the other state; the class switches beyond
    the first; and the margin: per drive and enabled channel the median over
    the settled moving samples of the estimate's distance from the threshold
    on the labelled side, in units of ``ref_high - ref_low`` (negative on the
    wrong side), averaged over the channels, and the smallest over the drives.
    """
    accs, switches, margins = [], 0, []
    for drive, lab, _kin, regs, moving in data:
        c = replace(cfg, initial_state="low" if lab == "high" else "high")
        _, out = brls_batch(drive.t, regs["long"][0], regs["long"][1], regs["lat"][0],
                            regs["lat"][1], c)
        cls = out.grip_class
        judged = settled(drive.t, moving)
        accs.append(float((cls[judged] == lab).mean()))
        known = cls[cls != "unknown"]
        switches += max(int(np.sum(known[1:] != known[:-1])) - 1, 0)
        side = 1.0 if lab == "high" else -1.0
        m = [float(np.median(side * (th[judged] - ch.threshold) / (ch.ref_high - ch.ref_low)))
             for ch, th in ((cfg.long, out.theta_long), (cfg.lat, out.theta_lat)) if ch.enabled]
        margins.append(float(np.mean(m)))
    return float(np.mean(accs)), switches, float(min(margins))


def calibrate(
    drives: Sequence[tuple[Drive, str]],
    *,
    base: BRLSConfig | None = None,
    kinematic: KinematicConfig = KinematicConfig(),
    quantiles: Sequence[float] = (0.5, 0.7, 0.85, 0.95),
    memories: Sequence[float] = (1.0, 2.0, 4.0, 8.0),
    prefilters: Sequence[float] = (0.0, 0.5, 1.0),
    lateral_regressors: Sequence[str] = ("axles", "rear"),
    error_clips: Sequence[float] = (math.inf, 1.0),
    theoretical_slips: Sequence[bool] = (False, True),
    friction: dict[str, float] | None = None,
) -> Calibration:
    """Learn the bRLS references, thresholds, gammas and memory, and the slip-map curves.

    On the samples where the vehicle moves, per channel and candidate:

    1. excitation level ``gamma ln 2`` = a quantile (``quantiles``) of ``|phi|``,
       or ``base``'s gamma;
       ``ref_high`` / ``ref_low`` = least squares through the origin per label on
       the samples that level calls excited (the candidate is dropped unless
       ``ref_high > ref_low``);
    2. memory = ``base.memory_s`` times one of ``memories``; plain RLS is run
       over each drive; the threshold candidates are the midpoint of the
       references, the value that maximises the balanced accuracy of
       ``theta > thr -> high`` on the excited settled samples
       (:func:`settled`), and the largest margin between the drives: halfway
       between the lowest median estimate of a 'high' drive and the highest
       median of a 'low' drive (when these are ordered).

    Both steps run on the prefiltered signals, for each prefilter time constant
    in ``prefilters`` [s] and each lateral regressor in ``lateral_regressors``
    (with slip angles or theoretical slips, ``theoretical_slips``); the
    lateral acceleration is ``base.lateral_acceleration``'s (a sensor choice,
    not learned). For every lateral regressor, prefilter, memory and error
    clip, each channel's candidates are run alone, and the best two of each
    channel together, as the full classifier over each labelled drive,
    starting in the *other* state (so that it must detect the labelled class),
    and scored over the settled moving samples (from
    :data:`CALIBRATION_SETTLING_S` after the drive first moves) by the mean
    fraction of time spent in the labelled class minus ``SWITCH_PENALTY`` per
    class switch beyond the first (a labelled drive has one true class, so
    every further switch is false). Among the candidates within
    :data:`SCORE_TOLERANCE` of the best score, the one with the largest margin
    wins: the median distance of the estimates from the threshold on the
    labelled side, in units of the reference gap, on the worst drive (see
    ``_score``). A few labelled drives do not rank near-equal candidates
    reliably by accuracy alone; the margin prefers the threshold that keeps
    both classes farthest from it. The calibration drives should each contain
    some excitation.

    Parameters
    ----------
    drives : sequence of (Drive, label)
        Labels 'high' or 'low'; both must occur.
    base : BRLSConfig, optional
        Settings kept from it (time constants, ``s0``); default :func:`default_config`.
    kinematic : KinematicConfig
    quantiles, memories, prefilters : sequence of float
        Candidate grids (see above).
    lateral_regressors : sequence of {'axles', 'rear'}
        Lateral regressors tried (:func:`regressors`).
    friction : dict, optional
        Peak-friction reference per class (``{'high': ..., 'low': ...}``); by
        default the median true friction of the drives of each class where they
        carry simulator truth (``mu_true``), else :data:`DEFAULT_FRICTION`.
    error_clips : sequence of float
        Prediction-error bounds tried [m/s²] (``BRLSConfig.error_clip``).
    theoretical_slips : sequence of bool
        Slip-angle or theoretical-slip lateral regressors tried
        (``BRLSConfig.theoretical_slip``).

    Returns
    -------
    Calibration
        ``diagnostics`` holds the winning score and each channel's status.
    """
    from roadgrip.estimators import slipmap

    labels = [lab for _, lab in drives]
    for lab in labels:
        if lab not in ("high", "low"):
            raise ValueError(f"calibration label must be 'high' or 'low', got {lab!r}")
    if "high" not in labels or "low" not in labels:
        raise ValueError("calibration needs at least one 'high' and one 'low' drive")
    base = base or default_config()
    kins = [(drive, lab, estimate_kinematics(drive, kinematic)) for drive, lab in drives]
    scored: list[tuple[float, BRLSConfig, float, int, float]] = []
    off = {name: replace(getattr(base, name), enabled=False) for name in ("long", "lat")}
    for lateral, theoretical in itertools.product(lateral_regressors, theoretical_slips):
        data = []
        for drive, lab, kin in kins:
            pl, pa = regressors(kin, drive.col("steer"), base.min_speed, lateral,
                                theoretical_slip=theoretical)
            moving = np.abs(kin.vx) >= base.min_speed
            ay = drive_lateral_acceleration(drive, kin, base.lateral_acceleration, kinematic)
            regs = {"long": (pl, drive.col("ax")), "lat": (pa, ay)}
            data.append((drive, lab, kin, regs, moving))
        for tau in prefilters:
            fdata = _filtered(data, float(tau))
            for mfac in memories:
                mem = base.memory_s * float(mfac)
                cands = {name: _channel_candidates(name, fdata, base, quantiles, mem)
                         for name in ("long", "lat")}
                for clip in error_clips:
                    common = {"memory_s": mem, "prefilter_tau_s": float(tau),
                              "lateral_regressor": lateral, "error_clip": float(clip),
                              "theoretical_slip": bool(theoretical)}

                    def run(cl, ca, common=common, data=data):
                        cfg = replace(base, long=cl, lat=ca, **common)
                        acc, sw, margin = _score(cfg, data)
                        return acc - SWITCH_PENALTY * sw, cfg, acc, sw, margin

                    # each channel alone, then the best two of each together
                    alone_l = sorted((run(cl, off["lat"]) for cl in cands["long"]),
                                     key=lambda r: -r[0])
                    alone_a = sorted((run(off["long"], ca) for ca in cands["lat"]),
                                     key=lambda r: -r[0])
                    results = alone_l + alone_a + [
                        run(rl[1].long, ra[1].lat) for rl in alone_l[:2] for ra in alone_a[:2]
                    ]
                    scored.extend(results)
    if not scored:
        raise ValueError(
            "calibration failed: no channel gives ordered high/low stiffness references; "
            "are the drives excited and correctly labelled?"
        )
    # within SCORE_TOLERANCE of the best score, the largest margin wins (first on ties)
    top = max(r[0] for r in scored)
    near = [r for r in scored if r[0] >= top - SCORE_TOLERANCE]
    best = max(near, key=lambda r: r[4])
    _, cfg, acc, sw, margin = best
    diag: dict[str, Any] = {
        "fraction_in_labelled_class": acc,
        "class_switches": sw,
        "margin": margin,
        "long_channel": "on" if cfg.long.enabled else "off",
        "lat_channel": "on" if cfg.lat.enabled else "off",
        "lateral_regressor": cfg.lateral_regressor,
        "prefilter_tau_s": cfg.prefilter_tau_s,
        "memory_s": cfg.memory_s,
        "error_clip": cfg.error_clip,
        "theoretical_slip": cfg.theoretical_slip,
        "lateral_acceleration": cfg.lateral_acceleration,
    }
    sm = slipmap.calibrate_section(kins, kinematic=kinematic)
    veh = kins[0][0].vehicle.name
    prov = tuple({"source": d[0].meta.source, "label": d[1], "samples": int(d[0].n)} for d in kins)
    if friction is None:
        friction = dict(DEFAULT_FRICTION)
        for lab in ("high", "low"):
            mus = [d.col("mu_true") for d, la, _ in kins if la == lab and d.has("mu_true")]
            if mus:
                friction[lab] = float(np.median(np.concatenate(mus)))
    friction = _friction_refs(friction, "calibrate")
    return Calibration(cfg, sm, veh, prov, diag, friction)


def calibrate_cli(
    drives: Sequence[str],
    output: str | Path,
    *,
    vehicle: str | None = None,
    fmt: str | None = None,
    console: Any = None,
) -> Calibration:
    """``roadgrip calibrate DRIVE:LABEL ... -o calibration.yaml``.

    Each argument is ``path:label`` or ``path:label=mu`` with label 'high' or
    'low' (split at the last colon); ``mu`` is the known peak friction of that
    surface, the class's friction reference (give it for both classes or for
    neither).
    """
    from roadgrip.io import read_drive

    if not drives:
        raise ValueError("give at least two labelled drives, e.g. dry.parquet:high gravel.parquet:low")
    pairs = []
    given: dict[str, list[float]] = {}
    for arg in drives:
        path, sep, label = str(arg).rpartition(":")
        label, eq, mu = label.partition("=")
        if not sep or label not in ("high", "low"):
            raise ValueError(
                f"expected DRIVE:LABEL or DRIVE:LABEL=MU with label 'high' or 'low', got {arg!r}"
            )
        if eq:
            try:
                given.setdefault(label, []).append(float(mu))
            except ValueError:
                raise ValueError(f"friction after '=' must be a number, got {mu!r} in {arg!r}") from None
        pairs.append((read_drive(path, format=fmt, vehicle=vehicle), label))
    friction = None
    if given:
        if set(given) != {"high", "low"}:
            raise ValueError("give the friction (LABEL=MU) for both classes or for neither")
        friction = {k: float(np.mean(v)) for k, v in given.items()}
    cal = calibrate(pairs, friction=friction)
    save_calibration(cal, output)
    if console is not None:
        b = cal.brls
        for name, ch in (("longitudinal", b.long), ("lateral", b.lat)):
            state = "on" if ch.enabled else "off"
            console.print(
                f"bRLS {name}: {state}; reference high {ch.ref_high:.4g}, low {ch.ref_low:.4g}, "
                f"threshold {ch.threshold:.4g}, gamma {ch.gamma:.3g}"
            )
        sm = cal.slipmap.get("config", {})
        console.print(
            f"slipmap: mid-friction peaks long {sm['long_curve']['D']:.3g}, "
            f"lat {sm['lat_curve']['D']:.3g}; low-pass {sm['lowpass_tau_s']:.3g} s"
        )
        console.print(f"fit: {_plain(cal.diagnostics)} {_plain(cal.slipmap.get('fit', {}))}")
        console.print(f"wrote {output}")
    return cal


# ---------------------------------------------------------------------------------------
# command line


def _progress(request: EstimateRequest, n: int) -> Callable[[], None]:
    if not request.progress or n < 200_000:
        return lambda: None
    from rich.console import Console

    Console(stderr=True).print(f"classifying {n} samples ...")
    return lambda: None


def summary_meta(table: pd.DataFrame, friction: dict[str, float] | None = None) -> dict[str, Any]:
    """``meta['summary']`` of a classification run.

    VSS-style friction (the output contract): the final class mapped to its
    friction reference, ``MostProbable = friction[class]`` with the band
    ``[mid, high]`` for 'high' and ``[low, mid]`` for 'low' (``mid`` halfway
    between the references); while 'unknown', ``MostProbable = mid`` and the
    band spans both references. Also the final class and grip index and the
    share of time in each class.
    """
    fr = friction or DEFAULT_FRICTION
    hi, lo = fr["high"], fr["low"]
    mid = 0.5 * (hi + lo)
    last = table.iloc[-1]
    cls = table["grip_class"].astype(str).to_numpy()
    final = str(last["grip_class"])
    band = {"high": (hi, mid, hi), "low": (lo, lo, mid)}.get(final, (mid, lo, hi))
    return {
        "MostProbable": float(band[0]),
        "LowerBound": float(band[1]),
        "UpperBound": float(band[2]),
        "GripClass": str(last["grip_class"]),
        "GripIndex": float(last["grip_index"]),
        "FractionHigh": float((cls == "high").mean()),
        "FractionLow": float((cls == "low").mean()),
        "FractionUnknown": float((cls == "unknown").mean()),
    }


def run_cli(drive: Drive, request: EstimateRequest) -> EstimateResult:
    """``roadgrip estimate DRIVE --method brls [--calibration FILE] [--plot FILE]``."""
    request.reject("brls", "particles", "basis", "curves_path", "curve_times")
    if request.options:
        raise ValueError(f"option(s) {sorted(request.options)} do not apply to brls")
    if request.calibration:
        cal = load_calibration(request.calibration)
        config, cal_note, friction = cal.brls, str(request.calibration), cal.friction
    else:
        config, cal_note = default_config(), "uncalibrated defaults (dry asphalt / gravel presets)"
        friction = dict(DEFAULT_FRICTION)
    meta: dict[str, Any] = {}
    done = _progress(request, drive.n)
    with timed(meta, drive.n, drive.duration):
        table, _ = _run_table(drive, config, KinematicConfig())
    done()
    meta["summary"] = summary_meta(table, friction)
    n_switch = int(np.sum(table["grip_class"].to_numpy()[1:] != table["grip_class"].to_numpy()[:-1]))
    meta["diagnostics"] = {
        "calibration": cal_note,
        "excited_fraction": float(table["excited"].mean()),
        "class_changes": n_switch,
        "long_channel": "on" if config.long.enabled else "off",
        "lat_channel": "on" if config.lat.enabled else "off",
    }
    meta["config"] = config.to_dict()
    if request.plot_path:
        from roadgrip.plots.classification import plot_classification

        plot_classification(drive, table, request.plot_path, method="brls")
    return EstimateResult("brls", conform(table), meta)
