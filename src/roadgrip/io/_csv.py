"""CSV parsing that reads floats back exactly."""

from __future__ import annotations

from typing import Any

import pandas as pd

_PANDAS_MAJOR = int(pd.__version__.split(".")[0])


def read_csv_exact(src: Any, **kwargs: Any) -> pd.DataFrame:
    """``pandas.read_csv`` with exact (round-trip) float parsing.

    pandas < 3 needs ``float_precision='round_trip'`` for that; from pandas 3 the
    default parser is exact and the argument is deprecated.
    """
    if _PANDAS_MAJOR < 3:
        kwargs.setdefault("float_precision", "round_trip")
    return pd.read_csv(src, **kwargs)
