r"""The whole GP-SSM step compiled, one call per block of steps.

:func:`run_steps` runs, for every sample of a block and without returning to Python,
everything :func:`~roadgrip.estimators.gpssm.reference.step_reference` does: the time
update of the information matrices (forgetting, the refactorisation every
``refactor_every`` steps, in ``'fast'`` mode the carried posterior moved with it), the
random draws, the per-particle pass of :func:`~roadgrip.estimators.gpssm.kernel.particle_pass`
(propagation, features, solves, friction sample, weights, statistics update), the
bookkeeping of the deferred updates, the slip histogram and moments, the features of the
peak search and :func:`~roadgrip.estimators.gpssm.kernel_ops.peak_summary`, systematic
resampling, and the honesty checks of :mod:`roadgrip.estimators.gpssm.guard`.

The random numbers are drawn from the filter's own ``numpy.random.Generator`` inside the
compiled code, in the order of the reference implementation (numba's generator methods
draw NumPy's stream from the same bit generator, which they advance), so a seed gives
the same particles whichever implementation runs. The tests hold the two to each other.

State layouts
-------------
``sc`` (:class:`SC`) holds the scalars of the state; the information matrices'
``Sigma`` slots are a pair (2, N, G, m, m) of which ``sc[SC.SIG]`` is the current one
(the other is the refactorisation's spare), and the pending rank-1 terms ``pend``,
``pgain`` and the carried ``P_B f`` of the peak features ``pkw`` are pairs of which
``sc[SC.PAR]`` is the current one (the step writes the other). The guard's window of
the last second of recorded ``a_y`` is ``gt``, ``gay`` (and the accelerometer's, ``gacc``,
where ``a_y`` is another source, and the normalised yaw-rate innovations, ``gnis``) between
``sc[SC.G_HEAD]`` and ``sc[SC.G_TAIL]``. One row
of :class:`OUT` per step, in the order of
:class:`~roadgrip.estimators.gpssm.state.GPSSMEstimate`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.gpssm import kernel as gk
from roadgrip.estimators.gpssm.block_ops import (
    _BAD,
    _C,
    _FLOOR,
    _FLOOR_ACCEL,
    _HEAD,
    _K,
    _NHIST,
    _NU,
    _PAR,
    _PKV,
    _PS,
    _RESETS,
    _SINCE,
    _SS,
    _STEER,
    _T,
    _TAIL,
    _UNTIL,
    _USED_F,
    _VX,
    _flush,
    _grid_features,
    _peak_rhs,
    _refactor,
    _refactored_posterior,
    _resample,
)
from roadgrip.estimators.gpssm.guard import (
    _COPIES,
    _ESS_COLLAPSED,
    _YAW_NIS_MAX,
    _YAW_SIGMAS,
    FLOOR_WINDOW,
    second_difference_noise,
)
from roadgrip.estimators.gpssm.kernel_ops import (
    PeakGrid,
    PeakParams,
    PeakPosterior,
    peak_summary,
    slot_plan,
)
from roadgrip.estimators.gpssm.linalg import FOLD_ROWS
from roadgrip.estimators.gpssm.model import VehicleConstants

__all__ = ["OUT", "SC", "Block", "Consts", "LinBuffers", "PeakTables", "Stats", "Work", "run_steps"]


class SC:
    """Slots of the scalar state ``sc``."""

    (K, T, STEER, VX, NU, SIGMA_SCALE, P_SCALE, C, SINCE, NHIST, PK_VALID, PAR, SIG,
     FLOOR, BAD_SINCE, FLAGGED_UNTIL, RESETS, G_HEAD, G_TAIL, FLOOR_ACCEL, USED_FRONT, USED_REAR,
     SIZE) = range(23)


class OUT:
    """Slots of an output row (the fields of ``GPSSMEstimate``, in order)."""

    (T, VY, VY_STD, YAW_RATE, YAW_RATE_STD, AY_GAIN, ALPHA_F, ALPHA_R, MU_NOW_F, MU_NOW_R, MU_F, MU_R,
     MU_F_LO, MU_F_HI, MU_R_LO, MU_R_HI, PEAK_ALPHA_F, PEAK_ALPHA_R, OBS_F, OBS_R, EXCITED, ESS,
     RESAMPLED, DIVERGED, FLOOR, COLLAPSED, SIZE) = range(27)


# module constants for the compiled code (it reads globals, not class attributes)
_E_ESS, _E_VY, _E_YR, _E_VY_STD, _E_YR_STD, _E_AF, _E_AR, _E_MU_F, _E_MU_R, _E_GAIN = range(10)
_PK_MU, _PK_LO, _PK_HI, _PK_ALPHA, _PK_OBS, _PK_BAND = range(6)
_Z95 = 1.959963984540054


class Block(NamedTuple):
    """Inputs of the block's steps, shape (K,) each (SI units; ``vy`` NaN: not measured)."""

    t: NDArray
    ay: NDArray
    yaw_rate: NDArray
    steer: NDArray
    vx: NDArray
    vy: NDArray
    recorded: NDArray
    fz_front: NDArray
    fz_rear: NDArray
    ay_accel: NDArray


class Consts(NamedTuple):
    """Constants of a run (configuration, vehicle, noise levels)."""

    lam: float
    refactor_every: int
    c0: float
    carry: bool
    conditional: bool
    tol: float
    max_terms: int
    mf: NDArray
    Lambda0: NDArray
    sigma_ay: float
    noise_scale: float
    sigma_r: float
    gain_walk: float
    gain_gate: float
    sigma_vy0: float
    tan_sideslip: float
    min_speed: float
    ess_threshold: float
    bin_width: float
    peak_visits: int
    excitation_slip: float
    margin: float
    floor2: float
    peak_max: float
    narrow: float
    ell: float
    slip_sigma: float
    slip_scale_sigma: float
    max_sideslip_ratio: float
    diverge_time: float
    slide_slip: float
    slide_mu: float
    reverse_slip: float
    reverse_mu: float
    relearn_time: float
    floor_margin: float
    veh: VehicleConstants


class LinBuffers(NamedTuple):
    """The information matrices (:class:`~roadgrip.estimators.gpssm.linalg.LinAlgState`)."""

    sigma2: NDArray
    pinv: NDArray
    hist: NDArray
    hcoef: NDArray
    hanc: NDArray
    pend2: NDArray
    pgain2: NDArray
    panc: NDArray
    sanc: NDArray
    pkw2: NDArray
    pkf: NDArray


class Stats(NamedTuple):
    """Scalars, slip statistics, peak slip angles and the guard's window."""

    sc: NDArray
    visits: NDArray
    moments: NDArray
    peak_alpha: NDArray
    gt: NDArray
    gay: NDArray
    gacc: NDArray
    gnis: NDArray


class PeakTables(NamedTuple):
    """The slip grid of the peak search: ``grid``, ``prior`` (ng,), ``where``, ``col`` (2, 2)."""

    grid: NDArray
    prior: NDArray
    where: NDArray
    col: NDArray


class Work(NamedTuple):
    """Scratch of a step, and the grid features cached for the ratio ``fkey[0]``."""

    M: NDArray
    Lam: NDArray
    alpha: NDArray
    vpk: NDArray
    munow: NDArray
    e: NDArray
    gdraw: NDArray
    zdraw: NDArray
    gwalk: NDArray
    fresh: NDArray
    fpk: NDArray
    pk: NDArray
    a_vis: NDArray
    ef: NDArray
    er: NDArray
    fp: NDArray
    fm: NDArray
    idx: NDArray
    tmp: NDArray
    cum: NDArray
    feats: NDArray
    fkey: NDArray


@numba.njit(cache=True)
def run_steps(p, lin, st, wk, blk, cst, basis, pt, rng, out):  # pragma: no cover - compiled
    """Every step of ``blk`` in turn, state in place; ``out`` (K, OUT.SIZE) their rows.

    ``p`` :class:`~roadgrip.estimators.gpssm.kernel.Particles`, ``lin``
    :class:`LinBuffers`, ``st`` :class:`Stats`, ``wk`` :class:`Work` (its ``M``, ``Lam``
    the carried posterior in ``'fast'`` mode), ``blk`` :class:`Block`, ``cst``
    :class:`Consts`, ``basis`` :class:`~roadgrip.estimators.gpssm.kernel.BasisTables`,
    ``pt`` :class:`PeakTables`, ``rng`` the filter's ``numpy.random.Generator``.
    """
    for i in range(blk.t.shape[0]):
        sc = st.sc
        N, G, d, m = p.Psi.shape
        lam = cst.lam
        t, vx, steer = blk.t[i], blk.vx[i], blk.steer[i]
        vy_meas = blk.vy[i]
        # 1. time update of the statistics (eq. 29): linalg.forget, refactor
        propagate = sc[_K] > 0
        dt = 0.0
        if propagate:
            dt = t - sc[_T]
            c_forgotten = sc[_C] * lam
            sc[_SS] *= lam
            sc[_PS] /= lam
            sc[_C] *= lam
            sc[_SINCE] += 1.0
            if sc[_SINCE] >= cst.refactor_every:
                _refactor(lin, sc, cst.c0)
            elif sc[_SINCE] == cst.refactor_every - 1:
                _flush(lin, sc)  # the refactorisation's fold a step ahead
            sc[_NU] = lam * sc[_NU]
            if cst.carry and sc[_SINCE] == 0.0:
                _refactored_posterior(wk.M, wk.Lam, lam, lin.pinv, sc[_PS], sc[_C] - c_forgotten)
        learn = vx >= cst.min_speed
        if learn and sc[_NHIST] >= min(lin.hist.shape[0], FOLD_ROWS):
            _flush(lin, sc)  # linalg.reserve
        # 2. random numbers, in the reference's order
        if propagate and cst.gain_walk != 0.0:
            _normals(rng, wk.gwalk)
            f = cst.gain_walk * math.sqrt(dt)
            for n in range(N):
                wk.gwalk[n] = f * wk.gwalk[n]
        else:
            wk.gwalk[:] = 0.0
        sxx, sxy = st.moments[0], st.moments[1]
        ratio = 1.0 if sxx <= 1e-10 else min(max(sxy / sxx, 0.2), 5.0)
        r_key = round(ratio, 2) if basis.tensor else 1.0
        _peak_rhs(basis, r_key, st.peak_alpha, wk)
        dof = sc[_NU] - d + 1.0
        if cst.conditional:
            _chisquares(rng, dof, wk.gdraw.reshape(-1))
            _normals(rng, wk.zdraw.reshape(-1))
        else:
            _normals(rng, wk.zdraw.reshape(-1))
            _chisquares(rng, dof, wk.gdraw.reshape(-1))
        vy_max = -1.0
        if cst.tan_sideslip >= 0.0:
            vy_max = cst.tan_sideslip * max(vx, 0.0)
        # 3. the per-particle pass (kernel.particle_pass)
        npk = wk.fpk.shape[2]
        for g in range(G):
            for q in range(npk):
                fr = sc[_PKV] == 0.0
                if not fr:
                    for k in range(m):
                        if lin.pkf[g, k, q] != wk.fpk[g, k, q]:
                            fr = True
                            break
                wk.fresh[g, q] = fr
        par = int(sc[_PAR])
        pdst, order = slot_plan(lin.panc)
        veh = cst.veh
        veh_k = VehicleConstants(veh.mass, blk.fz_front[i], blk.fz_rear[i], veh.lf, veh.lr, veh.yaw_inertia, veh.v_eps)
        has_vy = not math.isnan(vy_meas)
        gk.particle_pass(
            p,
            gk.Slots(lin.pinv.reshape(N * G, m, m), lin.panc, pdst, order, lin.pend2[par], lin.pgain2[par],
                     lin.pend2[1 - par], lin.pgain2[1 - par], lin.hist, int(sc[_NHIST])),
            gk.StepInput(propagate, dt, sc[_STEER], sc[_VX], steer, vx, blk.ay[i], blk.yaw_rate[i], has_vy,
                         vy_meas if has_vy else 0.0, learn),
            veh_k,
            gk.Params(cst.mf, lam, sc[_NU], cst.Lambda0, _sigma_ay(st, cst), cst.sigma_r, vy_max, sc[_PS],
                      0.0 if cst.carry else 1.0 - sc[_C], cst.tol, cst.max_terms, cst.conditional, cst.carry,
                      cst.gain_gate),
            basis,
            gk.PeakColumns(wk.fpk, lin.pkw2[par], lin.pkw2[1 - par], wk.fresh),
            gk.Draws(wk.gdraw, wk.zdraw, wk.gwalk),
            gk.Outputs(wk.alpha, wk.M, wk.Lam, wk.vpk, wk.munow, wk.e),
        )
        sc[_PAR] = 1 - par
        lin.panc[:] = pdst
        lin.pkf[:] = wk.fpk
        sc[_PKV] = 1.0
        if learn:
            nh = int(sc[_NHIST])
            lin.hcoef[nh] = 1.0 / sc[_SS]
            for n in range(N):
                lin.hanc[nh, n] = n
            sc[_NHIST] += 1.0
            sc[_NU] += 1.0
        # 4. slip statistics (state.slip_statistics)
        e = wk.e
        af, ar = e[_E_AF], e[_E_AR]
        nb = st.visits.shape[1]
        if learn:
            st.visits[0, min(int(abs(af) / cst.bin_width), nb - 1)] += 1
            st.visits[1, min(int(abs(ar) / cst.bin_width), nb - 1)] += 1
            st.moments[0] += af * af
            st.moments[1] += af * ar
        excited = learn and max(abs(af), abs(ar)) > cst.excitation_slip
        # 5. the peak per axle (posterior.peak_grid, state.visited_range, kernel_ops.peak_summary)
        if wk.fkey[0] != r_key:
            _grid_features(basis, r_key, pt.grid, wk)
            wk.fkey[0] = r_key
        for ax in range(2):
            wk.a_vis[ax] = 0.0
            for j in range(nb - 1, -1, -1):
                if st.visits[ax, j] >= cst.peak_visits:
                    wk.a_vis[ax] = (j + 1) * cst.bin_width
                    break
        peak_summary(PeakPosterior(wk.M, wk.Lam, p.logw, wk.vpk), PeakGrid(wk.feats, pt.prior, pt.grid, pt.where, pt.col),
                     wk.a_vis, PeakParams(max(sc[_NU] - d - 1.0, 1.0), cst.margin, _Z95, cst.floor2, cst.peak_max,
                                          cst.narrow, cst.ell), wk.pk)
        pk = wk.pk
        ess = e[_E_ESS]
        resampled = ess <= cst.ess_threshold * N
        for ax in range(2):
            st.peak_alpha[0, ax] = pk[ax, _PK_ALPHA]
            st.peak_alpha[1, ax] = pk[ax, _PK_BAND]
        sc[_K] += 1.0
        sc[_T] = t
        sc[_STEER] = steer
        sc[_VX] = vx
        if resampled:
            _resample(p, lin, wk, sc, rng, cst.carry)
        # 6. the estimate and the honesty checks (guard.guard_step)
        out[i, 0] = t
        out[i, 1] = e[_E_VY]
        out[i, 3] = e[_E_YR]
        out[i, 4] = e[_E_YR_STD]
        out[i, 5] = e[_E_GAIN]
        out[i, 6] = af
        out[i, 7] = ar
        out[i, 8] = e[_E_MU_F]
        out[i, 9] = e[_E_MU_R]
        out[i, 16] = pk[0, _PK_ALPHA]
        out[i, 17] = pk[1, _PK_ALPHA]
        out[i, 20] = 1.0 if excited else 0.0
        out[i, 21] = ess
        out[i, 22] = 1.0 if resampled else 0.0
        _guard(p, st, wk, blk, i, dt, cst, rng, out[i])


@numba.njit(cache=True)
def _normals(rng, out):  # pragma: no cover - compiled
    """``out[:] = rng.standard_normal(len(out))`` (one copy of the sampler's code)."""
    for n in range(out.shape[0]):
        out[n] = rng.standard_normal()


@numba.njit(cache=True)
def _chisquares(rng, dof, out):  # pragma: no cover - compiled
    """``out[:] = rng.chisquare(dof, len(out))``."""
    for n in range(out.shape[0]):
        out[n] = rng.chisquare(dof)


@numba.njit(cache=True)
def _sigma_ay(st, cst):  # pragma: no cover - compiled
    """:func:`roadgrip.estimators.gpssm.guard.step_sigma_ay` on the guard's window."""
    if cst.noise_scale == 0.0:
        return cst.sigma_ay
    head, tail = int(st.sc[_HEAD]), int(st.sc[_TAIL])
    return max(cst.sigma_ay, cst.noise_scale * second_difference_noise(st.gay[head:tail]))


@numba.njit(cache=True)
def _window_mean(a, head, tail):  # pragma: no cover - compiled
    """Mean of ``a[head:tail]`` summed in order (0 when empty): the guard's window of the
    last second (guard.Guard's floors and ``_mean``)."""
    if tail <= head:
        return 0.0
    s = 0.0
    for j in range(head, tail):
        s += a[j]
    return s / (tail - head)


@numba.njit(cache=True)
def _guard(p, st, wk, blk, i, dt, cst, rng, row):  # pragma: no cover - compiled
    """:func:`roadgrip.estimators.gpssm.guard.guard_step` on the row of step ``i``."""
    sc, gt, gay = st.sc, st.gt, st.gay
    N = p.x.shape[0]
    e_vy, e_yr, e_yr_std, e_gain, ess = row[1], row[3], row[4], row[5], row[21]
    t, vx, vy_meas, yaw_meas = blk.t[i], blk.vx[i], blk.vy[i], blk.yaw_rate[i]
    nis = (yaw_meas - e_yr) ** 2 / (cst.sigma_r**2 + e_yr_std**2)
    full = False
    if blk.recorded[i]:
        head, tail = int(sc[_HEAD]), int(sc[_TAIL])
        dt_hint = t - gt[tail - 1] if tail > head else (dt if dt > 0 else 0.04)
        gt[tail] = t
        gay[tail] = blk.ay[i]
        accel = blk.ay_accel[i]
        st.gacc[tail] = accel
        st.gnis[tail] = nis
        tail += 1
        while tail > head and gt[head] <= t - FLOOR_WINDOW + 1e-9:
            head += 1
        full = tail > head and t - gt[head] >= FLOOR_WINDOW - 1.5 * dt_hint
        if full:
            sc[_FLOOR] = max(sc[_FLOOR], abs(_window_mean(gay, head, tail)) / GRAVITY)
            if not math.isnan(accel):
                m_acc = _window_mean(st.gacc, head, tail)
                if not math.isnan(m_acc):
                    sc[_FLOOR_ACCEL] = max(sc[_FLOOR_ACCEL], abs(m_acc) / GRAVITY)
        sc[_HEAD] = head
        sc[_TAIL] = tail
    floor_raw = sc[_FLOOR]
    # the upper bands' floor: what the filter's a_y or the accelerometer shows the car used
    floor_upper = max(floor_raw, sc[_FLOOR_ACCEL])
    floor_gain = floor_raw / max(e_gain, 1e-6)
    moving = vx >= cst.min_speed
    measured = not math.isnan(vy_meas)
    vy_std = math.sqrt(wk.e[_E_VY_STD] ** 2 + (cst.slip_sigma * vx) ** 2)
    if not measured:
        # the slip angles' scale is not identified (guard docstring): the rear slip velocity
        vy_std = math.hypot(vy_std, cst.slip_scale_sigma * (e_vy - cst.veh.lr * e_yr))
    if not moving:
        gap = abs(vy_meas - e_vy) if measured else cst.max_sideslip_ratio * cst.min_speed
        vy_std = max(vy_std, gap / _Z95)
    # the yaw rate unexplained on average over the window (guard._YAW_NIS_MAX)
    unexplained = full and _window_mean(st.gnis, int(sc[_HEAD]), int(sc[_TAIL])) > _YAW_NIS_MAX
    runaway = moving and not measured and (abs(e_vy) > cst.max_sideslip_ratio * vx or unexplained)
    # learned frictions that push against both axles' slips (guard._reversed)
    n_rev = 0
    for ax in range(2):
        a_x, mu_x = row[6 + ax], row[8 + ax]
        if abs(a_x) > cst.reverse_slip and mu_x * math.copysign(1.0, a_x) < -cst.reverse_mu:
            n_rev += 1
    yaw_gap = abs(yaw_meas - e_yr) > _YAW_SIGMAS * math.hypot(cst.sigma_r, e_yr_std)
    if moving and not measured and n_rev == 2:
        runaway = True
    # slip angles the lateral acceleration contradicts (guard._slide_gap)
    slide_gap = False
    a_f, a_r = row[6], row[7]
    if not measured and min(abs(a_f), abs(a_r)) > cst.slide_slip and a_f * a_r > 0.0:
        ay_mean = _window_mean(gay, int(sc[_HEAD]), int(sc[_TAIL]))
        slide_gap = ay_mean / max(e_gain, 1e-6) * math.copysign(1.0, a_f) < cst.slide_mu * GRAVITY
    if moving and (yaw_gap or slide_gap or ess < _ESS_COLLAPSED):
        if math.isnan(sc[_BAD]):
            sc[_BAD] = t
    else:
        sc[_BAD] = np.nan
    lost = not math.isnan(sc[_BAD]) and t - sc[_BAD] >= cst.diverge_time
    if runaway or lost:
        # re-initialise the lateral state as at the start (guard._reinitialise)
        z = wk.gwalk  # free after the particle pass
        _normals(rng, z)
        for n in range(N):
            p.x[n, 0] = cst.sigma_vy0 * z[n]
        if cst.tan_sideslip >= 0.0:
            lim = cst.tan_sideslip * max(vx, 0.0)
            for n in range(N):
                p.x[n, 0] = min(max(p.x[n, 0], -lim), lim)
        _normals(rng, z)
        for n in range(N):
            p.x[n, 1] = yaw_meas + cst.sigma_r * z[n]
        p.logw[:] = -math.log(N)
        st.gnis[int(sc[_HEAD]):int(sc[_TAIL])] = 0.0  # the innovations of the state left behind
        sc[_RESETS] += 1.0
        sc[_BAD] = np.nan
        sc[_UNTIL] = t + cst.diverge_time
        sc[_USED_F] = 0.0  # what the wrong lateral state said the axles used
        sc[_USED_F + 1] = 0.0
    diverged = runaway or lost or t < sc[_UNTIL]
    if diverged and not measured:
        vy_std = max(vy_std, cst.sigma_vy0, abs(e_vy))
    row[2] = vy_std
    collapsed = ess < _ESS_COLLAPSED or e_yr_std < _COPIES * cst.sigma_r
    if collapsed:
        row[4] = max(e_yr_std, cst.sigma_r)  # copies of one particle: no spread (guard docstring)
    row[23] = 1.0 if diverged else 0.0
    row[24] = floor_raw
    row[25] = 1.0 if collapsed else 0.0
    for ax in range(2):
        obs = wk.pk[ax, _PK_OBS] != 0.0
        mu = wk.pk[ax, _PK_MU]
        lo, hi = wk.pk[ax, _PK_LO], wk.pk[ax, _PK_HI]
        if not diverged:
            sc[_USED_F + ax] = max(sc[_USED_F + ax], abs(row[8 + ax]))
        if obs and mu < floor_gain - cst.floor_margin:
            obs = False
            hi = cst.peak_max
        if not obs:
            # a lower bound no higher than the axle has been estimated to use (guard.guard_step)
            lo = min(lo, max(sc[_USED_F + ax], floor_gain))
        mu = max(mu, floor_gain)
        if t < sc[_UNTIL] - cst.diverge_time + cst.relearn_time:
            # relearning after a re-initialisation (guard.guard_step)
            obs = False
            lo = min(lo, floor_gain)
            hi = cst.peak_max
        if diverged:
            obs = False
            lo = 0.0
            hi = cst.peak_max
        row[10 + ax] = mu
        row[18 + ax] = 1.0 if obs else 0.0
        row[12 + 2 * ax] = min(lo, mu)
        row[13 + 2 * ax] = max(max(hi, floor_upper), mu)
