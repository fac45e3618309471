"""A few rows of NumPy columns read as a DataFrame's columns, without pandas' per-call cost.

:class:`ArrayFrame` answers the part of :class:`pandas.DataFrame` that
:class:`~roadgrip.drive.Drive` and the estimate tables' readers use (``frame[name].to_numpy(dtype)``,
``name in frame.columns``, ``len(frame)``, ``frame[name].astype(str)``), so that the
methods' own ``prepare`` runs on the last sample or two of a live stream
(:class:`~roadgrip.estimators.online.OnlineEstimator`) and the VSS rules
(:func:`roadgrip.io.vss.vss_records`) on one output row: the same implementation as on a
whole drive, at the cost of a handful of NumPy calls instead of a DataFrame's construction
(about a millisecond, the whole budget of a live row).

Nothing is validated here: the rows come from a stream whose first samples went through
:meth:`~roadgrip.drive.Drive.from_frame` and whose later ones were checked one by one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import DTypeLike

__all__ = ["ArrayColumn", "ArrayFrame"]


class ArrayColumn(np.ndarray):
    """A 1-D array with the ``to_numpy`` of a :class:`pandas.Series`."""

    def to_numpy(self, dtype: DTypeLike = None, copy: bool = False) -> np.ndarray:
        """The values as a plain ndarray (of ``dtype``; a copy when ``copy``)."""
        out = np.asarray(self.view(np.ndarray), dtype=dtype)
        return out.copy() if copy else out


class ArrayFrame:
    """Named 1-D columns of one length, read as a DataFrame's columns (module docstring).

    Parameters
    ----------
    columns : mapping of str to array_like, each shape (n,)

    Examples
    --------
    >>> f = ArrayFrame({"t": [0.0, 0.01], "ay": [0.5, 0.6]})
    >>> len(f), "ay" in f.columns, f["ay"].to_numpy(float).tolist()
    (2, True, [0.5, 0.6])
    """

    def __init__(self, columns: Mapping[str, Any]) -> None:
        self._cols = {str(k): np.asarray(v).view(ArrayColumn) for k, v in columns.items()}
        lengths = {len(v) for v in self._cols.values()}
        if len(lengths) > 1:
            raise ValueError(f"columns of different lengths: {sorted(lengths)}")
        self._n = lengths.pop() if lengths else 0
        self.columns: Sequence[str] = tuple(self._cols)
        self._records: Sequence[Mapping[str, Any]] = ()

    @classmethod
    def from_records(cls, records: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> ArrayFrame:
        """The frame of ``records`` (one mapping per row, each with every one of ``columns``)
        over ``columns``. A column becomes an array when it is first read: a reader that
        needs a few of many columns pays for those."""
        frame = cls({})
        frame._records = list(records)
        frame._n = len(frame._records)
        frame.columns = tuple(str(c) for c in columns)
        return frame

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, name: str) -> ArrayColumn:
        col = self._cols.get(name)
        if col is None:
            if name not in self.columns:  # every column of a frame not from records is built
                raise KeyError(name)
            col = self._cols[name] = np.asarray([r[name] for r in self._records]).view(ArrayColumn)
        return col
