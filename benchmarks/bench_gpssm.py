"""Speed and memory of the GP-SSM filter (roadgrip.estimators.gpssm).

Prints:

1. paper settings (N = 200, 10 x 10 tensor basis m = 100, snow-slalom 250 s at 25 Hz):
   exact and fast mode over the whole drive (wall time, steps/s, real-time factor; peak
   traced memory from a separate 300-step run, as tracing slows the filter), the largest
   difference between their posterior mean curves over the visited slip range (same
   seed; and two exact runs with seeds 0 and 1 as the Monte Carlo reference, and two
   with ``sigma_ay`` changed by 1e-9 and 1e-6 relative, which shows how far the filter's
   paths part under a perturbation of that size), the floor of a step at these settings
   (one rank-1 update and product over every particle's matrix, from cache and from main
   memory, and the refactorisation per step) against the 50x budget, and the
   straightforward per-particle solve ('direct') on a prefix, with the speed-up measured
   in the same run;
2. N = 200 with m = 20 basis functions (separable:10);
3. time per step against N (m = 20) and against m (N = 200).

With ``--accuracy`` it prints instead the acceptance figures of the paper's study: curve
MAE and 95 % band coverage over the slip bins visited at least 20 times, at t = 50 s and at
the end, and the lateral-velocity error, per basis and seed (``--seeds``, default 0,1;
the drive and the filter take the same seed; the paper's basis also in the fast mode:
its error against the truth, beside the exact mode's).

With ``--accuracy --multibody`` the acceptance figures on the multi-body snow slaloms of
both vehicles (seeds 0-4; ``--option KEY=VALUE`` sets filter options; ``--streams
0,1000,2000`` runs each drive with those offsets added to the filter's seed and prints a
summary over the Monte Carlo streams), with ``--accuracy
--realdata`` the honesty figures on every recording in ``../shared/data``
(docs/gpssm.md). With ``--accuracy --fast-vs-truth`` the fast mode against the truth beside
the exact mode, seeds 0-4, on the paper study and the multi-body snow slaloms (with
``--control`` the exact mode with another Monte Carlo stream in its place: the same
criterion on an estimator that has the exact mode's distribution).

With ``--speed`` the speed table of the compiled step (N = 200; m = 20, the default
basis and m = 100; exact and fast; the median of ``--reps`` runs), beside the same cases
of another revision (``--baseline REV``, its ``src`` tree from git) measured alternately
in the same run; ``--parts`` where the time of a step goes (ms per step); ``--refactor`` the
refactorisation's share of the latency (CPU per step at the refactorisation, at the folds of
the buffered rows and elsewhere, and its pieces); ``--layout`` the
particles-innermost layout against the present one; ``--many``
``run_many`` over 10 drives against the same runs one after another (on a quiet machine).

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_gpssm.py [--quick | --speed
[--reps 5] [--baseline REV] | --parts | --refactor | --layout | --many | --accuracy
[--seeds 0,1,2,3,4] [--multibody [--streams 0,1000,2000] | --realdata | --fast-vs-truth
[--control]]]``
(one core).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import resource
import time
import tracemalloc

import numba
import numpy as np

from roadgrip.estimators.gpssm import GPSSMConfig, run_filter
from roadgrip.estimators.gpssm import kernel as gk
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.accuracy import curve_accuracy
from roadgrip.estimators.gpssm.kernel_ops import neumann_solve, peak_summary, slot_plan
from roadgrip.sim.scenarios import simulate_scenario


def timed_run(drive, basis: str, n: int, mode: str, steps: int | None = None, curves=(), **config):
    d = drive if steps is None else drive.slice_time(drive.t[0], drive.t[0] + steps / 25.0 - 1e-9)
    cfg = GPSSMConfig(basis=basis, particles=n, linalg=mode, **config)
    # warm up the compiled kernels outside the timing
    run_filter(d.slice_time(d.t[0], d.t[0] + 0.2), cfg, seed=0)
    t0 = time.perf_counter()
    table, cv = run_filter(d, cfg, seed=0, curve_times=curves,
                           curve_alpha=np.radians(np.linspace(-20, 20, 161)))
    wall = time.perf_counter() - t0
    return d, table, cv, wall


def curve_difference(a, b, acc) -> list[tuple[float, float]]:
    """Largest and mean |posterior mean difference| of two curve sets over each axle's
    visited range (``acc`` from :func:`curve_accuracy`), front then rear."""
    out = []
    for ax, axle in enumerate(("front", "rear")):
        sel = (a.alpha >= acc[axle]["alpha_min"]) & (a.alpha <= acc[axle]["alpha_max"])
        dd = np.abs(a.mean[ax, sel] - b.mean[ax, sel])
        out.append((float(dd.max()), float(dd.mean())))
    return out


@numba.njit(fastmath=True)
def _sweep(P, u, r, y):  # pragma: no cover - compiled
    """Per matrix: ``P -= u u^T``, then ``y = P r``: the least per-step work on a particle's
    ``P_B`` (one rank-1 update and one product)."""
    n, m, _ = P.shape
    for k in range(n):
        for i in range(m):
            for j in range(m):
                P[k, i, j] -= u[i] * u[j]
        for i in range(m):
            acc = 0.0
            for j in range(m):
                acc += P[k, i, j] * r[j]
            y[k, i] = acc


def memory_floor(n: int, m: int, period: int, rate: float) -> None:
    """Lower bounds on a step at the paper settings: one rank-1 update and product over
    every particle's ``m x m`` matrix, from cache (the same ``8 n m²`` bytes swept again)
    and from main memory (four such sets in turn: 64 MiB at ``n = 200``, ``m = 100``,
    twice this machine's L3), and the refactorisation (Cholesky inverse of every
    ``Sigma + c I``) spread over its period."""
    rng = np.random.default_rng(0)
    sets = [np.broadcast_to(np.eye(m), (n, m, m)).copy() for _ in range(4)]
    u = rng.standard_normal(m) * 1e-6
    r = rng.standard_normal(m)
    y = np.empty((n, m))
    _sweep(sets[0], u, r, y)
    reps = 40
    t0 = time.perf_counter()
    for _ in range(reps):
        _sweep(sets[0], u, r, y)
    warm = (time.perf_counter() - t0) / reps
    t0 = time.perf_counter()
    for k in range(reps):
        _sweep(sets[k % 4], u, r, y)
    cold = (time.perf_counter() - t0) / reps
    st = la.init("exact", n, 1, m, history=period)
    st.hist[:] = rng.standard_normal(st.hist.shape) * 0.3
    st.hcoef[:] = 1.0
    refac = np.inf
    for _ in range(4):
        t0 = time.perf_counter()
        st = la.refactor(st._replace(nhist=period), 1.0)
        refac = min(refac, time.perf_counter() - t0)
    budget = 1.0 / (50.0 * rate)
    print(f"floor, N = {n}, m = {m} ({8 * n * m * m / 2**20:.0f} MiB of P_B): one rank-1 update and "
          f"product per matrix {1e3 * warm:.2f} ms from cache, {1e3 * cold:.2f} ms from main memory; "
          f"refactorisation (best of 4) {1e3 * refac:.1f} ms = {1e3 * refac / period:.2f} ms per step "
          f"(every {period} steps); 50x real time allows {1e3 * budget:.2f} ms per step")


def accuracy(seeds=(0, 1)) -> None:
    for seed in seeds:
        drive = simulate_scenario("snow-slalom", seed=seed)
        t_end = float(drive.t[-1])
        for basis, mode in (("tensor:10x10", "exact"), ("tensor:10x10", "fast"), ("tensor-odd:10x10", "exact"),
                            ("separable:20", "exact"), ("separable-odd:20", "exact")):
            cfg = GPSSMConfig(basis=basis, particles=200, linalg=mode)
            t0 = time.perf_counter()
            table, cv = run_filter(drive, cfg, seed=seed, curve_times=(50.0, t_end),
                                   curve_alpha=np.radians(np.linspace(-20, 20, 161)))
            wall = time.perf_counter() - t0
            err = table["vy"].to_numpy() - drive.col("vy_true")
            print(f"seed {seed} {basis:17s} {mode:5s} vy rmse {np.sqrt(np.mean(err**2)):.3f} m/s "
                  f"(bias {err.mean():+.3f}), {wall:5.1f} s")
            for t in (50.0, t_end):
                acc = curve_accuracy(cv[t], drive, t)
                print(f"    t = {t:5.0f} s  " + "  ".join(
                    f"{ax}: MAE {v['mae']:.4f} coverage {v['coverage']:.2f} ({v['bins']} bins)"
                    for ax, v in acc.items()))


MB_VEHICLES = ("ford-escort", "vw-vanagon")


def _mb_slalom(veh: str, seed: int):
    return simulate_scenario("snow-slalom", seed=seed, engine="multibody", vehicle=veh, cache=True)


def _multibody_run(drive, filter_seed: int, options: dict):
    """A multi-body drive through the filter (``filter_seed``, N = 200, ``options``): the
    table, the honesty figures with the final curve against the truth, and the wall time
    [s]."""
    from roadgrip.estimators.gpssm.accuracy import honesty_figures

    cfg = GPSSMConfig.from_options({"particles": 200, **options})
    t0 = time.perf_counter()
    table, cv = run_filter(drive, cfg, seed=filter_seed, curve_times=(1e9,),
                           curve_alpha=np.radians(np.linspace(-20, 20, 161)))
    wall = time.perf_counter() - t0
    return table, honesty_figures(drive, table, next(iter(cv.values()))), wall


def multibody(seeds=(0, 1, 2, 3, 4), vehicles=MB_VEHICLES, options=None) -> None:
    """The acceptance figures on the multi-body snow slaloms (truth that is not the
    filter's model): per vehicle, seed and axle the curve MAE and band coverage over the
    0.5-deg bins the truth visited at least 20 times, the peak at the end (observed, value
    and band against the true peak), the largest lower bound above the true peak, the
    samples whose upper bound lies below the sustained |a_y|/g, and the lateral velocity
    (samples past 0.5 vx not flagged diverged, its std covering the error against the truth
    and the pose); then whether the seeds' final peak bands overlap."""
    from roadgrip.estimators.gpssm.accuracy import bands_overlap, honesty_figures
    from roadgrip.signals import pose_velocity

    options = dict(options or {})
    for veh in vehicles:
        bands = {"front": [], "rear": []}
        for seed in seeds:
            drive = _mb_slalom(veh, seed)
            table, h, wall = _multibody_run(drive, seed, options)
            hp = honesty_figures(drive, table, vy_ref=pose_velocity(drive)[1])
            ndiv = int(table["diverged"].sum()) if "diverged" in table else 0
            print(f"{veh} seed {seed}: vy rmse {h['vy_rmse']:.3f} m/s, vy std covers truth {h['vy_coverage']:.2f} "
                  f"pose {hp['vy_coverage']:.2f}, |vy|>0.5vx unflagged {h['vy_runaway']}, diverged {ndiv}, "
                  f"floor {h['floor']:.3f}, {wall:4.1f} s")
            for axle in ("front", "rear"):
                f = h[axle]
                bands[axle].append((f["lower"], f["upper"]))
                print(f"    {axle:5s} MAE {f['mae']:.4f} coverage {f['coverage']:.2f} ({f['bins']} bins); "
                      f"peak {'obs' if f['observed'] else 'n/o'} {f['mu']:.3f} [{f['lower']:.3f}, {f['upper']:.3f}] "
                      f"true {f['true_peak']:.3f} sat {f['saturated']}; max lower-true {f['lower_excess']:+.3f}; "
                      f"upper < floor {f['upper_below_floor']}, observed < floor {f['observed_below_floor']}")
        for axle in ("front", "rear"):
            print(f"  {veh} {axle}: final peak bands of seeds {list(seeds)} overlap pairwise: "
                  f"{bands_overlap(bands[axle])}")


def multibody_streams(offsets=(0, 1000, 2000), vehicles=MB_VEHICLES, options=None) -> None:
    """The multi-body acceptance over Monte Carlo streams: each snow slalom (seeds 0-4) run
    with filter seeds ``seed + offset`` for every offset (the drives unchanged), then one
    line: the runs whose curve MAE exceeds 0.02 or whose band coverage falls below 0.9 on
    an axle, the worst MAE and coverage, the peaks observed, and the largest lower bound
    above the true peak (at any time)."""
    options = dict(options or {})
    rows = []
    for veh in vehicles:
        for seed in range(5):
            drive = _mb_slalom(veh, seed)
            for off in offsets:
                table, h, _ = _multibody_run(drive, seed + off, options)
                f, r = h["front"], h["rear"]
                rows.append((veh, seed, off, f["mae"], f["coverage"], r["mae"], r["coverage"], h["vy_rmse"],
                             f["observed"], r["observed"], f["lower_excess"], r["lower_excess"]))
                print(f"{veh} seed {seed} filter seed {seed + off}: front MAE {f['mae']:.4f} cov {f['coverage']:.2f} "
                      f"{'obs' if f['observed'] else 'n/o'}, rear MAE {r['mae']:.4f} cov {r['coverage']:.2f} "
                      f"{'obs' if r['observed'] else 'n/o'}, vy rmse {h['vy_rmse']:.3f}, gain "
                      f"{table['ay_gain'].iloc[-1]:.3f}", flush=True)
    a = np.array([x[3:] for x in rows], float)
    miss = [f"{x[0]} {x[1]}/{x[1] + x[2]}" for x in rows if max(x[3], x[5]) > 0.02 or min(x[4], x[6]) < 0.9]
    print(f"{len(rows)} runs {options}: MAE > 0.02 or coverage < 0.9 on {len(miss)} {miss}; worst MAE front "
          f"{a[:, 0].max():.4f} rear {a[:, 2].max():.4f}; worst coverage front {a[:, 1].min():.2f} rear "
          f"{a[:, 3].min():.2f}; peaks observed front {int(a[:, 5].sum())} rear {int(a[:, 6].sum())}; largest "
          f"lower - true front {a[:, 7].max():+.3f} rear {a[:, 8].max():+.3f}; vy rmse max {a[:, 4].max():.3f}")


def realdata(seeds=(0, 1, 2)) -> None:
    """The honesty figures on every recording in ``../shared/data`` (DART, frictionmaps)
    with the data sets' presets: per file and seed the largest |vy|, the samples past
    0.5 vx not flagged, the samples flagged diverged, the vy band against the pose, the
    upper bounds and observed peaks below the floor of the filter's own a_y, the final
    peaks; then whether the seeds' final bands overlap."""
    from pathlib import Path

    from roadgrip.estimators.gpssm import drive_inputs
    from roadgrip.estimators.gpssm.accuracy import bands_overlap, honesty_figures
    from roadgrip.io import read_drive
    from roadgrip.io.presets import preset_options
    from roadgrip.signals import pose_velocity

    root = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    files = [(p, "dart") for p in sorted((root / "dart").glob("*/*.csv"))]
    files += [(p, "frictionmaps") for p in sorted((root / "frictionmaps").glob("DS*"))]
    for path, fmt in files:
        d = read_drive(path, format=fmt)
        cfg = GPSSMConfig.from_options({"particles": 200, **preset_options("gpssm", d)})
        ay = drive_inputs(d, cfg.vx_source, cfg.vy_source, cfg.ay_source)[:, 1]
        vy_ref = d.col("vy_pose") if d.has("vy_pose") else pose_velocity(d)[1] if d.has("x", "y", "psi") else None
        bands = {"front": [], "rear": []}
        for seed in seeds:
            table, _ = run_filter(d, cfg, seed=seed)
            h = honesty_figures(d, table, vy_ref=vy_ref, ay=ay)
            print(f"{path.name[:28]:28s} seed {seed}: max |vy| {table['vy'].abs().max():.2f} m/s, past 0.5 vx "
                  f"unflagged {h['vy_runaway']}, diverged {int(table['diverged'].sum())}/{len(table)}, vy band "
                  f"covers the pose's {h.get('vy_coverage', float('nan')):.2f}, floor {h['floor']:.3f}, gain "
                  f"{table['ay_gain'].iloc[-1]:.3f}; " + "; ".join(
                      f"{ax} {'obs' if h[ax]['observed'] else 'n/o'} {h[ax]['mu']:.2f} [{h[ax]['lower']:.2f}, "
                      f"{h[ax]['upper']:.2f}] upper < floor {h[ax]['upper_below_floor']}, observed < floor "
                      f"{h[ax]['observed_below_floor']}" for ax in bands))
            for ax in bands:
                bands[ax].append((h[ax]["lower"], h[ax]["upper"]))
        print(f"  final bands of seeds {list(seeds)} overlap: " + ", ".join(
            f"{ax} {bands_overlap(b)}" for ax, b in bands.items()))


def fast_vs_truth(seeds=(0, 1, 2, 3, 4), control: bool = False) -> None:
    """The fast mode judged against the truth: per seed, the exact and the fast mode's
    curve MAE and band coverage at the end (the 0.5-deg bins the truth visited 20 times),
    on the paper study (the project's snow slalom, ``tensor:10x10``, drive and filter
    seeded alike) and on the multi-body snow slaloms of both vehicles (the command's
    defaults); then, per case and axle, whether the fast mode's MAE of every seed lies
    within the exact mode's seed-to-seed range (at most its largest) and its coverage is no
    worse than the exact mode's worst seed.

    ``control``: the same criterion applied to the exact mode itself with another
    Monte Carlo stream (filter seed + 1000, the drives unchanged) in place of the fast
    mode, i.e. to an estimator with the exact mode's distribution: how often the
    criterion fails on Monte Carlo noise alone."""
    alpha = np.radians(np.linspace(-20, 20, 161))
    cases = [("paper study snow-slalom tensor:10x10", None, {"basis": "tensor:10x10"})]
    cases += [(f"multi-body snow-slalom {veh}", veh, {}) for veh in MB_VEHICLES]
    second, offset = ("exact", 1000) if control else ("fast", 0)
    name2 = "exact+1000" if control else "fast"
    for label, veh, options in cases:
        figs = {mode: {"front": [], "rear": []} for mode in ("exact", name2)}
        for seed in seeds:
            if veh is None:
                drive = simulate_scenario("snow-slalom", seed=seed)
            else:
                drive = _mb_slalom(veh, seed)
            line = []
            for mode, linalg, fseed in (("exact", "exact", seed), (name2, second, seed + offset)):
                cfg = GPSSMConfig.from_options({"particles": 200, "linalg": linalg, **options})
                t0 = time.perf_counter()
                _, cv = run_filter(drive, cfg, seed=fseed, curve_times=(1e9,), curve_alpha=alpha)
                wall = time.perf_counter() - t0
                acc = curve_accuracy(next(iter(cv.values())), drive)
                for axle in ("front", "rear"):
                    figs[mode][axle].append((acc[axle]["mae"], acc[axle]["coverage"]))
                line.append(f"{mode} " + " ".join(
                    f"{axle} MAE {acc[axle]['mae']:.4f} cov {acc[axle]['coverage']:.2f}" for axle in ("front", "rear"))
                    + f" ({wall:.0f} s)")
            print(f"{label} seed {seed}: " + "; ".join(line), flush=True)
        for axle in ("front", "rear"):
            ex = np.array(figs["exact"][axle])
            fa = np.array(figs[name2][axle])
            within = bool(fa[:, 0].max() <= ex[:, 0].max())
            cover = bool(fa[:, 1].min() >= ex[:, 1].min())
            print(f"  {label} {axle}: exact MAE {ex[:, 0].min():.4f}-{ex[:, 0].max():.4f}, coverage worst "
                  f"{ex[:, 1].min():.2f}; {name2} MAE {fa[:, 0].min():.4f}-{fa[:, 0].max():.4f}, coverage worst "
                  f"{fa[:, 1].min():.2f}: MAE within the exact range {within}, coverage no worse {cover}",
                  flush=True)


@numba.njit
def _repeat_pass(k, p, lin, wk, blk, cst, basis, scal):  # pragma: no cover - compiled
    """The particle pass of the block's first sample ``k`` times (as block._step calls it);
    ``scal`` = (nu, p_scale, c)."""
    N, G, _, m = p.Psi.shape
    for _ in range(k):
        par = 0
        pdst, order = slot_plan(lin.panc)
        gk.particle_pass(
            p,
            gk.Slots(lin.pinv.reshape(N * G, m, m), lin.panc, pdst, order, lin.pend2[par], lin.pgain2[par],
                     lin.pend2[1 - par], lin.pgain2[1 - par], lin.hist, 0),
            gk.StepInput(True, 0.04, blk.steer[0], blk.vx[0], blk.steer[0], blk.vx[0], blk.ay[0],
                         blk.yaw_rate[0], False, 0.0, True),
            cst.veh,
            gk.Params(cst.mf, cst.lam, scal[0], cst.Lambda0, cst.sigma_ay, cst.sigma_r, -1.0, scal[1],
                      0.0 if cst.carry else 1.0 - scal[2], cst.tol, cst.max_terms, cst.conditional, cst.carry,
                      cst.gain_gate),
            basis,
            gk.PeakColumns(wk.fpk, lin.pkw2[par], lin.pkw2[1 - par], wk.fresh),
            gk.Draws(wk.gdraw, wk.zdraw, wk.gwalk),
            gk.Outputs(wk.alpha, wk.M, wk.Lam, wk.vpk, wk.munow, wk.e),
        )


@numba.njit
def _repeat_peak(k, post, pg, a_vis, prm, out):  # pragma: no cover - compiled
    for _ in range(k):
        peak_summary(post, pg, a_vis, prm, out)


@numba.njit
def _repeat_draws(k, rng, gdraw, zdraw, dof):  # pragma: no cover - compiled
    N, G = gdraw.shape
    for _ in range(k):
        for n in range(N):
            for g in range(G):
                gdraw[n, g] = rng.chisquare(dof)
        for n in range(N):
            for j in range(2):
                zdraw[n, 0, j] = rng.standard_normal()


def parts(steps: int = 1500) -> None:
    """Where the time of a compiled step goes, ms per step (N = 200): the whole step (a run
    over ``steps`` samples in blocks), and on the state at its end the particle pass (its
    cost per call, with the exact mode's Neumann series at a mid-period prior weight), the
    peak summary, the draws of the conditional proposal, resampling (one per step; the
    run's rate is printed) and the refactorisation spread over its period."""
    from roadgrip.estimators.gpssm import block as bk
    from roadgrip.estimators.gpssm.compiled import _consts, _pair, _work, advance, sample_array
    from roadgrip.estimators.gpssm.inputs import drive_inputs
    from roadgrip.estimators.gpssm.kernel_ops import PeakGrid, PeakParams, PeakPosterior
    from roadgrip.estimators.gpssm.state import Context

    drive = simulate_scenario("snow-slalom", seed=0)
    d = drive.slice_time(drive.t[0], drive.t[0] + steps / 25.0 - 1e-9)
    data = sample_array([(*r, 1.0) for r in drive_inputs(d)])
    print(f"{'basis':17s} {'mode':5s} {'step':>6s} {'pass':>6s} {'peak':>6s} {'draws':>6s} {'resmp':>6s} "
          f"{'refac':>6s} {'rest':>6s}  [ms per step; resampling rate]")
    for basis, mode in (("separable:10", "exact"), ("separable:10", "fast"), ("separable-odd:20", "exact"),
                        ("tensor:10x10", "exact"), ("tensor:10x10", "fast")):
        cfg = GPSSMConfig(basis=basis, particles=200, linalg=mode)
        k = steps if "separable" in basis else steps // 3
        ctx = Context(cfg, d.vehicle)
        advance(ctx, None, data[:10])
        ctx = Context(cfg, d.vehicle)
        t0 = time.perf_counter()
        state, out = advance(ctx, None, data[:k])
        whole = (time.perf_counter() - t0) / k
        rate = float(out[:, bk.OUT.RESAMPLED].mean())
        cst, btab, tables = _consts(ctx)
        wk = _work(ctx)
        if mode == "fast":
            wk = wk._replace(M=state.M, Lam=state.Lam)
        lin = state.lin
        la.settle(lin)
        pend2, _ = _pair(lin.pend, lin.pend.shape)
        pgain2, _ = _pair(lin.pgain, lin.pgain.shape)
        pkw2, _ = _pair(lin.pkw, lin.pkw.shape)
        lb = bk.LinBuffers(None, lin.pinv, lin.hist, lin.hcoef, lin.hanc, pend2, pgain2, lin.panc.copy(),
                           lin.sanc, pkw2, lin.pkf)
        blk = bk.Block(*(data[k - 1:k, j] for j in range(6)), data[k - 1:k, 7] != 0, np.full(1, ctx.veh.fz_front),
                       np.full(1, ctx.veh.fz_rear))
        p = gk.Particles(state.x.copy(), state.mu.copy(), state.logw.copy(), state.Psi.copy(), state.Phi.copy())
        reps = 200 if "separable" in basis else 40
        scal = (state.nu, lin.p_scale, lin.c)
        _repeat_pass(1, p, lb._replace(sigma2=np.zeros(1)), wk, blk, cst, btab, scal)
        t0 = time.perf_counter()
        _repeat_pass(reps, p, lb._replace(sigma2=np.zeros(1)), wk, blk, cst, btab, scal)
        t_pass = (time.perf_counter() - t0) / reps
        post = PeakPosterior(wk.M, wk.Lam, state.logw, wk.vpk)
        pg = PeakGrid(wk.feats, tables.prior, tables.grid, tables.where, tables.col)
        prm = PeakParams(10.0, cfg.peak_margin, 1.96, 1e-4, 2.0, 0.05)
        a_vis = np.radians([3.0, 3.0])
        pk = np.zeros((2, 7))
        _repeat_peak(1, post, pg, a_vis, prm, pk)
        t0 = time.perf_counter()
        _repeat_peak(reps * 5, post, pg, a_vis, prm, pk)
        t_peak = (time.perf_counter() - t0) / (reps * 5)
        rng = np.random.default_rng(0)
        _repeat_draws(1, rng, wk.gdraw, wk.zdraw, 50.0)
        t0 = time.perf_counter()
        _repeat_draws(reps * 5, rng, wk.gdraw, wk.zdraw, 50.0)
        t_draw = (time.perf_counter() - t0) / (reps * 5)
        from roadgrip.estimators.gpssm.block_ops import _resample
        sc = np.zeros(bk.SC.SIZE)
        _resample(p, lb, wk, sc, rng, mode == "fast")
        t0 = time.perf_counter()
        for _ in range(reps):
            _resample(p, lb, wk, sc, rng, mode == "fast")
        t_res = (time.perf_counter() - t0) / reps
        st = la.init(mode, 200, cfg.basis.groups, cfg.basis.m, history=80)
        st.hist[:] = np.random.default_rng(0).standard_normal(st.hist.shape) * 0.3
        st.hcoef[:] = 1.0
        st = la.refactor(st._replace(nhist=80), 1.0)
        t0 = time.perf_counter()
        la.refactor(st._replace(nhist=80), 1.0)
        t_ref = (time.perf_counter() - t0) / 80
        rest = whole - t_pass - t_peak - t_draw - rate * t_res - t_ref
        print(f"{basis:17s} {mode:5s} " + " ".join(f"{1e3 * v:6.3f}" for v in (
            whole, t_pass, t_peak, t_draw, rate * t_res, t_ref, rest)) + f"  {rate:.2f}", flush=True)


def many(n_drives: int = 10, duration: float = 60.0) -> None:
    """Throughput of :func:`~roadgrip.estimators.gpssm.run_many` over ``n_drives`` drives
    (snow-slalom seeds 0..n-1, ``duration`` s each, the command's defaults with N = 200)
    against the same runs one after another in this process, with the load average
    before and after (the figure means something only on a quiet machine), and whether
    every table equals its sequential run."""
    from roadgrip.estimators.gpssm import run, run_many

    drives = [simulate_scenario("snow-slalom", seed=s, duration=duration) for s in range(n_drives)]
    cfg = GPSSMConfig(particles=200)
    seeds = list(range(n_drives))
    run(drives[0].slice_time(0.0, 1.0), cfg)
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    alone = [run(d, cfg, seed=s) for d, s in zip(drives, seeds, strict=True)]
    t_seq = time.perf_counter() - t0
    t0 = time.perf_counter()
    together = run_many(drives, cfg, seeds)
    t_par = time.perf_counter() - t0
    load1 = os.getloadavg()
    same = all(a.table.equals(b.table) for a, b in zip(alone, together, strict=True))
    steps = sum(d.n for d in drives)
    print(f"{n_drives} drives of {duration:.0f} s ({steps} steps), {os.cpu_count()} cores, load average "
          f"{load0[0]:.2f} before, {load1[0]:.2f} after: one after another {t_seq:.1f} s ({steps / t_seq:.0f} "
          f"steps/s), run_many {t_par:.1f} s ({steps / t_par:.0f} steps/s): x{t_seq / t_par:.2f}; tables equal {same}")


@numba.njit(fastmath=True)
def _product_particle_major(P, R, X, reps):  # pragma: no cover - compiled
    """``X[n, r] = P[n] R[n, r]`` (two right-hand sides), each particle's matrix contiguous."""
    N, m, _ = P.shape
    for _ in range(reps):
        for n in range(N):
            for i in range(m):
                a0 = 0.0
                a1 = 0.0
                for j in range(m):
                    p = P[n, i, j]
                    a0 += p * R[n, 0, j]
                    a1 += p * R[n, 1, j]
                X[n, 0, i] = a0
                X[n, 1, i] = a1


@numba.njit(fastmath=True)
def _product_particles_innermost(P, R, X, reps):  # pragma: no cover - compiled
    """The same product with the particle index innermost (``P`` (m, m, N))."""
    m, _, N = P.shape
    for _ in range(reps):
        for i in range(m):
            for n in range(N):
                X[0, i, n] = 0.0
                X[1, i, n] = 0.0
            for j in range(m):
                for n in range(N):
                    p = P[i, j, n]
                    X[0, i, n] += p * R[0, j, n]
                    X[1, i, n] += p * R[1, j, n]


@numba.njit(fastmath=True)
def _neumann_sweep(P, R, X, pb, cur, nxt, delta, reps, terms):  # pragma: no cover - compiled
    """The exact mode's solve on every matrix with ``terms`` terms of the series."""
    for _ in range(reps):
        for b in range(P.shape[0]):
            neumann_solve(P[b], 1.0, delta, R[b], 2, 2, 0.0, terms, X[b], pb[b], cur, nxt)


def layout() -> None:
    """The particles-innermost layout measured against the present one on the product at
    the heart of the pass (N = 200, two right-hand sides, best of 5), and the cost of a
    term of the exact mode's Neumann series on 400 matrices of 10 x 10 (m = 20 separable)."""
    rng = np.random.default_rng(0)
    for m in (10, 20, 50):
        P = rng.standard_normal((200, m, m))
        R = rng.standard_normal((200, 2, m))
        X = np.zeros((200, 2, m))
        Pt, Rt = np.ascontiguousarray(P.transpose(1, 2, 0)), np.ascontiguousarray(R.transpose(1, 2, 0))
        Xt = np.zeros((2, m, 200))
        best = []
        for f, args in ((_product_particle_major, (P, R, X)), (_product_particles_innermost, (Pt, Rt, Xt))):
            f(*args, 1)
            b = np.inf
            for _ in range(5):
                t0 = time.perf_counter()
                f(*args, 500)
                b = min(b, (time.perf_counter() - t0) / 500)
            best.append(b)
        assert np.allclose(X, Xt.transpose(2, 0, 1))
        print(f"m = {m:3d}: product over N = 200, particle-major {1e6 * best[0]:6.1f} us, particles innermost "
              f"{1e6 * best[1]:6.1f} us (x{best[0] / best[1]:.2f})")
    A = rng.standard_normal((400, 10, 30))
    P = np.linalg.inv(A @ A.transpose(0, 2, 1) * 0.01 + np.eye(10))
    R = rng.standard_normal((400, 2, 10))
    X, pb, cur, nxt = np.zeros((400, 2, 10)), np.zeros((400, 10)), np.zeros((2, 10)), np.zeros((2, 10))
    times = []
    for terms in (0, 6):
        _neumann_sweep(P, R, X, pb, cur, nxt, 0.004, 1, terms)
        b = np.inf
        for _ in range(5):
            t0 = time.perf_counter()
            _neumann_sweep(P, R, X, pb, cur, nxt, 0.004, 100, terms)
            b = min(b, (time.perf_counter() - t0) / 100)
        times.append(b)
    print(f"exact solve of 400 matrices 10 x 10, two right-hand sides: the first product {1e3 * times[0]:.3f} ms, "
          f"each further term of the series {1e3 * (times[1] - times[0]) / 6:.3f} ms")


SPEED_CASES = (
    ("m = 20 (separable:10)", "separable:10", "exact", 2000),
    ("m = 20 (separable:10)", "separable:10", "fast", 2000),
    ("default (separable-odd:20, m = 2 x 20)", "separable-odd:20", "exact", 2000),
    ("m = 100 (tensor:10x10)", "tensor:10x10", "exact", 600),
    ("m = 100 (tensor:10x10)", "tensor:10x10", "fast", 600),
)
"""The speed table: label, basis, mode and steps (N = 200, snow-slalom from its start)."""


def speed_once(drive) -> list[float]:
    """Steps per second of every case of :data:`SPEED_CASES`, once."""
    out = []
    for _, basis, mode, steps in SPEED_CASES:
        d, _, _, wall = timed_run(drive, basis, 200, mode, steps)
        out.append(d.n / wall)
    return out


def _baseline_once(src: str) -> list[float]:
    """:func:`speed_once` of the package in ``src`` (another version's ``src`` tree), in a
    subprocess."""
    import json
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=src, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    res = subprocess.run([sys.executable, __file__, "--speed-json"], env=env, capture_output=True, text=True,
                         check=True, cwd="/")
    return json.loads(res.stdout.strip().splitlines()[-1])


def speed(reps: int, baseline: str | None) -> None:
    """The median of ``reps`` runs of every case of :data:`SPEED_CASES`, beside the same
    cases of the version ``baseline`` (a git revision) measured in the same run, the two
    alternating (this machine's speed drifts with its host and the other jobs on it)."""
    import subprocess
    import tempfile

    drive = simulate_scenario("snow-slalom", seed=0)
    src = None
    if baseline is not None:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        tmp = tempfile.mkdtemp(prefix="gpssm-baseline-")
        archive = subprocess.run(["git", "-C", root, "archive", baseline, "src"], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
        src = os.path.join(tmp, "src")
        _baseline_once(src)  # compiles the baseline's kernels into its own cache
    speed_once(drive.slice_time(drive.t[0], drive.t[0] + 2.0))
    now, before = [], []
    for _ in range(reps):
        now.append(speed_once(drive))
        if src is not None:
            before.append(_baseline_once(src))
    load = os.getloadavg()
    print(f"N = 200, snow-slalom, median of {reps} runs, load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}")
    print(f"{'case':42s} {'mode':5s} {'steps/s':>9s}" + (f" {baseline:>12s} {'ratio':>6s}" if src else ""))
    for k, (label, _, mode, _) in enumerate(SPEED_CASES):
        a = float(np.median([r[k] for r in now]))
        line = f"{label:42s} {mode:5s} {a:9.0f}"
        if src is not None:
            b = float(np.median([r[k] for r in before]))
            line += f" {b:12.0f} {a / b:6.2f}"
        print(line, flush=True)


def refactor_latency(duration: float = 30.0) -> None:
    """The refactorisation's share of the latency (issue 30), the defaults (N = 200, 20 odd
    functions per axle, 'exact', ``refactor_every`` 80) on the dry-gravel-dry drive at 100 Hz
    stepped one sample per call: the thread CPU time of a step [ms] by its place in the
    period (the refactorisation's step, the steps that fold ``FOLD_ROWS`` buffered rows or
    the rows a step before it, the others), and the pieces on a state like the filter's
    (random rows, scattered ancestors): the fold of ``FOLD_ROWS`` rows, the inversion alone
    (no buffered row) and a refactorisation that folds a whole period's rows (as before
    the fold was spread)."""
    from roadgrip.blas_threads import one_blas_thread
    from roadgrip.estimators.gpssm.compiled import advance, sample_array
    from roadgrip.estimators.gpssm.inputs import drive_inputs
    from roadgrip.estimators.gpssm.state import Context

    cfg = GPSSMConfig()
    J = cfg.refactor_every
    drive = simulate_scenario("dry-gravel-dry", seed=0, duration=duration)
    data = sample_array([(*r, 1.0) for r in drive_inputs(drive)])
    advance(Context(cfg, drive.vehicle), None, data[:3])  # compiled before timing
    ctx = Context(cfg, drive.vehicle)
    state, cpu, since, folded = None, [], [], []
    with one_blas_thread():
        for k in range(len(data)):
            nh = 0 if state is None else state.lin.nhist
            t0 = time.thread_time_ns()
            state, _ = advance(ctx, state, data[k:k + 1])
            cpu.append(1e-6 * (time.thread_time_ns() - t0))
            since.append(state.lin.since_refactor)
            folded.append(state.lin.nhist <= nh and state.lin.since_refactor != 0)
    warm = 100
    cpu, since, folded = np.array(cpu[warm:]), np.array(since[warm:]), np.array(folded[warm:])
    ref = since == 0
    other = ~ref & ~folded
    print(f"defaults, dry-gravel-dry {duration:g} s at 100 Hz, one sample per call: thread CPU per step [ms]")
    print(f"  all steps ({len(cpu)}): p50 {np.median(cpu):.3f}  p99 {np.percentile(cpu, 99):.3f}  "
          f"max {cpu.max():.3f}")
    for name, sel in (("refactorisation", ref), ("fold", folded), ("other", other)):
        print(f"  {name:16s} ({sel.sum():5d} = {100 * sel.mean():4.1f} %): median {np.median(cpu[sel]):.3f}  "
              f"p90 {np.percentile(cpu[sel], 90):.3f}")
    N, G, m = cfg.particles, cfg.basis.groups, cfg.basis.m
    rng = np.random.default_rng(0)
    st = la.init("exact", N, G, m, history=J)
    st.hist[:] = rng.standard_normal(st.hist.shape) * 0.3
    st.hcoef[:] = 1.0
    st.hanc[:] = rng.integers(0, N, (J, N))
    st.sanc[:] = rng.integers(0, N, N)
    out, pinv = np.empty_like(st.sigma), np.empty_like(st.sigma)

    def best(f, reps=30):
        f()
        ts = []
        for _ in range(reps):
            t0 = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t0)
        return 1e3 * float(np.median(ts))

    fold = best(lambda: la._fold(st.sigma, out, st.sanc, st.hist, st.hanc, st.hcoef, la.FOLD_ROWS))
    inv = best(lambda: la._rebuild(st.sigma, st.sanc, st.hist, st.hanc, st.hcoef, 1, 1.0, 1.01, out, pinv))
    whole = best(lambda: la._rebuild(st.sigma, st.sanc, st.hist, st.hanc, st.hcoef, J, 1.0, 1.01, out, pinv))
    print(f"  pieces (median of 30, warm cache) [ms]: fold of {la.FOLD_ROWS} rows {fold:.3f}; refactorisation "
          f"after the fold (one row) {inv:.3f}; refactorisation folding all {J} rows {whole:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="shorter drives and fewer points")
    ap.add_argument("--accuracy", action="store_true", help="acceptance figures instead")
    ap.add_argument("--multibody", action="store_true",
                    help="with --accuracy: the multi-body snow slaloms (both vehicles, seeds 0-4 by default)")
    ap.add_argument("--realdata", action="store_true",
                    help="with --accuracy: every recording in ../shared/data (seeds 0,1,2 by default)")
    ap.add_argument("--speed", action="store_true", help="the speed table (median of --reps runs)")
    ap.add_argument("--parts", action="store_true", help="where the time of a compiled step goes")
    ap.add_argument("--refactor", action="store_true",
                    help="the refactorisation's share of the latency: CPU per step by its place in the period")
    ap.add_argument("--layout", action="store_true", help="particles-innermost layout against the present one")
    ap.add_argument("--many", action="store_true", help="run_many over 10 drives against one after another")
    ap.add_argument("--reps", type=int, default=5, help="runs of --speed")
    ap.add_argument("--baseline", default=None, help="with --speed: a git revision measured beside, e.g. HEAD~3")
    ap.add_argument("--speed-json", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--fast-vs-truth", action="store_true",
                    help="with --accuracy: the fast and exact modes against the truth, seeds 0-4")
    ap.add_argument("--streams", default=None,
                    help="with --accuracy --multibody: filter-seed offsets, e.g. 0,1000,2000 (Monte Carlo streams)")
    ap.add_argument("--control", action="store_true",
                    help="with --fast-vs-truth: the exact mode with another Monte Carlo stream in place of the fast mode")
    ap.add_argument("--option", action="append", default=[], help="KEY=VALUE filter option (--multibody)")
    ap.add_argument("--seeds", default=None, help="drives and filter seeds of --accuracy (e.g. 0,1,2,3,4)")
    args = ap.parse_args()
    if args.speed_json:
        import json

        drive = simulate_scenario("snow-slalom", seed=0)
        speed_once(drive.slice_time(drive.t[0], drive.t[0] + 2.0))
        print(json.dumps(speed_once(drive)))
        return
    if args.speed:
        speed(args.reps, args.baseline)
        return
    if args.parts:
        parts()
        return
    if args.refactor:
        refactor_latency()
        return
    if args.many:
        many()
        return
    if args.layout:
        layout()
        return
    if args.accuracy and args.realdata:
        realdata(tuple(int(v) for v in (args.seeds or "0,1,2").split(",")))
        return
    if args.accuracy and args.fast_vs_truth:
        fast_vs_truth(tuple(int(v) for v in (args.seeds or "0,1,2,3,4").split(",")), control=args.control)
        return
    if args.accuracy and args.multibody:
        seeds = tuple(int(v) for v in (args.seeds or "0,1,2,3,4").split(","))
        opts = {}
        for kv in args.option:
            k, v = kv.split("=", 1)
            try:
                opts[k] = float(v) if "." in v or "e" in v else int(v)
            except ValueError:
                opts[k] = v
        if args.streams:
            multibody_streams(tuple(int(v) for v in args.streams.split(",")), options=opts)
        else:
            multibody(seeds, options=opts)
        return
    if args.accuracy:
        accuracy(tuple(int(v) for v in (args.seeds or "0,1").split(",")))
        return
    drive = simulate_scenario("snow-slalom", seed=0)
    print(f"snow-slalom: {drive.n} steps, {drive.duration:.0f} s at {drive.meta.sample_rate:.0f} Hz")

    print("\n== paper settings: N = 200, tensor:10x10 (m = 100) ==")
    steps = 1000 if args.quick else None
    res = {}
    for mode in ("exact", "fast"):
        # timed without tracing (tracemalloc slows every allocation), memory in its own run
        d, table, cv, wall = timed_run(drive, "tensor:10x10", 200, mode, steps, curves=(1e9,))
        tracemalloc.start()
        timed_run(drive, "tensor:10x10", 200, mode, 300, curves=(1e9,))
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        res[mode] = (d, table, cv, wall)
        print(f"{mode:6s}: {d.n} steps in {wall:6.1f} s = {d.n / wall:6.0f} steps/s, "
              f"{d.duration / wall:5.1f}x real time, peak traced memory {peak / 2**20:.0f} MiB "
              "(300-step run)")
    print(f"process max RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")
    d = res["exact"][0]
    ce = next(iter(res["exact"][2].values()))
    cf = next(iter(res["fast"][2].values()))
    acc = curve_accuracy(ce, d)
    diff = curve_difference(ce, cf, acc)
    print(f"fast vs exact (same seed): |posterior mean difference| over the visited range, largest / mean: "
          f"front {diff[0][0]:.4f} / {diff[0][1]:.4f}, rear {diff[1][0]:.4f} / {diff[1][1]:.4f}")
    te, tf = res["exact"][1], res["fast"][1]
    same = te["resampled"].to_numpy() == tf["resampled"].to_numpy()
    first = int(np.argmin(same)) if not same.all() else None
    print(f"  the two particle systems first resample differently at step {first} "
          "(the fast mode's prior weight c differs from 1 by up to 0.8 %, which moves the "
          "weights; the paths are independent after that)")
    # Monte Carlo reference: the same exact filter with another seed
    cfg1 = GPSSMConfig(basis="tensor:10x10", particles=200, linalg="exact")
    _, cv1 = run_filter(d, cfg1, seed=1, curve_times=(1e9,),
                        curve_alpha=np.radians(np.linspace(-20, 20, 161)))
    c1 = next(iter(cv1.values()))
    mc = curve_difference(ce, c1, acc)
    print(f"exact seed 0 vs exact seed 1 (Monte Carlo spread), largest / mean: "
          f"front {mc[0][0]:.4f} / {mc[0][1]:.4f}, rear {mc[1][0]:.4f} / {mc[1][1]:.4f}")
    # path sensitivity: the same exact filter, seed and drive, with sigma_ay changed in its
    # 9th / 6th digit; the resampling decisions part after a few hundred steps
    for eps in (1e-9, 1e-6):
        _, tp, cvp, _ = timed_run(drive, "tensor:10x10", 200, "exact", steps, curves=(1e9,),
                                  sigma_ay=GPSSMConfig.sigma_ay * (1.0 + eps))
        sp = curve_difference(ce, next(iter(cvp.values())), acc)
        same = te["resampled"].to_numpy() == tp["resampled"].to_numpy()
        first = int(np.argmin(same)) if not same.all() else None
        print(f"exact vs exact with sigma_ay x (1 + {eps:g}) (path sensitivity), largest / mean: "
              f"front {sp[0][0]:.4f} / {sp[0][1]:.4f}, rear {sp[1][0]:.4f} / {sp[1][1]:.4f}; "
              f"first differing resample at step {first}")
    memory_floor(200, 100, 80, d.meta.sample_rate)
    n_direct = 150 if args.quick else 400
    _, _, _, w_dir = timed_run(drive, "tensor:10x10", 200, "direct", n_direct)
    _, _, _, w_ex = timed_run(drive, "tensor:10x10", 200, "exact", n_direct)
    _, _, _, w_fa = timed_run(drive, "tensor:10x10", 200, "fast", n_direct)
    print(f"side by side on {n_direct} steps: direct per-particle solve {n_direct / w_dir:.0f} steps/s, "
          f"exact {n_direct / w_ex:.0f} steps/s (x{w_dir / w_ex:.1f}), "
          f"fast {n_direct / w_fa:.0f} steps/s (x{w_dir / w_fa:.1f})")

    print("\n== N = 200, m = 20 (separable:10) ==")
    for mode in ("exact", "fast"):
        d, _, _, wall = timed_run(drive, "separable:10", 200, mode, 600 if args.quick else 2000)
        print(f"{mode:6s}: {d.n / wall:.0f} steps/s")

    print("\n== time per step [ms] against N (separable:10, m = 20) ==")
    ns = (50, 200, 1000) if args.quick else (50, 100, 200, 500, 1000, 2000)
    print("   N   exact    fast")
    for n in ns:
        row = []
        for mode in ("exact", "fast"):
            k = max(60, int(20000 / n))
            d, _, _, wall = timed_run(drive, "separable:10", n, mode, k)
            row.append(1e3 * wall / d.n)
        print(f"{n:4d} {row[0]:7.2f} {row[1]:7.2f}")

    print("\n== time per step [ms] against m (N = 200) ==")
    bases = (("separable:10", 20), ("tensor:10x10", 100), ("separable:100", 200)) if args.quick else (
        ("separable:10", 20), ("separable:25", 50), ("tensor:10x10", 100), ("separable:50", 100),
        ("separable:100", 200), ("tensor:20x20", 400), ("separable:200", 400))
    print("   m  basis             exact    fast")
    for basis, m in bases:
        row = []
        for mode in ("exact", "fast"):
            k = 60 if m >= 200 else 150
            d, _, _, wall = timed_run(drive, basis, 200, mode, k)
            row.append(1e3 * wall / d.n)
        print(f"{m:4d}  {basis:15s} {row[0]:7.2f} {row[1]:7.2f}")


if __name__ == "__main__":
    main()
