"""Compiled bRLS classifier kernel: two bRLS channels (eq. 6) and the state machine (eq. 8).

The per-sample update :func:`_update` is one compiled function used by both
the pure step (:func:`brls_step`) and the batch loop (:func:`brls_batch`), so
a batch run equals stepping exactly. The kernel state is a flat vector whose
layout is named once below (``THETA_LONG``, ...; per channel the tuples
``THETA``, ``S``, ``E``, ``F_PHI``, ``F_Y`` indexed by channel ``0`` = long,
``1`` = lat); the parameters are a :class:`BRLSParams` record.
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.classify.brls_config import BRLSConfig
from roadgrip.estimators.classify.common import classes

__all__ = [
    "BRLSOutput",
    "BRLSParams",
    "BRLSState",
    "brls_batch",
    "brls_init",
    "brls_params",
    "brls_step",
]

# state vector layout
THETA_LONG, S_LONG, THETA_LAT, S_LAT, HIGH, INFORMED, E_LONG, E_LAT = range(8)
F_PHI_LONG, F_Y_LONG, F_PHI_LAT, F_Y_LAT = range(8, 12)
SINCE = 12
"""Time since an informed channel last supported the state [s]."""
WITHDRAWN = 13
"""A 'low' decided afresh (``redecide_low_s``) met informed samples that did not decide: not claimed."""
STATE_SIZE = 14
THETA = (THETA_LONG, THETA_LAT)
"""Stiffness estimate of channel ``c`` (0 long, 1 lat)."""
S = (S_LONG, S_LAT)
"""Its scaled covariance ``S``."""
E = (E_LONG, E_LAT)
"""Its low-passed measurement weight (channel information)."""
F_PHI = (F_PHI_LONG, F_PHI_LAT)
"""Prefiltered regressor of channel ``c``."""
F_Y = (F_Y_LONG, F_Y_LAT)
"""Prefiltered output of channel ``c``."""


class BRLSParams(NamedTuple):
    """Kernel parameters (:func:`brls_params` of a :class:`BRLSConfig`).

    Per-channel arrays have shape (2,), index 0 longitudinal, 1 lateral.
    """

    ref_high: NDArray[np.float64]
    ref_low: NDArray[np.float64]
    threshold: NDArray[np.float64]
    gamma: NDArray[np.float64]
    enabled: NDArray[np.bool_]
    memory_s: float
    s_max: float
    excitation_tau_s: float
    excitation_min: float
    prefilter_tau_s: float
    error_clip: float
    hold_high_s: float
    hold_low_s: float
    redecide_low_s: float


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
    since_support : float
        Time since an informed channel last supported the state [s] (inf before).
    withdrawn : bool
        A 'low' being decided afresh met informed samples that did not decide: it is
        not claimed until the new evidence supports it or switches the state.
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
    since_support: float = math.inf
    withdrawn: bool = False


class BRLSOutput(NamedTuple):
    """Per-sample output (scalars from :func:`brls_step`, arrays of shape (T,) from :func:`brls_batch`)."""

    grip_class: Any
    grip_index: Any
    excited: Any
    theta_long: Any
    theta_lat: Any
    w_long: Any
    w_lat: Any


def _ro(*values: float) -> NDArray:
    a = np.array(values)
    a.setflags(write=False)
    return a


@functools.lru_cache(maxsize=64)
def brls_params(cfg: BRLSConfig) -> BRLSParams:
    """The kernel parameters of ``cfg`` (cached per configuration; read-only arrays)."""
    chans = (cfg.long, cfg.lat)
    enabled = np.array([ch.enabled for ch in chans], dtype=np.bool_)
    enabled.setflags(write=False)
    return BRLSParams(
        ref_high=_ro(*(ch.ref_high for ch in chans)),
        ref_low=_ro(*(ch.ref_low for ch in chans)),
        threshold=_ro(*(ch.threshold for ch in chans)),
        gamma=_ro(*(ch.gamma for ch in chans)),
        enabled=enabled,
        memory_s=float(cfg.memory_s),
        s_max=float(cfg.s_max),
        excitation_tau_s=float(cfg.excitation_tau_s),
        excitation_min=float(cfg.excitation_min),
        prefilter_tau_s=float(cfg.prefilter_tau_s),
        error_clip=float(cfg.error_clip),
        hold_high_s=float(cfg.hold_high_s),
        hold_low_s=float(cfg.hold_low_s),
        redecide_low_s=float(cfg.redecide_low_s),
    )


def _state_vector(s: BRLSState) -> NDArray[np.float64]:
    v = np.empty(STATE_SIZE)
    v[THETA_LONG], v[S_LONG], v[THETA_LAT], v[S_LAT] = s.theta_long, s.s_long, s.theta_lat, s.s_lat
    v[HIGH], v[INFORMED] = float(s.high), float(s.informed)
    v[E_LONG], v[E_LAT] = s.e_long, s.e_lat
    v[F_PHI_LONG], v[F_Y_LONG], v[F_PHI_LAT], v[F_Y_LAT] = s.filtered
    v[SINCE] = s.since_support
    v[WITHDRAWN] = float(s.withdrawn)
    return v


def _state_from_vector(v: NDArray[np.float64]) -> BRLSState:
    return BRLSState(
        float(v[THETA_LONG]), float(v[S_LONG]), float(v[THETA_LAT]), float(v[S_LAT]),
        bool(v[HIGH] > 0.5), bool(v[INFORMED] > 0.5), float(v[E_LONG]), float(v[E_LAT]),
        (float(v[F_PHI_LONG]), float(v[F_Y_LONG]), float(v[F_PHI_LAT]), float(v[F_Y_LAT])),
        float(v[SINCE]), bool(v[WITHDRAWN] > 0.5),
    )


@numba.njit(cache=True)
def _update(st, dt, phi_long, y_long, phi_lat, y_lat, p):  # pragma: no cover - compiled
    """One classifier update in place on ``st``; returns (grip index, w_long, w_lat)."""
    # forgetting factor; after a long pause (a logger stopped for minutes) it would
    # underflow to 0 and divide by zero below: the memory is then simply emptied
    mu = max(np.exp(-dt / p.memory_s), 1e-9)
    ke = 1.0 - np.exp(-dt / p.excitation_tau_s)
    kf = 1.0 if p.prefilter_tau_s <= 0.0 else 1.0 - np.exp(-dt / p.prefilter_tau_s)
    e_min = p.excitation_min
    clip = p.error_clip
    high = st[HIGH] > 0.5
    # an expired claim (or a 'low' to decide afresh, still claimed: redecide_low_s): no
    # state to hold, the estimates relax to the thresholds
    stale = st[SINCE] > (p.hold_high_s if high else min(p.hold_low_s, p.redecide_low_s))
    # identical first-order prefilter on regressor and output (keeps y = theta phi)
    st[F_PHI_LONG] += kf * (phi_long - st[F_PHI_LONG])
    st[F_Y_LONG] += kf * (y_long - st[F_Y_LONG])
    st[F_PHI_LAT] += kf * (phi_lat - st[F_PHI_LAT])
    st[F_Y_LAT] += kf * (y_lat - st[F_Y_LAT])
    w0 = 0.0
    w1 = 0.0
    for c in range(2):
        if not p.enabled[c]:
            continue
        th = st[THETA[c]]
        s = st[S[c]]
        ph = st[F_PHI[c]]
        g = p.gamma[c]
        w = 1.0 if g == 0.0 else 1.0 - np.exp(-abs(ph) / g)
        ref = p.ref_high[c] if high else p.ref_low[c]
        if stale:
            ref = p.threshold[c]
        eps = st[F_Y[c]] - ph * th
        if eps > clip:
            eps = clip
        elif eps < -clip:
            eps = -clip
        eps_ref = w * eps + (1.0 - w) * ph * (ref - th)
        sp = s * ph
        eta = mu + ph * sp
        th = th + sp / eta * eps_ref
        s = (s - sp * sp / eta) / mu
        if s > p.s_max:
            s = p.s_max
        st[THETA[c]] = th
        st[S[c]] = s
        st[E[c]] = st[E[c]] + ke * (w - st[E[c]])
        if c == 0:
            w0 = w
        else:
            w1 = w
    # state machine, eq. 8 (roadgrip sign: larger stiffness = higher grip)
    says_low = False
    says_high = False
    for c in range(2):
        if p.enabled[c] and st[E[c]] >= e_min:
            st[INFORMED] = 1.0
            if st[THETA[c]] < p.threshold[c]:
                says_low = True
            elif st[THETA[c]] > p.threshold[c]:
                says_high = True
    switch = (high and says_low and not says_high) or ((not high) and says_high and not says_low)
    if stale:
        # a fresh decision: only an estimate clearly past its threshold (by a fifth
        # of the reference gap) claims a class again
        says_low = False
        says_high = False
        for c in range(2):
            if p.enabled[c] and st[E[c]] >= e_min:
                margin = 0.2 * (p.ref_high[c] - p.ref_low[c])
                if st[THETA[c]] < p.threshold[c] - margin:
                    says_low = True
                elif st[THETA[c]] > p.threshold[c] + margin:
                    says_high = True
        switch = (high and says_low and not says_high) or ((not high) and says_high and not says_low)
    if stale and not high and ((p.enabled[0] and st[E[0]] >= e_min) or (p.enabled[1] and st[E[1]] >= e_min)):
        # an informed channel on an old 'low': no claim unless it decides (below)
        st[WITHDRAWN] = 1.0
    if switch:
        high = not high
        st[HIGH] = 1.0 if high else 0.0
        for c in range(2):
            if p.enabled[c] and st[E[c]] < e_min:
                st[THETA[c]] = p.ref_high[c] if high else p.ref_low[c]
    # support of the (new) state by an informed channel: the claim's age
    support = False
    for c in range(2):
        if p.enabled[c] and st[E[c]] >= e_min:
            margin = 0.2 * (p.ref_high[c] - p.ref_low[c]) if stale else 0.0
            if (high and st[THETA[c]] > p.threshold[c] + margin) or (
                (not high) and st[THETA[c]] < p.threshold[c] - margin
            ):
                support = True
    st[SINCE] = 0.0 if support else st[SINCE] + dt
    if support or switch:
        st[WITHDRAWN] = 0.0
    # grip index: channel estimates between their references, weighted by information
    num = 0.05 * (1.0 if high else 0.0)
    den = 0.05
    for c in range(2):
        if p.enabled[c]:
            gi = (st[THETA[c]] - p.ref_low[c]) / (p.ref_high[c] - p.ref_low[c])
            gi = min(max(gi, 0.0), 1.0)
            num += st[E[c]] * gi
            den += st[E[c]]
    idx = num / den
    if st[INFORMED] < 0.5:
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
                     (0.0, 0.0, 0.0, 0.0), math.inf, False)


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
        Lateral regressor [rad] and lateral acceleration [m/s²].
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
    idx, wl, wa = _update(st, dt, phi_long, ax, phi_lat, ay, brls_params(config))
    new = _state_from_vector(st)
    excited = (wl >= 0.5 and config.long.enabled) or (wa >= 0.5 and config.lat.enabled)
    known = (new.informed and not new.withdrawn
             and new.since_support <= (config.hold_high_s if new.high else config.hold_low_s))
    cls = str(classes(np.array(new.high), np.array(known)))
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
    sv, idx, wl, wa = _batch(st, *arrs, brls_params(config), float(dt0))
    high = sv[:, HIGH] > 0.5
    informed = ((sv[:, INFORMED] > 0.5) & (sv[:, WITHDRAWN] < 0.5)
                & (sv[:, SINCE] <= np.where(high, config.hold_high_s, config.hold_low_s)))
    excited = ((wl >= 0.5) & config.long.enabled) | ((wa >= 0.5) & config.lat.enabled)
    out = BRLSOutput(classes(high, informed), idx, excited, sv[:, THETA_LONG],
                     sv[:, THETA_LAT], wl, wa)
    return _state_from_vector(st), out
