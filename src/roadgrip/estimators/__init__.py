"""Friction estimators, one module per method, and the method registry.

==========  ==================================================  ==========
method      module                                              paper
==========  ==================================================  ==========
gpssm       :mod:`roadgrip.estimators.gpssm`                    000
brls        :mod:`roadgrip.estimators.brls`                     002
slipmap     :mod:`roadgrip.estimators.slipmap`                  002
cascade     :mod:`roadgrip.estimators.cascade`                  003
==========  ==================================================  ==========

Each method module exposes ``run_cli(drive, request) -> EstimateResult``;
:func:`run_estimator` imports it lazily so that the CLI starts fast.
"""

from __future__ import annotations

import importlib

from roadgrip.estimators.base import CONTRACT_COLUMNS, EstimateRequest, EstimateResult

__all__ = ["CONTRACT_COLUMNS", "METHODS", "EstimateRequest", "EstimateResult", "run_estimator"]

METHODS: dict[str, str] = {
    "gpssm": "roadgrip.estimators.gpssm",
    "brls": "roadgrip.estimators.brls",
    "slipmap": "roadgrip.estimators.slipmap",
    "cascade": "roadgrip.estimators.cascade",
}


def run_estimator(method: str, drive, request: EstimateRequest | None = None) -> EstimateResult:
    """Run ``method`` over a whole :class:`~roadgrip.drive.Drive`."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {sorted(METHODS)}")
    module = importlib.import_module(METHODS[method])
    return module.run_cli(drive, request or EstimateRequest())
