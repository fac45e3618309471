"""The GP-SSM filter streamed over a long drive: peak memory, memory growth, throughput,
particle health and the bands of every row.

Run: ``.venv/bin/python benchmarks/bench_gpssm_stream.py [--hours 2] [--chunk-rows 60000]
[--particles 200] [--whole]``.

The drive is :func:`bench_long_drive.write_long_drive`'s (the sedan's planar scenarios
repeated at 100 Hz, one row group per hour, no pose, seams that jump in speed and yaw rate
as a logger restart would). It is read chunk by chunk
(:func:`roadgrip.cli.stream.drive_chunks`, 10-minute chunks by default) and filtered by
:func:`roadgrip.estimators.gpssm.stream.run_chunks` with the default configuration (200
particles, ``separable-odd:20``, exact mode), each chunk's table written to a Parquet file
as it comes. The run is in a child process, so that its peak resident memory
(:func:`roadgrip.cli.stream.peak_rss_bytes`) is its own.

Printed:

- peak resident memory, and the largest resident memory after the chunks of the first
  and of the second half of the drive (growth with the drive's length shows as a second
  half above the first), and the bytes of the state carried between chunks after the
  first and the last chunk;
- throughput (samples per second of wall clock and of the process's CPU time) against
  the first ten minutes of the same drive (one chunk, after a warm-up run that compiles),
  the median chunk rate of the first and the last third of the chunks, and the 24-hour
  wall time these rates extrapolate to;
- particle health: effective sample size (minimum, mean, 1st percentile) against the
  particle number, the rows with collapsed weights (ESS below 1.5 particles, the guard's
  collapse level), the resampling rate, the rows flagged ``diverged`` and the guard's
  re-initialisations; ``COLLAPSE`` is printed when any row's weights collapsed;
- the rows whose peak band is not finite or does not hold its estimate (``mu_*_lower <=
  mu_* <= mu_*_upper``, finite, for both axles), and the rows whose ``vy_std`` or
  ``yaw_rate_std`` is not finite or is zero.

With ``--whole`` the same drive also runs whole (:func:`roadgrip.estimators.gpssm.run`,
in its own child process): its peak memory, and whether its rows equal the streamed ones.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _long_drive_bench():
    """``benchmarks/bench_long_drive.py`` as a module (its drive builder and row checks)."""
    spec = importlib.util.spec_from_file_location("bench_long_drive", HERE / "bench_long_drive.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _rss_now_mib() -> float:
    import os

    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _std_rows(tab) -> tuple[int, int]:
    """Rows with a state standard deviation (``vy_std``, ``yaw_rate_std``) not finite, and
    rows with one of zero (every particle a copy of one after a resampling from collapsed
    weights: the particle spread is none)."""
    s = tab[["vy_std", "yaw_rate_std"]].to_numpy(float)
    return int((~np.isfinite(s)).any(axis=1).sum()), int((s == 0.0).any(axis=1).sum())


def _stream(path: str, out: str, config, rows: int, on_chunk=None) -> dict:
    """Stream ``path`` through the filter, writing the rows to ``out``; the wall and CPU
    time and the rows."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from roadgrip.cli.stream import drive_chunks
    from roadgrip.estimators.gpssm.stream import run_chunks

    _, chunks = drive_chunks(path, rows=rows)
    writer = None
    n = 0
    w0, c0 = time.perf_counter(), time.process_time()
    try:
        for res in run_chunks(chunks, config, 0):
            arrow = pa.Table.from_pandas(res.table, preserve_index=False)
            if writer is None:
                writer = pq.ParquetWriter(out, arrow.schema)
            writer.write_table(arrow)
            n += len(res.table)
            if on_chunk is not None:
                on_chunk(res)
    finally:
        if writer is not None:
            writer.close()
    return {"rows": n, "wall_s": time.perf_counter() - w0, "cpu_s": time.process_time() - c0}


def _run_streamed(path: str, short: str, rows: int, particles: int, out_dir: str) -> dict:
    """In this process: warm up, the short drive, then the long drive streamed."""
    from roadgrip.cli.stream import peak_rss_bytes
    from roadgrip.estimators.gpssm import GPSSMConfig
    from roadgrip.estimators.gpssm.stream import carried_bytes

    config = GPSSMConfig(particles=particles)
    warm = f"{out_dir}/warm.parquet"
    ld = _long_drive_bench()  # the import the parent made, so both processes hold the same modules
    import pyarrow.parquet as pq

    pf = pq.ParquetFile(short)
    pq.write_table(pf.read_row_group(0).slice(0, 3000).replace_schema_metadata(pf.schema_arrow.metadata), warm)
    _stream(warm, f"{out_dir}/warm_out.parquet", config, rows)  # compiles
    s = _stream(short, f"{out_dir}/short_out.parquet", config, rows)
    rss_short = peak_rss_bytes() / 2**20
    ck = {"chunks": 0, "rows": [], "rss_mib": [], "cpu_rate": [], "wall_rate": [], "ess_min": np.inf,
          "ess_sum": 0.0, "ess_p1": [], "collapsed_rows": 0, "bad_band_rows": 0, "nonfinite_std_rows": 0,
          "zero_std_rows": 0, "resampled_rows": 0,
          "diverged_rows": 0, "state_bytes": []}
    clock = [time.process_time(), time.perf_counter()]

    def check(res) -> None:
        c, w = time.process_time(), time.perf_counter()
        tab = res.table
        ess = tab["ess"].to_numpy(float)
        ck["chunks"] += 1
        ck["rows"].append(len(tab))
        ck["cpu_rate"].append(len(tab) / (c - clock[0]))  # read, filter and write of the chunk
        ck["wall_rate"].append(len(tab) / (w - clock[1]))
        ck["ess_min"] = min(ck["ess_min"], float(ess.min()))
        ck["ess_sum"] += float(ess.sum())
        ck["ess_p1"].append(float(np.percentile(ess, 1)))
        ck["collapsed_rows"] += int((ess < ld.COLLAPSED_ESS).sum())
        ck["resampled_rows"] += int(tab["resampled"].sum())
        ck["diverged_rows"] += int(tab["diverged"].sum())
        ck["bad_band_rows"] += ld.bad_band_rows(tab)
        nonfinite, zero = _std_rows(tab)
        ck["nonfinite_std_rows"] += nonfinite
        ck["zero_std_rows"] += zero
        ck["state_bytes"].append(carried_bytes(res.state))
        ck["resets"] = int(res.state.filter.guard.resets)
        ck["rss_mib"].append(_rss_now_mib())
        clock[0], clock[1] = time.process_time(), time.perf_counter()

    long = _stream(path, f"{out_dir}/long_out.parquet", config, rows, on_chunk=check)
    rss, rates = ck.pop("rss_mib"), ck.pop("cpu_rate")
    third = max(len(rates) // 3, 1)
    half = max(len(rss) // 2, 1)
    n = long["rows"]
    return {
        "mode": "streamed", "particles": particles, "chunk_rows": rows, "rows": n, "hours": n * 0.01 / 3600,
        "samples_per_s": n / long["wall_s"], "cpu_samples_per_s": n / long["cpu_s"],
        "short_rows": s["rows"], "short_samples_per_s": s["rows"] / s["wall_s"],
        "short_cpu_samples_per_s": s["rows"] / s["cpu_s"],
        "first_third_cpu_samples_per_s": float(np.median(rates[:third])),
        "last_third_cpu_samples_per_s": float(np.median(rates[-third:])),
        "peak_rss_mib": peak_rss_bytes() / 2**20, "rss_after_short_mib": rss_short,
        "rss_first_half_mib": max(rss[:half]), "rss_second_half_mib": max(rss[half:] or rss),
        "state_first_bytes": ck["state_bytes"][0], "state_last_bytes": ck["state_bytes"][-1],
        "state_max_bytes": max(ck["state_bytes"]),
        "ess_mean": ck["ess_sum"] / max(n, 1), "ess_min": ck["ess_min"], "ess_p1_min_chunk": min(ck["ess_p1"]),
        "collapsed_rows": ck["collapsed_rows"], "resampling_rate": ck["resampled_rows"] / max(n, 1),
        "diverged_rows": ck["diverged_rows"], "resets": ck.get("resets", 0), "bad_band_rows": ck["bad_band_rows"],
        "nonfinite_std_rows": ck["nonfinite_std_rows"], "zero_std_rows": ck["zero_std_rows"],
        "chunks": ck["chunks"], "chunk_rows_sum": int(sum(ck["rows"])), "wall_s": long["wall_s"],
        "rss_per_chunk_mib": [round(x) for x in rss], "cpu_rate_per_chunk": [round(x) for x in rates],
        "rows_out": f"{out_dir}/long_out.parquet",
    }


def _run_whole(path: str, particles: int, out_dir: str) -> dict:
    """In this process: the drive read whole and filtered whole."""
    from roadgrip.cli.stream import peak_rss_bytes
    from roadgrip.estimators.gpssm import GPSSMConfig, run
    from roadgrip.io import read_drive

    drive = read_drive(path)
    w0 = time.perf_counter()
    res = run(drive, GPSSMConfig(particles=particles), seed=0)
    wall = time.perf_counter() - w0
    res.table.to_parquet(f"{out_dir}/whole_out.parquet")
    return {"mode": "whole", "rows": drive.n, "samples_per_s": drive.n / wall, "wall_s": wall,
            "peak_rss_mib": peak_rss_bytes() / 2**20, "rows_out": f"{out_dir}/whole_out.parquet"}


def _child(args: list[str]) -> dict:
    proc = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"child {args[:2]} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hours", type=float, default=1.0, help="length of the drive [h]")
    ap.add_argument("--chunk-rows", type=int, default=None, help="rows per chunk (default the CLI's)")
    ap.add_argument("--particles", type=int, default=200)
    ap.add_argument("--whole", action="store_true", help="also run the drive whole and compare its rows")
    ap.add_argument("--dir", default=None, help="folder for the drive files (default: a temporary one)")
    ap.add_argument("--streamed", nargs=5, help=argparse.SUPPRESS)
    ap.add_argument("--whole-child", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.streamed:
        path, short, rows, particles, out = args.streamed
        print(json.dumps(_run_streamed(path, short, int(rows), int(particles), out)))
        return
    if args.whole_child:
        path, particles, out = args.whole_child
        print(json.dumps(_run_whole(path, int(particles), out)))
        return
    from roadgrip.cli.stream import CHUNK_ROWS

    rows = args.chunk_rows or CHUNK_ROWS
    folder = Path(args.dir or tempfile.mkdtemp(prefix="roadgrip-gpssm-stream-"))
    folder.mkdir(parents=True, exist_ok=True)
    bench = _long_drive_bench()
    path, short = str(folder / f"long_{args.hours:g}h.parquet"), str(folder / f"short_{args.hours:g}h.parquet")
    t0 = time.perf_counter()
    n = bench.write_long_drive(path, args.hours)
    bench._short_copy(path, short)
    print(f"# wrote {path}: {n} rows in {time.perf_counter() - t0:.0f} s; chunks of {rows} rows, "
          f"{args.particles} particles", flush=True)
    r = _child(["--streamed", path, short, str(rows), str(args.particles), str(folder)])
    day = 24 * 3600 * 100
    print(f"rows {r['rows']} ({r['hours']:.2f} h) in {r['chunks']} chunks (rows passed: {r['chunk_rows_sum']}), "
          f"wall {r['wall_s']:.0f} s")
    print(f"memory: peak {r['peak_rss_mib']:.0f} MiB (after the short drive {r['rss_after_short_mib']:.0f}); "
          f"largest after a chunk: first half {r['rss_first_half_mib']:.0f} MiB, second half "
          f"{r['rss_second_half_mib']:.0f} MiB; per chunk {r['rss_per_chunk_mib']}")
    print(f"carried state: {r['state_first_bytes'] / 2**20:.2f} MiB after the first chunk, "
          f"{r['state_last_bytes'] / 2**20:.2f} MiB after the last (largest {r['state_max_bytes'] / 2**20:.2f})")
    ratio = r["cpu_samples_per_s"] / r["short_cpu_samples_per_s"]
    print(f"throughput: {r['samples_per_s']:.0f} samples/s wall, {r['cpu_samples_per_s']:.0f} per CPU second; "
          f"short drive ({r['short_rows']} rows) {r['short_samples_per_s']:.0f} wall, "
          f"{r['short_cpu_samples_per_s']:.0f} CPU (long/short CPU {ratio:.2f}); chunk CPU rate first third "
          f"{r['first_third_cpu_samples_per_s']:.0f}, last third {r['last_third_cpu_samples_per_s']:.0f}")
    print(f"24 h ({day} samples) at these rates: {day / r['samples_per_s'] / 3600:.1f} h wall, "
          f"{day / r['cpu_samples_per_s'] / 3600:.1f} h of one core")
    flag = "  COLLAPSE" if r["collapsed_rows"] else ""
    print(f"particles ({r['particles']}): ESS mean {r['ess_mean']:.1f}, min {r['ess_min']:.2f}, "
          f"lowest chunk 1st percentile {r['ess_p1_min_chunk']:.1f}; collapsed rows (ESS < {bench.COLLAPSED_ESS}) "
          f"{r['collapsed_rows']}; resampling rate {r['resampling_rate']:.3f}; diverged rows "
          f"{r['diverged_rows']}, re-initialisations {r['resets']}{flag}")
    print(f"bands: {r['bad_band_rows']} of {r['rows']} rows with a peak band not finite or not holding the "
          f"estimate; state standard deviations: {r['nonfinite_std_rows']} rows not finite, "
          f"{r['zero_std_rows']} rows zero (no particle spread after resampling from collapsed weights)")
    if args.whole:
        import pandas as pd

        w = _child(["--whole-child", path, str(args.particles), str(folder)])
        a, b = pd.read_parquet(r["rows_out"]), pd.read_parquet(w["rows_out"])
        same = a.shape == b.shape and all(np.array_equal(a[c].to_numpy(), b[c].to_numpy(), equal_nan=True)
                                          if a[c].dtype.kind == "f" else (a[c] == b[c]).all() for c in a.columns)
        print(f"whole drive: peak {w['peak_rss_mib']:.0f} MiB, {w['samples_per_s']:.0f} samples/s wall; "
              f"rows equal to the streamed ones: {same}")
    print(json.dumps({k: v for k, v in r.items() if not k.endswith("per_chunk_mib") and k != "cpu_rate_per_chunk"}))


if __name__ == "__main__":
    main()
