"""Maps and scenarios: Moving AI benchmark maps, ASCII grids and images.

Every reader returns a boolean grid (rows, cols), True where the cell is an
obstacle.  Any malformed input raises :class:`MapFormatError` naming the file
and, for text formats, the line.

* ``.map``: Moving AI (maps/SOURCES.md gives the format): ``@``, ``T``, ``O``,
  ``W`` are obstacles; ``.`` and ``G`` / ``S`` are passable.
* ``.txt``: an ASCII grid, one row per line, ``#`` or ``@`` obstacle, ``.``
  free; every row as long as the first; blank lines at the end are ignored.
* ``.pgm`` / ``.png`` (any format Pillow reads): grey level < 128 (dark) is an
  obstacle, the rest free; colour images are converted to grey first.

:func:`load_grid` picks the reader by the file's suffix.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MapFormatError", "Scenario", "load_map", "load_ascii", "load_image", "load_grid", "load_scenarios"]

PASSABLE = set(".GS")
BLOCKED = set("@TOW")


class MapFormatError(ValueError):
    """A map or scenario file that does not follow the Moving AI format."""

    def __init__(self, path, line, message):
        super().__init__(f"{path}:{line}: {message}" if line is not None else f"{path}: {message}")
        self.path, self.line = path, line


@dataclass(frozen=True)
class Scenario:
    start: tuple      # (row, col)
    goal: tuple       # (row, col)
    optimal_length: float


def _header(path, lines, n, key):
    if n >= len(lines):
        raise MapFormatError(path, n + 1, f"missing '{key} N' line")
    words = lines[n].split()
    if len(words) != 2 or words[0] != key or not words[1].isdigit() or int(words[1]) == 0:
        raise MapFormatError(path, n + 1, f"expected '{key} N' with N > 0, got {lines[n]!r}")
    return int(words[1])


def load_map(path):
    """The map at ``path`` as a bool array (rows, cols), True = obstacle."""
    path = Path(path)
    lines = path.read_text().splitlines()
    if not lines or lines[0].split()[:1] != ["type"]:
        raise MapFormatError(path, 1, "expected 'type octile'")
    height = _header(path, lines, 1, "height")
    width = _header(path, lines, 2, "width")
    if len(lines) < 4 or lines[3].strip() != "map":
        raise MapFormatError(path, 4, "expected 'map'")
    rows = lines[4:4 + height]
    if len(rows) < height:
        raise MapFormatError(path, 4 + len(rows) + 1, f"map ends after {len(rows)} of {height} rows")
    grid = np.zeros((height, width), dtype=bool)
    for r, row in enumerate(rows):
        line = 5 + r
        if len(row) != width:
            raise MapFormatError(path, line, f"row has {len(row)} cells, width is {width}")
        for c, ch in enumerate(row):
            if ch in BLOCKED:
                grid[r, c] = True
            elif ch not in PASSABLE:
                raise MapFormatError(path, line, f"unknown terrain {ch!r} in column {c}")
    extra = [i for i, text in enumerate(lines[4 + height:], start=5 + height) if text.strip()]
    if extra:
        raise MapFormatError(path, extra[0], "text after the last map row")
    return grid


def load_ascii(path):
    """An ASCII grid (``#``/``@`` obstacle, ``.`` free) as a bool array, True = obstacle."""
    path = Path(path)
    lines = path.read_text().splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise MapFormatError(path, 1, "empty grid")
    width = len(lines[0])
    grid = np.zeros((len(lines), width), dtype=bool)
    for r, row in enumerate(lines):
        if len(row) != width:
            raise MapFormatError(path, r + 1, f"row has {len(row)} cells, the first row has {width}")
        for c, ch in enumerate(row):
            if ch in "#@":
                grid[r, c] = True
            elif ch != ".":
                raise MapFormatError(path, r + 1, f"unknown cell {ch!r} in column {c} (expected '#', '@' or '.')")
    return grid


def load_image(path):
    """A PGM/PNG image as a bool array: grey < 128 (dark) = obstacle."""
    from PIL import Image, UnidentifiedImageError
    path = Path(path)
    try:
        with Image.open(path) as im:
            grey = np.asarray(im.convert("L"))
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as e:
        if isinstance(e, FileNotFoundError):
            raise
        raise MapFormatError(path, None, f"not a readable image ({e})") from None
    if grey.size == 0:
        raise MapFormatError(path, None, "empty image")
    return grey < 128


def load_grid(path):
    """The map at ``path`` by its suffix: ``.map``, ``.txt``, else an image."""
    suffix = Path(path).suffix.lower()
    if suffix == ".map":
        return load_map(path)
    if suffix == ".txt":
        return load_ascii(path)
    if suffix in (".pgm", ".png", ".pbm", ".ppm", ".bmp", ".gif", ".tif", ".tiff"):
        return load_image(path)
    raise MapFormatError(path, None, f"unknown map format {suffix or '(no suffix)'!r}: use .map, .txt, .pgm or .png")


def load_scenarios(path, grid=None):
    """Scenario lines of ``path``; starts and goals are checked against ``grid``."""
    path = Path(path)
    lines = path.read_text().splitlines()
    if not lines or lines[0].split() != ["version", "1"]:
        raise MapFormatError(path, 1, "expected 'version 1'")
    out = []
    for n, text in enumerate(lines[1:], start=2):
        if not text.strip():
            continue
        f = text.split("\t") if "\t" in text else text.split()
        if len(f) != 9:
            raise MapFormatError(path, n, f"expected 9 fields, got {len(f)}")
        try:
            w, h, sx, sy, gx, gy = (int(x) for x in f[2:8])
            length = float(f[8])
        except ValueError as e:
            raise MapFormatError(path, n, f"bad number: {e}") from None
        if grid is not None:
            if (h, w) != grid.shape:
                raise MapFormatError(path, n, f"scenario is for a {w}x{h} map, the map is {grid.shape[1]}x{grid.shape[0]}")
            for name, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
                if not (0 <= x < w and 0 <= y < h):
                    raise MapFormatError(path, n, f"{name} ({x}, {y}) outside the map")
                if grid[y, x]:
                    raise MapFormatError(path, n, f"{name} ({x}, {y}) is on an obstacle")
        out.append(Scenario((sy, sx), (gy, gx), length))
    return out
