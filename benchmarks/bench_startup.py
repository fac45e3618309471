"""Start-up time and memory of the command line (issue "the first hour").

Run: ``.venv/bin/python benchmarks/bench_startup.py [--runs 5] [--scenario dry-gravel-dry]``.

Each command runs ``--runs`` times, each time in a fresh process (``roadgrip`` from the
interpreter's own ``bin`` folder), after one unmeasured warm-up run that fills the disk
cache and the byte-code cache:

- ``roadgrip --help``
- ``roadgrip scenarios``
- ``roadgrip info DRIVE`` on a one-minute drive it simulates first
  (``roadgrip simulate SCENARIO -o DRIVE --duration 60``, Parquet, or CSV with ``--csv``).

Per command it prints the median wall time, the median CPU time (user + system) and the
largest maximum resident set size of the runs, each read from ``os.wait4`` for that one
child (so one command's memory is never mixed with another's), against the targets. On a
loaded machine the wall time carries the load of whatever else runs; the CPU time does
much less. Not a test: nothing fails when a target is missed, the table says so.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROADGRIP = str(Path(sys.executable).with_name("roadgrip"))
"""The console script of the interpreter running this benchmark."""

TARGETS = {"--help": (0.6, None), "scenarios": (1.0, 200.0), "info": (1.0, 200.0)}
"""Per command: wall time [s] and maximum resident memory [MB] targets (None: no target)."""


@dataclass(frozen=True)
class Run:
    """One measured process: wall and CPU time [s], maximum resident set size [MB]."""

    wall: float
    cpu: float
    max_rss_mb: float


def run_once(argv: list[str]) -> Run:
    """Run ``argv`` in a fresh process; its own wall time, CPU time and peak memory.

    Raises
    ------
    RuntimeError
        When the command exits with a non-zero status (its standard error is quoted).
    """
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)  # the rusage of this child alone
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    stderr = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} exited {proc.returncode}: {stderr.strip()}")
    return Run(wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024)  # ru_maxrss in KiB


def measure(argv: list[str], runs: int) -> list[Run]:
    """``runs`` measured runs of ``argv`` after one unmeasured warm-up run."""
    run_once(argv)
    return [run_once(argv) for _ in range(runs)]


def verdict(value: float, target: float | None) -> str:
    """``'ok'`` / ``'MISSED'`` against ``target``, or ``''`` when there is none."""
    if target is None:
        return ""
    return "ok" if value <= target else "MISSED"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="Measured runs per command.")
    ap.add_argument("--scenario", default="dry-gravel-dry", help="Scenario of the one-minute drive.")
    ap.add_argument("--csv", action="store_true", help="Write the drive as CSV instead of Parquet.")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory() as tmp:
        drive = Path(tmp) / ("drive.csv" if args.csv else "drive.parquet")
        subprocess.run([ROADGRIP, "simulate", args.scenario, "-o", str(drive), "--duration", "60"],
                       check=True, capture_output=True)
        commands = {
            "--help": [ROADGRIP, "--help"],
            "scenarios": [ROADGRIP, "scenarios"],
            "info": [ROADGRIP, "info", str(drive)],
        }
        print(f"{args.runs} runs each after a warm-up; drive: {args.scenario}, 60 s, "
              f"{drive.suffix[1:]} {drive.stat().st_size / 1e6:.1f} MB; "
              f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
        print(f"{'command':<12} {'wall [s]':>9} {'target':>7} {'':>6}  {'cpu [s]':>8}  "
              f"{'max RSS [MB]':>12} {'target':>7} {'':>6}")
        for name, cmd in commands.items():
            results = measure(cmd, args.runs)
            wall = statistics.median(r.wall for r in results)
            cpu = statistics.median(r.cpu for r in results)
            rss = max(r.max_rss_mb for r in results)
            t_wall, t_rss = TARGETS[name]
            print(f"{name:<12} {wall:>9.2f} {t_wall:>7.1f} {verdict(wall, t_wall):>6}  {cpu:>8.2f}  "
                  f"{rss:>12.0f} {t_rss if t_rss is not None else '-':>7} {verdict(rss, t_rss):>6}")


if __name__ == "__main__":
    main()
