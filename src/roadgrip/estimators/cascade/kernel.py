"""The compiled cascade: one sample through the three stages, and the loop over a drive.

The filter state is a :class:`~roadgrip.estimators.cascade.layout.Filter` of
arrays updated in place by the compiled functions (the Python layer copies them
first, so its states stay immutable); the layouts of the state, the constants
and the output row are in :mod:`~roadgrip.estimators.cascade.layout`. The
equations are in :mod:`roadgrip.estimators.cascade`.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.cascade.layout import Aux, Filter, Inputs, Out, Params, Weights
from roadgrip.estimators.cascade.model import ForceMeasurement as Zf
from roadgrip.estimators.cascade.model import ForceState as Fs
from roadgrip.estimators.cascade.model import FrictionState as Ms
from roadgrip.estimators.cascade.model import VelocityState as Vs
from roadgrip.estimators.cascade.model import (
    brush_slope,
    force_measurement,
    force_transition,
    friction_measurement,
    inverted_observation,
    lateral_capacity,
    rotate_integrate,
    slip_bias_effect,
    slip_sensitivity,
)
from roadgrip.inference.kalman import (
    cholesky_lower,
    joseph_update,
    psd_sqrt,
    sigma_points,
    ukf_correct,
    unscented_transform,
)

__all__ = ["Aux", "Filter", "Inputs", "Out", "Params", "Weights", "run_kernel"]

# sizes as plain integers for the compiled code (numba's array constructors take no IntEnum)
_NV = int(Vs.SIZE)
_NVEL = int(Vs.BIAS_AX)  # the velocity block vx, vy of stage 1
_NF = int(Fs.SIZE)
_NKIN = int(Fs.FXF)  # the kinematic block vx, r, vy of stage 2
_NZ = int(Zf.SIZE)
_NM = int(Ms.SIZE)
_NOUT = int(Out.SIZE)


@njit(cache=True)
def _velocity_stage(f, u, k, dt, p):  # pragma: no cover - compiled
    """Stage 1, EKF (eq. 3-5): predict, speed, pose velocity, standstill and straight-driving updates."""
    xe = f.xe
    Pe = f.Pe
    aux = f.aux
    ax = u.ax[k]
    ay = u.ay[k]
    r = u.yaw_rate[k]
    steer = u.steer[k]
    vmeas = u.speed[k]
    vxp = u.vx_pose[k]
    vyp = u.vy_pose[k]
    m = p.mass
    var_acc = p.var_acc + p.var_acc_model
    if dt > 0.0:
        vx = xe[Vs.VX]
        vy = xe[Vs.VY]
        # inputs over the step: mean of the samples at both ends (trapezoid rule)
        ra = 0.5 * (r + aux[Aux.YAW_RATE_PREV])
        c = np.cos(ra * dt)
        s = np.sin(ra * dt)
        ch = np.cos(0.5 * ra * dt)
        sh = np.sin(0.5 * ra * dt)
        J = np.eye(_NV)
        J[Vs.VX, Vs.VX] = c
        J[Vs.VX, Vs.VY] = s
        J[Vs.VY, Vs.VX] = -s
        J[Vs.VY, Vs.VY] = c
        J[Vs.VX, Vs.BIAS_AX] = -dt * ch
        J[Vs.VX, Vs.BIAS_AY] = -dt * sh
        J[Vs.VY, Vs.BIAS_AX] = dt * sh
        J[Vs.VY, Vs.BIAS_AY] = -dt * ch
        axc = 0.5 * (ax + aux[Aux.AX_PREV]) - xe[Vs.BIAS_AX]
        ayc = 0.5 * (ay + aux[Aux.AY_PREV]) - xe[Vs.BIAS_AY]
        vxn, vyn = rotate_integrate(vx, vy, ra, axc, ayc, dt)
        xe[Vs.VX] = vxn
        xe[Vs.VY] = vyn
        vg = p.var_gyro
        Q = np.zeros((_NV, _NV))
        Q[Vs.VX, Vs.VX] = (var_acc + vg * vyn * vyn) * dt * dt
        Q[Vs.VX, Vs.VY] = -vg * vyn * vxn * dt * dt
        Q[Vs.VY, Vs.VX] = Q[Vs.VX, Vs.VY]
        Q[Vs.VY, Vs.VY] = (var_acc + vg * vxn * vxn) * dt * dt
        Q[Vs.BIAS_AX, Vs.BIAS_AX] = p.q_bias * dt
        Q[Vs.BIAS_AY, Vs.BIAS_AY] = p.q_bias * dt
        Pe[:, :] = J @ Pe @ J.T + Q
    aux[Aux.AX_PREV] = ax
    aux[Aux.AY_PREV] = ay
    aux[Aux.YAW_RATE_PREV] = r
    # measured speed: mean wheel-frame speed of the wheels used (eq. 5); the front
    # wheels, steered by d, see vx cos d + (vy + lf r) sin d, the rear wheels vx
    fs = p.front_share
    cd = np.cos(steer)
    sd = np.sin(steer)
    H = np.zeros((1, _NV))
    H[0, Vs.VX] = 1.0 - fs + fs * cd
    H[0, Vs.VY] = fs * sd
    resid = np.array([vmeas - (H[0, Vs.VX] * xe[Vs.VX] + H[0, Vs.VY] * xe[Vs.VY] + fs * sd * p.lf * r)])
    # wheels that brake (or drive) slip: their speed under-(over-)reads vx by about
    # |ax| / (g C_x); counted as noise, so that the pose and the kinematics carry vx then
    axw = ax - xe[Vs.BIAS_AX]
    kappa = -axw * p.speed_slip_brake if axw < 0.0 else axw * p.speed_slip_drive
    var_v = p.var_speed + (vmeas * kappa) ** 2
    xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), resid, H, np.array([[var_v]]))
    xe[:] = xn
    Pe[:, :] = Pn
    # body velocity from the localisation pose: bounds the drift of the integrated vy
    if p.var_pose > 0.0 and dt > 0.0 and vyp == vyp and vxp == vxp:
        Hp = np.zeros((2, _NV))
        Hp[0, Vs.VX] = 1.0
        Hp[1, Vs.VY] = 1.0
        vpose = p.var_pose / dt
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), np.array([vxp - xe[Vs.VX], vyp - xe[Vs.VY]]), Hp,
                                  np.diag(np.array([vpose, vpose])))
        xe[:] = xn
        Pe[:, :] = Pn
    # standstill (zero-velocity update): vx = vy = 0 and the accelerometers read their biases
    if abs(vmeas) < 0.05 and abs(r) < 0.05:
        Hz = np.eye(_NV)
        Rz = np.diag(np.array([1e-4, 1e-4, var_acc, var_acc]))
        zres = np.array([-xe[Vs.VX], -xe[Vs.VY], ax - xe[Vs.BIAS_AX], ay - xe[Vs.BIAS_AY]])
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), zres, Hz, Rz)
        xe[:] = xn
        Pe[:, :] = Pn
    # near-straight driving: linear-tire pseudo-measurement of vy (bounds its drift)
    ayc = ay - xe[Vs.BIAS_AY]
    if abs(ayc) < p.ay_straight:
        wb = p.lf + p.lr
        a_lin = m * ayc * p.lf / (wb * p.cr)
        vy_lin = p.lr * r - xe[Vs.VX] * a_lin
        sdv = abs(xe[Vs.VX]) * (p.slip_bias + abs(a_lin)) + 0.01  # floor 1 cm/s at standstill
        H2 = np.zeros((1, _NV))
        H2[0, Vs.VY] = 1.0
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), np.array([vy_lin - xe[Vs.VY]]), H2,
                                  np.array([[sdv * sdv]]))
        xe[:] = xn
        Pe[:, :] = Pn


@njit(cache=True)
def _force_stage(f, u, k, dt, p, w):  # pragma: no cover - compiled
    """Stage 2, UKF1 (eq. 6-10); returns the covariance repairs, the innovation and its covariance."""
    xe = f.xe
    Pe = f.Pe
    xu = f.xu
    Pu = f.Pu
    steer = u.steer[k]
    m = p.mass
    var_acc = p.var_acc + p.var_acc_model
    repairs = 0
    if dt > 0.0:
        L, Pu_used, rep = psd_sqrt(Pu)
        repairs += rep
        X = sigma_points(xu, L, w.gamma6)
        Y = force_transition(X, steer, dt, m, p.iz, p.lf, p.lr)
        Qu = np.zeros((_NF, _NF))
        qv = var_acc * dt * dt
        Qu[Fs.VX, Fs.VX] = qv
        Qu[Fs.VY, Fs.VY] = qv
        Qu[Fs.YAW_RATE, Fs.YAW_RATE] = p.q_yaw * dt * dt
        qf = p.q_force * dt * dt
        Qu[Fs.FXF, Fs.FXF] = qf
        Qu[Fs.FYF, Fs.FYF] = qf
        Qu[Fs.FYR, Fs.FYR] = qf
        mean, cov = unscented_transform(Y, w.wm6, w.wc6, Qu)
        xu[:] = mean
        Pu[:, :] = 0.5 * (cov + cov.T)
    L, Pu_used, rep = psd_sqrt(Pu)
    repairs += rep
    X = sigma_points(xu, L, w.gamma6)
    Z = force_measurement(X, steer, m)
    z = np.empty(_NZ)
    z[Zf.VX] = xe[Vs.VX]
    z[Zf.YAW_RATE] = u.yaw_rate[k]
    z[Zf.VY] = xe[Vs.VY]
    z[Zf.AX] = u.ax[k] - xe[Vs.BIAS_AX]
    z[Zf.AY] = u.ay[k] - xe[Vs.BIAS_AY]
    R = np.zeros((_NZ, _NZ))
    R[Zf.VX, Zf.VX] = Pe[Vs.VX, Vs.VX]
    R[Zf.VX, Zf.VY] = Pe[Vs.VX, Vs.VY]
    R[Zf.VY, Zf.VX] = Pe[Vs.VY, Vs.VX]
    R[Zf.VY, Zf.VY] = Pe[Vs.VY, Vs.VY]
    R[Zf.YAW_RATE, Zf.YAW_RATE] = p.var_gyro
    R[Zf.AX, Zf.AX] = var_acc + Pe[Vs.BIAS_AX, Vs.BIAS_AX]
    R[Zf.AY, Zf.AY] = var_acc + Pe[Vs.BIAS_AY, Vs.BIAS_AY]
    xn, Pn, res2, S2 = ukf_correct(xu.copy(), Pu_used, X, Z, w.wm6, w.wc6, z, R)
    xu[:] = xn
    Pu[:, :] = Pn
    return repairs, res2, S2


@njit(cache=True)
def _slip_and_loads(f, u, k, dt, p):  # pragma: no cover - compiled
    """Slip angles, their variances, the axle loads and longitudinal forces; updates the consistency residuals.

    Returns ``(alpha_f, alpha_r, var_alpha_f, var_alpha_r, Fzf, Fzr, Fxf, Fxr)`` [rad, rad², N].
    The stage-2 longitudinal force is split between the axles: a driving force
    by ``traction_front`` (the driven axles), a braking force in proportion to
    the axle loads (the ideal brake balance; NaN ``traction_front`` splits a
    driving force that way too).
    """
    xe = f.xe
    xu = f.xu
    aux = f.aux
    steer = u.steer[k]
    m = p.mass
    vx = xu[Fs.VX]
    r_e = xu[Fs.YAW_RATE]
    vy = xu[Fs.VY]
    sgn = 1.0 if vx >= 0.0 else -1.0
    uv = sgn * np.sqrt(vx * vx + p.v_eps * p.v_eps)
    lf = p.lf
    lr = p.lr
    qf_ = (vy + lf * r_e) / uv
    qr_ = (vy - lr * r_e) / uv
    alpha_f = steer - np.arctan(qf_)
    alpha_r = -np.arctan(qr_)
    # gradients of alpha wrt (vx, r, vy), first order
    cf = 1.0 / (1.0 + qf_ * qf_)
    cr = 1.0 / (1.0 + qr_ * qr_)
    gf = np.array([cf * qf_ / uv, -cf * lf / uv, -cf / uv])
    gr = np.array([cr * qr_ / uv, cr * lr / uv, -cr / uv])
    Pv = np.ascontiguousarray(f.Pu[:_NKIN, :_NKIN])
    # steering actuator: a commanded angle is reached with a lag; the part of the last
    # command changes not yet followed, |steer - low-pass(steer)|, is steering error
    tau_s = p.steer_tau
    if tau_s > 0.0:
        if aux[Aux.STEER_LP] != aux[Aux.STEER_LP]:
            aux[Aux.STEER_LP] = steer
        aux[Aux.STEER_LP] += min(dt / tau_s, 1.0) * (steer - aux[Aux.STEER_LP])
        steer_lag = steer - aux[Aux.STEER_LP]
    else:
        steer_lag = 0.0
    var_af = gf @ Pv @ gf + p.var_steer + steer_lag * steer_lag
    var_ar = gr @ Pv @ gr
    ax_est = (xu[Fs.FXF] * np.cos(steer) - xu[Fs.FYF] * np.sin(steer)) / m
    wb = lf + lr
    dfz = m * ax_est * p.h / wb
    fzf = max(m * GRAVITY * lr / wb - dfz, 0.0)
    fzr = max(m * GRAVITY * lf / wb + dfz, 0.0)
    fx = xu[Fs.FXF]
    share = p.traction_front if (fx > 0.0 and p.traction_front == p.traction_front) else fzf / max(fzf + fzr, 1e-9)
    fxf = share * fx
    fxr = fx - fxf
    # slip-angle consistency: rear slip against the linear tire at moderate ay (1 to 2 ay_straight)
    ayb = abs(u.ay[k] - xe[Vs.BIAS_AY])
    if (dt > 0.0 and abs(vx) >= p.v_min and p.ay_straight <= ayb <= 2.0 * p.ay_straight
            and fzr > 0.5 * m * GRAVITY * lf / (lf + lr)):
        e_lin = alpha_r - xu[Fs.FYR] / (p.kr * max(fzr, 1e-9))
        lam = min(dt / p.consist_tau, 1.0)
        aux[Aux.CONSIST_R] += lam * (e_lin * e_lin - aux[Aux.CONSIST_R])
        aux[Aux.CONSIST_W_R] += lam * (1.0 - aux[Aux.CONSIST_W_R])
        if fzf > 0.0:
            e_lin_f = alpha_f - xu[Fs.FYF] / (p.kf * fzf)
            aux[Aux.CONSIST_F] += lam * (e_lin_f * e_lin_f - aux[Aux.CONSIST_F])
            aux[Aux.CONSIST_W_F] += lam * (1.0 - aux[Aux.CONSIST_W_F])
    # kinematic check: the lateral velocity of the slip angles against the pose's, at every
    # lateral acceleration (no tire model: its running mean is the vy bias the slip angles carry)
    vyp = u.vy_pose[k]
    if dt > 0.0 and abs(vx) >= p.v_min and vyp == vyp:
        lam_p = min(dt / p.pose_check_tau, 1.0)
        aux[Aux.POSE_VY_BIAS] += lam_p * (vy - vyp - aux[Aux.POSE_VY_BIAS])
        aux[Aux.POSE_W] += lam_p * (1.0 - aux[Aux.POSE_W])
    # the lateral acceleration's change over the check's window: a latency of the accelerometer
    # behind the gyro integrates into a vy error of that change times the latency
    ay_m = u.ay[k] - xe[Vs.BIAS_AY]
    if dt > 0.0 and ay_m == ay_m:
        if aux[Aux.AY_LP] != aux[Aux.AY_LP]:
            aux[Aux.AY_LP] = ay_m
        aux[Aux.AY_LP] += min(dt / p.pose_check_tau, 1.0) * (ay_m - aux[Aux.AY_LP])
        aux[Aux.AY_DEV] = ay_m - aux[Aux.AY_LP]
    return alpha_f, alpha_r, var_af, var_ar, fzf, fzr, fxf, fxr


@njit(cache=True)
def consistency_mean_square(ms, weight, prior, prior_weight, evidence):  # pragma: no cover - compiled
    """Mean square of an axle's slip-angle consistency residual [rad²], with the prior.

    ``ms`` is the running mean square started from 0 and ``weight`` its evidence,
    ``1 - exp(-T / tau)`` after a time ``T`` in the consistency band. The prior ``prior``
    [rad²] is weighted ``w0 = prior_weight (1 - evidence)²``, fading as the evidence about
    the slip angles' accuracy grows (``evidence >= weight``: this band's or the kinematic
    check's, :func:`pose_slip_error`); the result is ``(ms + w0 prior) / (weight + w0)``: the
    prior before any evidence, the residuals' own mean square once there is (0 when the
    evidence is the kinematic check's alone).
    """
    w0 = prior_weight * (1.0 - evidence) ** 2
    den = weight + w0
    return (ms + w0 * prior) / den if den > 0.0 else 0.0


@njit(cache=True)
def pose_slip_error(bias_sum, weight, vx, v_eps, prior, var_pose, tau):  # pragma: no cover - compiled
    """Mean square slip-angle bias [rad²] the kinematic check finds against the pose.

    ``bias_sum`` [m/s] is the running mean (time constant ``tau`` [s]) of ``vy - vy_pose``
    started from 0 and ``weight`` its evidence, ``1 - exp(-T / tau)`` after a time ``T``
    with a pose velocity: ``b = bias_sum / weight / |vx|`` [rad] is the slip-angle bias it
    measures on both axles (``vx`` [m/s] regularised by ``v_eps``), with the variance
    ``s² = var_pose (2 - weight) / (2 tau weight) / vx²`` of the pose velocity's noise
    averaged over that window (``var_pose`` [m²/s]: its variance times its correlation
    time). The result is ``max(b² - s², 0) + (1 - g) prior``: the bias the pose shows beyond
    its own noise, plus the part of the prior bias variance ``prior`` [rad²] the data have
    not yet resolved, ``g = prior / (prior + s²)`` (the prior before the check has seen a
    pose, nothing of it once the noise is small against it).
    """
    if weight <= 0.0:
        return prior
    v2 = vx * vx + v_eps * v_eps
    b = bias_sum / weight
    s2 = var_pose * (2.0 - weight) / (2.0 * tau * weight) / v2
    shown = max(b * b / v2 - s2, 0.0)
    return shown + prior * s2 / (prior + s2) if prior > 0.0 else shown


@njit(cache=True)
def latency_slip_error(ay_change, vx, v_eps, var_latency):  # pragma: no cover - compiled
    """Mean square slip-angle error [rad²] an unknown accelerometer latency leaves unresolved.

    Stage 1 integrates ``ay - r vx``; an accelerometer that lags (or leads) the gyro by ``d``
    [s] turns a change of the lateral acceleration into a lateral-velocity error ``d`` times
    that change, which the running means of the checks follow only over their window. With
    ``ay_change`` [m/s²] the lateral acceleration minus its running mean over that window and
    ``var_latency`` [s²] the variance of ``d``: ``var_latency ay_change² / (vx² + v_eps²)``.
    """
    return var_latency * ay_change * ay_change / (vx * vx + v_eps * v_eps)


@njit(cache=True)
def _friction_stage(f, dt, p, w, slip, out):  # pragma: no cover - compiled
    """Stage 3, UKF2 (eq. 11-12) with the excitation tests; fills its part of ``out``, returns repairs."""
    xu = f.xu
    Pu = f.Pu
    xm = f.xm
    Pm = f.Pm
    aux = f.aux
    alpha_f, alpha_r, var_af, var_ar, fzf, fzr, fxf, fxr = slip
    vx = xu[Fs.VX]
    repairs = 0
    mu_min = p.mu_min
    mu_max = p.mu_max
    if dt > 0.0:
        # friction is a property of the place: over a distance d the state returns to the
        # prior, x <- mu0 + a (x - mu0), P <- a² P + (1 - a²) P0 with a = exp(-d / length)
        a = np.exp(-abs(vx) * dt / p.mu_length)
        for i in range(_NM):
            xm[i] = p.mu_prior + a * (xm[i] - p.mu_prior)
        Pm[:, :] = a * a * Pm
        Pm[Ms.MU_F, Ms.MU_F] = min(Pm[Ms.MU_F, Ms.MU_F] + (1.0 - a * a) * p.mu_var0 + p.q_mu * dt, p.mu_var0)
        Pm[Ms.MU_R, Ms.MU_R] = min(Pm[Ms.MU_R, Ms.MU_R] + (1.0 - a * a) * p.mu_var0 + p.q_mu * dt, p.mu_var0)
    prior_m0 = xm[Ms.MU_F]
    prior_m1 = xm[Ms.MU_R]
    prior_v0 = Pm[Ms.MU_F, Ms.MU_F]
    prior_v1 = Pm[Ms.MU_R, Ms.MU_R]
    prior_P = Pm.copy()
    exc_f = 0.0
    exc_r = 0.0
    r3f = np.inf
    r3r = np.inf
    bias_f = np.nan
    bias_r = np.nan
    obs_f = np.nan
    obs_r = np.nan
    obs_vf = np.inf
    obs_vr = np.inf
    if abs(vx) >= p.v_min and fzf > 0.0 and fzr > 0.0:
        kf = p.kf
        kr = p.kr
        cap_f = lateral_capacity(min(max(xm[Ms.MU_F], mu_min), mu_max), fxf, fzf, mu_min)
        cap_r = lateral_capacity(min(max(xm[Ms.MU_R], mu_min), mu_max), fxr, fzr, mu_min)
        sf = brush_slope(alpha_f, fzf, cap_f, kf)
        sr = brush_slope(alpha_r, fzr, cap_r, kr)
        me = p.model_err
        R3 = np.zeros((_NM, _NM))
        R3[Ms.MU_F, Ms.MU_F] = Pu[Fs.FYF, Fs.FYF] + sf * sf * var_af + (me * fzf) ** 2
        R3[Ms.MU_R, Ms.MU_R] = Pu[Fs.FYR, Fs.FYR] + sr * sr * var_ar + (me * fzr) ** 2
        r3f = R3[Ms.MU_F, Ms.MU_F]
        r3r = R3[Ms.MU_R, Ms.MU_R]
        L, Pm_used, rep = psd_sqrt(Pm)
        repairs += rep
        X = sigma_points(xm, L, w.gamma2)
        Z = friction_measurement(X, alpha_f, alpha_r, fzf, fzr, kf, kr, fxf, fxr, mu_min, mu_max)
        z = np.empty(_NM)
        z[Ms.MU_F] = xu[Fs.FYF]
        z[Ms.MU_R] = xu[Fs.FYR]
        xn, Pn, _, _ = ukf_correct(xm.copy(), Pm_used, X, Z, w.wm2, w.wc2, z, R3)
        clipped_f = not (mu_min < xn[Ms.MU_F] < mu_max)
        clipped_r = not (mu_min < xn[Ms.MU_R] < mu_max)
        xm[Ms.MU_F] = min(max(xn[Ms.MU_F], mu_min), mu_max)
        xm[Ms.MU_R] = min(max(xn[Ms.MU_R], mu_min), mu_max)
        Pm[:, :] = Pn
        # information gained per axle -> single-sample observation
        lam_f = 1.0 / Pm[Ms.MU_F, Ms.MU_F] - 1.0 / prior_v0
        lam_r = 1.0 / Pm[Ms.MU_R, Ms.MU_R] - 1.0 / prior_v1
        # robustness to a slip-angle bias, which does not average out over samples
        # a lateral-velocity bias of vy_bias_std is a slip-angle bias of vy_bias_std / |vx|
        sb = max(p.slip_bias, p.vy_bias / abs(vx))
        sbf = np.sqrt(sb * sb + p.steer_bias ** 2)
        # (in units of the lateral capacity, which moves no more than mu itself)
        bias_f = sbf * slip_sensitivity(alpha_f, fzf, lateral_capacity(xm[Ms.MU_F], fxf, fzf, mu_min), kf)
        bias_r = sb * slip_sensitivity(alpha_r, fzr, lateral_capacity(xm[Ms.MU_R], fxr, fzr, mu_min), kr)
        # slip angles measurably worse than assumed: test the whole inversion at that error
        # the band's tire residual holds at moderate ay only; the kinematic check (vy against the
        # pose's) holds at the ay driven now: the larger of the two, each axle
        wp = aux[Aux.POSE_W]
        kin = pose_slip_error(aux[Aux.POSE_VY_BIAS], wp, vx, p.v_eps, p.consist_prior, p.var_pose,
                              p.pose_check_tau) if wp > 0.0 else 0.0
        cons_r = max(consistency_mean_square(aux[Aux.CONSIST_R], aux[Aux.CONSIST_W_R], p.consist_prior,
                                             p.consist_prior_w, max(aux[Aux.CONSIST_W_R], wp)), kin)
        cons_f = max(consistency_mean_square(aux[Aux.CONSIST_F], aux[Aux.CONSIST_W_F], p.consist_prior,
                                             p.consist_prior_w, max(aux[Aux.CONSIST_W_F], wp)), kin)
        lat = latency_slip_error(aux[Aux.AY_DEV], vx, p.v_eps, p.var_latency)
        cons_r += lat
        cons_f += lat
        sc = np.sqrt(cons_r)
        if sc > sb:
            bias_f = max(bias_f, slip_bias_effect(xu[Fs.FYF], alpha_f, fzf, kf, np.sqrt(sc * sc + sbf * sbf)))
            bias_r = max(bias_r, slip_bias_effect(xu[Fs.FYR], alpha_r, fzr, kr, sc))
        # the same inversion across the slip angle's own uncertainty (z standard deviations):
        # a tire that may as well be in its linear range gives only a lower bound, |F| / Fz
        zs = p.slip_z
        gate_f = 0.0
        gate_r = 0.0
        slip_f = zs * np.sqrt(var_af + cons_f)
        slip_r = zs * np.sqrt(var_ar + cons_r)
        if zs > 0.0:
            gate_f = slip_bias_effect(xu[Fs.FYF], alpha_f, fzf, kf, slip_f)
            gate_r = slip_bias_effect(xu[Fs.FYR], alpha_r, fzr, kr, slip_r)
        # the single-sample observation: the brush model inverted at this sample's force and
        # slip (not the filter's update, whose linearisation point remembers earlier places)
        if (lam_f >= p.exc_prec * dt and dt > 0.0 and bias_f <= p.max_bias and not clipped_f
                and gate_f <= p.max_bias):
            obs_f, obs_vf = inverted_observation(xu[Fs.FYF], alpha_f, fzf, kf, fxf, r3f, mu_min, mu_max,
                                                 p.max_slip_ratio, abs(alpha_f) + slip_f)
            exc_f = 1.0 if (np.isfinite(obs_f) and 1.0 / obs_vf >= p.exc_prec * dt) else 0.0
            if exc_f < 0.5:
                obs_f = np.nan
                obs_vf = np.inf
        if (lam_r >= p.exc_prec * dt and dt > 0.0 and bias_r <= p.max_bias and not clipped_r
                and gate_r <= p.max_bias):
            obs_r, obs_vr = inverted_observation(xu[Fs.FYR], alpha_r, fzr, kr, fxr, r3r, mu_min, mu_max,
                                                 p.max_slip_ratio, abs(alpha_r) + slip_r)
            exc_r = 1.0 if (np.isfinite(obs_r) and 1.0 / obs_vr >= p.exc_prec * dt) else 0.0
            if exc_r < 0.5:
                obs_r = np.nan
                obs_vr = np.inf
        # a sample that fails the excitation test does not move that axle's estimate
        if exc_f < 0.5:
            xm[Ms.MU_F] = prior_m0
            Pm[Ms.MU_F, :] = prior_P[Ms.MU_F, :]
            Pm[:, Ms.MU_F] = prior_P[:, Ms.MU_F]
        if exc_r < 0.5:
            xm[Ms.MU_R] = prior_m1
            Pm[Ms.MU_R, :] = prior_P[Ms.MU_R, :]
            Pm[:, Ms.MU_R] = prior_P[:, Ms.MU_R]
    out[Out.EXC_F] = exc_f
    out[Out.EXC_R] = exc_r
    out[Out.OBS_F] = obs_f
    out[Out.OBS_R] = obs_r
    out[Out.OBS_VAR_F] = obs_vf
    out[Out.OBS_VAR_R] = obs_vr
    out[Out.R3_F] = r3f
    out[Out.R3_R] = r3r
    # systematic part: the slip-angle bias's effect and the brush model's error on the peak
    out[Out.SYS_F] = np.hypot(bias_f, p.peak_model_error * obs_f) if exc_f > 0.5 else np.nan
    out[Out.SYS_R] = np.hypot(bias_r, p.peak_model_error * obs_r) if exc_r > 0.5 else np.nan
    return repairs


@njit(cache=True)
def _step(f, u, k, dt, p, w, out):  # pragma: no cover - compiled
    """Sample ``k`` through the three stages, ``dt`` [s] after the previous one; fills ``out``."""
    _velocity_stage(f, u, k, dt, p)
    repairs, res2, S2 = _force_stage(f, u, k, dt, p, w)
    slip = _slip_and_loads(f, u, k, dt, p)
    repairs += _friction_stage(f, dt, p, w, slip, out)
    xe = f.xe
    xu = f.xu
    xm = f.xm
    Pe = f.Pe
    Pu = f.Pu
    Pm = f.Pm
    alpha_f, alpha_r, var_af, var_ar, fzf, fzr, fxf, fxr = slip
    nis = res2 @ np.linalg.solve(S2, res2)
    out[Out.VX] = xu[Fs.VX]
    out[Out.YAW_RATE] = xu[Fs.YAW_RATE]
    out[Out.VY] = xu[Fs.VY]
    out[Out.FXF] = xu[Fs.FXF]
    out[Out.FYF] = xu[Fs.FYF]
    out[Out.FYR] = xu[Fs.FYR]
    out[Out.ALPHA_F] = alpha_f
    out[Out.ALPHA_R] = alpha_r
    out[Out.FZF] = fzf
    out[Out.FZR] = fzr
    out[Out.MU_F] = xm[Ms.MU_F]
    out[Out.MU_R] = xm[Ms.MU_R]
    out[Out.VAR_F] = Pm[Ms.MU_F, Ms.MU_F]
    out[Out.VAR_R] = Pm[Ms.MU_R, Ms.MU_R]
    out[Out.NIS2] = nis
    out[Out.REPAIRS] = repairs
    out[Out.VX_EKF] = xe[Vs.VX]
    out[Out.VY_EKF] = xe[Vs.VY]
    # stage 1 without bias states (zero bias variance): check its velocity block
    if Pe[Vs.BIAS_AX, Vs.BIAS_AX] > 0.0:
        pe_ok = cholesky_lower(Pe)[1]
    else:
        pe_ok = cholesky_lower(np.ascontiguousarray(Pe[:_NVEL, :_NVEL]))[1]
    pd_ok = pe_ok and cholesky_lower(Pu)[1] and cholesky_lower(Pm)[1]
    out[Out.PD_OK] = 1.0 if pd_ok else 0.0
    out[Out.FYF_VAR] = Pu[Fs.FYF, Fs.FYF]
    out[Out.FYR_VAR] = Pu[Fs.FYR, Fs.FYR]
    out[Out.ALPHA_F_VAR] = var_af
    out[Out.ALPHA_R_VAR] = var_ar
    out[Out.FX_F] = fxf
    out[Out.FX_R] = fxr


@njit(cache=True)
def _run(f, u, t_prev, p, w):  # pragma: no cover - compiled
    """Compiled loop over the samples of ``u``; ``f`` is updated in place."""
    n = u.t.shape[0]
    out = np.empty((n, _NOUT))
    tp = t_prev
    for k in range(n):
        dt = u.t[k] - tp if tp == tp else 0.0  # no predict before the first sample
        _step(f, u, k, dt, p, w, out[k])
        tp = u.t[k]
    return out


def run_kernel(f: Filter, u: Inputs, t_prev: float, p: Params, w: Weights) -> NDArray[np.float64]:
    """Run the compiled cascade over the samples ``u`` from the filter ``f`` (updated in place).

    Parameters
    ----------
    f : Filter
        Filter state after the sample at ``t_prev``; its arrays are overwritten.
    u : Inputs
        Samples, times strictly after ``t_prev``.
    t_prev : float
        Time of the last sample the filter has seen [s]; NaN before the first.
    p : Params
    w : Weights

    Returns
    -------
    ndarray, shape (n, _NOUT)
        One output row per sample (:class:`Out`).
    """
    return _run(f, u, float(t_prev), p, w)
