"""The command-line frame shared by every ``python -m sim`` command.

* :data:`COMMANDS`: the command modules; a module that does not exist yet is
  simply not offered.
* :class:`CliError`: what a command raises for bad input; ``main`` prints it as
  ``sim <command>: error: <message>`` and exits with 2.
* :func:`parse_cell`, :func:`check_cell`: ``R,C`` arguments checked against a
  grid, with messages that name the argument.
"""

import argparse
import importlib
import importlib.util
import os
import sys

__all__ = ["COMMANDS", "CliError", "parse_cell", "check_cell", "main"]

# name -> module (in this package); order is the order of `python -m sim --help`.
COMMANDS = {
    "harmonic": f"{__package__}.harmonic",
    "edt": f"{__package__}.edt",
    "dflc": f"{__package__}.dflc",
    "track": f"{__package__}.track",
    "navigate": f"{__package__}.navigate",
}


class CliError(Exception):
    """Bad input to a command: printed as one line, exit code 2."""


def parse_cell(text, what="cell"):
    """``"R,C"`` -> ``(R, C)``; anything else is a :class:`CliError` naming ``what``."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return int(parts[0]), int(parts[1])
    except ValueError:
        raise CliError(f"{what} {text!r}: expected ROW,COL (two integers)") from None


def check_cell(grid, cell, what, free=True):
    """Refuse a cell outside ``grid`` (bool, True = obstacle) or, with ``free``, on an obstacle."""
    r, c = cell
    rows, cols = grid.shape
    if not (0 <= r < rows and 0 <= c < cols):
        raise CliError(f"{what} ({r}, {c}) is outside the {rows}x{cols} map")
    if free and grid[r, c]:
        raise CliError(f"{what} ({r}, {c}) is on an obstacle")
    return cell


def _available():
    return {name: mod for name, mod in COMMANDS.items() if importlib.util.find_spec(mod) is not None}


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``--help`` still shows the usage)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser():
    parser = _Parser(prog="python -m sim", description="navcores: models and RTL runs of the cores")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, mod in _available().items():
        module = importlib.import_module(mod)
        doc = (module.__doc__ or name).strip()
        p = sub.add_parser(name, help=doc.splitlines()[0], description=doc,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _prog=f"sim {name}")
    return parser


def main(argv=None):
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    parser = build_parser()
    args = parser.parse_args(argv)          # argparse itself exits 2 with one line on bad usage
    from navcores.models.maps import MapFormatError
    try:
        return int(args._run(args) or 0)
    except CliError as e:
        print(f"{args._prog}: error: {e}", file=sys.stderr)
        return 2
    except MapFormatError as e:
        print(f"{args._prog}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        name = f" {e.filename}" if getattr(e, "filename", None) else ""
        print(f"{args._prog}: error:{name}: {e.strerror or e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{args._prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - the promise is one line, never a traceback
        if os.environ.get("SIM_DEBUG") == "1":
            raise
        print(f"{args._prog}: internal error: {type(e).__name__}: {e} (SIM_DEBUG=1 shows the traceback)",
              file=sys.stderr)
        return 70
