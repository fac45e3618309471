"""Friction estimators, one package per method family, and the method registry.

==========  ===============================================  ==========
method      record                                           paper
==========  ===============================================  ==========
gpssm       :data:`roadgrip.estimators.gpssm.ESTIMATOR`      000
brls        :data:`roadgrip.estimators.classify.BRLS`        002
slipmap     :data:`roadgrip.estimators.classify.SLIPMAP`     002
cascade     :data:`roadgrip.estimators.cascade.ESTIMATOR`    003
==========  ===============================================  ==========

Every method is an :class:`~roadgrip.estimators.protocol.Estimator` record
(see :mod:`roadgrip.estimators.protocol`); :func:`get` imports it lazily so
that the command line starts fast.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from roadgrip.estimators.base import CONTRACT_COLUMNS, EstimateResult, ProgressCallback
from roadgrip.estimators.protocol import DriveInfo, Estimator, EstimatorConfig

__all__ = [
    "CONTRACT_COLUMNS",
    "METHODS",
    "EstimateResult",
    "Estimator",
    "EstimatorConfig",
    "get",
    "names",
    "register",
    "run_estimator",
    "unregister",
]

METHODS: dict[str, str] = {
    "gpssm": "roadgrip.estimators.gpssm:ESTIMATOR",
    "brls": "roadgrip.estimators.classify:BRLS",
    "slipmap": "roadgrip.estimators.classify:SLIPMAP",
    "cascade": "roadgrip.estimators.cascade:ESTIMATOR",
}
"""Method name -> ``'module:attribute'`` of its :class:`Estimator` record."""

_REGISTERED: dict[str, Estimator] = {}


def register(estimator: Estimator) -> None:
    """Add an estimator that is not part of the package (a plug-in or a test's)."""
    if estimator.name in METHODS:
        raise ValueError(f"method {estimator.name!r} is a built-in method")
    _REGISTERED[estimator.name] = estimator


def unregister(name: str) -> None:
    """Remove an estimator added by :func:`register`."""
    _REGISTERED.pop(name, None)


def names() -> list[str]:
    """Every method name: the built-in ones, then the registered ones."""
    return [*METHODS, *_REGISTERED]


def get(method: str) -> Estimator:
    """The :class:`Estimator` record of ``method``."""
    if method in _REGISTERED:
        return _REGISTERED[method]
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {', '.join(names())}")
    module, attr = METHODS[method].split(":")
    return getattr(importlib.import_module(module), attr)


def run_estimator(
    method: str,
    drive: Any,
    config: EstimatorConfig | Mapping[str, Any] | None = None,
    *,
    seed: int = 0,
    progress: ProgressCallback | None = None,
) -> EstimateResult:
    """Run ``method`` over a whole :class:`~roadgrip.drive.Drive`.

    ``config`` is the method's ``Config``, a mapping of options for
    ``Config.from_options`` or ``None`` for the defaults. ``meta['lookahead']`` [s] is
    the run's declared look-ahead (``Estimator.lookahead``; the method's own value
    where its ``run`` sets one).
    """
    est = get(method)
    if config is None or isinstance(config, Mapping):
        config = est.Config.from_options(config)
    elif not isinstance(config, est.Config):
        raise TypeError(f"{method} takes a {est.Config.__name__}, got {type(config).__name__}")
    result = est.run(drive, config, seed, progress)
    if "lookahead" not in result.meta:
        result.meta["lookahead"] = float(est.lookahead(config, DriveInfo.from_drive(drive)))
    return result
