"""``roadgrip demo`` end to end on shortened settings."""

from __future__ import annotations

from dataclasses import replace
from html.parser import HTMLParser

import pandas as pd
import pytest

from roadgrip.evaluate.cases import DEMO, default_cases
from roadgrip.report import SECTIONS, run_demo


class _Ids(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids, self.imgs = set(), []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.imgs.append(a.get("src", ""))


def test_demo_covers_the_three_scenarios_and_applicable_methods():
    pairs = {(c.drive, c.method) for c in default_cases(DEMO)}
    assert pairs == {("snow-slalom", "gpssm"), ("dry-gravel-dry", "gpssm"), ("dry-gravel-dry", "brls"),
                     ("dry-gravel-dry", "slipmap"), ("f1tenth-patches", "cascade"),
                     ("dry-gravel-dry:mb:ford-escort", "gpssm"), ("dry-gravel-dry:mb:ford-escort", "brls"),
                     ("dry-gravel-dry:mb:ford-escort", "slipmap")}


@pytest.mark.slow
def test_demo_writes_report_with_all_sections(tmp_path):
    settings = replace(DEMO, name="test", particles=20,
                       durations={"snow-slalom": 30.0, "dry-gravel-dry": 40.0, "f1tenth-patches": 40.0},
                       multibody_durations={"dry-gravel-dry": 70.0})
    path, _ = run_demo(tmp_path / "report", seed=0, settings=settings)
    assert path == tmp_path / "report" / "index.html" and path.is_file()
    p = _Ids()
    p.feed(path.read_text(encoding="utf-8"))
    assert set(SECTIONS) <= p.ids
    assert p.imgs and all(s.startswith("data:image/png;base64,") for s in p.imgs)
    table = pd.read_csv(tmp_path / "report" / "bench.csv")
    cases = default_cases(DEMO)
    assert len(table) == len(cases)
    for case, (_, row) in zip(cases, table.iterrows(), strict=True):
        assert (row["drive"], row["method"]) == (case.drive, case.label)
        assert row["status"] == "ok", f"{row['drive']} / {row['method']}: {row['status']}"
        assert row["samples_per_s"] > 0
    assert (tmp_path / "report" / "bench.md").is_file()
