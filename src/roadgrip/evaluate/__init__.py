"""Evaluation: accuracy metrics against truth, the scenario suite and the benchmark.

* :mod:`roadgrip.evaluate.metrics`: metric functions on plain arrays, and the
  truth series of a simulated drive they are compared with.
* :mod:`roadgrip.evaluate.map_metrics`: accuracy and calibration of a friction grid.
* :mod:`roadgrip.evaluate.cases`: which estimator runs on which scenario or real
  data set (:class:`~roadgrip.evaluate.cases.BenchSettings`, ``default_cases``).
* :mod:`roadgrip.evaluate.suite`: running the cases (``run_suite``, ``bench``).
* :mod:`roadgrip.evaluate.scoring`: how each run is scored.
* :mod:`roadgrip.evaluate.table`: the benchmark table and its Markdown/CSV files.
* :mod:`roadgrip.evaluate.maps`: friction grids of a run and their cell truth.
* :mod:`roadgrip.truth`: the true axle friction curve of a simulated drive,
  parametric or binned from its truth columns, and the axles' friction utilisation.

The output contract the metrics read is described in ``docs/output-contract.md``.
"""

from roadgrip.evaluate.map_metrics import MapMetrics, cell_truth, map_metrics
from roadgrip.evaluate.metrics import (
    ClassificationMetrics,
    CurveMetrics,
    DetectionEvent,
    band_coverage,
    classification_accuracy,
    confident_wrong_class_rate,
    confident_wrong_rate,
    count_switches,
    covered_mask,
    curve_error,
    detection_delays,
    peak_error,
    sustained,
    true_peak_series,
    truth_at_estimates,
    truth_excitation,
    truth_grip_class,
)
from roadgrip.truth import (
    BinnedCurve,
    binned_truth_curve,
    friction_utilisation,
    has_parametric_truth,
    true_curve,
)

__all__ = [
    "BinnedCurve",
    "ClassificationMetrics",
    "CurveMetrics",
    "DetectionEvent",
    "MapMetrics",
    "band_coverage",
    "binned_truth_curve",
    "cell_truth",
    "classification_accuracy",
    "confident_wrong_class_rate",
    "confident_wrong_rate",
    "count_switches",
    "covered_mask",
    "curve_error",
    "detection_delays",
    "friction_utilisation",
    "has_parametric_truth",
    "map_metrics",
    "peak_error",
    "sustained",
    "true_curve",
    "true_peak_series",
    "truth_at_estimates",
    "truth_excitation",
    "truth_grip_class",
]

