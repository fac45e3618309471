"""The honesty matrix: every estimator on every drive of the corpus, judged by one rule.

Prints one line per (drive, method) as it is computed and writes ``honesty_matrix.md`` /
``honesty_matrix.csv`` (default ``report/honesty``). The rule and the corpus are in
:mod:`roadgrip.evaluate.honesty` and :mod:`roadgrip.evaluate.honesty_matrix`.

Usage::

    python benchmarks/honesty_matrix.py [--size full|short] [--out DIR] [--methods gpssm,cascade]
        [--jobs N]

Exit status 0 always: the matrix is a measurement; the acceptance lives in the tests
(``tests/test_honesty_matrix.py``).
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from roadgrip.evaluate.honesty_matrix import METHODS, corpus, matrix, write


def _rows(spec, methods):
    return list(matrix(methods=methods, drives=[spec]))


def _line(r) -> str:
    if r.get("status") != "ok":
        return f"{r['drive']:<34} {r['method']:<8} {r.get('status')}"
    pct = lambda v: "    –" if v != v else f"{100 * v:5.1f}"  # noqa: E731
    return (f"{r['drive']:<34} {r['method']:<8} wrong axle {pct(r['wrong_axle'])} % vss {pct(r['wrong_vss'])} % "
            f"class {pct(r['wrong_class'])} % vy {pct(r['wrong_vy'])} % summary {'WRONG' if r['summary_wrong'] else 'ok'}"
            f" | informative {pct(r['informative'])} % width {r['width']:.2f} diverged {pct(r['diverged'])} %"
            f" | {r['wall_s']:.1f} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", choices=("full", "short"), default="full")
    ap.add_argument("--out", default="report/honesty")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    methods = tuple(m for m in args.methods.split(",") if m)
    specs = corpus(args.size)
    t0 = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(max_workers=max(args.jobs, 1)) as pool:
        for part in pool.map(_rows, specs, [methods] * len(specs)):
            for r in part:
                print(_line(r), flush=True)
                rows.append(r)
    write(rows, Path(args.out))
    ok = [r for r in rows if r.get("status") == "ok"]
    bad = [r for r in ok if not r["honest"]]
    print(f"\n{len(rows)} cells ({len(specs)} drives x {len(methods)} methods) in "
          f"{time.perf_counter() - t0:.0f} s; {len(rows) - len(ok)} failed to run; "
          f"{len(bad)} with more than 0.1 % wrong claims or a wrong summary:")
    for r in bad:
        print("  ", _line(r))
    print(f"table: {Path(args.out) / 'honesty_matrix.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
