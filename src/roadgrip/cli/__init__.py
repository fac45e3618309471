"""The ``roadgrip`` command line (typer + rich).

Every command that takes a drive accepts a canonical CSV/Parquet file or a
shared data set (``--format dart|frictionmaps``, detected where unambiguous).
Errors are printed as one line, ``error: ...``, with exit status 2.
"""

from __future__ import annotations

import sys

import typer

from roadgrip.cli import (  # noqa: F401  (importing a command module registers it)
    bench,
    calibrate,
    estimate,
    fleet,
    friction_map,
    info,
    live,
    report,
    simulate,
    vehicle,
)
from roadgrip.cli._common import app, err_console

__all__ = ["app", "main"]


def main() -> None:
    """Console entry point: one-line errors instead of tracebacks."""
    try:
        app(standalone_mode=False)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        err_console.print("aborted")
        sys.exit(130)
    except Exception as exc:  # the CLI's contract is one clear line
        if hasattr(exc, "show") and hasattr(exc, "exit_code"):  # usage errors
            exc.show()
            sys.exit(exc.exit_code)
        from rich.markup import escape

        msg = str(exc) or type(exc).__name__  # brackets in it ('mass [kg]') are text, not markup
        err_console.print(f"[bold red]error:[/] {escape(msg)}", highlight=False, soft_wrap=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
