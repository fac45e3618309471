"""The HTML report: structure, self-containment, and a render in headless Chromium."""

from __future__ import annotations

import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, conform
from roadgrip.evaluate.cases import Case, RunRecord
from roadgrip.evaluate.scoring import score
from roadgrip.report import SECTIONS, build_report, write_report
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _drive(n=600, dt=0.05):
    """A hand-made 'simulated' drive: dry for the first half, snow after, with truth."""
    t = np.arange(n) * dt
    surface = np.where(t < t[n // 2], "dry_asphalt", "snow")
    truth = {"surfaces": {s: {"front": SURFACES[s].lateral.to_dict(), "rear": SURFACES[s].lateral.to_dict(),
                              "mu": SURFACES[s].mu_peak} for s in ("dry_asphalt", "snow")}}
    alpha = 0.08 * np.sin(0.7 * t)
    df = pd.DataFrame({
        "t": t, "ax": 0.5 * np.cos(0.3 * t), "ay": 3.0 * np.sin(0.7 * t), "yaw_rate": 0.2 * np.sin(0.7 * t),
        "steer": 0.05 * np.sin(0.7 * t), "vx": np.full(n, 15.0),
        "x": 20 * np.cos(0.05 * t), "y": 20 * np.sin(0.05 * t), "psi": 0.05 * t,
        "alpha_f_true": alpha, "alpha_r_true": 0.8 * alpha,
        "mu_true": np.where(surface == "snow", 0.3, 1.0), "surface": surface,
    })
    return Drive.from_frame(df, PRESETS["sedan"], source="hand-made", truth=truth)


def _records(drive):
    t = drive.t
    n = drive.n
    mu = np.where(t < t[n // 2], 0.95, 0.32)
    tab = pd.DataFrame({"t": t, "mu_front": mu, "mu_rear": mu, "mu_front_lower": mu - 0.1,
                        "mu_front_upper": mu + 0.1, "mu_rear_lower": mu - 0.1, "mu_rear_upper": mu + 0.1,
                        "excited": np.abs(drive.col("ay")) > 2, "peak_observed_front": True,
                        "peak_observed_rear": True})
    grid = np.linspace(-0.15, 0.15, 61)
    snow = SURFACES["snow"].lateral
    curves = pd.concat([
        pd.DataFrame({"t": tc, "axle": axle, "alpha": grid, "mu_mean": snow.mu(grid) + 0.01,
                      "mu_lower": snow.mu(grid) - 0.03, "mu_upper": snow.mu(grid) + 0.05,
                      "mu_true": snow.mu(grid)})
        for tc in (15.0, float(t[-1])) for axle in ("front", "rear")
    ])
    friction = RunRecord(Case("hand", "gpssm", "gpssm"), "ok", drive,
                         EstimateResult("gpssm", conform(tab), {}, curves))
    cls = np.where(t < t[n // 2] + 1.0, "high", "low")
    ctab = conform(pd.DataFrame({"t": t, "grip_class": cls, "grip_index": np.where(cls == "high", 0.9, 0.1),
                                 "excited": np.abs(drive.col("ay")) > 2}))
    classes = RunRecord(Case("hand", "brls", "brls"), "ok", drive, EstimateResult("brls", ctab, {}))
    cells = pd.DataFrame({"x": [0.25, 0.75, 1.25], "y": [0.25, 0.25, 0.25], "mu_mean": [0.3, 0.9, np.nan],
                          "mu_std": [0.05, 0.05, 1.0], "n_obs": [12, 40, 0]})
    cells.attrs["cell_size"] = 0.5
    mapped = RunRecord(Case("hand", "cascade", "cascade"), "ok", drive,
                       EstimateResult("cascade", conform(tab), {}), map_cells=cells)
    missing = RunRecord(Case("hand", "slipmap", "slipmap"), "error: RuntimeError: diverged")
    for r in (friction, classes, mapped):
        score(r)
    return [friction, classes, mapped, missing]


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.imgs, self.refs, self.ids, self.scripts = [], [], set(), 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.imgs.append(a.get("src", ""))
        if tag == "script":
            self.scripts += 1
        for key in ("src", "href"):
            if key in a and tag != "img":
                self.refs.append(a[key])


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    drive = _drive()
    path = build_report(_records(drive), out, notes=["hand-made inputs"])
    return path


def test_report_is_self_contained_with_all_sections(report):
    text = report.read_text(encoding="utf-8")
    p = _Collect()
    p.feed(text)
    assert set(SECTIONS) <= p.ids
    assert len(p.imgs) >= 5  # signals, friction x2, curves, classification, map
    assert all(src.startswith("data:image/png;base64,") for src in p.imgs)
    assert all(not r.startswith(("http:", "https:", "//")) for r in p.refs)
    assert "http://" not in text and "https://" not in text
    assert p.scripts == 0
    pngs = sorted(f.name for f in report.parent.glob("*.png"))
    assert len(pngs) == len(p.imgs)
    assert any(n.startswith("map-") for n in pngs) and any(n.startswith("curves-") for n in pngs)
    assert "error: RuntimeError: diverged" in text  # the failed run is listed, not silently dropped


def test_report_benchmark_rows_carry_the_scores(report):
    text = report.read_text(encoding="utf-8")
    # The classification record detected the change 1 s late and never excited before it.
    assert "change to low at t = 15.0 s" in text
    # Curve MAE of a curve offset by +0.01 everywhere is 0.010.
    assert "MAE 0.0100" in text


def test_empty_sections_say_so(tmp_path):
    drive = _drive(100)
    path = build_report([], tmp_path, extra_drives={"only": drive})
    text = path.read_text()
    assert "Nothing to show" in text and "No estimator runs" in text
    p = _Collect()
    p.feed(text)
    assert len(p.imgs) == 1  # the signals of the drive


def test_write_report_reads_estimates_and_pairs_them_with_the_drive(tmp_path):
    drive = _drive(300)
    drive.save(tmp_path / "drive.parquet")
    rec = _records(drive)[0]
    rec.result.to_parquet(tmp_path / "est.parquet")
    rec.result.curves.to_parquet(tmp_path / "curves.parquet")
    path = write_report([str(tmp_path / "drive.parquet"), str(tmp_path / "est.parquet"),
                       str(tmp_path / "curves.parquet")], tmp_path / "out")
    text = path.read_text()
    assert "drive / gpssm" in text  # paired with the drive by its clock
    assert "curves-drive-gpssm.png" in text
    with pytest.raises(ValueError, match="no such file"):
        write_report([str(tmp_path / "missing.parquet")], tmp_path / "out2")


# -- headless browser -------------------------------------------------------------------
def _render(html_path: Path, tmp: Path) -> tuple[Path, str]:
    shot = tmp / "shot.png"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp / 'profile'}", "--enable-logging=stderr", "--v=0",
           f"--screenshot={shot}", "--window-size=1200,2000", html_path.resolve().as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    return shot, proc.stderr


def _console_errors(stderr: str) -> list[str]:
    out = []
    for line in stderr.splitlines():
        if "CONSOLE" in line and ("ERROR" in line or "Uncaught" in line or "console.error" in line):
            out.append(line)
        elif "Failed to load resource" in line or "net::ERR_" in line:
            out.append(line)
    return out


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install chromium); "
                    "the structural HTML checks above still run")
def test_report_renders_in_headless_chromium(report, tmp_path):
    from matplotlib.image import imread

    shot, stderr = _render(report, tmp_path)
    assert shot.is_file(), f"no screenshot; chromium said:\n{stderr[-2000:]}"
    img = imread(shot)[..., :3]
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    assert float(img.std()) > 0.05, "screenshot is blank"
    # a sizeable fraction of pixels is not background white: text and figures drew
    assert float(np.mean(img.mean(axis=2) < 0.9)) > 0.02
    assert _console_errors(stderr) == []


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed")
def test_console_error_detection_catches_a_broken_page(tmp_path):
    bad = tmp_path / "bad.html"
    bad.write_text("<html><body><p>x</p><script>console.error('boom'); undefined_fn();</script>"
                   "</body></html>")
    _, stderr = _render(bad, tmp_path)
    assert _console_errors(stderr), f"the broken page was not caught:\n{stderr[-2000:]}"


def test_report_command_with_a_benchmark_folder(tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.evaluate.cases import QUICK
    from roadgrip.evaluate.table import bench_table, write_outputs

    drive = _drive(200)
    drive.save(tmp_path / "drive.parquet")
    recs = _records(drive)
    recs[0].result.to_parquet(tmp_path / "est.parquet")
    write_outputs(recs, tmp_path / "bench", QUICK, seed=0)
    assert len(bench_table(recs)) == 4
    res = CliRunner().invoke(app, ["report", str(tmp_path / "drive.parquet"), str(tmp_path / "est.parquet"),
                                   str(tmp_path / "bench"), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "out" / "index.html").read_text()
    # the benchmark section shows the folder's table (4 rows, one failed)
    assert text.count("<tr") - text.count("<tr><th") >= 4 and "error: RuntimeError: diverged" in text
    assert "friction-drive-gpssm.png" in text


# -- captions say what the figures draw ----------------------------------------------------------
def _captions(path: Path) -> dict[str, str]:
    """Figure file name -> caption."""
    import html
    import re

    text = path.read_text(encoding="utf-8")
    return {m.group(2): html.unescape(m.group(1))
            for m in re.finditer(r"<figcaption>(.*?) \((\S+\.png)\)</figcaption>", text)}


def _real_like(drive: Drive) -> Drive:
    """The same drive as a recording gives it: no truth, no true slip angles, no surface labels."""
    df = drive.data.drop(columns=["alpha_f_true", "alpha_r_true", "mu_true", "surface"])
    return Drive.from_frame(df, PRESETS["sedan"], source="recording.csv")


def _truthless_records(drive, reference=None):
    """The GP-SSM and bRLS records of :func:`_records`, on a drive without truth (curves without it too)."""
    friction, classes = _records(_drive())[:2]
    res = friction.result
    res = EstimateResult(res.method, res.table, res.meta, res.curves.drop(columns="mu_true"))
    friction = RunRecord(Case("rec", "gpssm", "gpssm"), "ok", drive, res)
    classes = RunRecord(Case("rec", "brls", "brls", reference=reference), "ok", drive, classes.result)
    return [friction, classes]


def test_captions_with_truth_name_the_truth_and_the_histogram(report):
    caps = _captions(report)
    friction = caps["friction-hand-gpssm.png"]
    curves = caps["curves-hand-gpssm.png"]
    assert "true peak dashed" in friction and "no ground truth" not in friction
    assert "truth dashed" in curves and "grey: histogram of the visited (true) slip angles" in curves
    assert "true class dashed" in caps["classification-hand-brls.png"]


def test_captions_without_truth_mention_no_truth_and_no_histogram(tmp_path):
    drive = _real_like(_drive())
    caps = _captions(build_report(_truthless_records(drive), tmp_path))
    friction = caps["friction-rec-gpssm.png"]
    curves = caps["curves-rec-gpssm.png"]
    classes = caps["classification-rec-brls.png"]
    for cap in (friction, curves, classes):
        assert "no ground truth" in cap
        assert "dashed" not in cap and "histogram" not in cap and "grey" not in cap


def test_caption_of_a_floor_label_calls_it_so(tmp_path):
    drive = _real_like(_drive())
    caps = _captions(build_report(_truthless_records(drive, reference="high"), tmp_path))
    assert "the floor's label dashed" in caps["classification-rec-brls.png"]


def test_captions_follow_the_figure_not_the_inputs():
    """A truth that is NaN throughout draws nothing, and the caption says so."""
    from roadgrip.plots.signals import plot_friction_trace
    from roadgrip.report.builder import friction_caption

    tab = _records(_drive(100))[0].result.table
    nan = np.full(len(tab), np.nan)
    assert "true peak dashed" in friction_caption("x", plot_friction_trace(tab, {"front": tab["mu_front"],
                                                                                  "rear": tab["mu_rear"]}))
    assert "no ground truth" in friction_caption("x", plot_friction_trace(tab, {"front": nan, "rear": nan}))


# -- the demo says whether the real data were found and used ---------------------------------------
def test_demo_notes_say_the_real_data_were_found_but_not_used(tmp_path, monkeypatch):
    from roadgrip.evaluate.cases import DEMO
    from roadgrip.report import demo_notes

    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(tmp_path))
    notes = demo_notes(DEMO, [], seed=0, wall=1.0)
    text = " | ".join(notes)
    assert f"real data: found at {tmp_path.resolve()}, not used" in text
    assert "real data: no" not in text and "real data: yes" not in text


def test_demo_notes_say_the_real_data_were_not_found(tmp_path, monkeypatch):
    from roadgrip.evaluate.cases import DEMO
    from roadgrip.report import demo_notes

    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(tmp_path / "missing"))
    assert any(n.startswith("real data: not found") for n in demo_notes(DEMO, [], seed=0, wall=1.0))


def test_demo_notes_say_the_real_data_were_used(tmp_path, monkeypatch):
    from roadgrip.evaluate.cases import QUICK
    from roadgrip.report import demo_notes

    monkeypatch.setenv("ROADGRIP_SHARED_DATA", str(tmp_path))
    rec = RunRecord(Case("dart:high:0909-1412", "brls", "brls", path=str(tmp_path / "a.csv"), format="dart",
                         reference="high"), "ok")
    notes = demo_notes(QUICK, [rec], seed=0, wall=1.0)
    assert f"real data: used, 1 drive from {tmp_path.resolve()} (dart:high:0909-1412)" in notes
