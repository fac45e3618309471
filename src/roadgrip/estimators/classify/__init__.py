"""Friction-state classification (paper 002, Selmanaj, Corno, Savaresi): bRLS and the slip map.

==========================================  ==================================================
module                                      contents
==========================================  ==================================================
:mod:`.brls`                                bRLS estimator record :data:`BRLS`, regressors (eq. 4)
:mod:`.brls_config`                         bRLS settings and defaults
:mod:`.brls_kernel`                         compiled bRLS channels and state machine (eq. 6, 8)
:mod:`.slipmap`                             slip-map estimator record :data:`SLIPMAP`, its calibration
:mod:`.slipmap_config`                      slip-map settings and defaults
:mod:`.slipmap_evidence`                    reference accelerations, weights, probabilities (eq. 9-15)
:mod:`.slipmap_kernel`                      compiled recursion (eq. 16) and hysteresis class
:mod:`.calibration`                         :class:`Calibration` and the estimator configuration
:mod:`.learn`                               :func:`calibrate` from labelled drives
:mod:`.common`                              friction references, summary, settling rule
:mod:`.grip_model`                          saturation model: each class's accelerations from the slips
:mod:`.fit`                                 calibration of the saturation model
:mod:`.frontend`                            kinematic front end (slips, speed, lateral acceleration)
==========================================  ==================================================

Both records follow :mod:`roadgrip.estimators.protocol`; their one option is
``calibration`` (a :class:`Calibration` or ``None``).
"""

from __future__ import annotations

from roadgrip.estimators.classify.brls import BRLS, BRLSEstimatorConfig
from roadgrip.estimators.classify.brls_config import BRLSConfig, ChannelCalibration
from roadgrip.estimators.classify.calibration import Calibration, ClassifierConfig
from roadgrip.estimators.classify.common import DEFAULT_FRICTION, summary_meta
from roadgrip.estimators.classify.learn import calibrate
from roadgrip.estimators.classify.slipmap import SLIPMAP, SlipMapEstimatorConfig
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig

__all__ = [
    "BRLS",
    "DEFAULT_FRICTION",
    "SLIPMAP",
    "BRLSConfig",
    "BRLSEstimatorConfig",
    "Calibration",
    "ChannelCalibration",
    "ClassifierConfig",
    "SlipMapConfig",
    "SlipMapEstimatorConfig",
    "calibrate",
    "summary_meta",
]
