"""The user documentation points at things that exist.

Every relative link (and image) of README.md and docs/*.md names an existing file (and, with a
``#anchor``, a heading of it); every ``docs/....md`` named in code resolves; and every
``roadgrip ...`` command the pages show is a command of the command line, with options
that command takes.
"""

from __future__ import annotations

import functools
import re
import shlex
from pathlib import Path
from typing import Any

import pytest
import typer

from roadgrip.cli import app

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```", re.S | re.M)
_LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
_SPAN = re.compile(r"`([^`\n]+)`")
_DOC_PATH = re.compile(r"(?<![\w/.-])(docs/[\w.-]+\.md)\b")
_SHELL_FENCES = {"sh", "bash", "shell", "console"}


def _split(text: str) -> tuple[str, list[str], list[str]]:
    """Prose (fences removed), shell fences, other fences of a Markdown page."""
    shell, other = [], []
    for m in _FENCE.finditer(text):
        (shell if m.group(1).strip() in _SHELL_FENCES else other).append(m.group(2))
    return _FENCE.sub("", text), shell, other


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    s = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return s.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    prose, _, _ = _split(path.read_text(encoding="utf-8"))
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*$", prose, re.M)}


def _links(page: Path) -> list[str]:
    prose, _, _ = _split(page.read_text(encoding="utf-8"))
    prose = _SPAN.sub("", prose)
    return [t for t in _LINK.findall(prose) if not re.match(r"[a-z]+:", t)]


def _link_problems(page: Path, root: Path = ROOT) -> list[str]:
    """The relative links of ``page`` whose file, or heading, does not exist."""
    bad = []
    for target in _links(page):
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        rel = dest.relative_to(root).as_posix() if dest.is_relative_to(root) else str(dest)
        if not dest.exists():
            bad.append(f"{target}: no file {rel}")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            bad.append(f"{target}: no heading #{anchor} in {rel}")
    return bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_relative_link_resolves(page):
    bad = _link_problems(page)
    assert not bad, f"{page.name}: " + "; ".join(bad)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_docs_page_named_in_code_exists(page):
    text = page.read_text(encoding="utf-8")
    named = set(_DOC_PATH.findall(text))
    missing = sorted(n for n in named if not (ROOT / n).exists())
    assert not missing, f"{page.name} names {missing}"


def _commands(page: Path) -> list[str]:
    """The ``roadgrip ...`` command lines of a page: from its shell blocks (continuation
    lines joined, from ``roadgrip`` to the end of the command) and its inline code."""
    prose, shell, _ = _split(page.read_text(encoding="utf-8"))
    out: list[str] = []
    for block in shell:
        for line in block.replace("\\\n", " ").splitlines():
            out += re.findall(r"(?:^|[;&|(]|\bdo)\s*(roadgrip\s[^;&|#)]*)", line)
    for span in _SPAN.findall(prose):
        if span.startswith("roadgrip "):
            out.append(span.split("|")[0])
    return out


@functools.cache
def _root() -> Any:
    return typer.main.get_command(app)


def _is_group(cmd: Any) -> bool:
    return hasattr(cmd, "commands")


def _resolve(words: list[str]) -> tuple[Any, str]:
    """The command object ``roadgrip WORDS...`` names (descending into groups; typer's own
    click), or None, and its name."""
    cmd = _root()
    path = []
    for w in words:
        if not _is_group(cmd) or w.startswith("-"):
            break
        path.append(w)
        sub = cmd.commands.get(w)
        if sub is None:
            return None, " ".join(path)
        cmd = sub
    return cmd, " ".join(path)


def _command_problem(line: str) -> str | None:
    """What is wrong with the command line ``roadgrip ...``, or None."""
    words = shlex.split(line.replace("...", " "))[1:]
    cmd, name = _resolve(words)
    if cmd is None:
        return f"`roadgrip {name}` is not a command of `roadgrip --help`"
    if _is_group(cmd):
        rest = [w for w in words[len(name.split()):] if w != "--help"]
        return f"`roadgrip {name}` needs a sub-command, not {rest}" if rest else None
    known = {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)} | {"--help"}
    given = [w.split("=")[0] for w in words if re.match(r"--?[a-zA-Z]", w)]
    unknown = [o for o in given if o not in known]
    return f"`roadgrip {name}` has no option {unknown} ({line.strip()})" if unknown else None


def test_the_pages_show_commands():
    names = {c.split()[1] for p in PAGES for c in _commands(p)}
    assert {"demo", "estimate", "calibrate", "vehicle", "map"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_documented_command_exists_with_its_options(page):
    bad = [msg for line in _commands(page) if (msg := _command_problem(line))]
    assert not bad, f"{page.name}: " + "; ".join(bad)


def test_the_checks_catch_what_they_claim(tmp_path):
    """The parsing finds a bad link, a bad anchor, an unknown command and an unknown option."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "a.md").write_text("# Title\n\n## A section\n")
    page = tmp_path / "README.md"
    page.write_text(
        "See [a](docs/a.md#a-section), [b](docs/b.md), [c](docs/a.md#nope), [w](https://x.org).\n\n"
        "```sh\nroadgrip estimate d.parquet --method brls \\\n    --bogus 1 -o e.parquet\n"
        "for s in 0 1; do roadgrip simulate x --seed $s -o y.parquet; done\n```\n\n"
        "Run `roadgrip frobnicate now`.\n")
    assert _links(page) == ["docs/a.md#a-section", "docs/b.md", "docs/a.md#nope"]
    assert _link_problems(page, tmp_path.resolve()) == ["docs/b.md: no file docs/b.md",
                                                         "docs/a.md#nope: no heading #nope in docs/a.md"]
    assert _slug("Fleet maps on Dask: `roadgrip fleet`") == "fleet-maps-on-dask-roadgrip-fleet"
    assert "a-section" in _anchors(docs / "a.md") and "nope" not in _anchors(docs / "a.md")
    cmds = _commands(page)
    assert [c.split()[1] for c in cmds] == ["estimate", "simulate", "frobnicate"]
    assert "--bogus" in cmds[0]
    assert "no option ['--bogus']" in _command_problem(cmds[0])
    assert _command_problem(cmds[1]) is None
    assert "not a command" in _command_problem(cmds[2])
    assert _command_problem("roadgrip vehicle template -o x.yaml") is None
    assert "not a command" in _command_problem("roadgrip vehicle frob")
    assert "needs a sub-command" in _command_problem("roadgrip vehicle -o x.yaml")
    assert _command_problem("roadgrip --help") is None
