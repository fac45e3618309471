"""GP-SSM on the real DART recordings (JetRacer on two floors); skipped without the data."""

from pathlib import Path

import pytest

from roadgrip.estimators.basis import make_basis
from roadgrip.estimators.gpssm import DART_OPTIONS, GPSSM, GPSSMConfig

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "dart"
FILES = {
    "rubbery": "high_grip_rubbery_floor/car_1_Datarecording_09_09_2024_16_53_03steering_neg03_ramp.csv",
    "tiles": "low_grip_tape_and_tiles/car_1_Datarecording_09_09_2024_17_58_23steer_neg03_ramp.csv",
}

pytestmark = [pytest.mark.realdata, pytest.mark.slow]


def _peak(name):
    from roadgrip.io import read_drive

    path = DATA / FILES[name]
    if not path.exists():
        pytest.skip(f"DART data not found at {path}")
    d = read_drive(path, format="dart", vehicle="jetracer")
    cfg = GPSSMConfig(d.vehicle, basis=make_basis("separable-odd:20"), particles=200, **DART_OPTIONS)
    table, _ = GPSSM(cfg, seed=0).run(d)
    last = table.iloc[-1]
    return max(last["mu_front"], last["mu_rear"]), table


def test_learned_peak_friction_separates_the_two_floors():
    hi, _ = _peak("rubbery")
    lo, _ = _peak("tiles")
    # the authors' fit: about 0.84 on the rubbery floor; about 0.35 g on tape and tiles
    assert 0.55 <= hi <= 1.0
    assert 0.25 <= lo <= 0.5
    assert hi - lo > 0.2
