"""Every method on every scenario it applies to, and the GP-SSM's row on dry-gravel-dry."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.evaluate.cases import DEMO, FULL, MB_TAG, QUICK, default_cases


@pytest.mark.parametrize("settings", [FULL, QUICK, DEMO], ids=lambda s: s.name)
def test_gpssm_runs_on_dry_gravel_dry_beside_the_classifiers(settings, monkeypatch):
    monkeypatch.setenv("ROADGRIP_SHARED_DATA", "/nonexistent")
    cases = default_cases(settings)
    dgd = [c for c in cases if c.drive == "dry-gravel-dry"]
    assert [(c.label, c.method) for c in dgd] == [
        (settings.gpssm_other, "gpssm"), ("brls", "brls"), ("slipmap", "slipmap")]
    mb = {c.method for c in cases if c.drive.startswith(f"dry-gravel-dry{MB_TAG}")}
    assert mb == {"gpssm", "brls", "slipmap"}


@pytest.mark.slow
def test_gpssm_row_on_dry_gravel_dry_reads_as_abstention():
    """The demo's GP-SSM on dry-gravel-dry observes no peak: its row says so (a full demo run)."""
    from roadgrip.evaluate import suite
    from roadgrip.evaluate.table import bench_table, format_cell

    case = next(c for c in default_cases(DEMO) if c.drive == "dry-gravel-dry" and c.method == "gpssm")
    rec = suite.run_suite([case], DEMO, seed=0)[0]
    assert rec.status == "ok"
    row = bench_table([rec]).iloc[0]
    assert row["abstained"] >= 0.99
    assert np.isnan(row["peak_err_f"]) and np.isnan(row["peak_err_r"])
    assert format_cell("wrong_claims", row["wrong_claims"]) == "0.00%"
    assert sum("reported as a lower bound" in d and "the bound holds" in d for d in rec.details) == 2
