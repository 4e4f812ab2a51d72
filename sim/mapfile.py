"""Moving AI benchmark maps and scenarios (maps/SOURCES.md gives the format).

``load_map`` returns a boolean grid, True where the cell is an obstacle
(``@``, ``T``, ``O``, ``W``; ``.`` and ``G`` / ``S`` are passable).  Any
malformed input raises :class:`MapFormatError` naming the file and line.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MapFormatError", "Scenario", "load_map", "load_scenarios"]

PASSABLE = set(".GS")
BLOCKED = set("@TOW")


class MapFormatError(ValueError):
    """A map or scenario file that does not follow the Moving AI format."""

    def __init__(self, path, line, message):
        super().__init__(f"{path}:{line}: {message}")
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
