"""The common estimator check, in the spirit of scikit-learn's ``check_estimator``.

:func:`check_estimator` runs every check on one :class:`~roadgrip.estimators.protocol.Estimator`
and raises ``AssertionError`` naming the failed property. The test suite runs
it over every method of the registry; a new estimator passes it before it is
registered.

Checks
------
``config``
    ``Config()`` equals ``Config.from_options({})``, is frozen, and an
    unknown option is rejected by name.
``contract``
    ``run`` returns an :class:`~roadgrip.estimators.base.EstimateResult` whose
    table holds every contract column with its kind, one row per input
    sample time (strictly increasing, within the drive), classes in
    ``{'high', 'low', 'unknown'}``, a grip index in [0, 1], bands that hold
    their mean, no NaN where the estimator reports a friction, and a
    ``meta['summary']`` with a finite band.
``stepping``
    ``prepare`` / ``init`` / ``step`` over the samples give the rows ``run`` gives.
``seed``
    The same seed gives the same output.
``unexcited``
    On a drive without friction information the class is ``'unknown'`` and
    the summary band is at least 90 % as wide as ``prior_band(config)``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import CONTRACT_COLUMNS, EstimateResult
from roadgrip.estimators.protocol import Estimator, rows_to_table

__all__ = ["CHECKS", "check_estimator"]

CLASSES = {"high", "low", "unknown"}
MU_COLUMNS = [("mu_front", "mu_front_lower", "mu_front_upper"), ("mu_rear", "mu_rear_lower", "mu_rear_upper")]


def check_config(est: Estimator, drive: Drive, unexcited: Drive) -> None:
    cfg = est.Config()
    assert est.Config.from_options({}) == cfg, f"{est.name}: Config() differs from from_options({{}})"
    name = next(iter(dataclasses.fields(cfg))).name
    try:
        setattr(cfg, name, getattr(cfg, name))
    except dataclasses.FrozenInstanceError:
        pass
    else:
        raise AssertionError(f"{est.name}: Config is not frozen")
    try:
        est.Config.from_options({"no_such_option": 1})
    except ValueError as exc:
        assert "no_such_option" in str(exc), f"{est.name}: rejection does not name the option: {exc}"
    else:
        raise AssertionError(f"{est.name}: unknown option accepted")


def check_contract(est: Estimator, drive: Drive, unexcited: Drive) -> None:
    res = est.run(drive, est.Config(), 0)
    assert isinstance(res, EstimateResult), f"{est.name}: run returned {type(res).__name__}"
    assert res.method == est.name, f"{est.name}: result names method {res.method!r}"
    tab = res.table
    missing = [c for c in CONTRACT_COLUMNS if c not in tab.columns]
    assert not missing, f"{est.name}: contract columns missing: {missing}"
    assert len(tab) > 0, f"{est.name}: empty table"
    t = tab["t"].to_numpy(float)
    assert np.all(np.diff(t) > 0), f"{est.name}: output times not strictly increasing"
    assert t[0] >= drive.t[0] - 1e-9 and t[-1] <= drive.t[-1] + 1e-9, f"{est.name}: times outside the drive"
    assert np.isin(t, drive.t).all(), f"{est.name}: output times are not input sample times"
    cls = set(tab["grip_class"].astype(str))
    assert cls <= CLASSES, f"{est.name}: unknown classes {cls - CLASSES}"
    gi = tab["grip_index"].to_numpy(float)
    ok = np.isfinite(gi)
    assert np.all((gi[ok] >= 0) & (gi[ok] <= 1)), f"{est.name}: grip_index outside [0, 1]"
    for col in ("excited", "peak_observed_front", "peak_observed_rear"):
        assert tab[col].dtype == bool, f"{est.name}: {col} is {tab[col].dtype}, not bool"
    for mean, lo, hi in MU_COLUMNS:
        m, lo_, hi_ = (tab[c].to_numpy(float) for c in (mean, lo, hi))
        if np.isnan(m).all():
            continue  # the estimator does not report this axle's friction
        assert np.isfinite(m).all(), f"{est.name}: {mean} has NaN on {int(np.isnan(m).sum())} rows"
        assert np.isfinite(lo_).all() and np.isfinite(hi_).all(), f"{est.name}: {mean} band has NaN"
        assert np.all(lo_ <= m + 1e-12) and np.all(m <= hi_ + 1e-12), f"{est.name}: {mean} outside its band"
    summary = res.meta.get("summary", {})
    for key in ("MostProbable", "LowerBound", "UpperBound"):
        assert np.isfinite(summary.get(key, np.nan)), f"{est.name}: summary {key} missing or not finite"
    assert summary["LowerBound"] <= summary["MostProbable"] <= summary["UpperBound"], (
        f"{est.name}: summary MostProbable outside its band"
    )


def _assert_same(a: pd.DataFrame, b: pd.DataFrame, what: str, rtol: float = 1e-9) -> None:
    assert len(a) == len(b), f"{what}: {len(a)} rows vs {len(b)}"
    for col, kind in CONTRACT_COLUMNS.items():
        x, y = a[col].to_numpy(), b[col].to_numpy()
        if kind == "float":
            same = np.allclose(x.astype(float), y.astype(float), rtol=rtol, atol=1e-12, equal_nan=True)
        else:
            same = np.array_equal(x.astype(str), y.astype(str))
        assert same, f"{what}: column {col} differs"


def check_stepping(est: Estimator, drive: Drive, unexcited: Drive) -> None:
    cfg = est.Config()
    prepared = est.prepare(drive, cfg)
    state = est.init(prepared.info, cfg, 0)
    rows = []
    for sample in prepared.samples:
        state, row = est.step(state, sample)
        rows.append(row)
    stepped = rows_to_table(rows)
    _assert_same(stepped, est.run(drive, cfg, 0).table, f"{est.name}: stepping vs run")


def check_seed(est: Estimator, drive: Drive, unexcited: Drive) -> None:
    cfg = est.Config()
    _assert_same(est.run(drive, cfg, 3).table, est.run(drive, cfg, 3).table, f"{est.name}: same seed", rtol=0.0)


def check_unexcited(est: Estimator, drive: Drive, unexcited: Drive) -> None:
    cfg = est.Config()
    res = est.run(unexcited, cfg, 0)
    cls = set(res.table["grip_class"].astype(str))
    assert cls == {"unknown"}, f"{est.name}: unexcited drive classified {sorted(cls)}"
    lo, hi = est.prior_band(cfg)
    s = res.meta["summary"]
    width = s["UpperBound"] - s["LowerBound"]
    assert width >= 0.9 * (hi - lo), (
        f"{est.name}: unexcited band [{s['LowerBound']:.3f}, {s['UpperBound']:.3f}] narrower than "
        f"90 % of the prior band [{lo:.3f}, {hi:.3f}]"
    )


CHECKS: dict[str, Callable[[Estimator, Drive, Drive], None]] = {
    "config": check_config,
    "contract": check_contract,
    "stepping": check_stepping,
    "seed": check_seed,
    "unexcited": check_unexcited,
}


def check_estimator(est: Estimator, drive: Drive, unexcited: Drive, checks: tuple[str, ...] = tuple(CHECKS)) -> None:
    """Run the named checks (all by default) of ``est`` on an excited and an unexcited drive.

    Raises
    ------
    AssertionError
        Naming the estimator and the property that failed.
    """
    for name in checks:
        CHECKS[name](est, drive, unexcited)
