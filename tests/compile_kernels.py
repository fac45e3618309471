"""Compile the package's numba kernels into their on-disk cache, once, in one process.

Every kernel is compiled with ``cache=True``; on a fresh clone each pytest-xdist
worker would otherwise compile the same kernels itself. ``make test`` runs this
script first: it simulates every scenario briefly on each of its engines, runs
every estimator in batch over those drives and by stepping over one (each GP-SSM
basis and linear-algebra backend on one drive), and fuses a friction grid, so the workers then load
the compiled code from ``__pycache__``. A failure here is reported and skipped:
the tests report real problems.

Usage: ``python tests/compile_kernels.py``
"""

from __future__ import annotations

import itertools
import os
import time
import traceback

VERBOSE = bool(os.environ.get("ROADGRIP_KERNELS_VERBOSE"))

DURATION_S = 6.0
"""Simulated time per drive [s]: long enough to excite every branch of the filters."""

GPSSM_OPTIONS = [
    {"particles": 8, "basis": basis, "linalg": linalg, "curve_times": (2.0,)}
    for basis, linalg in itertools.product(("tensor:10x10", "separable:20", "separable-odd:20"),
                                           ("exact", "fast"))
]
STEPS = 80
"""Samples run by stepping (the per-step kernels) on each drive."""


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


def main() -> int:
    from roadgrip import estimators
    from roadgrip.sim.scenarios import SCENARIOS, simulate_scenario

    t0 = time.perf_counter()
    failures: list[str] = []
    drives = {}
    for name, sc in SCENARIOS.items():
        for engine in sc.engines:
            d = _try(f"simulate {name} ({engine})",
                     lambda name=name, engine=engine: simulate_scenario(
                         name, seed=0, engine=engine, duration=DURATION_S), failures)
            if d is not None:
                drives[f"{name}/{engine}"] = d
    t_sim = time.perf_counter() - t0
    for method in estimators.METHODS:
        est = _try(f"import {method}", lambda method=method: estimators.get(method), failures)
        if est is None:
            continue
        # The defaults on every drive (input-dependent paths), the GP-SSM variants on the first;
        # stepping (the per-step kernels) on the first drive.
        option_sets = [{}, *(GPSSM_OPTIONS if method == "gpssm" else [])]
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
                if method == "cascade" and res is not None:
                    from roadgrip.mapping import grid_from_estimates

                    _try(f"friction grid on {label}",
                         lambda res=res: grid_from_estimates(res.table, cell=0.5), failures)
    print(f"compiled kernels: {len(drives)} drives simulated in {t_sim:.0f} s, "
          f"estimators in {time.perf_counter() - t0 - t_sim:.0f} s; {len(failures)} step(s) failed")
    for f in failures:
        print(f"  skipped: {f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
