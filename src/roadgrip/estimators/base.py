"""The output contract shared by every estimator.

Every estimator produces an :class:`EstimateResult`: one row per processed
sample in ``table`` with the shared columns below (where they apply; absent
ones are filled with NaN / missing so that every file has the same columns)
plus method-specific extras, and a JSON-serialisable ``meta`` dictionary.

Shared columns
--------------
==========================  ======  =====================================================
column                      unit    meaning
==========================  ======  =====================================================
``t``                       s       sample time
``mu_front``, ``mu_rear``   -       peak-friction estimate per axle (posterior mean)
``mu_*_lower/upper``        -       95 % band of the peak friction
``grip_class``              -       ``'high'``, ``'low'`` or ``'unknown'``
``grip_index``              -       continuous grip index in [0, 1] (1 = high grip)
``excited``                 bool    this sample carried friction information
``peak_observed_front``     bool    data reached the region of the front curve's peak
``peak_observed_rear``      bool    same, rear
==========================  ======  =====================================================

``meta['summary']`` follows the VSS ``Vehicle.Body...Friction`` style:
``{'MostProbable': float, 'LowerBound': float, 'UpperBound': float}`` for the
final estimate. ``meta['timing']`` holds ``{'wall_s', 'samples', 'samples_per_s',
'realtime_factor'}``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "CONTRACT_COLUMNS",
    "EstimateResult",
    "conform",
    "timed",
]

CONTRACT_COLUMNS: dict[str, str] = {
    "t": "float",
    "mu_front": "float",
    "mu_rear": "float",
    "mu_front_lower": "float",
    "mu_front_upper": "float",
    "mu_rear_lower": "float",
    "mu_rear_upper": "float",
    "grip_class": "str",
    "grip_index": "float",
    "excited": "bool",
    "peak_observed_front": "bool",
    "peak_observed_rear": "bool",
}


def conform(table: pd.DataFrame) -> pd.DataFrame:
    """Add missing contract columns (NaN, ``'unknown'`` or ``False``) and order them first."""
    out = table.copy()
    for col, kind in CONTRACT_COLUMNS.items():
        if col not in out.columns:
            if kind == "float":
                out[col] = np.nan
            elif kind == "str":
                out[col] = "unknown"
            else:
                out[col] = False
    extras = [c for c in out.columns if c not in CONTRACT_COLUMNS]
    return out[list(CONTRACT_COLUMNS) + extras]


@dataclass(frozen=True)
class EstimateResult:
    """One estimator run: per-step table, optional curve table, metadata."""

    method: str
    table: pd.DataFrame
    meta: dict[str, Any] = field(default_factory=dict)
    curves: pd.DataFrame | None = None

    def to_parquet(self, path: str | Path) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(conform(self.table), preserve_index=False)
        md = dict(table.schema.metadata or {})
        md[b"roadgrip_estimate"] = json.dumps(
            {"method": self.method, **self.meta}, default=_json_default
        ).encode()
        pq.write_table(table.replace_schema_metadata(md), str(path))

    @classmethod
    def read_parquet(cls, path: str | Path) -> EstimateResult:
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            tab = pq.read_table(str(path))
        except (OSError, pa.ArrowException) as exc:  # truncated or not Parquet
            raise ValueError(f"{path} cannot be read as an estimates file: "
                             f"{' '.join(str(exc).split())[:200]}") from None
        raw = (tab.schema.metadata or {}).get(b"roadgrip_estimate")
        if raw is None:
            raise ValueError(f"{path} is not a roadgrip estimates file (no roadgrip metadata)")
        try:
            meta = json.loads(raw)
        except ValueError:
            meta = None
        if not isinstance(meta, dict) or not isinstance(meta.get("method"), str):
            raise ValueError(f"{path}: its roadgrip metadata is damaged (no method)")
        method = meta.pop("method")
        return cls(method, tab.to_pandas(), meta)


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


@contextmanager
def timed(meta: dict[str, Any], samples: int, duration_s: float) -> Iterator[None]:
    """Record wall time, samples/s and real-time factor into ``meta['timing']``."""
    t0 = time.perf_counter()
    yield
    wall = max(time.perf_counter() - t0, 1e-12)
    meta["timing"] = {
        "wall_s": wall,
        "samples": int(samples),
        "samples_per_s": samples / wall,
        "realtime_factor": duration_s / wall,
    }


ProgressCallback = Callable[[int], None]
"""Called with the number of samples processed since the last call."""
