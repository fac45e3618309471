"""Compiled recursion of the slip-map classifier: eq. 16, output low-pass and hysteresis class.

:func:`_recur` is the one compiled per-sample update, used by the pure step
(:func:`slipmap_step`) and the batch loop (:func:`slipmap_batch`), so a batch
run equals stepping exactly. The state vector's layout is named once below.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.classify.common import classes
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.estimators.classify.slipmap_evidence import SlipMapEvidence

__all__ = ["SlipMapOutput", "SlipMapState", "slipmap_batch", "slipmap_init", "slipmap_step"]

# state vector layout: eq. 16's F, its low-passed value, accumulated weight, class,
# low-passed evidence rate, time since the class was last supported [s], class claimed,
# claimed 'low' being decided afresh (redecide_low_s)
F, F_LP, INFO, HIGH, RATE, SINCE, KNOWN, AFRESH = range(8)
STATE_SIZE = 8
RATE_TAU_S = 0.3
"""Time constant of the evidence rate [s]."""


class SlipMapState(NamedTuple):
    """Recursion state: ``F`` (eq. 16), its low-passed value, accumulated weight, class,
    low-passed evidence rate, time since the class was last supported [s], whether a
    class is claimed (an expired claim waits for the index to leave the hysteresis band)
    and whether a claimed 'low' is being decided afresh (its index restarted at 1/2 and
    only leaving the band supports it again: ``redecide_low_s``)."""

    f: float
    f_lp: float
    info: float
    high: bool
    rate: float = 0.0
    since: float = math.inf
    known: bool = True
    afresh: bool = False


class SlipMapOutput(NamedTuple):
    """Per-sample output (scalars from :func:`slipmap_step`, arrays of shape (T,) from a batch)."""

    grip_class: Any
    grip_index: Any
    excited: Any
    w_x: Any
    w_y: Any


def slipmap_init() -> SlipMapState:
    """Agnostic start: ``F = 1/2``, no information."""
    return SlipMapState(0.5, 0.5, 0.0, True, 0.0, math.inf, True, False)


def _state_vector(s: SlipMapState) -> NDArray[np.float64]:
    v = np.empty(STATE_SIZE)
    v[F], v[F_LP], v[INFO], v[HIGH] = s.f, s.f_lp, s.info, float(s.high)
    v[RATE], v[SINCE], v[KNOWN], v[AFRESH] = s.rate, s.since, float(s.known), float(s.afresh)
    return v


def _state_from_vector(v: NDArray[np.float64]) -> SlipMapState:
    return SlipMapState(float(v[F]), float(v[F_LP]), float(v[INFO]), bool(v[HIGH] > 0.5),
                        float(v[RATE]), float(v[SINCE]), bool(v[KNOWN] > 0.5), bool(v[AFRESH] > 0.5))


class Holds(NamedTuple):
    """Claim settings of the recursion: hysteresis, claim times [s], support rate,
    whether the output low-pass is paced by the evidence (1.0) or by time (0.0), and the
    age [s] from which a claimed 'low' is decided afresh."""

    hyst: float
    hold_high_s: float
    hold_low_s: float
    support_min: float
    paced: float
    redecide_low_s: float


def _holds(config: SlipMapConfig) -> Holds:
    return Holds(float(config.hysteresis), float(config.hold_high_s), float(config.hold_low_s),
                 float(config.support_min), float(config.paced_by_evidence),
                 float(config.redecide_low_s))


@numba.njit(cache=True)
def _recur(st, dt, p_high, p_low, p_old, w_sum, tau, h):  # pragma: no cover - compiled
    """Eq. 16, low-pass, information, hysteresis class and claim age, in place on ``st``."""
    high = st[HIGH] > 0.5
    stale = st[SINCE] > (h.hold_high_s if high else h.hold_low_s)
    if stale and st[KNOWN] > 0.5:
        # an expired claim: the index forgets the old class, one must be claimed afresh
        st[KNOWN] = 0.0
        st[AFRESH] = 0.0
        st[F] = 0.5
        st[F_LP] = 0.5
    elif not high and st[KNOWN] > 0.5 and st[AFRESH] < 0.5 and st[SINCE] > h.redecide_low_s:
        # an old 'low', still claimed, decided afresh: the index forgets it, and only the
        # new evidence taking it out of the hysteresis band supports it again or switches
        st[AFRESH] = 1.0
        st[F] = 0.5
        st[F_LP] = 0.5
    st[F] = p_old * st[F] + p_high
    # paced by the evidence (config.paced_by_evidence), the index moves at full speed where
    # the sample's evidence rate reaches support_min, in proportion below it, and not at all
    # without evidence: the paper's low-pass would settle, through the silence after a
    # manoeuvre, on F's last value, which with eq. 16's short memory is the manoeuvre's
    # final transient (the end of an acceleration, where a_x and the slips arrive with
    # different bus latencies)
    pace = min(1.0, (p_high + p_low) / h.support_min) if h.paced > 0.5 else 1.0
    k = 1.0 - np.exp(-dt / tau * pace)
    st[F_LP] = st[F_LP] + k * (st[F] - st[F_LP])
    st[INFO] = st[INFO] + w_sum
    st[RATE] = st[RATE] + (1.0 - np.exp(-dt / RATE_TAU_S)) * (p_high + p_low - st[RATE])
    if st[AFRESH] > 0.5 and st[KNOWN] > 0.5 and st[RATE] >= h.support_min:
        # the evidence rate on the old 'low' would support a class: no claim unless the
        # index leaves the band (below)
        st[KNOWN] = 0.0
    fresh = False
    afresh = st[AFRESH] > 0.5
    if st[F_LP] > 0.5 + h.hyst:
        fresh = st[KNOWN] < 0.5 or not high or afresh
        st[HIGH] = 1.0
        st[KNOWN] = 1.0
        st[AFRESH] = 0.0
    elif st[F_LP] < 0.5 - h.hyst:
        fresh = st[KNOWN] < 0.5 or high or afresh
        st[HIGH] = 0.0
        st[KNOWN] = 1.0
        st[AFRESH] = 0.0
    high = st[HIGH] > 0.5
    side = st[F_LP] > 0.5 if high else st[F_LP] < 0.5
    if fresh or (st[RATE] >= h.support_min and side and st[AFRESH] < 0.5):
        st[SINCE] = 0.0
    else:
        st[SINCE] = st[SINCE] + dt


@numba.njit(cache=True)
def _recur_batch(st, t, p_high, p_low, p_old, w_sum, tau, h, dt0):  # pragma: no cover
    n = t.shape[0]
    out = np.empty((n, STATE_SIZE))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        _recur(st, dt, p_high[i], p_low[i], p_old[i], w_sum[i], tau, h)
        out[i] = st
    return out


def _claimed(known, high, since, config: SlipMapConfig):
    """Whether a class is claimed: set and supported within its claim time (elementwise)."""
    return np.logical_and(known, since <= np.where(high, config.hold_high_s, config.hold_low_s))


def slipmap_step(
    state: SlipMapState, dt: float, ev: SlipMapEvidence, config: SlipMapConfig
) -> tuple[SlipMapState, SlipMapOutput]:
    """One recursion step (pure) from one sample's evidence (fields of shape () or (1,))."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive and finite, got {dt}")
    st = _state_vector(state)
    wx, wy = float(np.ravel(ev.w_x)[0]), float(np.ravel(ev.w_y)[0])
    _recur(st, dt, float(np.ravel(ev.p_high)[0]), float(np.ravel(ev.p_low)[0]),
           float(np.ravel(ev.p_old)[0]), wx + wy, config.lowpass_tau_s, _holds(config))
    new = _state_from_vector(st)
    known = new.info >= config.info_min and _claimed(new.known, new.high, new.since, config)
    cls = str(classes(np.array(new.high), np.array(known)))
    excited = max(wx, wy) >= config.w_excited
    return new, SlipMapOutput(cls, min(max(new.f_lp, 0.0), 1.0), bool(excited), wx, wy)


def slipmap_batch(
    t: NDArray, ev: SlipMapEvidence, config: SlipMapConfig,
    state: SlipMapState | None = None, dt0: float | None = None,
) -> tuple[SlipMapState, SlipMapOutput]:
    """The recursion over whole arrays (compiled; equals :func:`slipmap_step` repeated).

    Parameters
    ----------
    t : ndarray, shape (T,)
        Sample times [s], strictly increasing.
    ev : SlipMapEvidence
        Fields of shape (T,).
    config : SlipMapConfig
    state : SlipMapState, optional
        Start state (default :func:`slipmap_init`).
    dt0 : float, optional
        Step before the first sample [s]; default the first time step.
    """
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
    st = _state_vector(state or slipmap_init())
    out = _recur_batch(st, t, ev.p_high, ev.p_low, ev.p_old, ev.w_x + ev.w_y,
                       config.lowpass_tau_s, _holds(config), float(dt0))
    high = out[:, HIGH] > 0.5
    known = (out[:, INFO] >= config.info_min) & _claimed(out[:, KNOWN] > 0.5, high, out[:, SINCE], config)
    cls = classes(high, known)
    excited = np.maximum(ev.w_x, ev.w_y) >= config.w_excited
    res = SlipMapOutput(cls, np.clip(out[:, F_LP], 0.0, 1.0), excited, ev.w_x, ev.w_y)
    return _state_from_vector(st), res
