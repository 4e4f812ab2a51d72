"""The command-line frame shared by every ``python -m sim`` command.

* :data:`COMMANDS`: the command modules; a module that does not exist yet is
  simply not offered.  :data:`ENGINES`: the engines a command runs on (the
  golden model, or the RTL on one of the runner's simulators).
* The options every command spells the same way: :func:`add_map`
  (``MAP``, ``--cell``, ``--unknown``), :func:`add_place` (``--start`` /
  ``--goal`` as ``R,C`` cells, ``--start-xy`` / ``--goal-xy`` in metres in
  the map frame), :func:`add_engine`, :func:`add_outputs` (``--json``,
  ``--plot``, ``--csv``), :func:`add_block`, :func:`add_schedule`, and the
  number types :func:`number` and :func:`integer` (finite, within bounds).
* :class:`CliError`: what a command raises for bad input; ``main`` prints it as
  ``sim <command>: error: <message>`` and exits with 2.  Exit statuses
  (:data:`EXIT_STATUS`, in every ``--help``): 0 done, 1 ran but no result,
  2 bad input.
* Outputs: ``main`` checks every output path before the command runs
  (folders created, a probe file written and removed), and
  :func:`write_text` / :func:`save_figure` replace the file in one step, so
  a failed run leaves no partial file.
"""

import argparse
import importlib
import importlib.util
import math
import os
import re
import sys
import tempfile
from pathlib import Path

from .rtl.runner import SIMULATORS

__all__ = ["COMMANDS", "ENGINES", "EXIT_STATUS", "CliError", "parse_cell", "check_cell", "parse_xy",
           "number", "integer", "finite_numbers", "Once", "add_map", "add_place", "add_engine", "add_outputs", "add_block",
           "engine_type", "SERIAL",
           "add_schedule", "parse_block", "parse_schedule", "load_map_arg", "places", "write_text",
           "save_figure", "guarded", "main"]

# name -> module (in this package); order is the order of `python -m sim --help`.
COMMANDS = {
    "harmonic": f"{__package__}.harmonic",
    "edt": f"{__package__}.edt",
    "dflc": f"{__package__}.dflc",
    "track": f"{__package__}.track",
    "navigate": f"{__package__}.navigate",
    "board": f"{__package__}.board",
}

ENGINES = ("model", *SIMULATORS)
SERIAL = "serial:"      # --engine serial:PORT[@BAUD]: a board (sim/serial_engine.py)
PLOT_SUFFIXES = (".png", ".pdf", ".svg")

EXIT_STATUS = ("exit status: 0 done; 1 ran, but no result (no path, did not reach the goal or the end, "
               "not converged); 2 bad input (one line on stderr, nothing written)")


class CliError(Exception):
    """Bad input to a command: printed as one line, exit code 2."""


# --- values ---------------------------------------------------------------------

def number(lo=None, hi=None, lo_open=False, unit="", why=""):
    """An argparse ``type``: a finite float in [lo, hi] (``lo_open``: > lo);
    the message gives the range and ``why``."""
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text}: must be a finite number")
        below = v <= lo if lo_open else v < lo if lo is not None else False
        if below or (hi is not None and v > hi):
            rng = f"{'>' if lo_open else '>='} {lo:g}" if hi is None else \
                f"in {'(' if lo_open else '['}{lo:g}, {hi:g}]" if lo is not None else f"<= {hi:g}"
            raise argparse.ArgumentTypeError(f"{text}: must be {rng}{' ' + unit if unit else ''}"
                                             + (f" ({why})" if why else ""))
        return v
    parse.__name__ = "number"
    return parse


def integer(lo=None, hi=None, why=""):
    """An argparse ``type``: an integer in [lo, hi]."""
    def parse(text):
        try:
            v = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            rng = f">= {lo}" if hi is None else f"in {lo}..{hi}" if lo is not None else f"<= {hi}"
            raise argparse.ArgumentTypeError(f"{text}: must be {rng}" + (f" ({why})" if why else ""))
        return v
    parse.__name__ = "integer"
    return parse


def parse_cell(text, what="cell"):
    """``"R,C"`` -> ``(R, C)``; anything else is a :class:`CliError` naming ``what``."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return int(parts[0]), int(parts[1])
    except ValueError:
        raise CliError(f"{what} {text!r}: expected ROW,COL (two integers)") from None


def finite_numbers(text, n):
    """``"a,b,..."`` -> a tuple of ``n`` finite floats, or None."""
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        return None
    return values if len(values) == n and all(math.isfinite(v) for v in values) else None


def parse_xy(text, what):
    """``"X,Y"`` (metres) -> ``(X, Y)``, two finite numbers."""
    xy = finite_numbers(text, 2)
    if xy is None:
        raise CliError(f"{what} {text!r}: expected X,Y (two finite numbers, metres in the map frame)")
    return xy


def check_cell(grid, cell, what, free=True):
    """Refuse a cell outside ``grid`` (bool, True = obstacle) or, with ``free``, on an obstacle."""
    r, c = cell
    rows, cols = grid.shape
    if not (0 <= r < rows and 0 <= c < cols):
        raise CliError(f"{what} ({r}, {c}) is outside the {rows}x{cols} map")
    if free and grid[r, c]:
        raise CliError(f"{what} ({r}, {c}) is on an obstacle")
    return cell


def read_lines(path, max_bytes, what="file"):
    """The lines of a text file; a missing, binary, non-UTF-8 or oversized one
    is a :class:`CliError` naming the file (and the line of a bad byte)."""
    path = Path(path)
    if not path.is_file():
        raise CliError(f"{path}: no such {what}" if not path.exists() else f"{path}: not a file")
    size = path.stat().st_size
    if size > max_bytes:
        raise CliError(f"{path}: {size} bytes; a {what} of at most {max_bytes >> 20} MiB is read")
    data = path.read_bytes()
    bad = data.find(b"\0")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        bad = e.start if bad < 0 else min(bad, e.start)
    else:
        if bad < 0:
            return text.splitlines()
    line = data[:bad].count(b"\n") + 1
    raise CliError(f"{path}:{line}: byte 0x{data[bad]:02x}: binary data or not UTF-8: not a {what}")


# --- options --------------------------------------------------------------------

class _Place(argparse.Action):
    """``--start`` / ``--start-xy`` (and the goal's) into one list of
    (kind, text), in the order given; ``once``: a second one is refused."""

    def __init__(self, option_strings, dest, kind="cell", once=False, **kw):
        self.kind, self.once = kind, once
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        have = list(getattr(namespace, self.dest, None) or [])
        if self.once and have:
            parser.error(f"{option_string}: one {self.dest} only (given twice: "
                         f"{have[0][1]!r} and {values!r})")
        setattr(namespace, self.dest, have + [(self.kind, values, option_string)])


def add_place(parser, role, many=False, required=False, help=""):
    """``--<role> R,C`` and ``--<role>-xy X,Y`` (``many``: repeatable, else one)."""
    what = help or role
    group = parser.add_argument_group(f"{role}: --{role} or --{role}-xy" + (", repeatable" if many else ", once")
                                      + (", required" if required else ""))
    group.add_argument(f"--{role}", dest=role, action=_Place, kind="cell", once=not many, metavar="R,C",
                       default=[], help=f"{what} as a cell: row, column from the map's top left (0-based)")
    group.add_argument(f"--{role}-xy", dest=role, action=_Place, kind="xy", once=not many, metavar="X,Y",
                       default=[], help=f"{what} as a point in metres in the map frame (a ROS map's, "
                                        "else the drawing frame at --cell)")


class Once(argparse.Action):
    """``store``, but the option may be given once (a second one is a usage error)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, self.dest, None) is not None:
            parser.error(f"{option_string}: given twice ({getattr(namespace, self.dest)!r} and {values!r}); "
                         "give it once")
        setattr(namespace, self.dest, values)


def add_map(parser, cell=True, option=False):
    """``MAP`` (``option``: ``--map MAP``), ``--cell``, ``--unknown``."""
    help = ("map: .map (Moving AI), .txt ('#'/'@' obstacle), .pgm/.png (dark = obstacle) or a ROS "
            "map_server .yaml beside its image")
    if option:
        parser.add_argument("--map", metavar="MAP", action=Once, help=help)
    else:
        parser.add_argument("map", metavar="MAP", help=help)
    if cell:
        parser.add_argument("--cell", type=number(0, 1000, lo_open=True, unit="m",
                                                  why="metres a cell; 1 km is no robot map"),
                            default=None, metavar="METRES",
                            help="cell size in metres of a map without its own frame (default 0.1; "
                                 "a ROS map gives its resolution)")
    parser.add_argument("--unknown", choices=("obstacle", "free"), default="obstacle",
                        help="a ROS map's unknown cells: obstacles (default) or free")


def engine_type(serial):
    """``--engine``'s type: one of ENGINES or, with ``serial``,
    ``serial:PORT[@BAUD]`` (a board; sim/serial_engine.py checks it)."""
    def parse(text):
        if text in ENGINES or serial and text.startswith(SERIAL):
            return text
        more = ", 'serial:PORT[@BAUD]'" if serial else ""
        raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from "
                                         f"{', '.join(map(repr, ENGINES))}{more})")
    parse.__name__ = "engine"
    return parse


def add_engine(parser, what, serial=False):
    """``--engine``; ``serial``: a board over its serial port is offered too."""
    board = ("; serial:PORT[@BAUD]: the core on a board (make bitstream) over its USB serial port, "
             "checked against the model") if serial else ""
    parser.add_argument("--engine", type=engine_type(serial), default="model",
                        metavar="model|icarus|verilator" + ("|serial:PORT[@BAUD]" if serial else ""),
                        help=f"model (default): the golden model; icarus / verilator: {what}{board}")


def add_outputs(parser, json=True, plot=True, csv=False, plot_help="plot"):
    if json:
        parser.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    if plot:
        parser.add_argument("--plot", metavar="OUT.png", help=f"{plot_help} (.png, .pdf or .svg)")
    if csv:
        parser.add_argument("--csv", metavar="OUT.csv",
                            help="write the path as CSV: row, col, and x, y in metres in the map frame")


def add_block(parser, default):
    parser.add_argument("--block", metavar="NxM", default=f"{default[0]}x{default[1]}",
                        help="harmonic block size in nodes (default %(default)s)")


def add_schedule(parser, default):
    parser.add_argument("--schedule", metavar="P1,P2,...|P1:STEP:PMAX", default=default,
                        help="harmonic precisions, increasing (default %(default)s)")


MAX_BLOCK_SIDE = 4096   # the map is padded to whole blocks: keep that bounded
P_LIMIT = 1022          # the deepest word (p+2 bits) a 1024-deep node RAM holds


def parse_block(text):
    """``"NxM"`` -> (N, M) (``N,M`` is accepted too)."""
    parts = text.lower().replace(",", "x").split("x")
    try:
        if len(parts) != 2:
            raise ValueError
        n, m = int(parts[0]), int(parts[1])
    except ValueError:
        raise CliError(f"--block {text!r}: expected NxM (two positive integers, e.g. 16x16)") from None
    if n < 1 or m < 1:
        raise CliError(f"--block {text!r}: both sides must be >= 1")
    if n > MAX_BLOCK_SIDE or m > MAX_BLOCK_SIDE:
        raise CliError(f"--block {text!r}: sides above {MAX_BLOCK_SIDE} are not supported "
                       "(the map is padded to whole blocks)")
    return n, m


def parse_schedule(text, limit=P_LIMIT):
    """``"P1,P2,..."`` or ``"P1:STEP:PMAX"`` -> strictly increasing list of precisions."""
    text = text.strip()
    try:
        if ":" in text:
            parts = [int(x) for x in text.split(":")]
            if len(parts) != 3:
                raise ValueError
            first, step, last = parts
            if step < 1:
                raise CliError(f"--schedule {text!r}: STEP must be >= 1")
            if last < first:
                raise CliError(f"--schedule {text!r}: PMAX {last} is below P1 {first}")
            if first < 2 or last > limit:
                raise CliError(f"--schedule {text!r}: precisions must lie in 2..{limit} "
                               "(a 1024-word node RAM holds p + 2 <= 1024 bits)")
            ps = list(range(first, last + 1, step))
        else:
            ps = [int(x) for x in text.split(",")]
    except ValueError:
        raise CliError(f"--schedule {text!r}: expected P1,P2,... or P1:STEP:PMAX (integers)") from None
    if not ps:
        raise CliError(f"--schedule {text!r}: no precision")
    if any(b <= a for a, b in zip(ps, ps[1:])):
        raise CliError(f"--schedule {text!r}: precisions must increase")
    if ps[0] < 2 or ps[-1] > limit:
        raise CliError(f"--schedule {text!r}: precisions must lie in 2..{limit} "
                       "(a 1024-word node RAM holds p + 2 <= 1024 bits)")
    return ps


# --- maps and places ----------------------------------------------------------------

DEFAULT_CELL = 0.1


def load_map_arg(args):
    """(GridMap, frame) of ``args.map``: a ROS map's own frame, else the
    drawing frame at ``--cell`` (default 0.1 m)."""
    from navcores.models.maps import load
    path = Path(args.map)
    if not path.is_file():
        raise CliError(f"{path}: no such map file" if not path.exists() else f"{path}: not a file")
    gm = load(path, getattr(args, "unknown", "obstacle"))
    cell = getattr(args, "cell", None)
    if gm.frame is not None and cell is not None and cell != gm.frame.resolution:
        raise CliError(f"--cell {cell:g}: {path.name} is a ROS map with its own resolution "
                       f"({gm.frame.resolution:g} m a cell); leave --cell out")
    return gm, gm.frame_or(DEFAULT_CELL if cell is None else cell)


def places(args, role, grid, frame, free=True):
    """The cells of ``--<role>`` / ``--<role>-xy`` (in the order given), each
    inside the map (and, with ``free``, not on an obstacle)."""
    out = []
    for kind, text, option in getattr(args, role) or []:
        if kind == "cell":
            cell = parse_cell(text, option)
        else:
            x, y = parse_xy(text, option)
            r, c = frame.xy_to_cell(x, y)
            cell = (int(r), int(c))
            rows, cols = grid.shape
            if not (0 <= cell[0] < rows and 0 <= cell[1] < cols):
                raise CliError(f"{option} {text}: ({x:g}, {y:g}) m is off the map "
                               f"({_extent(frame)})")
        out.append(check_cell(grid, cell, role, free=free))
    return out


def _extent(frame):
    xs, ys = frame.corners()
    return (f"x {xs.min():g}..{xs.max():g} m, y {ys.min():g}..{ys.max():g} m")


def path_xy(frame, cells):
    """[[x, y], ...] (metres, map frame) of the cell centres along ``cells``."""
    if not len(cells):
        return []
    rows, cols = zip(*cells)
    xs, ys = frame.cell_to_xy(list(rows), list(cols))
    return [[float(x), float(y)] for x, y in zip(xs, ys)]


def path_csv(frame, cells, prefix=()):
    """CSV lines ``row,col,x,y`` of a cell path (``prefix``: leading columns)."""
    out = []
    for (r, c), (x, y) in zip(cells, path_xy(frame, cells)):
        out.append(",".join([*map(str, prefix), str(r), str(c), repr(x), repr(y)]))
    return out


# --- outputs ------------------------------------------------------------------------

OUTPUTS = (("json", None), ("plot", PLOT_SUFFIXES), ("csv", None))
INPUTS = ("map", "path", "input", "fll")


def check_outputs(args):
    """Every output path of ``args`` usable, before any work: not an input, not
    a folder, its folder created, a probe file written there and removed."""
    seen = {}
    inputs = {Path(v).resolve() for k in INPUTS if isinstance(v := getattr(args, k, None), str)}
    for name, suffixes in OUTPUTS:
        value = getattr(args, name, None)
        if value is None:
            continue
        opt = f"--{name}"
        if not value.strip():
            raise CliError(f"{opt}: empty file name")
        path = Path(value)
        if suffixes and path.suffix.lower() not in suffixes:
            raise CliError(f"{opt} {value}: expected a {', '.join(suffixes)} file name")
        if path.resolve() in inputs:
            raise CliError(f"{opt} {value}: that is an input file; write somewhere else")
        if path.resolve() in seen:
            raise CliError(f"{opt} {value}: the same file as {seen[path.resolve()]}")
        seen[path.resolve()] = opt
        if path.is_dir():
            raise CliError(f"{opt} {value}: is a folder, expected a file name")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.", delete=True):
                pass
        except OSError as e:
            raise CliError(f"{opt} {value}: cannot write there ({e.strerror or e})") from None


def _replace(path, write):
    """Write through ``write(tmp_path)`` into a temporary file beside
    ``path``, then rename it over ``path`` (no partial file on failure)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)          # as a plainly created file (mkstemp makes it 0600)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text(path, text):
    def write(tmp):
        Path(tmp).write_text(text)
    _replace(path, write)


def save_figure(fig, path, **kw):
    _replace(path, lambda tmp: fig.savefig(tmp, format=Path(path).suffix[1:].lower(), **kw))


# --- the frame --------------------------------------------------------------------

def _available():
    return {name: mod for name, mod in COMMANDS.items() if importlib.util.find_spec(mod) is not None}


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``--help`` still shows the usage),
    and a value such as ``-1.5,2`` (a point or cell left of / above the
    origin) is a value, not an option."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self._negative_number_matcher = re.compile(r"^-\d+$|^-\d*\.\d+$|^-[\d.]+([eE][-+]?\d+)?"
                                                   r"(,[-+]?[\d.]+([eE][-+]?\d+)?)+$")

    def error(self, message):
        # the same prefix as every other error of the command: "sim <command>: error:"
        self.exit(2, f"{self.prog.removeprefix('python -m ')}: error: {message} (see --help)\n")


def build_parser():
    parser = _Parser(prog="python -m sim", description="navcores: models and RTL runs of the cores",
                     epilog=EXIT_STATUS)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, mod in _available().items():
        module = importlib.import_module(mod)
        doc = (module.__doc__ or name).strip()
        p = sub.add_parser(name, help=doc.splitlines()[0], description=doc, epilog=EXIT_STATUS,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _prog=f"sim {name}")
    return parser


def fail(prog, message, status=2):
    print(f"{prog}: error: {message}", file=sys.stderr)
    return status


def guarded(prog, work):
    """``work()`` with the frame's promise: its status, or one line on stderr
    and 2 for bad input (CliError, MapFormatError, an unusable file, memory);
    an unexpected error is one line and 70 (``SIM_DEBUG=1``: the traceback)."""
    from navcores.models.maps import MapFormatError
    try:
        return int(work() or 0)
    except (CliError, MapFormatError) as e:
        return fail(prog, str(e))
    except OSError as e:
        name = f" {e.filename}:" if getattr(e, "filename", None) else ""
        return fail(prog, f"{name} {e.strerror or e}".strip())
    except MemoryError:
        return fail(prog, "out of memory: the input is too large for this machine")
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - the promise is one line, never a traceback
        if os.environ.get("SIM_DEBUG") == "1":
            raise
        print(f"{prog}: internal error: {type(e).__name__}: {e} (SIM_DEBUG=1 shows the traceback)",
              file=sys.stderr)
        return 70


def main(argv=None):
    os.environ.setdefault("AMARANTH_USE_YOSYS", "builtin")
    parser = build_parser()
    try:
        args = parser.parse_args(argv)      # a usage error: one line, 2; --help: 0
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else 2

    def work():
        check_outputs(args)
        return args._run(args)
    return guarded(args._prog, work)
