"""VehicleParams: presets, YAML round trip, validation naming the field."""

from __future__ import annotations

import math

import pytest
import yaml

from roadgrip.constants import GRAVITY
from roadgrip.vehicle import PRESET_SOURCES, PRESETS, VehicleParams, load_vehicle


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_load_and_are_consistent(name):
    v = PRESETS[name]
    assert v.name == name
    assert name in PRESET_SOURCES and len(PRESET_SOURCES[name]) > 50
    assert v.fz_front + v.fz_rear == pytest.approx(v.mass * GRAVITY)
    assert v.fz_front * v.lf == pytest.approx(v.fz_rear * v.lr)  # moment balance
    assert v.wheelbase == pytest.approx(v.lf + v.lr)
    assert load_vehicle(name) is v


def test_data_set_presets_match_the_data_readme():
    f1 = PRESETS["f1tenth"]
    assert (f1.mass, f1.yaw_inertia, f1.lf, f1.lr, f1.cg_height) == (3.33, 0.0687, 0.112, 0.208, 0.075)
    assert 2 * math.pi * f1.wheel_radius == pytest.approx(0.319, abs=1e-3)
    assert f1.gear_ratio == 11.85
    jr = PRESETS["jetracer"]
    assert (jr.mass, jr.lf, jr.lr, jr.yaw_inertia) == (1.58, 0.0805, 0.093, 0.0048)
    assert jr.drive == "rwd"


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_yaml_round_trip(tmp_path, name):
    p = tmp_path / f"{name}.yaml"
    PRESETS[name].to_yaml(p)
    back = VehicleParams.from_yaml(p)
    assert back == PRESETS[name]
    assert load_vehicle(p) == PRESETS[name]
    assert load_vehicle(str(p)) == PRESETS[name]


def test_unknown_key_rejected(tmp_path):
    d = PRESETS["sedan"].to_dict() | {"masss": 1500.0}
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ValueError, match=r"unknown vehicle field\(s\) \['masss'\]"):
        load_vehicle(p)


def test_missing_key_rejected():
    d = PRESETS["sedan"].to_dict()
    del d["lf"]
    with pytest.raises(ValueError, match=r"missing vehicle field\(s\) \['lf'\]"):
        VehicleParams.from_dict(d)


@pytest.mark.parametrize(
    ("field", "value"),
    [("mass", 0.0), ("mass", -1500.0), ("lf", 0.0), ("lr", -0.1), ("yaw_inertia", float("nan")),
     ("wheel_radius", float("inf")), ("cg_height", "high"), ("track_width", True)],
)
def test_invalid_value_names_the_field(tmp_path, field, value):
    d = PRESETS["sedan"].to_dict() | {field: value}
    with pytest.raises(ValueError, match=f"vehicle field '{field}'"):
        VehicleParams.from_dict(d)
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ValueError, match=f"vehicle field '{field}'"):
        load_vehicle(p)


def test_invalid_drive_and_steer():
    with pytest.raises(ValueError, match="vehicle field 'drive'"):
        PRESETS["sedan"].replace(drive="4x4")
    with pytest.raises(ValueError, match="vehicle field 'max_steer'"):
        PRESETS["sedan"].replace(max_steer=2.0)


def test_load_vehicle_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown vehicle 'tractor'"):
        load_vehicle("tractor")
    with pytest.raises(ValueError, match="vehicle file not found"):
        load_vehicle(tmp_path / "none.yaml")
    p = tmp_path / "broken.yaml"
    p.write_text("mass: [1, 2\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_vehicle(p)
    p.write_text("")
    with pytest.raises(ValueError, match="must be a mapping"):
        load_vehicle(p)


def test_understeer_gradient_formula():
    v = PRESETS["f1tenth"]
    k = v.mass / v.wheelbase * (v.lr / v.cornering_stiffness_front - v.lf / v.cornering_stiffness_rear)
    assert v.understeer_gradient == pytest.approx(k)
    assert v.understeer_gradient > 0


def test_vehicle_path_that_is_a_folder(tmp_path):
    d = tmp_path / "car.yaml"
    d.mkdir()
    with pytest.raises(ValueError, match="cannot be read"):
        load_vehicle(d)
