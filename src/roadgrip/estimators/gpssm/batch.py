"""The GP-SSM filter over many drives at once: one process per core.

:func:`run_many` runs :func:`~roadgrip.estimators.gpssm.estimator.run` over a list of
drives in a pool of worker processes (one per core by default), each with BLAS held to
one thread (the filter's ``run`` does that itself; the workers also start with
``OPENBLAS_NUM_THREADS=1``), so that the cores each run a filter instead of sharing
every small product. The filter is sequential within a drive and every drive is
independent, so this is where a fleet's drives or a benchmark's seeds use the machine.
Each drive's result is the one :func:`run` gives alone, to the last bit: the filter's
random stream comes from its seed only, and one BLAS thread sums in the same order in a
worker as in the caller.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from roadgrip.estimators.base import EstimateResult
from roadgrip.estimators.gpssm.config import GPSSMConfig
from roadgrip.estimators.gpssm.estimator import run

__all__ = ["run_many"]

_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _one_thread() -> None:
    for var in _THREAD_VARS:
        os.environ[var] = "1"


def _run_one(args: tuple[Any, GPSSMConfig, int]) -> EstimateResult:
    drive, config, seed = args
    return run(drive, config, seed)


def run_many(
    drives: Sequence[Any],
    config: GPSSMConfig | None = None,
    seeds: int | Sequence[int] = 0,
    *,
    workers: int | None = None,
    done: Callable[[int], None] | None = None,
) -> list[EstimateResult]:
    """:func:`~roadgrip.estimators.gpssm.estimator.run` over every drive, in parallel.

    Parameters
    ----------
    drives : sequence of Drive
    config : GPSSMConfig, optional
        One configuration for every drive (default ``GPSSMConfig()``).
    seeds : int or sequence of int
        The filter's seed per drive (one for all when an int).
    workers : int, optional
        Processes (default: the number of cores, at most the number of drives); 1 runs
        the drives one after another in this process.
    done : callable, optional
        Called with the index of each drive as its result is collected (in order).

    Returns
    -------
    list of EstimateResult
        In the order of ``drives``; each equal to ``run(drive, config, seed)``.

    Examples
    --------
    >>> from roadgrip.sim.scenarios import simulate_scenario
    >>> drives = [simulate_scenario("snow-slalom", seed=s, duration=2.0) for s in (0, 1)]
    >>> results = run_many(drives, GPSSMConfig(particles=20, basis="separable:8"), seeds=[0, 1])
    >>> len(results)
    2
    """
    config = config if config is not None else GPSSMConfig()
    seeds = [int(seeds)] * len(drives) if isinstance(seeds, int) else [int(s) for s in seeds]
    if len(seeds) != len(drives):
        raise ValueError(f"run_many needs one seed per drive: {len(drives)} drives, {len(seeds)} seeds")
    n = len(drives)
    workers = min(workers if workers is not None else os.cpu_count() or 1, n)
    if workers < 1 and n:
        raise ValueError(f"workers must be at least 1, got {workers!r}")
    jobs = list(zip(drives, [config] * n, seeds, strict=True))
    if workers <= 1:
        out = []
        for i, job in enumerate(jobs):
            out.append(_run_one(job))
            if done is not None:
                done(i)
        return out
    # fork where the platform has it: the workers start with the compiled kernels loaded
    method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context(method),
                             initializer=_one_thread) as pool:
        futures = [pool.submit(_run_one, job) for job in jobs]
        results = []
        for i, f in enumerate(futures):
            results.append(f.result())
            if done is not None:
                done(i)
    return results
