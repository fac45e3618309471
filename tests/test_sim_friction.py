"""Surfaces and friction fields: validation, serialisation, scaling."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.sim.friction import (
    ConstantFriction,
    Patch,
    PatchFriction,
    PiecewiseTime,
    SurfaceTires,
    brush_surface,
    encode_tire,
    field_from_dict,
    mu_at,
    surface_from_preset,
    tire_table,
)
from roadgrip.tire import SURFACES, Burckhardt
from roadgrip.vehicle import PRESETS


def test_preset_surface_round_trip_and_peaks():
    s = surface_from_preset("gravel")
    back = SurfaceTires.from_dict("gravel", s.to_dict())
    assert back.to_dict() == s.to_dict()
    assert s.mu == pytest.approx(SURFACES["gravel"].mu_peak)
    table, peaks = tire_table([s, surface_from_preset("snow")])
    assert table.shape == (2, 4, 5)
    np.testing.assert_allclose(peaks[1], [0.3, 0.3, 0.3, 0.3])
    with pytest.raises(ValueError, match="tarmac"):
        surface_from_preset("tarmac")


def test_scaled_surface_keeps_shape():
    s = surface_from_preset("dry_asphalt").scaled("half", 0.5)
    assert s.label == "half" and s.mu == pytest.approx(0.5)
    assert s.front.peak()[0] == pytest.approx(SURFACES["dry_asphalt"].lateral.peak()[0])


def test_brush_surface_matches_preset_cornering_stiffness():
    v = PRESETS["f1tenth"]
    s = brush_surface("low", 0.45, v)
    assert s.front.slope0() * v.fz_front == pytest.approx(v.cornering_stiffness_front)
    assert s.rear.slope0() * v.fz_rear == pytest.approx(v.cornering_stiffness_rear)
    assert s.mu == pytest.approx(0.45) and s.front_long.peak()[1] == pytest.approx(0.45)


def test_unsupported_curve_is_rejected():
    with pytest.raises(ValueError, match="Burckhardt"):
        encode_tire(Burckhardt(1.0, 20.0, 0.5))


def test_piecewise_time_validation_and_changes():
    f = PiecewiseTime((0.0, 5.0, 9.0), ("a", "b", "a"))
    assert f.labels == ("a", "b")
    assert f.changes == [{"t": 5.0, "from": "a", "to": "b"}, {"t": 9.0, "from": "b", "to": "a"}]
    np.testing.assert_array_equal(f.labels_at(np.array([0.0, 4.99, 5.0, 8.0, 9.0, 100.0]), 0, 0),
                                  [0, 0, 1, 1, 0, 0])
    with pytest.raises(ValueError, match="begin at 0"):
        PiecewiseTime((1.0, 2.0), ("a", "b"))
    with pytest.raises(ValueError, match="one start time"):
        PiecewiseTime((0.0,), ("a", "b"))


def test_patches_later_wins_and_validation():
    f = PatchFriction("base", (Patch(0, 2, 0, 2, "lo"), Patch(1, 3, 1, 3, "hi")))
    assert f.labels == ("base", "lo", "hi")
    got = f.labels_at(0.0, np.array([0.5, 1.5, 2.5, 5.0]), np.array([0.5, 1.5, 2.5, 5.0]))
    np.testing.assert_array_equal(got, [1, 2, 2, 0])
    d = f.to_dict()
    assert d["kind"] == "patches" and d["patches"][1]["surface"] == "hi"
    with pytest.raises(ValueError, match="x1 > x0"):
        Patch(1, 0, 0, 1, "x")
    assert ConstantFriction("a").to_dict() == {"kind": "constant", "surface": "a"}


def test_fields_round_trip_through_dicts():
    fields = [
        ConstantFriction("a"),
        PiecewiseTime((0.0, 5.0), ("a", "b")),
        PatchFriction("a", (Patch(0, 2, 0, 2, "b"),)),
    ]
    rng = np.random.default_rng(0)
    t, x, y = rng.uniform(0, 10, 200), rng.uniform(-1, 3, 200), rng.uniform(-1, 3, 200)
    for f in fields:
        back = field_from_dict(f.to_dict())
        assert back == f
        np.testing.assert_array_equal(back.labels_at(t, x, y), f.labels_at(t, x, y))
        mu = mu_at(dict(f.to_dict(), mu={"a": 0.7, "b": 0.3}), t, x, y)
        np.testing.assert_allclose(mu, np.where(f.labels_at(t, x, y) == 0, 0.7, 0.3))
    with pytest.raises(ValueError, match="kind"):
        field_from_dict({"kind": "spline"})
    with pytest.raises(ValueError, match="'mu'"):
        mu_at(ConstantFriction("a").to_dict(), 0.0, 0.0, 0.0)
