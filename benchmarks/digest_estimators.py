"""Digest of every estimator's output on the quick bench drives.

Runs the quick benchmark's cases (simulated, multi-body and, where present,
the shared real data), and writes for each case the estimates table, the
posterior curves, the friction-map cells and the scores to a directory,
plus ``digest.json`` with one SHA-256 per case and table. Two directories
written by different versions of the code are compared with ``--compare``:
the script prints, per case and column, whether the values are identical
and otherwise the largest absolute difference.

Usage::

    python benchmarks/digest_estimators.py OUT_DIR [--compare OTHER_DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.evaluate.suite import QUICK, default_cases, run_suite

TIMING = {"wall_s", "rtf", "samples_per_s"}
"""Scores that measure speed, not output: left out of the digest."""


def _key(case) -> str:
    return f"{case.drive}|{case.label}".replace("/", "_").replace(":", "~")


def _frames(rec) -> dict[str, pd.DataFrame]:
    out: dict[str, pd.DataFrame] = {}
    if rec.result is not None:
        out["table"] = rec.result.table.reset_index(drop=True)
        if rec.result.curves is not None:
            out["curves"] = rec.result.curves.reset_index(drop=True)
    if rec.map_cells is not None:
        out["cells"] = rec.map_cells.reset_index(drop=True)
    scores = {k: v for k, v in rec.metrics.items() if k not in TIMING}
    if scores:
        out["metrics"] = pd.DataFrame({k: [float(v)] for k, v in sorted(scores.items())})
    return out


def _sha(frame: pd.DataFrame) -> str:
    h = hashlib.sha256()
    for col in frame.columns:
        h.update(str(col).encode())
        values = frame[col].to_numpy()
        if values.dtype.kind in "fiub":
            h.update(np.ascontiguousarray(values.astype(np.float64)).tobytes())
        else:
            h.update("\x1f".join(map(str, values)).encode())
    return h.hexdigest()


def write(out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    cases = default_cases(QUICK)
    t0 = time.perf_counter()
    records = run_suite(cases, QUICK, seed=0)
    digest: dict = {}
    for rec in records:
        key = _key(rec.case)
        entry = {"status": rec.status}
        for name, frame in _frames(rec).items():
            frame.to_parquet(out / f"{key}.{name}.parquet")
            entry[name] = _sha(frame)
        digest[key] = entry
    (out / "digest.json").write_text(json.dumps(digest, indent=1, sort_keys=True))
    print(f"{len(records)} cases in {time.perf_counter() - t0:.0f} s -> {out}/digest.json")
    return digest


def _diff(a: pd.DataFrame, b: pd.DataFrame) -> list[str]:
    lines = []
    if len(a) != len(b):
        return [f"rows {len(a)} vs {len(b)}"]
    for col in sorted(set(a.columns) | set(b.columns)):
        if col not in a.columns or col not in b.columns:
            lines.append(f"{col}: only in {'new' if col in a.columns else 'old'}")
            continue
        x, y = a[col].to_numpy(), b[col].to_numpy()
        if x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
            x, y = x.astype(float), y.astype(float)
            same_nan = np.isnan(x) == np.isnan(y)
            if not same_nan.all():
                lines.append(f"{col}: NaN pattern differs on {(~same_nan).sum()} rows")
                continue
            ok = ~np.isnan(x)
            d = float(np.max(np.abs(x[ok] - y[ok]), initial=0.0))
            if d > 0:
                lines.append(f"{col}: max |diff| {d:.3g}")
        elif not np.array_equal(x.astype(str), y.astype(str)):
            lines.append(f"{col}: {(x.astype(str) != y.astype(str)).sum()} rows differ")
    return lines


def compare(new: Path, old: Path) -> int:
    dn = json.loads((new / "digest.json").read_text())
    do = json.loads((old / "digest.json").read_text())
    differing = 0
    for key in sorted(set(dn) | set(do)):
        if key not in dn or key not in do:
            print(f"{key}: only in {'new' if key in dn else 'old'}")
            differing += 1
            continue
        if dn[key] == do[key]:
            print(f"{key}: identical")
            continue
        differing += 1
        print(f"{key}: DIFFERS (status {do[key]['status']!r} -> {dn[key]['status']!r})")
        for name in ("table", "curves", "cells", "metrics"):
            pn, po = new / f"{key}.{name}.parquet", old / f"{key}.{name}.parquet"
            if pn.exists() and po.exists() and dn[key].get(name) != do[key].get(name):
                for line in _diff(pd.read_parquet(pn), pd.read_parquet(po)):
                    print(f"    {name}.{line}")
    print(f"{differing} of {len(set(dn) | set(do))} cases differ")
    return differing


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--compare", type=Path, default=None)
    args = ap.parse_args(argv)
    write(args.out)
    if args.compare is not None:
        compare(args.out, args.compare)
    return 0


if __name__ == "__main__":
    sys.exit(main())
