"""Running noise levels of the cascade: what it measures about its sensors from the samples so far.

The cascade needs the white-noise levels of its accelerometers, gyro and speed signal,
the error of a pose-derived body velocity, and whether the accelerometer biases are
observable (a standstill). Each is a causal estimate here, so that every row depends only
on the samples up to its time (the look-ahead of ``docs/output-contract.md``):

* **noise levels** are re-estimated every :data:`UPDATE_PERIOD` seconds, at the first
  sample at or after the update time, from the samples of the trailing
  :data:`NOISE_WINDOW` seconds before it (the robust scale of second differences,
  :func:`roadgrip.signals.white_noise_std`, at least :data:`~roadgrip.estimators.cascade.inputs.NOISE_FLOORS`);
  before the first update the filter uses
  :data:`~roadgrip.estimators.cascade.inputs.NOISE_PRIOR`;
* the **pose velocity**, when the cascade differentiates the pose itself over several
  windows (:func:`~roadgrip.estimators.cascade.inputs.drive_inputs`), is taken at each
  update from the window whose ``vx`` has the smallest robust root-mean-square error
  against the measured speed over the same trailing samples, and that error (at least
  0.01 m/s) is its standard deviation; before the first update the longest window with
  the configured ``pose_velocity_std``;
* the **accelerometer biases** are switched on (initial standard deviation
  :data:`BIAS_STD`, random walk ``accel_bias_rate_std``) at the sample that completes
  :data:`STANDSTILL_S` of standstill (speed and yaw rate both below 0.05), where a
  zero-velocity update makes them observable; before it they are off.

A value given in the configuration, or by the reader (``meta.extra['sensor_noise']``),
is used as given and not estimated (:class:`NoisePlan`). The memory
(:class:`NoiseMemory`) holds the trailing window's samples: bounded by the window, not
the drive.

:func:`run_adaptive` runs the compiled kernel between these events; a block of one
sample (the online ``step``), consecutive chunks and a whole drive give the same rows
to the last bit, since each event sees the same samples.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.cascade.inputs import NOISE_FLOORS
from roadgrip.estimators.cascade.kernel import Filter, Inputs, Params, Weights, run_kernel
from roadgrip.estimators.cascade.model import VelocityState
from roadgrip.signals import white_noise_std

__all__ = [
    "BIAS_STD",
    "NOISE_WINDOW",
    "RECENT_BLOCKS",
    "STANDSTILL_S",
    "UPDATE_PERIOD",
    "NoiseMemory",
    "NoisePlan",
    "memory_init",
    "noise_levels",
    "run_adaptive",
]

NOISE_WINDOW = 30.0
"""Trailing window [s] of the noise estimates."""

UPDATE_PERIOD = 2.0
"""Time [s] between two noise estimates."""

STANDSTILL_S = 1.0
"""Standstill [s] after which the accelerometer biases are observable and switched on."""

BIAS_STD = 0.3
"""Initial standard deviation of the biases switched on at a standstill [m/s²]."""

STILL_SPEED = 0.05
"""Speed [m/s] and yaw rate [rad/s] below which a sample stands still."""



class NoisePlan(NamedTuple):
    """What the run estimates, fixed at ``prepare`` (SI units).

    Attributes
    ----------
    running : tuple of str
        Keys of ``accel_std, gyro_std, speed_std`` estimated on the run (the others are given).
    pose_windows : tuple of float
        Differentiation windows [s] of the candidate pose velocities (empty: the cascade
        derives none); each is the correlation time of its error.
    bias_auto : bool
        The biases are switched on at the first standstill.
    bias_rate_var : float
        Random-walk variance of the biases once on [m²/s⁵].
    """

    running: tuple[str, ...]
    pose_windows: tuple[float, ...]
    bias_auto: bool
    bias_rate_var: float


class NoiseMemory(NamedTuple):
    """The samples of the trailing window and the event times (never modified in place).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Times [s] of the window's samples (and possibly older ones, which the estimates
        leave out: the window is cut when blocks are joined).
    x : ndarray, shape (m, 4 + C)
        Their ``ax, ay`` [m/s²], yaw rate [rad/s], speed [m/s] and the error
        ``vx - speed`` [m/s] of each of the ``C`` candidate pose velocities.
    next_update : float
        Time [s] of the next noise estimate (NaN before the first sample).
    still_since : float
        Start [s] of the current standstill (NaN while moving).
    bias_on : bool
        The biases have been switched on by a standstill.
    pose_choice : int
        Index of the candidate pose velocity in use (the last, the longest window, first).
    recent : tuple of (ndarray, ndarray)
        The ``(t, x)`` blocks after ``t``, ``x``, not yet joined to them (at most
        :data:`RECENT_BLOCKS`): a block of one sample, the online step, does not copy the
        window.
    """

    t: NDArray[np.float64]
    x: NDArray[np.float64]
    next_update: float
    still_since: float
    bias_on: bool
    pose_choice: int = -1
    recent: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...] = ()

    def joined(self, t: NDArray[np.float64] | None = None, x: NDArray[np.float64] | None = None,
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Times and samples of the memory followed by ``t``, ``x``, as two arrays."""
        blocks = [(self.t, self.x), *self.recent] + ([] if t is None or x is None else [(t, x)])
        if len(blocks) == 1:
            return blocks[0]
        return np.concatenate([b[0] for b in blocks]), np.concatenate([b[1] for b in blocks])


RECENT_BLOCKS = 64
"""Blocks held in :attr:`NoiseMemory.recent` before they are joined to the window (and the
window cut to :data:`NOISE_WINDOW`)."""


def memory_init(candidates: int = 0) -> NoiseMemory:
    """Memory before the first sample, with ``candidates`` pose velocities."""
    return NoiseMemory(np.zeros(0), np.zeros((0, 4 + candidates)), math.nan, math.nan, False,
                       candidates - 1)


def noise_levels(x: NDArray[np.float64]) -> dict[str, Any]:
    """Noise standard deviations of the window's samples ``x`` (columns of :class:`NoiseMemory`).

    Returns
    -------
    dict
        ``accel_std`` [m/s²] (the larger of ``ax``, ``ay``), ``gyro_std`` [rad/s],
        ``speed_std`` [m/s], at least :data:`~roadgrip.estimators.cascade.inputs.NOISE_FLOORS`
        (NaN where the window holds fewer than 12 samples), and ``pose_std``, shape (C,),
        the robust root-mean-square error of each candidate pose velocity [m/s], at least
        0.01 (NaN for fewer than 20 samples with a pose).
    """
    acc = max(white_noise_std(x[:, 0]), white_noise_std(x[:, 1]))
    out: dict[str, Any] = {"accel_std": acc, "gyro_std": white_noise_std(x[:, 2]),
                           "speed_std": white_noise_std(x[:, 3])}
    out = {k: max(v, NOISE_FLOORS[k]) if np.isfinite(v) else math.nan for k, v in out.items()}
    pose = np.full(x.shape[1] - 4, math.nan)
    for c in range(len(pose)):
        e = x[:, 4 + c][np.isfinite(x[:, 4 + c])]
        if len(e) >= 20:
            pose[c] = max(float(np.sqrt(np.median(e * e) / 0.4549)), 0.01)
    out["pose_std"] = pose
    return out


def _update(plan: NoisePlan, params: Params, x: NDArray[np.float64], choice: int) -> tuple[Params, int]:
    lv = noise_levels(x)
    new: dict[str, float] = {}
    for key, field in (("accel_std", "var_acc"), ("gyro_std", "var_gyro"), ("speed_std", "var_speed")):
        if key in plan.running and np.isfinite(lv[key]):
            new[field] = lv[key] ** 2
    pose = lv["pose_std"]
    if len(pose) and np.isfinite(pose).any():
        choice = int(np.nanargmin(pose))
        new["var_pose"] = pose[choice] ** 2 * plan.pose_windows[choice]
    return params._replace(**new), choice


def _stand_start(t: NDArray, still: NDArray, since: float) -> NDArray[np.float64]:
    """Start time of the standstill each sample belongs to (NaN when moving)."""
    n = len(t)
    idx = np.arange(n)
    starts = still.copy()
    starts[1:] &= ~still[:-1]
    first = np.maximum.accumulate(np.where(starts, idx, -1)) if n else idx
    out = np.where(still, t[np.maximum(first, 0)], np.nan)
    if n and still[0] and since == since:  # the standstill goes on from the previous block
        run0 = still & (first == 0)
        out[run0] = since
    return out


def run_adaptive(plan: NoisePlan, memory: NoiseMemory, f: Filter, u: Inputs, t_prev: float,
                 params: Params, w: Weights, candidates: NDArray[np.float64] | None = None,
                 ) -> tuple[NDArray[np.float64], NoiseMemory, Params]:
    """The compiled kernel over ``u`` with the noise levels and biases updated at their events.

    Parameters
    ----------
    plan : NoisePlan
    memory : NoiseMemory
        Before the first sample of ``u``.
    f : Filter
        Updated in place (the biases' covariance is set where they are switched on).
    u : Inputs
        Samples, each shape (n,), times after ``t_prev`` (``vx_pose, vy_pose`` are replaced
        by the chosen candidate's where ``candidates`` is given).
    t_prev : float
        Time of the last sample the filter has seen [s]; NaN before the first.
    params : Params
        The constants in force before the first sample.
    w : Weights
    candidates : ndarray, shape (C, 2, n), optional
        Candidate pose velocities ``(vx, vy)`` [m/s], one per ``plan.pose_windows``.

    Returns
    -------
    out : ndarray, shape (n, Out.SIZE)
    memory : NoiseMemory
        After the last sample.
    params : Params
        In force after the last sample.
    """
    n = len(u.t)
    if n == 0:
        return np.zeros((0, 0)), memory, params
    t = u.t
    cand = candidates if candidates is not None and len(plan.pose_windows) else None
    n_cand = 0 if cand is None else cand.shape[0]
    x_new = np.empty((n, 4 + n_cand))
    for c, a in enumerate((u.ax, u.ay, u.yaw_rate, u.speed)):
        x_new[:, c] = a
    for c in range(n_cand):
        x_new[:, 4 + c] = cand[c, 0] - u.speed  # type: ignore[index]
    t_all: NDArray[np.float64] | None = None  # the memory and the block, joined at an update
    x_all = t_all
    m0 = 0
    still = (np.abs(u.speed) < STILL_SPEED) & (np.abs(u.yaw_rate) < STILL_SPEED)
    since = _stand_start(t, still, memory.still_since)
    bias_at = n
    if plan.bias_auto and not memory.bias_on:
        hits = np.flatnonzero(t - since >= STANDSTILL_S - 1e-12)
        bias_at = int(hits[0]) if len(hits) else n
    next_update = memory.next_update if memory.next_update == memory.next_update else float(t[0]) + UPDATE_PERIOD
    bias_on, choice = memory.bias_on, memory.pose_choice
    parts = []
    k = 0
    while k < n:
        if k == bias_at:
            params = params._replace(q_bias=plan.bias_rate_var)
            for i in (VelocityState.BIAS_AX, VelocityState.BIAS_AY):
                f.Pe[i, :] = 0.0
                f.Pe[:, i] = 0.0
                f.Pe[i, i] = BIAS_STD**2
            bias_on = True
        if t[k] >= next_update:
            if t_all is None:
                m0 = len(memory.t) + sum(len(b[0]) for b in memory.recent)
                t_all, x_all = memory.joined(t, x_new)
            lo = int(np.searchsorted(t_all, t[k] - NOISE_WINDOW, side="right"))
            params, choice = _update(plan, params, x_all[lo:m0 + k], choice)
            next_update = float(t[k]) + UPDATE_PERIOD
        j = int(np.searchsorted(t, next_update, side="left"))
        j = max(j, k + 1)
        if bias_at > k:
            j = min(j, bias_at)
        j = min(j, n)
        block = Inputs(*(a[k:j] for a in u))
        if cand is not None:
            block = block._replace(vx_pose=np.ascontiguousarray(cand[choice, 0, k:j]),
                                   vy_pose=np.ascontiguousarray(cand[choice, 1, k:j]))
        parts.append(run_kernel(f, block, t_prev, params, w))
        t_prev = float(t[j - 1])
        k = j
    recent = (*memory.recent, (t.copy(), x_new))
    if t_all is None and len(recent) < RECENT_BLOCKS:
        mem = NoiseMemory(memory.t, memory.x, next_update, float(since[-1]), bias_on, choice, recent)
    else:
        if t_all is None:
            t_all, x_all = memory.joined(t, x_new)
        keep = t_all > float(t[-1]) - NOISE_WINDOW
        mem = NoiseMemory(t_all[keep], x_all[keep], next_update, float(since[-1]), bias_on, choice)  # type: ignore[index]
    return np.concatenate(parts) if len(parts) > 1 else parts[0], mem, params
