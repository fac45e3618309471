"""Evaluation: accuracy metrics against truth, the scenario suite and the benchmark.

* :mod:`roadgrip.evaluate.metrics`: metric functions on plain arrays.
* :mod:`roadgrip.evaluate.suite`: which estimator runs on which scenario or
  real data set, how each run is scored, and ``roadgrip bench``.
* :mod:`roadgrip.evaluate.maps`: friction grids of a run and their cell truth.
* :mod:`roadgrip.truth`: the true axle friction curve of a simulated drive,
  parametric or binned from its truth columns, and the axles' friction utilisation.

The output contract the metrics read is described in ``docs/output-contract.md``.
"""

from roadgrip.evaluate.metrics import (
    ClassificationMetrics,
    CurveMetrics,
    DetectionEvent,
    MapMetrics,
    band_coverage,
    cell_truth,
    classification_accuracy,
    confident_wrong_class_rate,
    confident_wrong_rate,
    count_switches,
    covered_mask,
    curve_error,
    detection_delays,
    map_metrics,
    peak_error,
    sustained,
    true_peak_series,
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
    "bench_cli",
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
    "truth_excitation",
    "truth_grip_class",
]


def bench_cli(output, *, quick: bool = False, seed: int = 0, console=None):
    """``roadgrip bench``: see :func:`roadgrip.evaluate.suite.bench_cli`."""
    from roadgrip.evaluate.suite import bench_cli as _bench_cli

    return _bench_cli(output, quick=quick, seed=seed, console=console)
