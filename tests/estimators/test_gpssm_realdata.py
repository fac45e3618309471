"""GP-SSM on the real DART recordings (JetRacer on two floors); skipped without the data."""

from pathlib import Path

import numpy as np
import pytest

from roadgrip.estimators.basis import make_basis
from roadgrip.estimators.gpssm import DART_OPTIONS, GPSSM, GPSSMConfig, drive_vx

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "dart"
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
    cfg = GPSSMConfig(d.vehicle, basis=make_basis("separable-odd:20"), particles=200, **DART_OPTIONS)
    table, _ = GPSSM(cfg, seed=seed).run(d)
    return d, table


@pytest.mark.parametrize("name", sorted(FILES))
def test_runs_on_the_recordings_without_nan(name):
    d, t = _run(name)
    assert len(t) == d.n
    # the sideslip bound of DART_OPTIONS: no lateral-velocity run-away (was hundreds of m/s)
    vx_max = np.nanmax(drive_vx(d, DART_OPTIONS["vx_source"]))
    assert t["vy"].abs().max() <= np.tan(DART_OPTIONS["max_sideslip"]) * vx_max + 1e-9
    assert np.isfinite(t.select_dtypes("number").to_numpy()).all()
    assert (t["mu_front_lower"] <= t["mu_front"] + 1e-12).all()
    assert (t["mu_front"] <= t["mu_front_upper"] + 1e-12).all()


@pytest.mark.xfail(
    reason="the recordings are steady one-direction turns: the lateral velocity (a common "
    "shift of both slip angles) is not identified, and the learned peak depends on the random "
    "seed (max over axles, seeds 0-5: rubbery 0.23-0.65, tape and tiles 0.05-0.71)",
    strict=False,
)
def test_learned_peak_friction_separates_the_two_floors():
    # the authors' fit: about 0.84 on the rubbery floor; about 0.35 g on tape and tiles
    peaks = {}
    for name in FILES:
        _, t = _run(name, seed=1)
        peaks[name] = max(t["mu_front"].iloc[-1], t["mu_rear"].iloc[-1])
    assert 0.55 <= peaks["rubbery"] <= 1.0
    assert 0.25 <= peaks["tiles"] <= 0.5
