"""``bracketed_root``, the root finder of the tire curves (peak slip, slip at a fraction of
the peak), against scipy's brentq with the same tolerance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadgrip.io.describe import slip_at_fraction_of_peak
from roadgrip.tire import SURFACES, MagicFormula, bracketed_root


def _brentq_peak_slip(m: MagicFormula) -> float:
    """The peak slip as the tire module found it with scipy's brentq."""
    from scipy.optimize import brentq

    x_target = np.tan(np.pi / (2 * m.C))

    def f(bs):
        return bs - m.E * (bs - np.arctan(bs)) - x_target

    hi = 1.0
    while f(hi) < 0:
        hi *= 2.0
    return brentq(f, 0.0, hi, xtol=1e-14) / m.B


def _curves() -> list[MagicFormula]:
    rng = np.random.default_rng(0)
    shipped = [m for s in SURFACES.values() for m in (s.lateral, s.longitudinal)
               if isinstance(m, MagicFormula) and m.C > 1.0]
    drawn = [MagicFormula(B=rng.uniform(2, 30), C=rng.uniform(1.05, 2.5), D=rng.uniform(0.1, 1.3),
                          E=rng.uniform(-2.0, 0.99)) for _ in range(200)]
    return shipped + drawn


@pytest.mark.parametrize(("f", "lo", "hi", "root"), [
    (lambda x: x * x - 2.0, 0.0, 2.0, math.sqrt(2.0)),
    (lambda x: math.cos(x) - x, 0.0, 1.0, 0.7390851332151607),
    (lambda x: x**3, -1.0, 3.0, 0.0),  # a flat root
    (lambda x: math.exp(x) - 1e-8, -30.0, 0.0, math.log(1e-8)),
    (lambda x: 1.0 if x > 0.3 else -1.0, 0.0, 1.0, 0.3),  # a step: bisection's case
])
def test_bracketed_root_finds_the_root_to_its_tolerance(f, lo, hi, root):
    for xtol in (1e-6, 1e-12, 1e-14):
        x = bracketed_root(f, lo, hi, xtol=xtol)
        assert abs(x - root) <= xtol + 8 * np.finfo(float).eps * abs(root)
        assert abs(bracketed_root(f, hi, lo, xtol=xtol) - x) <= xtol  # either order


def test_bracketed_root_ends_and_errors():
    assert bracketed_root(lambda x: x - 1.0, 1.0, 2.0) == 1.0
    assert bracketed_root(lambda x: x - 2.0, 1.0, 2.0) == 2.0
    with pytest.raises(ValueError, match="change sign"):
        bracketed_root(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="change sign"):
        bracketed_root(lambda x: math.nan, -1.0, 1.0)
    with pytest.raises(ValueError, match="NaN"):
        bracketed_root(lambda x: math.nan if abs(x) < 0.5 else x, -1.0, 1.0)
    with pytest.raises(ValueError, match="after 3 steps"):
        bracketed_root(lambda x: x**3 - 0.123, 0.0, 1.0, xtol=1e-15, max_iter=3)


def test_magic_formula_peak_slip_is_brentqs():
    for m in _curves():
        s_peak, mu_peak = m.peak()
        assert mu_peak == m.D
        assert s_peak == pytest.approx(_brentq_peak_slip(m), rel=1e-13)
        assert abs(float(m.dmu(s_peak))) <= 1e-9 * m.B * m.D  # the curve is flat there


def test_slip_at_fraction_of_peak_is_brentqs():
    from scipy.optimize import brentq

    for m in _curves():
        s = slip_at_fraction_of_peak(m, 0.8)
        target = 0.8 * m.D
        ref = brentq(lambda x, m=m, target=target: float(m.mu(x)) - target, 0.0, m.peak()[0], xtol=1e-12)
        assert abs(s - ref) <= 2e-12 + 1e-15 * ref
        assert float(m.mu(s)) == pytest.approx(target, rel=1e-9)
