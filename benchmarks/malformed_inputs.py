"""Malformed files through every reader and command: counts per class (tests/malformed_corpus.py).

Each kind of input file (drives and the files beside them) under each mutation, drawn
with ``--seeds`` seeds, goes to every entry that takes it (the library reader,
``roadgrip info``, ``estimate``, ``map``, ``vehicle fit``, ``calibrate``, the fleet's
per-drive task). Prints, per kind and per mutation, how many runs were accepted,
refused naming the file or a mutated column, refused without naming one ("vague"),
and crashed (an exception other than ``ValueError``, or one raised from it), then the
first crash and vague message of each class. Exit status 1 when anything crashed.

    .venv/bin/python benchmarks/malformed_inputs.py [--seeds N] [--kinds csv,mdf,...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import malformed_corpus as M

STATUSES = ("accepted", "refused", "vague", "crash")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10, help="seeds per kind and mutation")
    ap.add_argument("--kinds", default=",".join(M.KINDS))
    a = ap.parse_args()
    kinds = [k for k in a.kinds.split(",") if k]
    if any(k in M.REALDATA_KINDS for k in kinds) and not (M.DART_RUN.is_file() and M.FM_RUN.is_dir()):
        print("../shared/data not present: dart and frictionmaps left out")
        kinds = [k for k in kinds if k not in M.REALDATA_KINDS]
    by_kind: dict[str, Counter] = defaultdict(Counter)
    by_mutation: dict[str, Counter] = defaultdict(Counter)
    by_entry: dict[str, Counter] = defaultdict(Counter)
    examples: dict[tuple[str, str, str], str] = {}
    t0 = time.perf_counter()
    n_inputs = 0
    with tempfile.TemporaryDirectory() as tmp:
        for kind in kinds:
            for mutation in M.mutations_of(kind):
                for seed in range(a.seeds):
                    try:
                        case = M.make_case(kind, mutation, 1000 * seed + 17, Path(tmp) / kind)
                    except Exception as exc:  # a generator that cannot write this case: say so
                        examples.setdefault(("no case", kind, mutation), f"{type(exc).__name__}: {exc}"[:160])
                        continue
                    n_inputs += 1
                    for entry in M.entries_of(kind):
                        out = M.run_entry(case, entry, Path(tmp) / "out")
                        by_kind[kind][out.status] += 1
                        by_mutation[mutation][out.status] += 1
                        by_entry[entry][out.status] += 1
                        if out.status in ("crash", "vague"):
                            examples.setdefault((out.status, kind, mutation),
                                                f"{entry} seed {1000 * seed + 17}: {out.message[:160]}")
    total: Counter = sum(by_kind.values(), Counter())
    print(f"{n_inputs} malformed inputs, {sum(total.values())} runs through "
          f"{len(M.ENTRIES)} entries in {time.perf_counter() - t0:.0f} s")
    for title, table in (("kind", by_kind), ("mutation", by_mutation), ("entry", by_entry)):
        print(f"\n{title:18s}" + "".join(f"{s:>10s}" for s in STATUSES))
        for key, c in table.items():
            print(f"{key:18s}" + "".join(f"{c[s]:10d}" for s in STATUSES))
    print(f"{'total':18s}" + "".join(f"{total[s]:10d}" for s in STATUSES))
    for (status, kind, mutation), msg in sorted(examples.items()):
        print(f"  {status:6s} {kind}/{mutation}: {msg}")
    print(f"\nuncaught exceptions: {total['crash']} of {sum(total.values())} runs")
    return 1 if total["crash"] else 0


if __name__ == "__main__":
    sys.exit(main())
