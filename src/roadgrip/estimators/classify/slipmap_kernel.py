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

# state vector layout
F, F_LP, INFO, HIGH = range(4)
STATE_SIZE = 4


class SlipMapState(NamedTuple):
    """Recursion state: ``F`` (eq. 16), its low-passed value, accumulated weight, class."""

    f: float
    f_lp: float
    info: float
    high: bool


class SlipMapOutput(NamedTuple):
    """Per-sample output (scalars from :func:`slipmap_step`, arrays of shape (T,) from a batch)."""

    grip_class: Any
    grip_index: Any
    excited: Any
    w_x: Any
    w_y: Any


def slipmap_init() -> SlipMapState:
    """Agnostic start: ``F = 1/2``, no information."""
    return SlipMapState(0.5, 0.5, 0.0, True)


def _state_vector(s: SlipMapState) -> NDArray[np.float64]:
    v = np.empty(STATE_SIZE)
    v[F], v[F_LP], v[INFO], v[HIGH] = s.f, s.f_lp, s.info, float(s.high)
    return v


def _state_from_vector(v: NDArray[np.float64]) -> SlipMapState:
    return SlipMapState(float(v[F]), float(v[F_LP]), float(v[INFO]), bool(v[HIGH] > 0.5))


@numba.njit(cache=True)
def _recur(st, dt, p_high, p_low, p_old, w_sum, tau, hyst):  # pragma: no cover - compiled
    """Eq. 16, low-pass, information and hysteresis class, in place on ``st``."""
    st[F] = p_old * st[F] + p_high
    k = 1.0 - np.exp(-dt / tau)
    st[F_LP] = st[F_LP] + k * (st[F] - st[F_LP])
    st[INFO] = st[INFO] + w_sum
    if st[F_LP] > 0.5 + hyst:
        st[HIGH] = 1.0
    elif st[F_LP] < 0.5 - hyst:
        st[HIGH] = 0.0


@numba.njit(cache=True)
def _recur_batch(st, t, p_high, p_low, p_old, w_sum, tau, hyst, dt0):  # pragma: no cover
    n = t.shape[0]
    out = np.empty((n, STATE_SIZE))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        _recur(st, dt, p_high[i], p_low[i], p_old[i], w_sum[i], tau, hyst)
        out[i] = st
    return out


def slipmap_step(
    state: SlipMapState, dt: float, ev: SlipMapEvidence, config: SlipMapConfig
) -> tuple[SlipMapState, SlipMapOutput]:
    """One recursion step (pure) from one sample's evidence (fields of shape () or (1,))."""
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive and finite, got {dt}")
    st = _state_vector(state)
    wx, wy = float(np.ravel(ev.w_x)[0]), float(np.ravel(ev.w_y)[0])
    _recur(st, dt, float(np.ravel(ev.p_high)[0]), float(np.ravel(ev.p_low)[0]),
           float(np.ravel(ev.p_old)[0]), wx + wy, config.lowpass_tau_s, config.hysteresis)
    new = _state_from_vector(st)
    cls = str(classes(np.array(new.high), np.array(new.info >= config.info_min)))
    excited = max(wx, wy) >= config.w_excited
    return new, SlipMapOutput(cls, float(np.clip(new.f_lp, 0, 1)), bool(excited), wx, wy)


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
                       config.lowpass_tau_s, config.hysteresis, float(dt0))
    cls = classes(out[:, HIGH] > 0.5, out[:, INFO] >= config.info_min)
    excited = np.maximum(ev.w_x, ev.w_y) >= config.w_excited
    res = SlipMapOutput(cls, np.clip(out[:, F_LP], 0.0, 1.0), excited, ev.w_x, ev.w_y)
    return _state_from_vector(st), res
