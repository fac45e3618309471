"""The calibration of the classifiers and the configuration that carries it.

A :class:`Calibration` holds what :func:`roadgrip.estimators.classify.calibrate`
learns from labelled drives: the bRLS settings, the slip-map settings, the
peak-friction reference of each class, and the provenance. It converts to and
from a plain dictionary (:meth:`Calibration.to_dict`, :meth:`Calibration.from_dict`),
which the command line writes as YAML (:mod:`roadgrip.cli.calibrate`).

:class:`ClassifierConfig` is the estimator configuration of both classifiers:
one option, ``calibration`` (``None`` = the uncalibrated defaults).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from roadgrip.estimators.classify.brls_config import BRLSConfig
from roadgrip.estimators.classify.common import DEFAULT_FRICTION, friction_refs
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.estimators.protocol import EstimatorConfig, to_plain

__all__ = ["CALIBRATION_VERSION", "Calibration", "ClassifierConfig"]

CALIBRATION_VERSION = 1
"""Version of the dictionary layout of :meth:`Calibration.to_dict`."""


@dataclass(frozen=True)
class Calibration:
    """What the classifiers learn from labelled drives.

    Attributes
    ----------
    brls : BRLSConfig
        bRLS references, thresholds and settings.
    slipmap : SlipMapConfig or None
        Slip-map settings (``None``: the calibration has no slip-map part).
    slipmap_fit : dict
        Scores of the slip-map fit (balanced accuracies, final score).
    vehicle : str
        Vehicle name of the labelled drives.
    drives : tuple of dict
        Provenance: source, label, samples.
    diagnostics : dict
        Score of the winning bRLS settings and each channel's status.
    friction : dict
        Peak-friction reference of each class, ``{'high': float, 'low': float}``
        (mapped to ``meta['summary']``, see
        :func:`roadgrip.estimators.classify.common.summary_meta`).
    """

    brls: BRLSConfig
    slipmap: SlipMapConfig | None = None
    slipmap_fit: dict[str, Any] = field(default_factory=dict)
    vehicle: str = ""
    drives: tuple[dict[str, Any], ...] = ()
    diagnostics: dict[str, Any] = field(default_factory=dict)
    friction: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_FRICTION))

    def __post_init__(self) -> None:
        if not isinstance(self.brls, BRLSConfig):
            raise ValueError(f"brls must be a BRLSConfig, got {type(self.brls).__name__}")
        if self.slipmap is not None and not isinstance(self.slipmap, SlipMapConfig):
            raise ValueError(f"slipmap must be a SlipMapConfig or None, got {type(self.slipmap).__name__}")
        object.__setattr__(self, "friction", friction_refs(self.friction, "calibration"))

    def __hash__(self) -> int:
        return hash((self.brls, self.slipmap, self.vehicle, tuple(sorted(self.friction.items()))))

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary of builtin types (YAML-able), read back by :meth:`from_dict`."""
        slipmap: dict[str, Any] = {}
        if self.slipmap is not None:
            slipmap = {"config": self.slipmap.to_dict(), "fit": dict(self.slipmap_fit)}
        doc = {
            "roadgrip_calibration": CALIBRATION_VERSION,
            "vehicle": self.vehicle,
            "drives": [dict(d) for d in self.drives],
            "brls": self.brls.to_dict(),
            "slipmap": slipmap,
            "diagnostics": to_plain(self.diagnostics),
            "friction": {k: float(v) for k, v in self.friction.items()},
        }
        return to_plain(doc)

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], where: str = "calibration") -> Calibration:
        """The calibration of a :meth:`to_dict` dictionary.

        Raises
        ------
        ValueError
            Naming ``where`` when ``doc`` is not a roadgrip calibration or its contents are invalid.
        """
        if not isinstance(doc, Mapping) or "roadgrip_calibration" not in doc:
            raise ValueError(f"{where} is not a roadgrip calibration (no 'roadgrip_calibration' key)")
        if doc["roadgrip_calibration"] != CALIBRATION_VERSION:
            raise ValueError(f"{where}: unsupported calibration version {doc['roadgrip_calibration']!r}")
        if "brls" not in doc:
            raise ValueError(f"{where}: calibration lacks the 'brls' section")
        sm = dict(doc.get("slipmap") or {})
        return cls(
            brls=BRLSConfig.from_dict(doc["brls"]),
            slipmap=SlipMapConfig.from_dict(sm["config"]) if "config" in sm else None,
            slipmap_fit=dict(sm.get("fit") or {}),
            vehicle=str(doc.get("vehicle", "")),
            drives=tuple(doc.get("drives") or ()),
            diagnostics=dict(doc.get("diagnostics") or {}),
            friction=friction_refs(doc.get("friction") or DEFAULT_FRICTION, where),
        )


@dataclass(frozen=True)
class ClassifierConfig(EstimatorConfig):
    """Configuration of a paper 002 classifier.

    Attributes
    ----------
    calibration : Calibration or None
        Learned settings and friction references; ``None`` runs the
        uncalibrated defaults (dry-asphalt / gravel presets).
    """

    calibration: Calibration | None = None

    def __post_init__(self) -> None:
        if self.calibration is not None and not isinstance(self.calibration, Calibration):
            raise ValueError(
                f"calibration must be a Calibration or None, got {type(self.calibration).__name__}"
            )

    @property
    def friction(self) -> dict[str, float]:
        """Peak-friction reference of each class."""
        return dict(self.calibration.friction if self.calibration else DEFAULT_FRICTION)
