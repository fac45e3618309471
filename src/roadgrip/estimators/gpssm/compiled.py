"""The GP-SSM state handed to the compiled whole step (:mod:`roadgrip.estimators.gpssm.block`).

:func:`advance` runs a block of samples through one call of
:func:`~roadgrip.estimators.gpssm.block.run_steps`: it packs the
:class:`~roadgrip.estimators.gpssm.state.GPSSMState` into the kernel's named
structures (no copy where the buffers are already laid out for it), runs the block and
returns the state after it and one row per sample. ``'exact'`` and ``'fast'`` modes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.gpssm import block as bk
from roadgrip.estimators.gpssm import kernel as gk
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.kernel_ops import PEAK
from roadgrip.estimators.gpssm.posterior import axle_rows, held, peak_cols
from roadgrip.estimators.gpssm.state import (
    Context,
    GPSSMEstimate,
    GPSSMState,
    check_sample,
    init_state,
)
from roadgrip.vehicle.params import axle_loads

__all__ = ["advance", "estimate", "sample_array"]

_BOOLS = (bk.OUT.OBS_F, bk.OUT.OBS_R, bk.OUT.EXCITED, bk.OUT.RESAMPLED, bk.OUT.DIVERGED, bk.OUT.COLLAPSED)
ROW_FIELDS = GPSSMEstimate._fields
"""Names of the columns of a row of :func:`advance`."""
BOOL_COLUMNS = tuple(ROW_FIELDS[i] for i in _BOOLS)


def sample_array(samples: list[Sample]) -> NDArray:
    """Samples as an array (n, 9) in the field order of :class:`Sample`."""
    return np.array(samples, dtype=float).reshape(-1, len(Sample._fields))


def estimate(row: NDArray) -> GPSSMEstimate:
    """The :class:`GPSSMEstimate` of a row of :func:`advance`."""
    vals = row.tolist()
    for i in _BOOLS:
        vals[i] = bool(vals[i])
    return GPSSMEstimate(*vals)


def _consts(ctx: Context) -> tuple[bk.Consts, gk.BasisTables, bk.PeakTables]:
    kc = ctx.kernel
    if "block" not in kc:
        config = ctx.config
        pt = config.prior_tire
        exact = config.linalg == "exact"
        lam = config.forgetting
        c0 = lam ** (-0.5 * config.refactor_every)
        if not 0.5 < c0 < 2.0:
            raise ValueError(f"prior weight at refactorisation must be near 1, got {c0!r}")
        cst = bk.Consts(
            lam=float(lam), refactor_every=int(config.refactor_every), c0=float(c0), carry=not exact,
            conditional=config.proposal == "conditional", tol=la.EXACT_TOL if exact else 1.0,
            max_terms=60 if exact else 0, mf=np.array([pt.B, pt.C, pt.D, pt.E], float),
            Lambda0=np.ascontiguousarray(config.Lambda0), sigma_ay=float(ctx.sigma_ay),
            noise_scale=float(ctx.noise_scale),
            sigma_r=float(ctx.sigma_yaw_rate), gain_walk=float(ctx.gain_walk),
            gain_gate=float(config.ay_gain_gate), sigma_vy0=float(config.sigma_vy0),
            tan_sideslip=-1.0 if config.max_sideslip is None else math.tan(config.max_sideslip),
            min_speed=float(config.min_speed), ess_threshold=float(config.ess_threshold),
            bin_width=float(config.bin_width), peak_visits=int(config.peak_visits),
            excitation_slip=float(config.excitation_slip), margin=float(config.peak_margin),
            floor2=float(config.curve_sigma_floor**2), peak_max=float(config.peak_max),
            narrow=float(config.peak_narrow), ell=float(config.basis.ell), slip_sigma=float(config.slip_sigma),
            slip_scale_sigma=float(config.slip_scale_sigma),
            max_sideslip_ratio=float(config.max_sideslip_ratio), diverge_time=float(config.diverge_time),
            slide_slip=float(config.slide_slip), slide_mu=float(config.slide_mu),
            reverse_slip=float(config.reverse_slip), reverse_mu=float(config.reverse_mu),
            relearn_time=float(config.relearn_time),
            floor_margin=float(config.floor_margin), veh=ctx.veh,
        )
        grid = np.linspace(0.0, min(config.peak_range, config.alpha_limit), config.peak_grid)
        tables = bk.PeakTables(grid, np.ascontiguousarray(config.prior_tire.mu(held(config, grid)), float),
                               axle_rows(config), peak_cols(config))
        kc["block"] = (cst, gk.basis_tables(config.basis, config.alpha_limit), tables)
    return kc["block"]


def _work(ctx: Context) -> bk.Work:
    """Scratch of the compiled step, kept in the context (nothing in it outlives a step
    but the grid features, which carry the manifold ratio they were computed for)."""
    kc = ctx.kernel
    if "block_work" not in kc:
        config = ctx.config
        b = config.basis
        N, G, d, m = config.particles, b.groups, b.outputs, b.m
        npk = 4 if b.kind == "tensor" else 2
        nf = kc["block"][1].nf
        zshape = (N, 1, 2) if config.proposal == "conditional" else (N, G, d)
        kc["block_work"] = bk.Work(
            M=np.zeros((N, G, d, m)), Lam=np.zeros((N, G, d, d)), alpha=np.zeros((N, 2)),
            vpk=np.zeros((N, G, npk)), munow=np.zeros((N, 2)), e=np.zeros(gk.EST.SIZE), gdraw=np.zeros((N, G)),
            zdraw=np.zeros(zshape), gwalk=np.zeros(N), fresh=np.ones((G, npk), np.bool_),
            fpk=np.zeros((G, m, npk)), pk=np.zeros((2, PEAK.SIZE)), a_vis=np.zeros(2), ef=np.zeros(nf),
            er=np.zeros(nf), fp=np.zeros(m), fm=np.zeros(m), idx=np.zeros(N, np.int64),
            tmp=np.zeros(N, np.int64), cum=np.zeros(N), feats=np.zeros((2, config.peak_grid, m)),
            fkey=np.full(1, np.nan),
        )
    return kc["block_work"]


def _pair(a: NDArray | None, shape: tuple[int, ...], dtype: Any = float) -> tuple[NDArray, int]:
    """``a`` as one half of a (2, ...) buffer: its own base when it is one, else a new
    pair holding a copy of it (zeros for None); and the half it is."""
    if a is not None:
        b = a.base
        if (isinstance(b, np.ndarray) and b.shape == (2, *a.shape) and b.dtype == a.dtype
                and b.flags.c_contiguous):
            ptr = a.__array_interface__["data"][0]
            for i in (0, 1):
                if b[i].__array_interface__["data"][0] == ptr and b[i].strides == a.strides:
                    return b, i
    pair = np.zeros((2, *shape), dtype)
    if a is not None:
        pair[0] = a
    return pair, 0


def _check_block(state: GPSSMState | None, data: NDArray) -> None:
    """The errors of ``check_sample`` and of a time that does not increase, for the first
    offending sample."""
    vals = data[:, :5]
    bad = ~np.isfinite(vals).all(axis=1) | np.isinf(data[:, 5]) | np.isinf(data[:, 6])
    if bad.any():
        check_sample(Sample(*data[int(np.argmax(bad))]))
    t = data[:, 0]
    prev = np.concatenate([[-np.inf if state is None else state.t], t[:-1]])
    back = ~(t - prev > 0)
    if state is None:
        back[0] = False
    if back.any():
        i = int(np.argmax(back))
        raise ValueError(f"GP-SSM samples must have increasing time: {prev[i]} then {t[i]}")


def advance(ctx: Context, state: GPSSMState | None, data: NDArray, seed: int = 0) -> tuple[GPSSMState, NDArray]:
    """Run the samples ``data`` (K, 9) (:func:`sample_array`) through the compiled step.

    ``state=None`` initialises from the first sample with ``seed``. The returned state
    reuses the arrays of ``state``, as :func:`~roadgrip.estimators.gpssm.stepping.step`.

    Returns
    -------
    state : GPSSMState
    rows : ndarray, shape (K, len(GPSSMEstimate._fields))
        One row per sample (:func:`estimate`; booleans as 0 / 1).
    """
    data = np.ascontiguousarray(data, dtype=float)
    _check_block(state, data)
    config = ctx.config
    cst, basis, tables = _consts(ctx)
    if state is None:
        state = init_state(ctx, Sample(*data[0]), seed)
    wk = _work(ctx)
    carry = config.linalg == "fast"
    if carry:
        wk = wk._replace(M=state.M, Lam=state.Lam)
    N, G, _, m = state.Psi.shape
    npk = wk.fpk.shape[2]
    lin = state.lin
    sig2, si = _pair(lin.sigma, lin.sigma.shape)
    pend2, par = _pair(lin.pend, lin.pend.shape)
    pgain2, par_g = _pair(lin.pgain, lin.pgain.shape)
    pkw2, par_w = _pair(lin.pkw, (N, G, npk, m))
    if par_g != par or par_w != par:  # halves out of step (a state put together by hand)
        pgain2, pend2, pkw2 = (_pair(a.copy(), a.shape)[0] for a in (pgain2[par_g], pend2[par], pkw2[par_w]))
        par = 0
    pkf = np.zeros((G, m, npk)) if lin.pkf is None else lin.pkf.copy()
    g = state.guard
    n0 = len(g.times)
    gt = np.zeros(n0 + len(data) + 1)
    gay = np.zeros_like(gt)
    gacc = np.zeros_like(gt)
    gnis = np.zeros_like(gt)
    gt[:n0], gay[:n0], gacc[:n0], gnis[:n0] = g.times, g.ay, g.accel, g.nis
    sc = np.zeros(bk.SC.SIZE)
    sc[[bk.SC.K, bk.SC.T, bk.SC.STEER, bk.SC.VX, bk.SC.NU]] = (state.k, state.t, *state.u, state.nu)
    sc[[bk.SC.SIGMA_SCALE, bk.SC.P_SCALE, bk.SC.C, bk.SC.SINCE, bk.SC.NHIST]] = (
        lin.sigma_scale, lin.p_scale, lin.c, lin.since_refactor, lin.nhist)
    sc[[bk.SC.PK_VALID, bk.SC.PAR, bk.SC.SIG]] = (lin.pkf is not None, par, si)
    sc[[bk.SC.FLOOR, bk.SC.BAD_SINCE, bk.SC.FLAGGED_UNTIL, bk.SC.RESETS, bk.SC.G_HEAD, bk.SC.G_TAIL]] = (
        g.floor_raw, g.bad_since, g.flagged_until, g.resets, 0, n0)
    sc[bk.SC.FLOOR_ACCEL] = g.floor_accel
    sc[[bk.SC.USED_FRONT, bk.SC.USED_REAR]] = g.used
    panc = np.ascontiguousarray(lin.panc, np.int64)
    sanc = np.ascontiguousarray(lin.sanc, np.int64)
    x, mu, logw = (np.ascontiguousarray(a) for a in (state.x, state.mu, state.logw))
    Psi, Phi = np.ascontiguousarray(state.Psi), np.ascontiguousarray(state.Phi)
    visits, moments = np.ascontiguousarray(state.visits), np.array(state.slip_moments, float)
    peak_alpha = np.array(state.peak_alpha, float)
    fzf = np.full(len(data), ctx.veh.fz_front)
    fzr = np.full(len(data), ctx.veh.fz_rear)
    if config.axle_loads == "dynamic":
        ok = np.isfinite(data[:, 6])
        if ok.any():
            f, r = axle_loads(ctx.vehicle, data[ok, 6])
            fzf[ok], fzr[ok] = f, r
    out = np.empty((len(data), bk.OUT.SIZE))
    bk.run_steps(
        gk.Particles(x, mu, logw, Psi, Phi),
        bk.LinBuffers(sig2, lin.pinv, lin.hist, lin.hcoef, lin.hanc, pend2, pgain2, panc, sanc, pkw2, pkf),
        bk.Stats(sc, visits, moments, peak_alpha, gt, gay, gacc, gnis),
        wk,
        bk.Block(data[:, 0], data[:, 1], data[:, 2], data[:, 3], data[:, 4], data[:, 5], data[:, 7] != 0.0,
                 fzf, fzr, data[:, 8]),
        cst, basis, tables, state.rng, out,
    )
    si, par = int(sc[bk.SC.SIG]), int(sc[bk.SC.PAR])
    lin = lin._replace(
        sigma=sig2[si], sigma_spare=sig2[1 - si], sigma_scale=float(sc[bk.SC.SIGMA_SCALE]),
        p_scale=float(sc[bk.SC.P_SCALE]), c=float(sc[bk.SC.C]), since_refactor=int(sc[bk.SC.SINCE]),
        nhist=int(sc[bk.SC.NHIST]), pend=pend2[par], pgain=pgain2[par], pkw=pkw2[par],
        pkf=pkf if sc[bk.SC.PK_VALID] else None, panc=panc, sanc=sanc,
    )
    head, tail = int(sc[bk.SC.G_HEAD]), int(sc[bk.SC.G_TAIL])
    g.times, g.ay, g.accel = gt[head:tail].tolist(), gay[head:tail].tolist(), gacc[head:tail].tolist()
    g.nis = gnis[head:tail].tolist()
    g.floor_raw, g.bad_since = float(sc[bk.SC.FLOOR]), float(sc[bk.SC.BAD_SINCE])
    g.floor_accel = float(sc[bk.SC.FLOOR_ACCEL])
    g.used = [float(sc[bk.SC.USED_FRONT]), float(sc[bk.SC.USED_REAR])]
    g.flagged_until, g.resets = float(sc[bk.SC.FLAGGED_UNTIL]), int(sc[bk.SC.RESETS])
    new = GPSSMState(
        k=int(sc[bk.SC.K]), t=float(sc[bk.SC.T]), u=sc[[bk.SC.STEER, bk.SC.VX]].copy(), x=x, mu=mu, logw=logw,
        lin=lin, Psi=Psi, Phi=Phi, nu=float(sc[bk.SC.NU]), visits=visits, slip_moments=moments,
        peak_alpha=peak_alpha, rng=state.rng, M=wk.M if carry else None, Lam=wk.Lam if carry else None, guard=g,
    )
    return new, out
