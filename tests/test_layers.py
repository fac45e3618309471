"""The import contracts of pyproject.toml ([tool.importlinter]) hold, and catch an upward import."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).parent / "lint-imports"


def _lint(package_parent: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(package_parent))
    return subprocess.run([str(LINT), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
                          capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


def test_the_package_keeps_its_import_contracts():
    res = _lint(ROOT / "src", ROOT)
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-2000:]


def test_an_upward_import_or_a_terminal_library_below_the_command_line_breaks_them(tmp_path):
    shutil.copytree(ROOT / "src" / "roadgrip", tmp_path / "roadgrip",
                    ignore=shutil.ignore_patterns("__pycache__"))
    with (tmp_path / "roadgrip" / "tire.py").open("a") as f:
        f.write("\nfrom roadgrip import evaluate  # noqa: E402,F401\n")
    with (tmp_path / "roadgrip" / "drive.py").open("a") as f:
        f.write("\nimport rich  # noqa: E402,F401\n")
    res = _lint(tmp_path, tmp_path)
    out = res.stdout
    assert res.returncode != 0
    assert "roadgrip.tire is not allowed to import roadgrip.evaluate" in out, out[-4000:]
    assert "roadgrip.drive is not allowed to import rich" in out, out[-4000:]
