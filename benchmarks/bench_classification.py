"""Throughput of the paper 002 classifiers: batch and online, one core.

Prints samples per second of

* the bRLS kernel with its state machine (two channels) in batch over arrays,
* the slip-map recursion in batch, and the slip-map evidence (vectorised),
* the kinematic stage in batch,
* the whole batch pipelines over a simulated drive (kinematics + classifier),
* online stepping: the pure bRLS step kernel and the estimators' protocol
  ``step`` (kinematic step + regressors or evidence + classifier step), with
  the per-step latency.

Run: ``.venv/bin/python benchmarks/bench_classification.py [--samples N]``.
The paper's presets are timed in the kernels; the pipelines also with the saturation
model (the estimators' uncalibrated default). Accuracy on multi-body surface changes and
on DART: ``benchmarks/classification_accuracy.py`` (figures in ``docs/classification.md``).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from roadgrip.estimators.classify import BRLS, SLIPMAP
from roadgrip.estimators.classify.brls import brls_table
from roadgrip.estimators.classify.brls_config import default_config, saturation_config
from roadgrip.estimators.classify.brls_kernel import brls_batch, brls_init, brls_step
from roadgrip.estimators.classify.slipmap import slipmap_table
from roadgrip.estimators.classify.slipmap_config import default_config as slipmap_default
from roadgrip.estimators.classify.slipmap_config import saturation_config as slipmap_saturation
from roadgrip.estimators.classify.slipmap_evidence import SlipMapEvidence, evidence
from roadgrip.estimators.classify.slipmap_kernel import slipmap_batch
from roadgrip.inference.kinematic import estimate_kinematics


def _best(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=5_000_000, help="batch length for the kernels")
    ap.add_argument("--online", type=int, default=20_000, help="samples stepped online")
    args = ap.parse_args()
    n = args.samples
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.01
    phi_long = 0.02 * rng.standard_normal(n)
    phi_lat = 0.03 * np.sin(2 * np.pi * 0.2 * t) + 0.002 * rng.standard_normal(n)
    ax = 40.0 * phi_long + 0.05 * rng.standard_normal(n)
    ay = 60.0 * phi_lat + 0.05 * rng.standard_normal(n)
    cfg = default_config()

    brls_batch(t[:100], phi_long[:100], ax[:100], phi_lat[:100], ay[:100], cfg)  # compile
    w = _best(lambda: brls_batch(t, phi_long, ax, phi_lat, ay, cfg))
    print(f"bRLS + state machine, batch kernel: {n / w:,.0f} samples/s ({n:,} samples, {w:.3f} s)")

    cfg_pf = replace(cfg, prefilter_tau_s=0.5)
    w = _best(lambda: brls_batch(t, phi_long, ax, phi_lat, ay, cfg_pf))
    print(f"bRLS + state machine with prefilter, batch kernel: {n / w:,.0f} samples/s")

    z = np.zeros(n)
    ev = SlipMapEvidence(z, z, np.abs(phi_long), np.abs(phi_lat), 0.3 * np.abs(phi_long),
                                 0.3 * np.abs(phi_lat), 1.0 - 0.3 * np.abs(phi_long) - 0.3 * np.abs(phi_lat), z)
    scfg = slipmap_default()
    slipmap_batch(t[:100], SlipMapEvidence(*(f[:100] for f in ev)), scfg)
    w = _best(lambda: slipmap_batch(t, ev, scfg))
    print(f"slipmap recursion (eq. 16 + low-pass), batch kernel: {n / w:,.0f} samples/s")

    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=0)
    estimate_kinematics(drive.slice_time(0, 1))
    w = _best(lambda: estimate_kinematics(drive))
    print(f"kinematic stage, batch over dry-gravel-dry: {drive.n / w:,.0f} samples/s ({drive.n} samples)")
    kin = estimate_kinematics(drive)
    w = _best(lambda: evidence(kin.kappa, kin.alpha_f, kin.alpha_r, drive.col("ax"),
                                       drive.col("ay"), drive.col("steer"), kin.wheels_valid,
                                       drive.vehicle, scfg, kin.vx))
    print(f"slipmap evidence (eq. 9-15), vectorised: {drive.n / w:,.0f} samples/s")
    for name, fn in (
        ("bRLS pipeline (kinematics + regressors + bRLS)", lambda: brls_table(drive, cfg)),
        ("slipmap pipeline (kinematics + evidence + recursion)", lambda: slipmap_table(drive, scfg)),
        ("bRLS pipeline, saturation model", lambda: brls_table(drive, saturation_config())),
        ("slipmap pipeline, saturation model", lambda: slipmap_table(drive, slipmap_saturation())),
    ):
        w = _best(fn)
        print(f"{name}, batch over dry-gravel-dry: {drive.n / w:,.0f} samples/s, "
              f"real-time factor {drive.duration / w:,.0f}")

    # online: one step at a time
    m = min(args.online, n)
    st = brls_init(cfg)
    brls_step(st, 0.01, 0.0, 0.0, 0.0, 0.0, cfg)
    t0 = time.perf_counter()
    for i in range(m):
        st, _ = brls_step(st, 0.01, float(phi_long[i]), float(ax[i]), float(phi_lat[i]), float(ay[i]), cfg)
    w = time.perf_counter() - t0
    print(f"bRLS step kernel, online: {m / w:,.0f} samples/s, {1e6 * w / m:.1f} µs per step")

    for name, est in (("bRLS", BRLS), ("slipmap", SLIPMAP)):
        config = est.Config()
        prepared = est.prepare(drive, config)
        samples = prepared.samples[: min(m, drive.n)]
        state = est.init(prepared.info, config, 0)
        state, _ = est.step(state, samples[0])
        lat = np.empty(len(samples) - 1)
        for i, s in enumerate(samples[1:]):
            t0 = time.perf_counter()
            state, _ = est.step(state, s)
            lat[i] = time.perf_counter() - t0
        print(f"{name} protocol step (kinematics + classifier per sample): "
              f"{1 / lat.mean():,.0f} samples/s; latency median {1e6 * np.median(lat):.0f} µs, "
              f"99th percentile {1e6 * np.quantile(lat, 0.99):.0f} µs")


if __name__ == "__main__":
    main()
