"""A day of driving: peak memory and throughput of each estimator over a 24-hour drive.

Run: ``.venv/bin/python benchmarks/bench_long_drive.py [--hours 24] [--methods cascade,brls]``.

The drive repeats the sedan's planar scenarios (``dry-gravel-dry`` with three seeds and
``straight-cruise``, all at 100 Hz; 24 h are 8.64 M samples), written to a Parquet file
hour by hour (the builder's memory does not grow with the length). The pose is left
out (a repeated pose jumps back at every seam); the seams themselves jump in speed and
yaw rate by what the scenarios' ends differ, as a logger restart would.

Each method runs in its own process, so that its peak resident memory is its own:

- ``cascade``, ``brls`` and ``slipmap`` are streamed
  (:func:`roadgrip.cli.stream.stream_estimate`, 10-minute chunks, estimates written as
  they come). After each chunk: the cascade's three stages' covariances are checked
  positive definite and every output row's standard deviations finite and positive; the
  classifiers' rows checked to carry a grip class ('high', 'low' or 'unknown', as every
  row of the whole run does) and a finite grip index in [0, 1], the bRLS channels'
  covariances ``S`` positive and their estimates finite, the slip map's recursion state
  finite with its index in [0, 1];
- ``gpssm`` is streamed too; after each chunk its rows are checked to carry finite peak
  bands that hold their estimate, and the rows whose weights collapsed (effective sample
  size below 1.5 particles), those flagged ``collapsed`` (which include the copies after
  a collapse), the collapsed rows flagged neither ``collapsed`` nor ``diverged`` (none
  should be) and those flagged ``diverged`` are counted (the filter's guard
  re-initialises a diverged filter and says so in ``diverged``). At about a thousand
  samples per second one day needs hours, so it is only run when named, on
  ``--gpssm-hours`` (``benchmarks/bench_gpssm_stream.py`` looks at its state closer).

Throughput is compared with the same method on the first ten minutes of the drive, in
the same process after a warm-up run (compilation excluded from both; the median of three
runs). Streamed, the drive's chunks are as long as the short drive: the median chunk rate
and those of the first and last third of the chunks show whether anything slows down
with the drive's length. Those rates are per second of the process's CPU time (the wall
clock rates, printed too, carry the load of whatever else runs on the machine).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SCENARIOS = (("dry-gravel-dry", 0), ("straight-cruise", 0), ("dry-gravel-dry", 1), ("dry-gravel-dry", 2))
"""The pieces of the long drive, repeated in this order (all the sedan at 100 Hz)."""

SHORT_S = 600.0
"""The short drive the throughput is compared with [s]."""


def write_long_drive(path: str | Path, hours: float) -> int:
    """Write a drive of ``hours`` [h] repeating :data:`SCENARIOS`; returns its rows."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from roadgrip.drive import SIGNAL_COLUMNS, Drive
    from roadgrip.sim.scenarios import simulate_scenario

    pieces = []
    for name, seed in SCENARIOS:
        d = simulate_scenario(name, seed=seed)
        cols = [c for c in SIGNAL_COLUMNS if c in d.data.columns and c not in ("x", "y", "psi")]
        pieces.append(d.data[cols].reset_index(drop=True))
    vehicle = simulate_scenario(SCENARIOS[0][0], seed=0, duration=1.0).vehicle
    dt = 0.01
    total = round(hours * 3600.0 / dt)
    meta_drive = Drive.from_frame(pieces[0].iloc[:10], vehicle, source=f"long drive ({hours:g} h)")
    md = {b"roadgrip": meta_drive.meta.to_json().encode()}
    writer = None
    written, k, t_next = 0, 0, 0.0
    hour_rows = round(3600.0 / dt)
    buffer, size = [], 0
    try:
        while written < total:
            piece = pieces[k % len(pieces)].copy()
            k += 1
            piece["t"] = t_next + dt * np.arange(len(piece))
            piece = piece.iloc[: total - written - size]
            t_next = float(piece["t"].iloc[-1]) + dt
            buffer.append(piece)
            size += len(piece)
            if size >= hour_rows or written + size >= total:
                table = pa.Table.from_pandas(
                    __import__("pandas").concat(buffer, ignore_index=True), preserve_index=False)
                if writer is None:
                    schema = table.schema.with_metadata(md)
                    writer = pq.ParquetWriter(str(path), schema)
                writer.write_table(table.cast(schema), row_group_size=hour_rows)
                written += size
                buffer, size = [], 0
    finally:
        if writer is not None:
            writer.close()
    return written


def current_rss_bytes() -> int:
    """Resident memory of this process now [B] (Linux ``/proc/self/statm``)."""
    import os

    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def min_active_eig(cov: np.ndarray) -> float:
    """Smallest eigenvalue of a covariance over its estimated states (a state switched off
    by the configuration, e.g. the accelerometer biases without a standstill, keeps a zero
    row and column)."""
    active = np.diag(cov) > 0
    return float(np.linalg.eigvalsh(cov[np.ix_(active, active)]).min()) if active.any() else np.inf


def _check_cascade(res, checks: dict) -> None:
    """The three stages' covariances positive definite, every row's mu and its standard
    deviations finite (and positive)."""
    st = res.state
    for cov in (st.velocity_cov, st.force_cov, st.friction_cov):
        checks["min_cov_eig"] = min(checks["min_cov_eig"], min_active_eig(cov))
    tab = res.table
    std = tab[["mu_front_std", "mu_rear_std"]].to_numpy()
    checks["bad_std_rows"] += int((~(np.isfinite(std) & (std > 0))).any(axis=1).sum())
    checks["nan_mu_rows"] += int(tab[["mu_front", "mu_rear"]].isna().any(axis=1).sum())


def _bad_class_rows(tab) -> int:
    """Rows without a grip class or with a grip index outside [0, 1] (the whole run gives
    every row both)."""
    labelled = tab["grip_class"].isin(("high", "low", "unknown")).to_numpy()
    idx = tab["grip_index"].to_numpy(float)
    return int((~labelled | ~(np.isfinite(idx) & (idx >= 0.0) & (idx <= 1.0))).sum())


def _check_brls(res, checks: dict) -> None:
    """Each enabled bRLS channel's covariance ``S`` positive (a 1x1 covariance: its own
    eigenvalue) and its estimate finite; every row classified."""
    core, cfg = res.state.core, res.state.settings
    for ch, s, theta in ((cfg.long, core.s_long, core.theta_long), (cfg.lat, core.s_lat, core.theta_lat)):
        if ch.enabled:
            checks["min_cov_eig"] = min(checks["min_cov_eig"], float(s))
            checks["bad_state_chunks"] += int(not np.isfinite(theta))
    checks["bad_class_rows"] += _bad_class_rows(res.table)


def _check_slipmap(res, checks: dict) -> None:
    """The recursion's state finite, its index in [0, 1]; every row classified."""
    core = res.state.core
    ok = (np.isfinite([core.f, core.f_lp, core.info, core.rate]).all() and 0.0 <= core.f_lp <= 1.0
          and core.info >= 0.0)
    checks["bad_state_chunks"] += int(not ok)
    checks["bad_class_rows"] += _bad_class_rows(res.table)


COLLAPSED_ESS = 1.5
"""Effective sample size [particles] below which the GP-SSM's weights count as collapsed
(the guard's level, :mod:`roadgrip.estimators.gpssm.guard`)."""


def bad_band_rows(tab) -> int:
    """Rows whose axle bands are not finite or do not hold the estimate."""
    bad = np.zeros(len(tab), bool)
    for axle in ("front", "rear"):
        lo, mu, hi = (tab[c].to_numpy(float) for c in (f"mu_{axle}_lower", f"mu_{axle}", f"mu_{axle}_upper"))
        bad |= ~(np.isfinite(lo) & np.isfinite(mu) & np.isfinite(hi) & (lo <= mu) & (mu <= hi))
    return int(bad.sum())


def _check_gpssm(res, checks: dict) -> None:
    """Every row's peak bands finite and holding their estimate; collapsed and diverged rows
    counted; every particle's information matrix ``H = Sigma + I`` (at least ``I``) and
    posterior ``Lambda = Lambda0 + Phi - Psi H^-1 Psi^T`` positive definite."""
    from roadgrip.estimators.gpssm import linalg as la

    st = res.state.filter
    if st is not None:
        H = la.information(st.lin)
        lam = res.state.ctx.config.Lambda0 + st.Phi - st.Psi @ np.linalg.solve(H, np.swapaxes(st.Psi, -1, -2))
        checks["min_info_eig"] = min(checks["min_info_eig"], float(np.linalg.eigvalsh(H).min()))
        checks["min_cov_eig"] = min(checks["min_cov_eig"], float(np.linalg.eigvalsh(lam).min()))
    tab = res.table
    checks["bad_band_rows"] += bad_band_rows(tab)
    collapsed = tab["ess"].to_numpy(float) < COLLAPSED_ESS
    checks["collapsed_rows"] += int(collapsed.sum())
    # the rows flagged 'collapsed' (the weights' collapse and the copies after it)
    flagged = tab["collapsed"].to_numpy(bool)
    diverged = tab["diverged"].to_numpy(bool)
    checks["collapsed_flagged_rows"] += int(flagged.sum())
    checks["collapsed_unflagged_rows"] += int((collapsed & ~flagged & ~diverged).sum())
    checks["diverged_rows"] += int(diverged.sum())


CHECKS = {
    "cascade": lambda: {"chunks": 0, "min_cov_eig": np.inf, "bad_std_rows": 0, "nan_mu_rows": 0},
    "brls": lambda: {"chunks": 0, "min_cov_eig": np.inf, "bad_state_chunks": 0, "bad_class_rows": 0},
    "slipmap": lambda: {"chunks": 0, "bad_state_chunks": 0, "bad_class_rows": 0},
    "gpssm": lambda: {"chunks": 0, "min_info_eig": np.inf, "min_cov_eig": np.inf, "bad_band_rows": 0,
                      "collapsed_rows": 0, "collapsed_flagged_rows": 0,
                      "collapsed_unflagged_rows": 0, "diverged_rows": 0},
}
"""The counters of each streamed method's checks after every chunk."""

STATE_CHECKS = {"cascade": _check_cascade, "brls": _check_brls, "slipmap": _check_slipmap, "gpssm": _check_gpssm}
"""Each streamed method's check of a chunk's result (state and rows)."""


def _run_one(method: str, path: str, short_path: str) -> dict:
    """In this process: warm up on the short drive, time it, then the long drive."""
    from roadgrip.cli.stream import STREAM_METHODS, peak_rss_bytes, stream_estimate

    out = tempfile.mkdtemp(prefix="roadgrip-long-")
    if method in STREAM_METHODS:
        checks = CHECKS[method]()
        rates: list[float] = []
        rows: list[int] = []
        rss: list[float] = []
        clock = [time.process_time()]

        def check(res) -> None:
            now = time.process_time()
            rates.append(len(res.table) / (now - clock[0]))  # read, estimate and write of one chunk
            STATE_CHECKS[method](res, checks)
            checks["chunks"] += 1
            rows.append(len(res.table))
            rss.append(current_rss_bytes() / 2**20)
            # progress on stderr (a run of hours leaves its figures so far if it is stopped)
            print(f"# {method} chunk {checks['chunks']}: {sum(rows)} rows, {rates[-1]:.0f} samples per CPU s, "
                  f"{rss[-1]:.0f} MiB, {checks}", file=sys.stderr, flush=True)
            clock[0] = time.process_time()

        # the short drive is one chunk: its rate against the median chunk of the long drive
        # (SHORT '-': no throughput comparison, the checks only)
        short_rates, short_cpu = [np.nan], [np.nan]
        if short_path != "-":
            stream_estimate(short_path, f"{out}/warm.parquet", method)
            short_rates, short_cpu = [], []
            for _ in range(3):
                c0 = time.process_time()
                res = stream_estimate(short_path, f"{out}/short.parquet", method)
                short_rates.append(res["samples_per_s"])
                short_cpu.append(res["rows"] / (time.process_time() - c0))
        short = float(np.median(short_rates))
        rss_short = peak_rss_bytes()
        c0 = clock[0] = time.process_time()
        long = stream_estimate(path, f"{out}/long.parquet", method, on_chunk=check)
        cpu = time.process_time() - c0
        third = max(len(rates) // 3, 1)
        return {"method": method, "mode": "streamed", "rows": long["rows"], "hours": long["duration_s"] / 3600,
                "samples_per_s": long["samples_per_s"], "short_samples_per_s": short,
                "cpu_samples_per_s": long["rows"] / cpu, "short_cpu_samples_per_s": float(np.median(short_cpu)),
                "median_chunk_samples_per_s": float(np.median(rates)), "chunk_rates": [round(x) for x in rates], "chunk_rows": rows,
                "rss_first_half_mib": max(rss[: max(len(rss) // 2, 1)]), "rss_second_half_mib": max(rss[len(rss) // 2:]),
                "first_third_samples_per_s": float(np.median(rates[:third])),
                "last_third_samples_per_s": float(np.median(rates[-third:])),
                "peak_rss_mib": long["peak_rss_bytes"] / 2**20, "rss_after_short_mib": rss_short / 2**20,
                "wall_s": long["wall_s"], **checks}
    from roadgrip.estimators import run_estimator
    from roadgrip.io import read_drive

    short_drive = read_drive(short_path)
    run_estimator(method, short_drive)
    t0 = time.perf_counter()
    run_estimator(method, short_drive)
    short_rate = short_drive.n / (time.perf_counter() - t0)
    rss_short = peak_rss_bytes()
    drive = read_drive(path)
    t0 = time.perf_counter()
    res = run_estimator(method, drive)
    wall = time.perf_counter() - t0
    # the classifiers report a grip class (mu only with a calibrated friction)
    missing = res.table["grip_class"].isna() if "grip_class" in res.table else res.table["mu_front"].isna()
    return {"method": method, "mode": "whole drive", "rows": drive.n, "hours": drive.duration / 3600,
            "samples_per_s": drive.n / wall, "short_samples_per_s": short_rate,
            "peak_rss_mib": peak_rss_bytes() / 2**20, "rss_after_short_mib": rss_short / 2**20,
            "wall_s": wall, "missing_output_rows": int(missing.sum())}


def _short_copy(path: str, short_path: str) -> None:
    import pyarrow.parquet as pq

    pf = pq.ParquetFile(path)
    n = int(SHORT_S / 0.01)
    table = pf.read_row_group(0).slice(0, n)
    pq.write_table(table.replace_schema_metadata(pf.schema_arrow.metadata), short_path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hours", type=float, default=24.0, help="length of the drive [h]")
    ap.add_argument("--methods", default="cascade,brls,slipmap",
                    help="comma-separated methods (gpssm only when named)")
    ap.add_argument("--gpssm-hours", type=float, default=0.5, help="length of gpssm's drive [h]")
    ap.add_argument("--dir", default=None, help="folder for the drive files (default: a temporary one)")
    ap.add_argument("--one", nargs=3, metavar=("METHOD", "DRIVE", "SHORT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(_run_one(*args.one)))
        return
    folder = Path(args.dir or tempfile.mkdtemp(prefix="roadgrip-long-"))
    folder.mkdir(parents=True, exist_ok=True)
    files: dict[float, tuple[str, str]] = {}
    print(f"{'method':<8} {'mode':<12} {'hours':>6} {'rows':>10} {'samples/s':>10} {'short s/s':>10} "
          f"{'ratio':>6} {'peak MiB':>9} {'wall [s]':>9}  checks", flush=True)
    for method in args.methods.split(","):
        hours = args.gpssm_hours if method == "gpssm" else args.hours
        if hours not in files:
            path, short = str(folder / f"long_{hours:g}h.parquet"), str(folder / f"short_{hours:g}h.parquet")
            t0 = time.perf_counter()
            rows = write_long_drive(path, hours)
            _short_copy(path, short)
            print(f"# wrote {path}: {rows} rows in {time.perf_counter() - t0:.0f} s", flush=True)
            files[hours] = (path, short)
        path, short = files[hours]
        # stderr passes through (the per-chunk progress)
        proc = subprocess.run([sys.executable, __file__, "--one", method, path, short],
                              stdout=subprocess.PIPE, text=True)
        if proc.returncode != 0:
            print(f"{method:<8} failed with exit code {proc.returncode} (its error above)", flush=True)
            continue
        r = json.loads(proc.stdout.strip().splitlines()[-1])
        checks = {k: (round(r[k]) if k.endswith(("samples_per_s", "_mib")) else r[k])
                  for k in ("chunks", "min_cov_eig", "bad_std_rows", "nan_mu_rows", "bad_state_chunks",
                            "bad_class_rows", "missing_output_rows", "min_info_eig", "bad_band_rows", "collapsed_rows", "collapsed_flagged_rows",
                            "collapsed_unflagged_rows", "diverged_rows",
                            "cpu_samples_per_s", "short_cpu_samples_per_s",
                            "median_chunk_samples_per_s", "first_third_samples_per_s",
                            "last_third_samples_per_s", "rss_first_half_mib", "rss_second_half_mib") if k in r}
        if "chunk_rows" in r:  # every row through the estimator once
            checks["rows_once"] = sum(r["chunk_rows"]) == r["rows"]
        print(f"{method:<8} {r['mode']:<12} {r['hours']:>6.2f} {r['rows']:>10} {r['samples_per_s']:>10.0f} "
              f"{r['short_samples_per_s']:>10.0f} {r['samples_per_s'] / r['short_samples_per_s']:>6.2f} "
              f"{r['peak_rss_mib']:>9.0f} {r['wall_s']:>9.0f}  {checks}", flush=True)


if __name__ == "__main__":
    main()
