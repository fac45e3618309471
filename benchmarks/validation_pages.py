"""Write the generated parts of the validation pages from a honesty-matrix run.

``benchmarks/honesty_matrix.py --size full --out DIR`` writes ``DIR/honesty_matrix.csv``;
this script puts, between the ``<!-- generated: ... -->`` and ``<!-- end generated -->``
markers, the full matrix table into ``docs/validation-honesty.md`` and the per-method
summary (honest cells, the informative share per corpus) into ``docs/validation.md``.

Usage::

    python benchmarks/validation_pages.py DIR/honesty_matrix.csv [--docs docs]
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pandas as pd

from roadgrip.evaluate.honesty_matrix import table_markdown

CORPORA = (("simulated", "sim:"), ("multi-body", "mb:"), ("DART", "dart:"),
           ("frictionmaps", "frictionmaps:"), ("race car", "revs"))


def method_summary(df: pd.DataFrame) -> str:
    """Per method: honest cells and the largest informative share per corpus."""
    head = ["method", "honest cells"]
    counts = {label: df[df.drive.str.startswith(prefix)].drive.nunique() for label, prefix in CORPORA}
    head += [f"informative: {label} ({n})" for label, n in counts.items()]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for method, g in df.groupby("method", sort=False):
        cells = [method, f"{int(g.honest.sum())} of {len(g)}"]
        for _, prefix in CORPORA:
            sub = g[g.drive.str.startswith(prefix)]
            cells.append(f"up to {100 * sub.informative.max():.1f} %" if len(sub) else "–")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def replace_block(text: str, name: str, body: str) -> str:
    """``text`` with the block between the markers of ``name`` replaced by ``body``."""
    pat = re.compile(rf"(<!-- generated: {re.escape(name)} -->\n).*?(<!-- end generated -->)", re.S)
    if not pat.search(text):
        raise SystemExit(f"no '<!-- generated: {name} -->' block found")
    return pat.sub(lambda m: m.group(1) + body + m.group(2), text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", type=Path)
    ap.add_argument("--docs", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    args = ap.parse_args()
    df = pd.read_csv(args.csv)
    df["honest"] = df["honest"].astype(bool)
    dishonest = df[~df.honest]
    summary = (f"{len(df)} cells ({df.drive.nunique()} drives x {df.method.nunique()} methods), "
               f"{int(df.honest.sum())} honest; not honest: "
               + ", ".join(f"{r.drive} {r.method}" for r in dishonest.itertuples()) + ".\n\n")
    page = args.docs / "validation-honesty.md"
    page.write_text(replace_block(page.read_text(), "honesty-matrix", summary + table_markdown(df.to_dict("records"))))
    page = args.docs / "validation.md"
    page.write_text(replace_block(page.read_text(), "method-summary", method_summary(df)))
    print(summary.strip())


if __name__ == "__main__":
    main()
