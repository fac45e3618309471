"""Size limits of the source: modules under 600 lines, compiled kernels with at most 12 parameters."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "roadgrip"
MAX_LINES = 600
MAX_KERNEL_PARAMS = 12


def _modules() -> list[Path]:
    return sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def _is_compiled(fn: ast.FunctionDef) -> bool:
    for dec in fn.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in {"njit", "jit", "vectorize", "guvectorize", "generated_jit"}:
            return True
    return False


def compiled_kernels(path: Path) -> dict[str, int]:
    """Name -> parameter count of every numba-decorated function in ``path``."""
    tree = ast.parse(path.read_text())
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and _is_compiled(node):
            a = node.args
            out[node.name] = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg)
    return out


def test_no_module_over_600_lines():
    long = {str(p.relative_to(SRC)): n for p in _modules() if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def test_no_compiled_kernel_over_12_parameters():
    wide = {f"{p.relative_to(SRC)}:{name}": n for p in _modules()
            for name, n in compiled_kernels(p).items() if n > MAX_KERNEL_PARAMS}
    assert not wide, f"compiled kernels with more than {MAX_KERNEL_PARAMS} parameters: {wide}"


def test_the_kernel_scan_sees_decorated_functions(tmp_path):
    """The scan is not vacuous: it finds the package's kernels and counts a wide one."""
    assert sum(len(compiled_kernels(p)) for p in _modules()) > 30
    f = tmp_path / "k.py"
    f.write_text("import numba\n@numba.njit(cache=True)\ndef k(" + ", ".join(f"a{i}" for i in range(13)) + "):\n    pass\n")
    assert compiled_kernels(f) == {"k": 13}
