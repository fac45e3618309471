"""GP-SSM on the real recordings: DART (JetRacer on two floors) and FrictionMaps (F1/10);
skipped without the data."""

from pathlib import Path

import numpy as np
import pytest

from roadgrip.estimators.gpssm import GPSSMConfig, drive_vx, run_filter
from roadgrip.io.presets import (
    dart_options,
    frictionmaps_options,
    options_for_drive,
    preset_options,
)

DART_OPTIONS = dart_options()
DATA = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "dart"
FILES = {
    "rubbery": "high_grip_rubbery_floor/car_1_Datarecording_09_09_2024_16_53_03steering_neg03_ramp.csv",
    "tiles": "low_grip_tape_and_tiles/car_1_Datarecording_09_09_2024_17_58_23steer_neg03_ramp.csv",
}

pytestmark = [pytest.mark.realdata, pytest.mark.slow]


def _run(name, seed=0):
    from roadgrip.io import read_drive

    path = DATA / FILES[name]
    if not path.exists():
        pytest.skip(f"DART data not found at {path}")
    d = read_drive(path, format="dart", vehicle="jetracer")
    assert options_for_drive(d) == DART_OPTIONS
    assert preset_options("gpssm", d) == DART_OPTIONS and preset_options("brls", d) == {}
    cfg = GPSSMConfig(basis="separable-odd:20", particles=200, **DART_OPTIONS)
    table, _ = run_filter(d, cfg, seed=seed)
    return d, table


@pytest.mark.parametrize("name", sorted(FILES))
def test_runs_on_the_recordings_without_nan(name):
    d, t = _run(name)
    assert len(t) == d.n
    # the sideslip bound of DART_OPTIONS: no lateral-velocity run-away (was hundreds of m/s)
    vx_max = np.nanmax(drive_vx(d, DART_OPTIONS["vx_source"]))
    assert t["vy"].abs().max() <= np.tan(DART_OPTIONS["max_sideslip"]) * vx_max + 1e-9
    assert np.isfinite(t.drop(columns="grip_index").select_dtypes("number").to_numpy()).all()
    assert (t["mu_front_lower"] <= t["mu_front"] + 1e-12).all()
    assert (t["mu_front"] <= t["mu_front_upper"] + 1e-12).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_learned_peak_friction_separates_the_two_floors(seed):
    # the authors' fit: about 0.84 on the rubbery floor; about 0.35 g on tape and tiles.
    # With the pose measuring the lateral velocity (DART_OPTIONS) the slip angles are
    # observed and the result no longer depends on the seed (it did from the IMU alone)
    peaks, lower = {}, {}
    for name in FILES:
        _, t = _run(name, seed=seed)
        last = t.iloc[-1]
        peaks[name] = max(last["mu_front"], last["mu_rear"])
        lower[name] = max(last["mu_front_lower"], last["mu_rear_lower"])
        print(f"DART {name} seed {seed}: front {last['mu_front']:.2f} "
              f"[{last['mu_front_lower']:.2f}, {last['mu_front_upper']:.2f}], rear {last['mu_rear']:.2f} "
              f"[{last['mu_rear_lower']:.2f}, {last['mu_rear_upper']:.2f}]")
    assert 0.65 <= peaks["rubbery"] <= 0.95
    assert 0.25 <= peaks["tiles"] <= 0.45
    assert lower["rubbery"] > peaks["tiles"] + 0.2


ALL_DART = sorted(DATA.glob("*/*.csv")) if DATA.exists() else []
FRICTIONMAPS = DATA.parent / "frictionmaps"


def _honesty(d, cfg, seeds, coverage=None, raw_floor=False):
    """Runs of the filter with the given seeds, each checked: no |vy| past 0.5 vx that is
    not flagged diverged, no upper bound below the sustained |a_y|/g of the filter's own
    lateral acceleration, no peak (observed or not) below that floor over the learned
    accelerometer gain less floor_margin, with ``coverage`` the vy band covering the error
    against the pose's ``vy_pose`` on at least that share of the samples, with ``raw_floor``
    no observed peak below the floor as read; returns the final peak bands per axle."""
    from roadgrip.estimators.gpssm import drive_inputs
    from roadgrip.estimators.gpssm.accuracy import honesty_figures

    ay = drive_inputs(d, cfg.vx_source, cfg.vy_source, cfg.ay_source)[:, 1]
    bands = {"front": [], "rear": []}
    for seed in seeds:
        t, _ = run_filter(d, cfg, seed=seed)
        h = honesty_figures(d, t, ay=ay, vy_ref=d.col("vy_pose") if coverage is not None else None)
        assert h["vy_runaway"] == 0, seed
        if coverage is not None:
            assert h["vy_coverage"] >= coverage, (seed, h["vy_coverage"])
        floor_gain = t["floor"].to_numpy() / t["ay_gain"].to_numpy()
        for axle in bands:
            assert h[axle]["upper_below_floor"] == 0, (seed, axle)
            if raw_floor:
                assert h[axle]["observed_below_floor"] == 0, (seed, axle)
            obs = t[f"peak_observed_{axle}"].to_numpy(bool)
            assert not np.any(obs & (t[f"mu_{axle}"].to_numpy() < floor_gain - cfg.floor_margin)), (seed, axle)
            assert (t[f"mu_{axle}_lower"] <= t[f"mu_{axle}"] + 1e-12).all()
            bands[axle].append((h[axle]["lower"], h[axle]["upper"]))
        assert np.isfinite(t.drop(columns="grip_index").select_dtypes("number").to_numpy()).all()
    return bands


@pytest.mark.parametrize("path", ALL_DART, ids=[p.stem[-12:] for p in ALL_DART])
def test_every_dart_recording_is_honest_and_seeds_overlap(path):
    from roadgrip.estimators.gpssm.accuracy import bands_overlap
    from roadgrip.io import read_drive

    d = read_drive(path, format="dart", vehicle="jetracer")
    cfg = GPSSMConfig(particles=200, **options_for_drive(d))
    bands = _honesty(d, cfg, (0, 1, 2))
    for axle, b in bands.items():
        assert bands_overlap(b), (axle, b)


@pytest.mark.parametrize("name", ["DS1", "DS2", "DS3", "DS4", "DS5"])
def test_frictionmaps_recordings_flag_what_they_cannot_follow(name):
    # the F1/10 recordings from the IMU alone (no option preset): the lateral velocity is
    # not followed well (docs/gpssm.md), and the filter says so rather than run away
    from roadgrip.io import read_drive

    path = FRICTIONMAPS / name
    if not path.exists():
        pytest.skip(f"frictionmaps data not found at {path}")
    d = read_drive(path, format="frictionmaps")
    _honesty(d, GPSSMConfig(particles=200), (0,))


@pytest.mark.parametrize("name", ["DS1", "DS2", "DS3", "DS4", "DS5"])
def test_frictionmaps_recordings_with_their_preset_are_honest_and_seeds_overlap(name):
    """With the data set's preset (the lateral velocity from the localisation, the
    accelerometer's gain fixed): the vy band covers the error against the pose's vy on
    90 % of the samples, no upper bound and no observed peak below the sustained |a_y|/g
    as read, and the final bands of seeds 0-4 overlap."""
    from roadgrip.estimators.gpssm.accuracy import bands_overlap
    from roadgrip.io import read_drive

    path = FRICTIONMAPS / name
    if not path.exists():
        pytest.skip(f"frictionmaps data not found at {path}")
    d = read_drive(path, format="frictionmaps")
    assert options_for_drive(d) == frictionmaps_options()
    cfg = GPSSMConfig.from_options({"particles": 200, **preset_options("gpssm", d)})
    # with the gain fixed the floor over the gain is the floor as read
    bands = _honesty(d, cfg, (0, 1, 2, 3, 4), coverage=0.9, raw_floor=True)
    for axle, b in bands.items():
        assert bands_overlap(b), (axle, b)


def test_race_car_lateral_velocity_band_holds_the_ins():
    """The full-size race car (revs, 550 s at 16-61 m/s, no measured lateral velocity):
    unflagged samples whose vy band misses the INS's by more than 0.1 m/s are at most 5 %
    (the issue's figure for this car; before the running accelerometer noise and the
    slip-scale band 78 %, with 5 % flagged), and no peak band or estimate lies below the
    friction the car demonstrably used (the honesty rule's axle and VSS paths)."""
    from roadgrip.evaluate.honesty_matrix import DriveSpec, load_drive, run_cell

    root = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "revs"
    path = root / "race_car_100hz.csv"
    if not path.exists():
        pytest.skip(f"revs data not found at {path}")
    spec = DriveSpec("revs", path=str(path), format="canonical", vehicle=str(root / "race_car.yaml"))
    drive, vy_ref = load_drive(spec)
    cell = run_cell("gpssm", drive, vy_ref)
    print({k: cell[k] for k in ("wrong_axle", "wrong_vss", "wrong_vy", "diverged")})
    assert cell["wrong_vy"] <= 0.05, cell["wrong_vy"]
    assert cell["diverged"] <= 0.05, cell["diverged"]
    assert cell["wrong_axle"] == 0.0 and cell["wrong_vss"] == 0.0 and not cell["summary_wrong"]


def test_race_car_second_half_follows_the_ins():
    """The GP-SSM started on the race car's second half (275 s, the shipped vehicle file):
    lateral-velocity RMSE against the INS at most 0.4 m/s and the band holding it on at
    least 90 % of the unflagged samples (measured 0.22 m/s and 100 %, filter seed 0; 0.30
    with seed 1). Over the whole drive the RMSE is 1.65 m/s: what the filter learns in the
    first half stretches the curve. With the file ``roadgrip vehicle fit`` writes from the
    first half, its calibration applied as the command line applies it, the second half
    gave 3.9 m/s while the fit moved the accelerometer 113 ms earlier (the sideslip rate's
    lag, not the sensor's: next test)."""
    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.honesty import reference_vy
    from roadgrip.io import read_drive

    root = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "revs"
    path = root / "race_car_100hz.csv"
    if not path.exists():
        pytest.skip(f"revs data not found at {path}")
    drive = read_drive(path, format="canonical", vehicle=str(root / "race_car.yaml"))
    second = drive.slice_time(drive.t[0] + 0.5 * drive.duration, np.inf)
    table = run_estimator("gpssm", second, {"basis": "separable-odd:20"}, seed=0).table
    err = table["vy"].to_numpy() - reference_vy(path, second.t)
    ok = ~table["diverged"].to_numpy(bool)
    rmse = float(np.sqrt(np.mean(err**2)))
    cover = float((np.abs(err) <= Z95 * table["vy_std"].to_numpy() + 0.1)[ok].mean())
    print(f"race car, second half: vy RMSE {rmse:.3f} m/s, cover {cover:.3f}, flagged {1 - ok.mean():.3f}")
    assert rmse <= 0.4 and cover >= 0.9 and ok.mean() >= 0.95


def test_race_car_second_half_with_the_fitted_file_holds_the_ins():
    """Issue 29's chain on the race car: ``roadgrip vehicle fit`` on the first half, its
    file applied to the second half as the command line applies it. Without a pose the
    accelerometer's delay is named undetermined (the sideslip rate lends ``a_y`` about
    90 ms against ``v_x r``), so ``a_y`` stays as logged; the band then holds the INS on
    at least 95 % of the unflagged samples (filter seeds 0-4: 99.4-100 %; ``v_y`` RMSE
    0.17, 0.46, 0.29, 0.18, 1.62 m/s, so the RMSE is not asserted). With the 113 ms the
    fit used to apply, the same seeds held it on 76-100 % (``benchmarks/race_car.py``)."""
    from roadgrip.constants import Z95
    from roadgrip.estimators import run_estimator
    from roadgrip.evaluate.honesty import reference_vy
    from roadgrip.inference.vehicle_identification import fit_vehicle
    from roadgrip.io import read_drive

    root = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "revs"
    path = root / "race_car_100hz.csv"
    if not path.exists():
        pytest.skip(f"revs data not found at {path}")
    drive = read_drive(path, format="canonical", vehicle=str(root / "race_car.yaml"))
    mid = drive.t[0] + 0.5 * drive.duration
    fit = fit_vehicle(drive.slice_time(drive.t[0], mid), drive.vehicle)
    assert not fit.values["delay_accelerometer"].fitted
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        car = Path(tmp) / "car.yaml"
        car.write_text(fit.to_yaml())
        fitted = read_drive(path, format="canonical", vehicle=str(car))
    assert "delay_accelerometer" not in fitted.meta.extra["calibration"]
    second = fitted.slice_time(mid, np.inf)
    table = run_estimator("gpssm", second, {"basis": "separable-odd:20"}, seed=0).table
    err = table["vy"].to_numpy() - reference_vy(path, second.t)
    ok = ~table["diverged"].to_numpy(bool)
    cover = float((np.abs(err) <= Z95 * table["vy_std"].to_numpy() + 0.1)[ok].mean())
    print(f"race car, second half, fitted file: vy RMSE {np.sqrt(np.mean(err**2)):.3f} m/s, cover {cover:.3f}")
    assert cover >= 0.95 and ok.mean() >= 0.95
