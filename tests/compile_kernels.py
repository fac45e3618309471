"""Compile the package's numba kernels into their on-disk cache, once, in one process.

Every kernel is compiled with ``cache=True``; on a fresh clone each pytest-xdist
worker would otherwise compile the same kernels itself. ``make test`` runs this
script first: it simulates every scenario briefly on each of its engines, runs
every estimator in batch over those drives and by stepping over one (each GP-SSM
basis and linear-algebra backend on one drive), and fuses a friction grid, so the workers then load
the compiled code from ``__pycache__``. A failure here is reported and skipped:
the tests report real problems.

The work is split over two processes (the GP-SSM, the other estimators; both
simulate the drives) where two cores are available.

Usage: ``python tests/compile_kernels.py [--jobs N] [--methods gpssm,brls,...]``
"""

from __future__ import annotations

import argparse
import itertools
import os
import subprocess
import sys
import time
import traceback

VERBOSE = bool(os.environ.get("ROADGRIP_KERNELS_VERBOSE"))

DURATION_S = 10.0
"""Simulated time per drive [s]: long enough to excite every branch of the filters."""

GPSSM_OPTIONS = [
    {"particles": 8, "basis": basis, "linalg": linalg, "curve_times": (2.0,)}
    for basis, linalg in itertools.product(("tensor:10x10", "separable:20", "separable-odd:20"),
                                           ("exact", "fast"))
]
STEPS = 250
"""Samples run by stepping (the per-step kernels; the GP-SSM's buffered updates fold after 64)."""


def _try(label: str, fn, failures: list[str]):
    t0 = time.perf_counter()
    try:
        return fn()
    except Exception as exc:  # reported, never fatal
        failures.append(f"{label}: {type(exc).__name__}: {exc}")
        traceback.print_exc(limit=1)
        return None
    finally:
        if VERBOSE and time.perf_counter() - t0 > 0.5:
            print(f"{time.perf_counter() - t0:6.1f} s  {label}")


def _step(est, drive, config) -> None:
    prepared = est.prepare(drive, config)
    state = est.init(prepared.info, config, 0)
    for _, sample in zip(range(STEPS), prepared.samples, strict=False):
        state, _ = est.step(state, sample)


PARTS = ((("gpssm",), True), (("brls", "slipmap", "cascade"), False))
"""Methods compiled by each process when two run in parallel, and whether it simulates the
multi-body drives too (their columns and types are those of the single-track drives, so one
process compiling the multi-body engine is enough)."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--methods", help="comma-separated methods (default: every registered one)")
    ap.add_argument("--single-track", action="store_true", help="leave out the multi-body drives")
    args = ap.parse_args(argv)
    if args.jobs > 1 and args.methods is None:
        procs = [subprocess.Popen([sys.executable, __file__, "--jobs", "1", "--methods", ",".join(part),
                                   *([] if multibody else ["--single-track"])])
                 for part, multibody in PARTS]
        return max(p.wait() for p in procs)
    return compile_kernels(args.methods.split(",") if args.methods else None,
                           multibody=not args.single_track)


def compile_kernels(methods: list[str] | None = None, multibody: bool = True) -> int:
    """Simulate the drives and run ``methods`` (default: all) over them; 0 (failures are listed)."""
    from roadgrip import estimators
    from roadgrip.sim.scenarios import SCENARIOS, simulate_scenario

    t0 = time.perf_counter()
    failures: list[str] = []
    drives = {}
    for name, sc in SCENARIOS.items():
        for engine in sc.engines:
            if engine == "multibody" and not multibody:
                continue
            d = _try(f"simulate {name} ({engine})",
                     lambda name=name, engine=engine: simulate_scenario(
                         name, seed=0, engine=engine, duration=DURATION_S), failures)
            if d is not None:
                drives[f"{name}/{engine}"] = d
    t_sim = time.perf_counter() - t0
    for method in methods or list(estimators.METHODS):
        est = _try(f"import {method}", lambda method=method: estimators.get(method), failures)
        if est is None:
            continue
        # The defaults on every drive (input-dependent paths), the GP-SSM variants on the first;
        # stepping (the per-step kernels) on the first drive.
        option_sets = [{"particles": 8}, *GPSSM_OPTIONS] if method == "gpssm" else [{}]
        for k, options in enumerate(option_sets):
            config = _try(f"{method} {options}", lambda est=est, o=options: est.Config.from_options(o),
                          failures)
            if config is None:
                continue
            for i, (label, d) in enumerate(drives.items()):
                if k > 0 and i > 0:
                    break
                res = _try(f"{method} on {label}", lambda est=est, c=config, d=d: est.run(d, c, 0),
                           failures)
                if i == 0:
                    _try(f"{method} stepping on {label}", lambda est=est, c=config, d=d: _step(est, d, c),
                         failures)
                if method == "brls" and k == 0 and label == "dry-gravel-dry/planar":
                    from roadgrip.estimators.classify import calibrate

                    half = d.t[0] + 0.5 * d.duration
                    _try("calibrate on dry-gravel-dry", lambda d=d, half=half: calibrate(
                        [(d.slice_time(d.t[0], half), "high"), (d.slice_time(half, d.t[-1]), "low")],
                        friction={"high": 1.0, "low": 0.6}, model="stiffness"), failures)
                if method == "cascade" and res is not None:
                    from roadgrip.mapping import grid_from_estimates

                    _try(f"friction grid on {label}",
                         lambda res=res: grid_from_estimates(res.table, cell=0.5), failures)
    print(f"compiled kernels of {', '.join(methods or estimators.METHODS)}: {len(drives)} drives "
          f"simulated in {t_sim:.0f} s, "
          f"estimators in {time.perf_counter() - t0 - t_sim:.0f} s; {len(failures)} step(s) failed")
    for f in failures:
        print(f"  skipped: {f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
