"""From a planner's cell path to chains the fuzzy tracker can follow (paper 003, section 3).

World frame: the map's :class:`~models.maps.MapFrame` (``frame``), or a cell
size ``cell`` in metres for the *drawing frame*: cell (r, c) of an H x W map
is then the square ``c*cell <= x < (c+1)*cell``, ``r*cell <= y <
(r+1)*cell``, centre ``((c + 1/2) cell, (r + 1/2) cell)`` (y grows with the
row index, as the map is drawn: a frame mirrored with respect to the usual
counter-clockwise one; the differential drive is mirror-symmetric, so
nothing else changes).  A ROS map's frame has y up, its origin and yaw
(models/maps.py); every function below works in either.

1. :func:`safe_cells`: a diagonal step between two cells (8-connected BFS
   paths) gets the free orthogonal cell inserted when the other one is an
   obstacle, so that consecutive cells never touch an obstacle only at a
   corner.
2. :func:`shorten`: greedy line-of-sight shortening: from each kept vertex,
   jump to the farthest later cell whose centre segment is *clear*: a point
   of the segment, sampled every ``cell/20``, and the four points
   ``±clearance`` away from it in x and y, all lie in free cells.  It never
   crosses an obstacle cell and keeps ``clearance`` (default a quarter cell)
   of margin for the tracker's corner cutting.  The fallback is the next cell,
   whose step is clear by construction of step 1.
3. :func:`split_monotone`: the polyline cut into maximal chains whose edge
   directions span less than ``max_spread`` (default 120 degrees): each is
   strictly monotone, and keeping the spread well below 180 degrees keeps
   |sin(θ_s - θ_k)| >= sin(30 degrees) for the SWAM's default shifting angle,
   so Ω stays moderate.  Consecutive chains share their joint vertex.
4. :func:`collisions`: poses whose point lies in an obstacle cell (or off the
   map).
"""

import math

import numpy as np

from .maps import MapFrame
from .swam import Swam, monotone_direction

__all__ = ["as_frame", "cell_centre", "safe_cells", "segment_clear", "shorten", "split_monotone", "to_chains",
           "collisions"]


def as_frame(obstacle, frame):
    """``frame`` itself, or the drawing frame of ``obstacle`` at ``frame`` metres a cell."""
    if isinstance(frame, MapFrame):
        return frame
    return MapFrame.drawing(*np.shape(obstacle), float(frame))


def cell_centre(cell_rc, frame):
    """The centre (x, y) of cell ``(r, c)``: ``frame`` is a MapFrame or the drawing frame's cell size."""
    r, c = cell_rc
    if not isinstance(frame, MapFrame):
        return ((c + 0.5) * frame, (r + 0.5) * frame)
    x, y = frame.cell_to_xy(r, c)
    return (float(x), float(y))


def safe_cells(path, obstacle):
    """Insert the free orthogonal cell into diagonal steps that pass an obstacle corner."""
    out = [tuple(path[0])]
    for r, c in path[1:]:
        pr, pc = out[-1]
        if abs(r - pr) == 1 and abs(c - pc) == 1:
            a, b = (pr, c), (r, pc)
            if obstacle[a] and not obstacle[b]:
                out.append(b)
            elif obstacle[b] and not obstacle[a]:
                out.append(a)
        out.append((int(r), int(c)))
    return out


def _free_at(obstacle, x, y, frame):
    r, c = as_frame(obstacle, frame).xy_to_cell(x, y)
    inside = (r >= 0) & (r < obstacle.shape[0]) & (c >= 0) & (c < obstacle.shape[1])
    ok = inside.copy()
    ok[inside] = ~obstacle[r[inside], c[inside]]
    return ok


def segment_clear(obstacle, a, b, frame, clearance):
    """True when the segment a-b (metres) keeps ``clearance`` from every obstacle cell (sampled)."""
    frame = as_frame(obstacle, frame)
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = max(2, int(math.ceil(np.hypot(*(b - a)) / (frame.resolution / 20))) + 1)
    t = np.linspace(0, 1, n)
    x = a[0] + t * (b[0] - a[0])
    y = a[1] + t * (b[1] - a[1])
    for dx, dy in ((0, 0), (clearance, 0), (-clearance, 0), (0, clearance), (0, -clearance)):
        if not _free_at(obstacle, x + dx, y + dy, frame).all():
            return False
    return True


def shorten(cells, obstacle, frame, clearance=None):
    """Greedy line-of-sight shortening of a cell path; returns vertices (n, 2) in metres."""
    frame = as_frame(obstacle, frame)
    clearance = frame.resolution / 4 if clearance is None else clearance
    pts = [cell_centre(rc, frame) for rc in cells]
    keep = [0]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not segment_clear(obstacle, pts[i], pts[j], frame, clearance):
            j -= 1
        keep.append(j)
        i = j
    return np.array([pts[k] for k in keep])


def split_monotone(vertices, max_spread=math.radians(120)):
    """Cut a polyline into maximal chains whose edge directions span < ``max_spread``."""
    v = np.asarray(vertices, dtype=float)
    d = np.diff(v, axis=0)
    ang = np.arctan2(d[:, 1], d[:, 0])
    chains, start = [], 0
    for k in range(1, len(ang) + 1):
        if k == len(ang) or monotone_direction(ang[start:k + 1])[1] >= max_spread:
            chains.append(v[start:k + 1])
            start = k
    return chains


def to_chains(vertices, max_spread=math.radians(120)):
    """:func:`split_monotone` as Swam objects (default shifting angles)."""
    return [Swam(c) for c in split_monotone(vertices, max_spread)]


def collisions(poses, obstacle, frame):
    """Number of poses (x, y, ...) inside an obstacle cell or off the map."""
    p = np.asarray(poses, dtype=float)
    return int((~_free_at(obstacle, p[:, 0], p[:, 1], frame)).sum())
