"""Maps, their frames and scenarios: every map format the project reads, for every layer.

A reader returns the map as a boolean grid (rows, cols), True where the cell
is an obstacle, row 0 being the top row of the map *as drawn* (the first text
row, the image's top row); commands take cells as ``ROW,COL`` in that order.
Any malformed input raises :class:`MapFormatError` naming the file and, for
text formats, the line: never a ``UnicodeDecodeError`` or a ``MemoryError``.

* ``.map``: Moving AI (maps/SOURCES.md gives the format): ``@``, ``T``, ``O``,
  ``W`` are obstacles; ``.`` and ``G`` / ``S`` are passable.
* ``.txt``: an ASCII grid, one row per line, ``#`` or ``@`` obstacle, ``.``
  free; every row as long as the first; blank lines at the end are ignored.
* ``.pgm`` / ``.png`` (any format Pillow reads): grey level < 128 (dark) is an
  obstacle, the rest free; colour images are converted to grey first.
* ``.yaml`` / ``.yml``: a ROS map_server / nav2 map, read as nav2's
  ``map_io.cpp`` (``loadMapYaml``, ``loadMapFromFile``) reads it:

  - ``image``: the image file, relative to the YAML file's folder unless
    absolute; ``resolution`` (metres per cell); ``origin: [x, y, yaw]``, the
    pose of the image's *lower-left* pixel corner in the map frame;
    ``occupied_thresh``, ``free_thresh``, ``negate`` (0/1 or a bool) are
    required, ``mode`` is ``trinary`` (default), ``scale`` or ``raw``.
  - A pixel's *shade* is the average of its red, green and blue quantums on
    a 0..1 scale (GraphicsMagick's Q16 arithmetic: an 8-bit value v is the
    quantum 257 v); in trinary mode an image with an alpha channel averages
    the alpha in as a fourth channel (opaque = 1), as nav2 does "to preserve
    existing behaviour".  ``occ = shade`` with ``negate``, else
    ``1 - shade``.
  - trinary: occupied (100) if ``occ > occupied_thresh``, free (0) if
    ``occ < free_thresh``, else unknown (-1).  scale: unknown if the pixel is
    not fully opaque, else occupied / free as trinary, else
    ``rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100)``.
    raw: ``round(shade * 255)`` if that is 0..100, else unknown.
  - The OccupancyGrid's row 0 is the image's *bottom* row (nav2 flips the
    rows so that the map frame's y axis points up): :attr:`GridMap.occupancy`
    holds nav2's int8 values in that order.
  - The obstacle grid: a cell is an obstacle when its value is 100 or more
    (the nav2 costmap static layer's default ``lethal_threshold`` 100 with
    ``trinary_costmap``: values below are free); unknown cells (-1) are
    obstacles, or free with ``unknown="free"``.

  Beyond nav2's loader (its map saver refuses the same): thresholds must lie
  in 0..1 with ``free_thresh <= occupied_thresh``, the resolution must be
  finite and > 0, the origin finite.

Frames (:class:`MapFrame`).  A YAML map carries its frame: x along the image
columns, y *up* the image, origin and yaw as given.  A map without one (the
other formats) gets the *drawing frame*: x along the columns, y down the rows
(as the map is drawn), the top-left corner at (0, 0), ``cell`` metres per
cell.  Either way cell (r, c) is the square of side ``resolution`` whose
centre :meth:`MapFrame.cell_to_xy` gives, and :meth:`MapFrame.xy_to_cell`
is its inverse.

Size: no map above :data:`MAX_CELLS` cells is read (before anything of its
size is allocated).

:func:`load` picks the reader by the file's suffix and returns a
:class:`GridMap` (grid, frame, nav2 values); :func:`load_grid` only the grid.
:func:`longest_scenario` is the one choice of a bundled map's job (the
demo's, the benchmarks').  :func:`save_map` / :func:`save_ros` write the
Moving AI and ROS formats (the bundled ``maps/room-32-32-4.yaml`` is
``room-32-32-4.map`` converted by them).
"""

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MapFormatError", "Scenario", "MapFrame", "GridMap", "MAX_CELLS", "MAP_SUFFIXES", "load",
           "load_map", "load_ascii", "load_image", "load_ros", "load_grid", "load_scenarios",
           "longest_scenario", "save_map", "save_ros", "nav2_values"]

PASSABLE = set(".GS")
BLOCKED = set("@TOW")

# Every command holds a handful of H x W arrays per map (the EDT/BFS model
# keeps about a dozen int64 planes, ~100 bytes a cell): 2**26 cells (an
# 8192 x 8192 map) is about 6.7 GB there, what this class of machine can
# spend.  The largest map any top of hdl/ holds is far smaller.
MAX_CELLS = 1 << 26
MAX_TEXT_BYTES = 2 * MAX_CELLS          # a text map: one character a cell plus line ends
IMAGE_SUFFIXES = (".pgm", ".png", ".pbm", ".ppm", ".bmp", ".gif", ".tif", ".tiff")
MAP_SUFFIXES = (".map", ".txt", ".yaml", ".yml") + IMAGE_SUFFIXES
MODES = ("trinary", "scale", "raw")
UNKNOWN = ("obstacle", "free")
LETHAL = 100                             # nav2 costmap static layer: lethal_threshold default
_Q16 = 65535                             # GraphicsMagick Q16's MaxRGB


class MapFormatError(ValueError):
    """A map or scenario file that does not follow its format."""

    def __init__(self, path, line, message):
        super().__init__(f"{path}:{line}: {message}" if line is not None else f"{path}: {message}")
        self.path, self.line = path, line


@dataclass(frozen=True)
class Scenario:
    start: tuple      # (row, col)
    goal: tuple       # (row, col)
    optimal_length: float


@dataclass(frozen=True)
class MapFrame:
    """Where the cells of an ``height`` x ``width`` map lie in metres.

    ``origin`` = (x, y, yaw): the pose of the map's corner from which the
    cells count: the lower-left corner with ``y_up`` (ROS), the top-left one
    without (the drawing frame).  Cell (r, c) has local centre
    ``u = (c + 1/2) res`` and ``v = (H - r - 1/2) res`` (``y_up``) or
    ``(r + 1/2) res``; the map frame is the local one rotated by yaw and
    moved to the origin."""

    height: int
    width: int
    resolution: float
    origin: tuple = (0.0, 0.0, 0.0)
    y_up: bool = True

    @classmethod
    def drawing(cls, height, width, cell):
        """The frame of a map that has none: x right, y down, top-left corner at 0."""
        return cls(int(height), int(width), float(cell), (0.0, 0.0, 0.0), False)

    def _rot(self):
        yaw = self.origin[2]
        return (1.0, 0.0) if yaw == 0 else (math.cos(yaw), math.sin(yaw))

    def local_to_xy(self, u, v):
        cos, sin = self._rot()
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        if sin == 0 and cos == 1:           # no rotation: exact (the drawing frame's arithmetic)
            return u + self.origin[0], v + self.origin[1]
        return self.origin[0] + cos * u - sin * v, self.origin[1] + sin * u + cos * v

    def cell_to_xy(self, rows, cols):
        """Centres (x, y), metres, of the cells (rows, cols) (scalars or arrays)."""
        res = self.resolution
        rows, cols = np.asarray(rows, dtype=float), np.asarray(cols, dtype=float)
        v = (self.height - rows - 0.5) * res if self.y_up else (rows + 0.5) * res
        return self.local_to_xy((cols + 0.5) * res, v)

    def xy_to_local(self, x, y):
        cos, sin = self._rot()
        dx = np.asarray(x, dtype=float) - self.origin[0]
        dy = np.asarray(y, dtype=float) - self.origin[1]
        if sin == 0 and cos == 1:
            return dx, dy
        return cos * dx + sin * dy, -sin * dx + cos * dy

    def xy_to_cell(self, x, y):
        """The cells (rows, cols), int arrays, that hold the points (x, y); a point
        off the map gets a row or column outside 0..H-1 / 0..W-1 (NaN: -1)."""
        u, v = self.xy_to_local(x, y)
        with np.errstate(invalid="ignore"):
            j = np.floor(u / self.resolution)
            i = np.floor(v / self.resolution)
            bad = ~(np.isfinite(i) & np.isfinite(j))
            big = float(max(self.height, self.width) + 1)
            i, j = np.where(bad, -1, np.clip(i, -big, big)), np.where(bad, -1, np.clip(j, -big, big))
        i, j = i.astype(np.int64), j.astype(np.int64)
        rows = self.height - 1 - i if self.y_up else i
        return np.where(bad, -1, rows), j

    def corners(self):
        """(X, Y), (H+1) x (W+1) arrays: the cell corners in the map frame (row-major as drawn)."""
        res = self.resolution
        r = np.arange(self.height + 1, dtype=float)[:, None]
        c = np.arange(self.width + 1, dtype=float)[None, :]
        v = (self.height - r) * res if self.y_up else r * res
        return self.local_to_xy(np.broadcast_to(c * res, (self.height + 1, self.width + 1)),
                                np.broadcast_to(v, (self.height + 1, self.width + 1)))

    def as_dict(self):
        return {"resolution": self.resolution, "origin": list(self.origin),
                "y_up": self.y_up, "frame": "map (ROS)" if self.y_up else "drawing (y down)"}


@dataclass(frozen=True)
class GridMap:
    """A map read by :func:`load`: ``obstacle`` (bool, rows as drawn), its
    ``frame`` (None for formats without one) and, for a ROS map, nav2's
    OccupancyGrid values ``occupancy`` (int8, row 0 = the image's bottom row)."""

    obstacle: np.ndarray
    frame: MapFrame | None = None
    occupancy: np.ndarray | None = None
    path: Path | None = None

    def frame_or(self, cell):
        """Its own frame, else the drawing frame at ``cell`` metres per cell."""
        return self.frame or MapFrame.drawing(*self.obstacle.shape, cell)


# --- text formats --------------------------------------------------------------

def _read_text(path):
    """The lines of a text file; a binary or non-UTF-8 file is a MapFormatError."""
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(2, "No such file", str(path))
        raise MapFormatError(path, None, "not a regular file")
    size = path.stat().st_size
    if size > MAX_TEXT_BYTES:
        raise MapFormatError(path, None, f"{size} bytes: larger than any map of at most {MAX_CELLS} cells")
    data = path.read_bytes()
    if b"\0" in data:
        raise MapFormatError(path, data[:data.index(b"\0")].count(b"\n") + 1, "a NUL byte: not a text file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise MapFormatError(path, line, f"byte 0x{data[e.start]:02x} is not UTF-8 text") from None
    return text.splitlines()


def _check_size(path, height, width, line=None):
    if height * width > MAX_CELLS:
        raise MapFormatError(path, line, f"a {height}x{width} map has {height * width} cells; at most "
                                         f"{MAX_CELLS} (2**26) are read: the commands hold about 100 bytes "
                                         f"a cell, {MAX_CELLS * 100 / 1e9:.1f} GB at that size")


def _header(path, lines, n, key):
    if n >= len(lines):
        raise MapFormatError(path, n + 1, f"missing '{key} N' line")
    words = lines[n].split()
    if len(words) != 2 or words[0] != key or not words[1].isdecimal() or not words[1].isascii() \
            or int(words[1]) == 0:
        raise MapFormatError(path, n + 1, f"expected '{key} N' with N > 0, got {lines[n][:60]!r}")
    return int(words[1])


def load_map(path):
    """The Moving AI map at ``path`` as a bool array (rows, cols), True = obstacle."""
    path = Path(path)
    lines = _read_text(path)
    if not lines or lines[0].split()[:1] != ["type"]:
        raise MapFormatError(path, 1, "expected 'type octile'")
    height = _header(path, lines, 1, "height")
    width = _header(path, lines, 2, "width")
    _check_size(path, height, width, 3)
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
    lines = _read_text(path)
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise MapFormatError(path, 1, "empty grid")
    width = len(lines[0])
    _check_size(path, len(lines), width)
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


# --- images -------------------------------------------------------------------

def _open_image(path):
    """(quantums (H, W, 3) float64 on GraphicsMagick's Q16 scale, alpha (H, W)
    on the same scale or None when the image has no alpha channel)."""
    from PIL import Image, UnidentifiedImageError
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(2, "No such file", str(path))
        raise MapFormatError(path, None, "not a regular file")
    try:
        with Image.open(path) as im:
            w, h = im.size
            if w * h == 0:
                raise MapFormatError(path, None, "empty image")
            _check_size(path, h, w)
            mode = im.mode
            if mode == "F":
                raise MapFormatError(path, None, "a floating-point image: expected 8 or 16 bits a channel")
            if mode.startswith("I"):             # 16-bit grey (I;16, or I for a 16-bit PNG)
                grey = np.asarray(im, dtype=np.float64)
                if grey.min() < 0 or grey.max() > _Q16:
                    raise MapFormatError(path, None, "a 32-bit image: expected 8 or 16 bits a channel")
                return np.repeat(grey[..., None], 3, axis=2), None
            has_alpha = "A" in im.getbands() or "transparency" in im.info
            rgba = np.asarray(im.convert("RGBA" if has_alpha else "RGB"), dtype=np.float64) * 257.0
    except MapFormatError:
        raise
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError) as e:
        if isinstance(e, FileNotFoundError):
            raise
        raise MapFormatError(path, None, f"not a readable image ({str(e)[:120]})") from None
    if has_alpha:
        return rgba[..., :3], rgba[..., 3]
    return rgba, None


def load_image(path):
    """A PGM/PNG image as a bool array: grey < 128 (dark) = obstacle."""
    from PIL import Image
    rgb, _ = _open_image(path)
    # Pillow's "L" conversion (ITU-R 601-2 luma, rounded) of the 8-bit channels
    r, g, b = (rgb[..., k] / 257.0 for k in range(3))
    if np.array_equal(r, g) and np.array_equal(g, b):
        grey = r
    else:
        grey = np.asarray(Image.fromarray(np.stack([r, g, b], -1).round().astype(np.uint8), "RGB").convert("L"))
    return grey < 128


def nav2_values(rgb, alpha, mode="trinary", negate=False, occupied_thresh=0.65, free_thresh=0.25):
    """nav2's OccupancyGrid values (int8: -1 unknown, 0..100) of pixels given
    as Q16 quantums (``rgb`` (..., 3), ``alpha`` (...) or None), in the
    pixels' own order (map_io.cpp ``loadMapFromFile``, before the row flip)."""
    if mode not in MODES:
        raise ValueError(f"mode {mode!r}: expected one of {', '.join(MODES)}")
    channels = [rgb[..., 0], rgb[..., 1], rgb[..., 2]]
    if mode == "trinary" and alpha is not None:
        channels.append(alpha)               # nav2 averages the alpha in (GraphicsMagick: MaxRGB - opacity)
    total = channels[0] + channels[1] + channels[2] + (channels[3] if len(channels) == 4 else 0.0)
    shade = (total / len(channels)) / _Q16
    occ = shade if negate else 1.0 - shade
    out = np.full(shade.shape, -1, dtype=np.int8)
    if mode == "raw":
        value = np.floor(shade * 255 + 0.5)          # std::round, shade >= 0
        ok = (value >= 0) & (value <= 100)
        out[ok] = value[ok].astype(np.int8)
        return out
    occupied = occupied_thresh < occ
    free = occ < free_thresh
    if mode == "trinary":
        out[occupied] = 100
        out[~occupied & free] = 0
        return out
    opaque = np.ones(shade.shape, dtype=bool) if alpha is None else alpha == _Q16
    between = np.rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100.0) \
        if occupied_thresh != free_thresh else np.zeros(shade.shape)
    out[opaque] = np.where(occupied, 100, np.where(free, 0, between))[opaque].astype(np.int8)
    return out


# --- ROS map_server / nav2 ------------------------------------------------------

def _yaml_number(path, doc, key, lines):
    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MapFormatError(path, _key_line(lines, key), f"'{key}' must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise MapFormatError(path, _key_line(lines, key), f"'{key}' must be finite, got {value}")
    return value


def _key_line(lines, key):
    for n, text in enumerate(lines, start=1):
        if text.lstrip().startswith(f"{key}:") or text.lstrip().startswith(f'"{key}":'):
            return n
    return None


def load_ros(path, unknown="obstacle"):
    """A ROS map_server / nav2 map (``.yaml`` beside its image) as a :class:`GridMap`."""
    import yaml
    path = Path(path)
    if unknown not in UNKNOWN:
        raise ValueError(f"unknown={unknown!r}: expected one of {', '.join(UNKNOWN)}")
    lines = _read_text(path)
    try:
        doc = yaml.safe_load("\n".join(lines))
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        what = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise MapFormatError(path, mark.line + 1 if mark else None, f"not valid YAML: {what}") from None
    except RecursionError:
        raise MapFormatError(path, None, "not valid YAML: nested too deeply") from None
    if not isinstance(doc, dict):
        raise MapFormatError(path, 1, "expected a YAML mapping with image, resolution, origin, "
                                      "occupied_thresh, free_thresh, negate (a ROS map_server map)")
    missing = [k for k in ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate")
               if k not in doc]
    if missing:
        raise MapFormatError(path, None, f"missing {', '.join(missing)} (a ROS map_server map names all of "
                                         "image, resolution, origin, occupied_thresh, free_thresh, negate)")
    image = doc["image"]
    if not isinstance(image, str) or not image.strip():
        raise MapFormatError(path, _key_line(lines, "image"), f"'image' must name the image file, got {image!r}")
    resolution = _yaml_number(path, doc, "resolution", lines)
    if resolution <= 0:
        raise MapFormatError(path, _key_line(lines, "resolution"), f"resolution {resolution}: must be > 0 "
                                                                   "(metres per cell)")
    origin = doc["origin"]
    if not isinstance(origin, list) or len(origin) != 3 or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in origin):
        raise MapFormatError(path, _key_line(lines, "origin"),
                             f"'origin' must be [x, y, yaw], three finite numbers, got {origin!r}")
    occ_th = _yaml_number(path, doc, "occupied_thresh", lines)
    free_th = _yaml_number(path, doc, "free_thresh", lines)
    if not (0.0 <= free_th <= occ_th <= 1.0):
        raise MapFormatError(path, _key_line(lines, "free_thresh"),
                             f"free_thresh {free_th}, occupied_thresh {occ_th}: expected "
                             "0 <= free_thresh <= occupied_thresh <= 1")
    negate = doc["negate"]
    if not isinstance(negate, (bool, int)):
        raise MapFormatError(path, _key_line(lines, "negate"), f"'negate' must be 0, 1 or a bool, got {negate!r}")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MapFormatError(path, _key_line(lines, "mode"), f"mode {mode!r}: expected one of {', '.join(MODES)}")
    image_path = Path(image) if Path(image).is_absolute() else path.parent / image
    if not image_path.is_file():
        raise MapFormatError(path, _key_line(lines, "image"), f"image {image_path}: no such file "
                                                              "(a relative path is relative to the YAML file)")
    rgb, alpha = _open_image(image_path)
    values = nav2_values(rgb, alpha, mode, bool(negate), occ_th, free_th)
    occupancy = values[::-1].copy()                 # nav2: data[W * (H - y - 1) + x], row 0 at the bottom
    obstacle = values >= LETHAL
    if unknown == "obstacle":
        obstacle |= values < 0
    h, w = obstacle.shape
    frame = MapFrame(h, w, resolution, tuple(float(v) for v in origin), True)
    return GridMap(obstacle, frame, occupancy, path)


# --- any map --------------------------------------------------------------------

def load(path, unknown="obstacle"):
    """The map at ``path`` by its suffix, as a :class:`GridMap` (``unknown``:
    what a ROS map's unknown cells are, ``"obstacle"`` or ``"free"``)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        return load_ros(path, unknown)
    if suffix == ".map":
        return GridMap(load_map(path), path=path)
    if suffix == ".txt":
        return GridMap(load_ascii(path), path=path)
    if suffix in IMAGE_SUFFIXES:
        return GridMap(load_image(path), path=path)
    raise MapFormatError(path, None, f"unknown map format {suffix or '(no suffix)'!r}: use .map, .txt, "
                                     ".pgm, .png or a ROS map's .yaml")


def load_grid(path, unknown="obstacle"):
    """The obstacle grid of the map at ``path`` (:func:`load`)."""
    return load(path, unknown).obstacle


def load_scenarios(path, grid=None):
    """Scenario lines of ``path``; starts and goals are checked against ``grid``."""
    path = Path(path)
    lines = _read_text(path)
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


def longest_scenario(map_path, obstacle=None, scen=None):
    """The job a bundled map stands for: the longest scenario of ``scen``
    (default: the map's first ``<stem>-even-*.scen`` file); a map without one
    gets its first and last free cell (raster order) as start and goal, with
    ``optimal_length`` NaN."""
    map_path = Path(map_path)
    obstacle = load_grid(map_path) if obstacle is None else obstacle
    if scen is None:
        found = sorted(map_path.parent.glob(map_path.stem + "-even-*.scen"))
        scen = found[0] if found else None
    if scen is not None:
        scenarios = load_scenarios(scen, obstacle)
        if not scenarios:
            raise MapFormatError(scen, None, "no scenario")
        return max(scenarios, key=lambda s: s.optimal_length)
    free = np.argwhere(~obstacle)
    if not len(free):
        raise MapFormatError(map_path, None, "no free cell")
    return Scenario(tuple(int(v) for v in free[0]), tuple(int(v) for v in free[-1]), float("nan"))


# --- writers --------------------------------------------------------------------

def save_map(path, obstacle):
    """Write ``obstacle`` as a Moving AI map (``@`` obstacle, ``.`` free)."""
    obstacle = np.asarray(obstacle, dtype=bool)
    rows = ["".join("@" if v else "." for v in row) for row in obstacle]
    Path(path).write_text(f"type octile\nheight {obstacle.shape[0]}\nwidth {obstacle.shape[1]}\nmap\n"
                          + "\n".join(rows) + "\n")


def save_ros(path, obstacle, resolution, origin=(0.0, 0.0, 0.0), image=None):
    """Write ``obstacle`` as a ROS map: ``path`` (.yaml) and its PGM image
    (default: same stem, .pgm), as nav2's map saver writes a trinary map:
    occupied 0, free 254, thresholds 0.65 / 0.25, negate 0."""
    path = Path(path)
    image = Path(image) if image is not None else path.with_suffix(".pgm")
    grid = np.asarray(obstacle, dtype=bool)
    h, w = grid.shape
    pixels = np.where(grid, 0, 254).astype(np.uint8)
    image.write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.tobytes())
    x, y, yaw = (float(v) for v in origin)
    rel = image.name if image.parent == path.parent else str(image)
    path.write_text(f"image: {rel}\nmode: trinary\nresolution: {float(resolution)!r}\n"
                    f"origin: [{x!r}, {y!r}, {yaw!r}]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n")
