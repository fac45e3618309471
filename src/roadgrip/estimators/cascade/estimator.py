"""The Kalman cascade as an estimator of the protocol: prepare, init, step, run.

``step`` and ``run`` share the compiled kernel (:mod:`~roadgrip.estimators.cascade.kernel`):
``step`` runs it on one sample from copies of the state's arrays, ``run`` on
the whole drive, so the two give the same rows to the last bit.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, ProgressCallback, conform, timed
from roadgrip.estimators.cascade.config import CascadeConfig, prior_band
from roadgrip.estimators.cascade.inputs import (
    NOISE_PRIOR,
    CascadeSample,
    CascadeSamples,
    drive_inputs,
    drive_pose,
    given_noise,
)
from roadgrip.estimators.cascade.kernel import Aux, Filter, Inputs, Params, Weights
from roadgrip.estimators.cascade.model import ForceState, FrictionState, VelocityState
from roadgrip.estimators.cascade.result import diagnostics, output_columns, summary
from roadgrip.estimators.cascade.running_noise import (
    BIAS_STD,
    NoiseMemory,
    NoisePlan,
    memory_init,
    run_adaptive,
)
from roadgrip.estimators.protocol import DriveInfo, Estimator, Prepared
from roadgrip.inference.kalman import merwe_weights
from roadgrip.signals import current_grip, grip_step, undriven_wheels
from roadgrip.vehicle.params import VehicleParams

__all__ = ["ESTIMATOR", "CascadeState", "init", "lookahead", "prepare", "prepare_rows", "run", "run_filter", "step"]

CONSISTENCY_TIME = 5.0
"""Time constant [s] of the running mean square of the slip-angle consistency residuals."""
CONSISTENCY_PRIOR_TIME = 2.0
"""Weight of ``CascadeConfig.slip_error_prior`` in that mean square before any evidence, as the
time [s] of samples in the consistency band that would carry as much; it fades as the band's
evidence grows (:func:`~roadgrip.estimators.cascade.kernel.consistency_mean_square`)."""
POSE_CHECK_TIME = 2.0
"""Time constant [s] of the running mean of the lateral velocity against the pose's (the kinematic
slip-angle check, :func:`~roadgrip.estimators.cascade.kernel.pose_slip_error`): long against the
pose velocity's correlation time (0.25-1 s), so that its noise averages out and a bias remains,
short against a corner, so that it measures the bias at the lateral acceleration driven now."""

_CHUNK = 20_000
"""Samples per kernel call when ``run`` reports progress."""


class CascadeState(NamedTuple):
    """Posterior of the three stages after a sample, and the constants of the filter.

    Attributes
    ----------
    t : float
        Time of the last sample [s] (NaN before the first).
    velocity_mean, velocity_cov : ndarray, (4,), (4, 4)
        Stage 1 (:class:`~roadgrip.estimators.cascade.model.VelocityState`).
    force_mean, force_cov : ndarray, (6,), (6, 6)
        Stage 2 (:class:`~roadgrip.estimators.cascade.model.ForceState`).
    friction_mean, friction_cov : ndarray, (2,), (2, 2)
        Stage 3 (:class:`~roadgrip.estimators.cascade.model.FrictionState`).
    aux : ndarray, (6,)
        Previous inputs, slip-angle consistency residuals and the low-passed
        steering angle (:class:`~roadgrip.estimators.cascade.kernel.Aux`).
    params : Params
        Constants of the compiled step.
    weights : Weights
        Unscented weights of stages 2 and 3.
    floor_memory : tuple or None
        Memory of the sustained-grip floor (:func:`roadgrip.signals.sustained_grip_step`).
    noise_plan : NoisePlan or None
        What the run estimates as it goes (:mod:`~roadgrip.estimators.cascade.running_noise`);
        None: nothing.
    noise_memory : NoiseMemory or None
        The trailing samples and event times of those estimates.
    """

    t: float
    velocity_mean: NDArray[np.float64]
    velocity_cov: NDArray[np.float64]
    force_mean: NDArray[np.float64]
    force_cov: NDArray[np.float64]
    friction_mean: NDArray[np.float64]
    friction_cov: NDArray[np.float64]
    aux: NDArray[np.float64]
    params: Params
    weights: Weights
    floor_memory: tuple | None = None
    noise_plan: NoisePlan | None = None
    noise_memory: NoiseMemory | None = None

    def filter_copy(self) -> Filter:
        """The arrays as a fresh :class:`Filter` for the kernel (the state itself is never written)."""
        arrays = (self.velocity_mean, self.velocity_cov, self.force_mean, self.force_cov,
                  self.friction_mean, self.friction_cov, self.aux)
        return Filter(*(np.array(a, dtype=float, copy=True) for a in arrays))


def make_params(vehicle: VehicleParams, config: CascadeConfig, derived: dict[str, Any]) -> Params:
    """Constants of the compiled step from the vehicle, the configuration and the drive's derived values."""
    noise = derived["noise"]
    f = float
    return Params(
        mass=f(vehicle.mass),
        iz=f(vehicle.yaw_inertia),
        lf=f(vehicle.lf),
        lr=f(vehicle.lr),
        h=f(vehicle.cg_height),
        kf=f(vehicle.cornering_stiffness_front / vehicle.fz_front),
        kr=f(vehicle.cornering_stiffness_rear / vehicle.fz_rear),
        var_acc=f(noise["accel_std"] ** 2),
        var_gyro=f(noise["gyro_std"] ** 2),
        var_speed=f(noise["speed_std"] ** 2),
        var_steer=f(config.steer_std**2),
        var_acc_model=f(config.accel_model_std**2),
        q_force=f((vehicle.mass * config.jerk_std) ** 2),
        # yaw acceleration error: the accelerometer model error across the wheelbase
        q_yaw=f((config.accel_model_std / vehicle.wheelbase) ** 2),
        q_mu=f(config.mu_rate_std**2),
        mu_var0=f(config.mu_prior_std**2),
        mu_min=f(config.mu_bounds[0]),
        mu_max=f(config.mu_bounds[1]),
        model_err=f(config.model_error),
        exc_prec=f(1.0 / config.excitation_std**2),
        v_min=f(config.v_min),
        v_eps=f(config.v_eps),
        front_share=f(derived["front_share"]),
        slip_bias=f(config.slip_bias_std),
        max_bias=f(config.max_slip_bias_effect),
        cr=f(vehicle.cornering_stiffness_rear),
        ay_straight=f(config.ay_straight),
        q_bias=f(config.accel_bias_rate_std**2 if derived.get("accel_bias_std") else 0.0),
        steer_bias=f(config.steer_bias_std),
        vy_bias=f(config.vy_bias_std),
        consist_tau=CONSISTENCY_TIME,
        consist_prior=f(config.slip_error_prior**2),
        consist_prior_w=CONSISTENCY_PRIOR_TIME / CONSISTENCY_TIME,
        pose_check_tau=POSE_CHECK_TIME,
        var_pose=f(derived.get("pose_velocity_std", config.pose_velocity_std) ** 2
                   * derived.get("pose_velocity_corr_time", config.pose_velocity_corr_time)),
        var_latency=f(config.accel_latency_std**2),
        slip_z=f(config.slip_noise_z),
        steer_tau=f(derived["steer_response_time"] or 0.0),
        mu_prior=f(config.mu_prior),
        mu_length=f(config.mu_length) if config.mu_length > 0 else float("inf"),
        traction_front={"fwd": 1.0, "rwd": 0.0}.get(vehicle.drive, float("nan")),
        speed_slip_brake=f(derived["speed_slip"][0]),
        speed_slip_drive=f(derived["speed_slip"][1]),
        max_slip_ratio=f(config.max_slip_ratio),
        peak_model_error=f(config.peak_model_error),
    )


def make_weights(config: CascadeConfig) -> Weights:
    """Unscented weights of stage 2 (6 states) and stage 3 (2 states)."""
    w6 = merwe_weights(ForceState.SIZE, config.alpha, config.beta, config.kappa)
    w2 = merwe_weights(FrictionState.SIZE, config.alpha, config.beta, config.kappa)
    return Weights(w6.wm, w6.wc, float(w6.gamma), w2.wm, w2.wc, float(w2.gamma))


def _speed_slip(source: str, drive: Drive, config: CascadeConfig) -> tuple[float, float]:
    """Wheel slip per acceleration of the wheels the speed comes from, braking and driving [s²/m].

    ``1 / (g C_x)`` with ``C_x = config.wheel_slip_stiffness``; driving counts only
    when a measured wheel is driven, i.e. when the car has no undriven wheel (the
    speed comes from the undriven wheels where there are any,
    :func:`~roadgrip.estimators.cascade.inputs.measured_speed`). Zero for a speed
    that is not from wheel speeds.
    """
    if not source.startswith("wheel speeds") or config.wheel_slip_stiffness <= 0:
        return 0.0, 0.0
    gain = 1.0 / (GRAVITY * config.wheel_slip_stiffness)
    return gain, 0.0 if undriven_wheels(drive.vehicle.drive).any() else gain


def prepare(drive: Drive, config: CascadeConfig) -> Prepared:
    """Inputs of the cascade and what it knows of the drive before its first sample.

    ``info.derived`` holds ``noise`` (the standard deviations at the first sample,
    :func:`~roadgrip.estimators.cascade.inputs.given_noise`) and ``noise_running`` (the
    keys the run estimates from the samples so far), ``speed_source``, ``front_share``,
    ``vx0`` (first measured speed [m/s]), ``accel_bias_std`` (the configured value, else
    0 until a standstill of 1 s switches the biases on, ``bias_at_standstill``),
    ``steer_response_time`` (the configured value, else 0.1 s when
    ``meta.extra['steer_is_command']``, else 0) and the pose velocity's use
    (:func:`~roadgrip.estimators.cascade.inputs.drive_inputs`). None of them depends on
    a sample after the first: the run is causal up to :func:`lookahead`.

    Raises
    ------
    DriveValidationError
        Missing or non-finite inputs (:func:`~roadgrip.estimators.cascade.inputs.drive_inputs`).
    """
    inputs, src, share, pose, candidates = drive_inputs(drive, config)
    tau = config.steer_response_time
    if tau is None:
        tau = 0.1 if bool(drive.meta.extra.get("steer_is_command", False)) else 0.0
    noise, running = given_noise(config, drive, src)
    info = DriveInfo.from_drive(
        drive,
        noise=noise,
        noise_running=running,
        speed_source=src,
        front_share=float(share),
        vx0=float(inputs.speed[0]),
        accel_bias_std=float(config.accel_bias_std or 0.0),
        bias_at_standstill=config.accel_bias_std is None,
        steer_response_time=float(tau),
        speed_slip=_speed_slip(src, drive, config),
        **pose,
    )
    return Prepared(info, CascadeSamples(inputs, drive_pose(drive), candidates))


def prepare_rows(drive: Drive, config: CascadeConfig, info: DriveInfo) -> CascadeSamples:
    """The samples of a piece of a drive after its start (:func:`prepare`'s, without the
    drive's info, which ``info`` holds from its first samples)."""
    inputs, _src, _share, _pose, candidates = drive_inputs(drive, config)
    return CascadeSamples(inputs, drive_pose(drive), candidates)


JITTER_MARGIN = 1.1
"""Factor on half the pose window in the look-ahead: the fit's half-width is a number of
samples, which a jittered clock (the DART recordings') stretches by a few percent."""


def lookahead(config: CascadeConfig, info: DriveInfo | None = None) -> float:
    """Look-ahead [s]: a row depends on the samples up to its time plus this.

    Half the longest pose-differentiation window (the centred fit), times
    :data:`JITTER_MARGIN`, ``0.55 pose_window``, when the cascade derives the body
    velocity from ``x, y, psi`` itself (``info.derived['pose_velocity'] == 'derived'``;
    without ``info``, whenever it may), else 0.
    """
    if info is not None and info.derived.get("pose_velocity") != "derived":
        return 0.0
    if config.pose_velocity_std > 0 and config.pose_window > 0:
        return 0.5 * JITTER_MARGIN * float(config.pose_window)
    return 0.0


def init(info: DriveInfo, config: CascadeConfig, seed: int = 0) -> CascadeState:
    """Initial state: the first measured speed, zero lateral velocity and forces, the friction prior.

    The initial covariances come from the noise model: speed-sensor variance for
    ``vx``, gyro variance for the yaw rate, ``(0.2 m/s)²`` for ``vy``,
    ``accel_bias_std²`` for the biases and ``(m g)²`` for each force (a force
    of the order of the weight is possible). The cascade is deterministic:
    ``seed`` is not used.
    """
    d = info.derived
    n = d.get("noise") or {k: getattr(config, k) or NOISE_PRIOR[k] for k in NOISE_PRIOR}
    vx0 = float(d.get("vx0", 0.0))
    vehicle = info.vehicle
    vmin = max(n["speed_std"], 0.05)
    b0 = d.get("accel_bias_std", 0.0)
    xe = np.zeros(VelocityState.SIZE)
    xe[VelocityState.VX] = vx0
    pe = np.empty(VelocityState.SIZE)
    pe[[VelocityState.VX, VelocityState.VY]] = vmin**2, 0.2**2
    pe[[VelocityState.BIAS_AX, VelocityState.BIAS_AY]] = b0**2
    xu = np.zeros(ForceState.SIZE)
    xu[ForceState.VX] = vx0
    pu = np.full(ForceState.SIZE, (vehicle.mass * GRAVITY) ** 2)
    pu[[ForceState.VX, ForceState.YAW_RATE, ForceState.VY]] = vmin**2, max(n["gyro_std"], 0.01) ** 2, 0.2**2
    Pe, Pu = np.diag(pe), np.diag(pu)
    xm = np.full(FrictionState.SIZE, config.mu_prior)
    Pm = np.eye(FrictionState.SIZE) * config.mu_prior_std**2
    aux = np.zeros(Aux.SIZE)
    aux[Aux.STEER_LP] = np.nan
    aux[Aux.AY_LP] = np.nan
    windows = tuple(d.get("pose_windows", ())) if d.get("pose_velocity") == "derived" else ()
    plan = NoisePlan(tuple(d.get("noise_running", ())), windows,
                     bool(d.get("bias_at_standstill", False)), float(config.accel_bias_rate_std**2))
    return CascadeState(float("nan"), xe, Pe, xu, Pu, xm, Pm, aux,
                        make_params(vehicle, config, dict(d)), make_weights(config),
                        noise_plan=plan, noise_memory=memory_init(len(windows)))


def _check_sample(sample: CascadeSample) -> None:
    for name, v in zip(CascadeSample._fields, sample, strict=True):
        if name == "pose_candidates":
            if np.isinf(v).any():
                raise ValueError("cascade sample field 'pose_candidates' is infinite (NaN marks a missing value)")
            continue
        if name in ("vx_pose", "vy_pose", "x", "y", "psi"):
            if math.isinf(v):
                raise ValueError(f"cascade sample field {name!r} is infinite (NaN marks a missing value)")
            continue
        if not math.isfinite(v):
            raise ValueError(f"cascade sample field {name!r} is not finite: {v!r}")


def _row(out: NDArray[np.float64], sample: CascadeSample, params: Params, floor: float,
         now: float) -> dict[str, Any]:
    pose = None
    if np.isfinite(sample.x) and np.isfinite(sample.y):
        pose = tuple(np.array([v]) for v in (sample.x, sample.y, sample.psi) if np.isfinite(v))
    cols = output_columns(out, np.array([sample.t]), pose, params.lf, params.lr, np.array([floor]),
                          np.array([now]))
    return {k: v[0].item() for k, v in cols.items()}


def step(state: CascadeState, sample: CascadeSample) -> tuple[CascadeState, dict[str, Any]]:
    """Pure single step: the new state and the output row of ``sample`` (time after ``state.t``)."""
    _check_sample(sample)
    if state.t == state.t and sample.t <= state.t:
        raise ValueError(f"sample time {sample.t} does not follow the state time {state.t}")
    u = Inputs(*(np.array([getattr(sample, name)]) for name in Inputs._fields))
    cand = np.array(sample.pose_candidates, dtype=np.float64).reshape(-1, 2, 1) if sample.pose_candidates else None
    out, new = run_filter(state, CascadeSamples(u, None, cand))
    memory, now, floor = grip_step(state.floor_memory, sample.t, sample.ay)
    return new._replace(floor_memory=memory), _row(out, sample, new.params, floor, now)


def run_filter(state: CascadeState, samples: CascadeSamples,
               progress: ProgressCallback | None = None) -> tuple[NDArray[np.float64], CascadeState]:
    """Run the compiled cascade over ``samples`` from ``state``, with the running noise
    estimates of ``state.noise_plan`` (:func:`~roadgrip.estimators.cascade.running_noise.run_adaptive`).

    Returns
    -------
    out : ndarray, shape (n, Out.SIZE)
        Kernel rows (:class:`~roadgrip.estimators.cascade.kernel.Out`).
    state : CascadeState
        The state after the last sample (its ``floor_memory`` is not advanced).
    """
    f = state.filter_copy()
    u = samples.inputs
    n = len(samples)
    plan = state.noise_plan or NoisePlan((), (), False, 0.0)
    memory = state.noise_memory if state.noise_memory is not None else memory_init(len(plan.pose_windows))
    params, t_prev, parts = state.params, state.t, []
    step_n = n if progress is None else _CHUNK
    for k0 in range(0, n, step_n):
        chunk = Inputs(*(a[k0:k0 + step_n] for a in u))
        cand = None if samples.candidates is None else samples.candidates[:, :, k0:k0 + step_n]
        out_k, memory, params = run_adaptive(plan, memory, f, chunk, t_prev, params, state.weights, cand)
        parts.append(out_k)
        t_prev = float(chunk.t[-1])
        if progress is not None:
            progress(len(chunk.t))
    out = np.concatenate(parts) if parts else np.zeros((0, 0))
    t_last = float(u.t[-1]) if n else state.t
    return out, state._replace(t=t_last, velocity_mean=f.xe, velocity_cov=f.Pe, force_mean=f.xu,
                               force_cov=f.Pu, friction_mean=f.xm, friction_cov=f.Pm, aux=f.aux,
                               params=params, noise_memory=memory)


def run(drive: Drive, config: CascadeConfig | None = None, seed: int = 0,
        progress: ProgressCallback | None = None) -> EstimateResult:
    """The cascade over a whole drive: one row per sample, summary, diagnostics, timing.

    ``meta['derived']`` holds the values :func:`prepare` derived from the drive, with
    ``noise`` the standard deviations in force at the last sample (``noise_initial`` at
    the first), ``pose_velocity_std`` likewise and ``accel_bias_std`` the biases'
    initial standard deviation once a standstill has switched them on; ``meta['lookahead']`` is
    :func:`lookahead` [s].
    """
    config = config if config is not None else CascadeConfig()
    meta: dict[str, Any] = {}
    with timed(meta, drive.n, drive.duration):
        prepared = prepare(drive, config)
        state = init(prepared.info, config, seed)
        samples: CascadeSamples = prepared.samples  # type: ignore[assignment]
        out, end = run_filter(state, samples, progress)
    derived = dict(prepared.info.derived)
    derived["noise_initial"] = derived["noise"]
    derived["noise"] = {"accel_std": float(np.sqrt(end.params.var_acc)),
                        "gyro_std": float(np.sqrt(end.params.var_gyro)),
                        "speed_std": float(np.sqrt(end.params.var_speed))}
    if end.noise_memory is not None and end.noise_memory.bias_on:
        derived["accel_bias_std"] = BIAS_STD
    if derived.get("pose_velocity") == "derived" and end.noise_memory is not None:
        window = derived["pose_windows"][end.noise_memory.pose_choice]
        derived["pose_velocity_corr_time"] = float(window)
        derived["pose_velocity_std"] = float(np.sqrt(end.params.var_pose / window))
    now = current_grip(samples.inputs.t, samples.inputs.ay)
    floor = np.maximum.accumulate(now) if len(now) else now
    table = pd.DataFrame(output_columns(out, samples.inputs.t, samples.pose, state.params.lf, state.params.lr,
                                        floor, now))
    meta["summary"] = summary(table.iloc[-1])
    meta["diagnostics"] = diagnostics(table, out, derived)
    meta["config"] = config.to_meta()
    meta["derived"] = derived
    meta["lookahead"] = lookahead(config, prepared.info)
    meta["seed"] = int(seed)
    return EstimateResult("cascade", conform(table), meta)


ESTIMATOR = Estimator(
    name="cascade",
    paper="003",
    summary="Three-stage Kalman cascade EKF -> UKF -> UKF: velocities, axle forces, axle friction.",
    Config=CascadeConfig,
    prepare=prepare,
    prepare_rows=prepare_rows,
    init=init,
    step=step,
    run=run,
    prior_band=prior_band,
    lookahead=lookahead,
)
