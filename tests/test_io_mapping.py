"""Column-mapping files for foreign logs: units, signs, scales, errors."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import yaml

from roadgrip.constants import GRAVITY
from roadgrip.io import read_mapped
from roadgrip.vehicle import PRESETS

MAPPING = {
    "vehicle": "sedan",
    "time_zero": True,
    "keep": ["brake_bar"],
    "columns": {
        "t": {"column": "time_ms", "unit": "ms"},
        "ax": {"column": "AccX", "unit": "g"},
        "ay": {"column": "AccY", "unit": "g", "sign": -1, "axis": "sensor y points right"},
        "yaw_rate": {"column": "GyroZ", "unit": "deg/s", "sign": -1, "axis": "sensor z down"},
        "steer": {"column": "SWA", "unit": "deg", "scale": 0.0625, "axis": "wheel angle / 16"},
        "vx": {"column": "Speed", "unit": "km/h"},
        "omega_fl": {"column": "WheelFL", "unit": "rpm"},
    },
}


def _log(tmp_path, seed=11, n=300):
    """A hand-made foreign log of a known SI drive, and that drive."""
    rng = np.random.default_rng(seed)
    t = 1000.0 + np.arange(n) * 0.02
    vx = 15.0 + rng.normal(0, 0.5, n)
    r = 0.2 * np.sin(t)
    si = pd.DataFrame(
        {"t": t, "ax": rng.normal(0, 0.5, n), "ay": vx * r, "yaw_rate": r,
         "steer": 0.03 * np.sin(t), "vx": vx, "omega_fl": vx / 0.31}
    )
    log = pd.DataFrame(
        {
            "time_ms": si["t"] * 1e3,
            "AccX": si["ax"] / GRAVITY,
            "AccY": -si["ay"] / GRAVITY,
            "GyroZ": -np.rad2deg(si["yaw_rate"]),
            "SWA": np.rad2deg(si["steer"]) * 16.0,
            "Speed": si["vx"] * 3.6,
            "WheelFL": si["omega_fl"] * 60.0 / (2 * math.pi),
            "brake_bar": rng.uniform(0, 5, n),
            "ignored": 1.0,
        }
    )
    csv = tmp_path / "foreign.csv"
    log.to_csv(csv, index=False)
    return csv, si, log


def _write(tmp_path, mapping):
    p = tmp_path / "map.yaml"
    p.write_text(yaml.safe_dump(mapping))
    return p


def test_mapped_log_converts_to_si(tmp_path):
    csv, si, log = _log(tmp_path)
    d = read_mapped(csv, _write(tmp_path, MAPPING))
    assert d.vehicle == PRESETS["sedan"]
    assert np.allclose(d.t, si["t"] - si["t"].iloc[0], atol=1e-9)
    for c in ("ax", "ay", "yaw_rate", "steer", "vx", "omega_fl"):
        assert np.allclose(d.col(c), si[c], rtol=1e-12, atol=1e-12), c
    assert d.extra_columns == ["brake_bar"]
    assert np.array_equal(d.col("brake_bar"), log["brake_bar"].to_numpy())
    assert "ignored" not in d.data.columns
    assert d.meta.extra["t_offset_s"] == pytest.approx(1000.0)
    assert d.meta.extra["mapping"]["ay"]["sign"] == -1


def test_vehicle_argument_overrides(tmp_path):
    csv, _, _ = _log(tmp_path)
    m = {k: v for k, v in MAPPING.items() if k != "vehicle"}
    with pytest.raises(ValueError, match="needs a vehicle"):
        read_mapped(csv, m)
    assert read_mapped(csv, m, vehicle="suv").vehicle.name == "suv"


def test_sign_is_applied(tmp_path):
    # the sign matters: without it ay and vx*yaw_rate disagree in sign, which validation names
    csv, _, _ = _log(tmp_path)
    m = yaml.safe_load(yaml.safe_dump(MAPPING))
    m["columns"]["ay"]["sign"] = 1
    with pytest.raises(ValueError, match="ay looks like it has a flipped sign"):
        read_mapped(csv, m)


def test_unit_mistake_caught_by_validation(tmp_path):
    # declaring g-valued accelerations as m/s^2 leaves them in g: validation names it
    csv, _, _ = _log(tmp_path)
    m = yaml.safe_load(yaml.safe_dump(MAPPING))
    m["columns"]["ay"]["unit"] = "m/s^2"
    with pytest.raises(ValueError, match="ay looks like it is in g"):
        read_mapped(csv, m)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: m["columns"]["vx"].update(unit="furlong/fortnight"), "unknown unit 'furlong/fortnight'"),
        (lambda m: m["columns"]["vx"].update(unit="deg"), "unit 'deg' measures angle, but 'vx' is a speed"),
        (lambda m: m["columns"]["ay"].update(sign=2), "sign must be \\+1 or -1"),
        (lambda m: m["columns"]["ay"].update(colour="red"), "unknown key\\(s\\) \\['colour'\\]"),
        (lambda m: m["columns"].update(beta={"column": "b", "unit": "rad"}), "'beta' is not a canonical"),
        (lambda m: m["columns"].pop("t"), "must give the time column 't'"),
        (lambda m: m["columns"]["vx"].pop("unit"), "column 'vx': missing 'unit'"),
        (lambda m: m.update(colour="red"), "unknown key\\(s\\) \\['colour'\\]"),
        (lambda m: m["columns"]["vx"].update(column="NoSuch"), "source column 'NoSuch' \\(for 'vx'\\) not found"),
    ],
)
def test_mapping_errors_name_the_problem(tmp_path, change, message):
    csv, _, _ = _log(tmp_path)
    m = yaml.safe_load(yaml.safe_dump(MAPPING))
    change(m)
    with pytest.raises(ValueError, match=message):
        read_mapped(csv, _write(tmp_path, m))


def test_missing_mapping_file(tmp_path):
    csv, _, _ = _log(tmp_path)
    with pytest.raises(ValueError, match="mapping file not found"):
        read_mapped(csv, tmp_path / "none.yaml")


def test_a_compressed_csv_name_reads_as_canonical(tmp_path):
    import gzip

    from roadgrip.io.read import detect_format, read_drive
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("f1tenth-patches", 0, duration=2.0)
    plain = tmp_path / "drive.csv"
    drive.to_csv(plain)
    packed = tmp_path / "drive.csv.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert detect_format(packed) == "canonical"
    back = read_drive(packed, vehicle=drive.vehicle)
    np.testing.assert_array_equal(back.col("ay"), read_drive(plain, vehicle=drive.vehicle).col("ay"))


BAD_ENTRIES = {
    "no source": ({"unit": "g"}, "expected a mapping with '{key}'"),
    "not a mapping": (3, "expected a mapping with '{key}'"),
    "unknown key": ({"{key}": "A", "gain": 2}, r"unknown key\(s\) \['gain'\]"),
    "unknown unit": ({"{key}": "A", "unit": "furlong"}, "unit 'furlong' is not understood"),
    "unit of another quantity": ({"{key}": "A", "unit": "deg/s"}, "unit 'deg/s' measures rate, but 'ax' is a acceleration"),
    "sign": ({"{key}": "A", "sign": 2}, "sign must be"),
    "boolean sign": ({"{key}": "A", "sign": True}, "sign must be"),
    "zero scale": ({"{key}": "A", "scale": 0}, "scale must be"),
    "text scale": ({"{key}": "A", "scale": "x"}, "scale must be"),
}


@pytest.mark.parametrize("case", sorted(BAD_ENTRIES))
@pytest.mark.parametrize("reader", ["mdf", "can"])
def test_channel_and_signal_maps_share_one_entry_check(case, reader):
    """The MDF4 channel map and the CAN signal map refuse the same entry mistakes alike,
    each naming its own source key, and accept the shorthand and their own extra keys."""
    from roadgrip.io.can import load_signal_map
    from roadgrip.io.mdf import load_channel_map

    load, key, section, extra = {"mdf": (load_channel_map, "channel", "channels", {"group": 1}),
                                 "can": (load_signal_map, "signal", "signals", {"message": "M", "timeout": 0.2})
                                 }[reader]
    entry, message = BAD_ENTRIES[case]
    if isinstance(entry, dict):
        entry = {k.format(key=key): v for k, v in entry.items()}
    with pytest.raises(ValueError, match=f"map: {section[:-1]} 'ax': " + message.format(key=key)):
        load({section: {"ax": entry}})
    ok = load({section: {"ax": "A", "ay": {key: "B", "unit": "m/s²", "sign": -1, **extra}}})
    assert ok[section]["ax"] == {key: "A"} and ok[section]["ay"]["sign"] == -1
    other = {"mdf": {"message": "M"}, "can": {"group": 1}}[reader]  # the other reader's key
    with pytest.raises(ValueError, match="unknown key"):
        load({section: {"ax": {key: "A", **other}}})
