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


# -- physical ranges and the YAML user experience --------------------------------------------

@pytest.mark.parametrize(
    ("field", "value"),
    [("mass", 5e-324), ("mass", 1e6), ("lr", 1e300), ("lf", 1e-5), ("yaw_inertia", 1e9),
     ("cg_height", 40.0), ("wheel_radius", 20.0), ("track_width", 1e-4), ("wheel_inertia", 1e5),
     ("cornering_stiffness_front", 1e12), ("cornering_stiffness_rear", 0.01), ("gear_ratio", 1e9),
     ("max_steer", 1.56), ("roll_gradient", -0.01)],
)
def test_value_outside_physical_range_names_field_value_and_range(field, value):
    from roadgrip.vehicle.params import FIELD_RANGES

    _lo, hi, unit, _ = FIELD_RANGES[field]
    with pytest.raises(ValueError, match=f"vehicle field '{field}'") as exc:
        PRESETS["sedan"].replace(**{field: value})
    msg = str(exc.value)
    assert repr(value) in msg and f"{hi:g}" in msg and unit in msg


def test_ranges_hold_every_preset_and_a_heavy_truck():
    from roadgrip.vehicle.params import FIELD_RANGES

    for v in PRESETS.values():
        for f, (lo, hi, _, _) in FIELD_RANGES.items():
            assert lo <= getattr(v, f) <= hi, (v.name, f)
    truck = PRESETS["suv"].replace(name="truck", mass=40_000.0, yaw_inertia=3.0e5, lf=3.5, lr=2.5,
                                   cg_height=2.0, wheel_radius=0.53, track_width=2.05,
                                   wheel_inertia=30.0, cornering_stiffness_front=1.2e6,
                                   cornering_stiffness_rear=2.4e6)
    assert truck.mass == 40_000.0


def test_missing_fields_reported_at_once_with_units():
    d = PRESETS["sedan"].to_dict()
    for k in ("mass", "lf", "wheel_radius"):
        del d[k]
    with pytest.raises(ValueError) as exc:
        VehicleParams.from_dict(d)
    msg = str(exc.value)
    assert "['mass', 'lf', 'wheel_radius']" in msg
    assert "mass [kg]" in msg and "lf [m]" in msg and "wheel_radius [m]" in msg


@pytest.mark.parametrize("encoding", ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be"])
def test_yaml_in_any_unicode_encoding_and_name_from_stem(tmp_path, encoding):
    d = PRESETS["sedan"].to_dict()
    del d["name"]
    p = tmp_path / "my-truck.yaml"
    p.write_bytes(yaml.safe_dump(d).encode(encoding))
    v = load_vehicle(p)
    assert v.name == "my-truck"
    assert v == PRESETS["sedan"].replace(name="my-truck")


def test_numeric_name_becomes_text_and_bad_bytes_name_the_line(tmp_path):
    v = PRESETS["sedan"].replace(name=12345)
    assert v.name == "12345"
    p = tmp_path / "v.yaml"
    p.write_bytes(b"name: a\nmass: \xff\xfe\xfd 1\n")
    with pytest.raises(ValueError, match=r"v.yaml:2: not UTF-8"):
        load_vehicle(p)
    p.write_text(yaml.safe_dump(PRESETS["sedan"].to_dict() | {"name": ["a", "b"]}))
    with pytest.raises(ValueError, match="vehicle field 'name'"):
        load_vehicle(p)


def test_cli_template_loads_back_and_list_shows_multibody(tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    runner = CliRunner()
    out = tmp_path / "van.yaml"
    res = runner.invoke(app, ["vehicle", "template", "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "mass: 1500.0  # [kg]" in text
    v = load_vehicle(out)
    assert v == PRESETS["sedan"].replace(name="van")
    res = runner.invoke(app, ["vehicle", "template", "-o", str(out)])
    assert res.exit_code != 0 and "exists" in str(res.exception)
    res = runner.invoke(app, ["vehicle", "list"])
    assert res.exit_code == 0
    for name in PRESETS:
        assert name in res.output
    rows = [line for line in res.output.splitlines() if "ford-escort" in line or "vw-vanagon" in line]
    assert len(rows) == 2 and all("yes" in r for r in rows)


def test_combinations_no_vehicle_has_are_refused():
    suv = PRESETS["suv"]
    # each value in range, together impossible: a 2.1 t SUV with the yaw inertia of a toy car
    with pytest.raises(ValueError, match=r"vehicle field 'yaw_inertia' = 0.0001 kg m² is 2.44e-08 x mass"):
        suv.replace(yaw_inertia=1e-4)
    with pytest.raises(ValueError, match=r"vehicle field 'cornering_stiffness_rear' = 10.0 N/rad is 0.001"):
        suv.replace(cornering_stiffness_rear=10.0)
    # the presets lie well inside: dynamic index 0.4-1.2, stiffness 5-20 /rad of the axle load
    for v in PRESETS.values():
        assert 0.3 < v.yaw_inertia / (v.mass * v.lf * v.lr) < 1.5, v.name
        for c, fz in ((v.cornering_stiffness_front, v.fz_front), (v.cornering_stiffness_rear, v.fz_rear)):
            assert 3.0 < c / fz < 25.0, v.name


def test_cli_error_keeps_the_units_in_brackets(tmp_path):
    import subprocess
    import sys

    d = PRESETS["sedan"].to_dict()
    del d["mass"]
    p = tmp_path / "van.yaml"
    p.write_text(yaml.safe_dump(d))
    drive = tmp_path / "d.csv"
    drive.write_text("t,ax\n0.0,0.1\n0.01,0.2\n")
    code = ("import sys; sys.argv = ['roadgrip', 'info', sys.argv[1], '--vehicle', sys.argv[2]]; "
            "from roadgrip.cli import main; main()")
    res = subprocess.run([sys.executable, "-c", code, str(drive), str(p)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert "mass [kg]: total mass" in " ".join(res.stderr.split())
