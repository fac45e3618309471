"""A held 'low' decided afresh once old (``redecide_low_s`` of both classifiers).

Synthetic channels: 'low' evidence for 2 s, 10 s of silence (no informed sample), then
12 s on either weak high-grip evidence or low-grip evidence again. A 'low' older than
``redecide_low_s`` stays claimed through the silence, is withdrawn or switched by fresh
high-grip evidence, and is claimed again at once on fresh low-grip evidence.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from roadgrip.estimators.classify.brls_config import (
    CALIBRATED_HOLD_HIGH_S,
    CALIBRATED_REDECIDE_LOW_S,
    BRLSConfig,
    saturation_config,
)
from roadgrip.estimators.classify.brls_kernel import brls_batch, brls_init, brls_step
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.estimators.classify.slipmap_config import saturation_config as slipmap_saturation
from roadgrip.estimators.classify.slipmap_evidence import SlipMapEvidence
from roadgrip.estimators.classify.slipmap_kernel import slipmap_batch, slipmap_init, slipmap_step

T = np.arange(0.0, 24.0, 0.01)
"""Sample times [s]: evidence in [0, 2) and [12, 24), silence between."""
ON = (T < 2.0) | (T >= 12.0)
LATER = T >= 12.0
ZERO = np.zeros_like(T)


def _brls(redecide_low_s: float) -> BRLSConfig:
    return replace(saturation_config(hold_high_s=CALIBRATED_HOLD_HIGH_S, hold_low_s=math.inf),
                   redecide_low_s=redecide_low_s)


def _brls_inputs(later_position: float, phi: float) -> tuple[np.ndarray, np.ndarray]:
    """Regressor and output of the long channel: class position -0.1 (low) first, then
    ``later_position`` (the saturation model's references: 0 low, 1 high, threshold 1/2)."""
    reg = np.where(ON, phi, 0.0)
    return reg, np.where(LATER, later_position, -0.1) * reg


def _brls_classes(cfg: BRLSConfig, later_position: float, phi: float = 0.4) -> np.ndarray:
    reg, y = _brls_inputs(later_position, phi)
    _, out = brls_batch(T, reg, y, ZERO, ZERO, cfg)
    return np.asarray(out.grip_class)


def test_brls_weak_high_grip_evidence_withdraws_an_old_low():
    # weight 0.6 on a position of 0.75: held, the 'low' reference pulls the estimate to
    # 0.6 * 0.75 = 0.45, short of the threshold; decided afresh it is 0.6 * 0.75 + 0.4 * 0.5
    # = 0.65, past the threshold but not by the margin (0.7): no class
    held = _brls_classes(_brls(math.inf), 0.75)
    fresh = _brls_classes(_brls(CALIBRATED_REDECIDE_LOW_S), 0.75)
    silence = (T > 2.5) & (T < 12.0)
    assert (held[silence] == "low").all() and (fresh[silence] == "low").all()
    assert (held[LATER] == "low").all()
    assert not (fresh[T >= 12.3] == "low").any()
    assert (fresh[T >= 12.3] == "unknown").all()


def test_brls_clear_high_grip_evidence_switches_an_old_low():
    fresh = _brls_classes(_brls(CALIBRATED_REDECIDE_LOW_S), 1.0, phi=1.0)
    assert (fresh[T >= 12.3] == "high").all()


def test_brls_an_old_low_is_claimed_again_at_once_on_low_grip_evidence():
    fresh = _brls_classes(_brls(CALIBRATED_REDECIDE_LOW_S), -0.1)
    assert (fresh[T > 0.5] == "low").all()


def test_brls_a_young_low_is_not_decided_afresh():
    # 10 s of silence against a 12 s redecision: held, as the paper's state machine does
    fresh = _brls_classes(_brls(12.0), 0.75)
    assert (fresh[LATER] == "low").all()


def test_brls_steps_equal_the_batch_through_a_withdrawal():
    cfg = _brls(CALIBRATED_REDECIDE_LOW_S)
    reg, y = _brls_inputs(0.75, 0.4)
    _, out = brls_batch(T, reg, y, ZERO, ZERO, cfg)
    st = brls_init(cfg)
    stepped = []
    for i in range(T.size):
        st, o = brls_step(st, 0.01, reg[i], y[i], 0.0, 0.0, cfg)
        stepped.append(o.grip_class)
    np.testing.assert_array_equal(np.asarray(stepped), np.asarray(out.grip_class))
    assert st.withdrawn


def _slipmap(redecide_low_s: float) -> SlipMapConfig:
    return replace(slipmap_saturation(hold_high_s=CALIBRATED_HOLD_HIGH_S, hold_low_s=math.inf),
                   redecide_low_s=redecide_low_s)


def _evidence(later_high: float, w: float = 0.9) -> SlipMapEvidence:
    """Eq. 16's evidence: weight ``w`` while on, first all of it for 'low', later the
    share ``later_high`` of it for 'high'."""
    weight = np.where(ON, w, 0.0)
    p_high = np.where(LATER, later_high, 0.0) * 0.5 * weight
    return SlipMapEvidence(ZERO, ZERO, weight, ZERO, p_high, 0.5 * weight - p_high, 1.0 - 0.5 * weight, ZERO)


def _slipmap_classes(cfg: SlipMapConfig, later_high: float) -> np.ndarray:
    _, out = slipmap_batch(T, _evidence(later_high), cfg)
    return np.asarray(out.grip_class)


def test_slipmap_high_grip_evidence_ends_an_old_low_sooner():
    held = _slipmap_classes(_slipmap(math.inf), 1.0)
    fresh = _slipmap_classes(_slipmap(CALIBRATED_REDECIDE_LOW_S), 1.0)
    silence = (T > 2.5) & (T < 12.0)
    assert (held[silence] == "low").all() and (fresh[silence] == "low").all()
    # the held index starts from 'low' (near 0), the fresh one from 1/2: it leaves the
    # band (0.6) after ln(0.5 / 0.4) rather than ln(1 / 0.4) output time constants
    end_held = T[LATER][np.argmax(held[LATER] != "low")]
    end_fresh = T[LATER][np.argmax(fresh[LATER] != "low")]
    tau = _slipmap(math.inf).lowpass_tau_s
    assert end_fresh - 12.0 <= tau * math.log(0.5 / 0.4) + 0.05
    assert end_held - 12.0 >= tau * math.log(1.0 / 0.4) - 0.05
    assert (fresh[T >= end_fresh] == "high").all()


def test_slipmap_undecided_evidence_withdraws_an_old_low():
    # half the evidence each way: the index stays at 1/2, no class
    fresh = _slipmap_classes(_slipmap(CALIBRATED_REDECIDE_LOW_S), 0.5)
    held = _slipmap_classes(_slipmap(math.inf), 0.5)
    assert (fresh[T >= 12.1] == "unknown").all()
    assert (held[LATER] == "low").all()


def test_slipmap_an_old_low_is_claimed_again_on_low_grip_evidence():
    fresh = _slipmap_classes(_slipmap(CALIBRATED_REDECIDE_LOW_S), 0.0)
    assert (fresh[(T > 0.5) & (T < 12.0)] == "low").all()
    assert (fresh[T >= 12.1] == "low").all()
    assert np.sum(LATER & (fresh != "low")) * 0.01 <= 0.1


def test_slipmap_steps_equal_the_batch_through_a_redecision():
    cfg = _slipmap(CALIBRATED_REDECIDE_LOW_S)
    ev = _evidence(0.5)
    _, out = slipmap_batch(T, ev, cfg)
    st = slipmap_init()
    stepped = []
    for i in range(T.size):
        st, o = slipmap_step(st, 0.01, SlipMapEvidence(*(np.asarray(a)[i:i + 1] for a in ev)), cfg)
        stepped.append(o.grip_class)
    np.testing.assert_array_equal(np.asarray(stepped), np.asarray(out.grip_class))
    assert st.afresh and not st.known


@pytest.mark.parametrize("config", [_brls, _slipmap])
def test_redecide_low_s_must_be_positive(config):
    with pytest.raises(ValueError, match="redecide_low_s"):
        config(0.0)
