"""Golden model of the EDT/NNT + BFS path-planning array (paper 004, sections III-IV).

Neighbourhood (Fig. 1), ``p_i = p + OFFSETS[i]`` as (row, column)::

    6 2 5
    3 0 1
    7 4 8

Number format
-------------
All quantities are integers.  Per pixel p:

* ``(dx, dy)``: the *signed* displacement of p from its nearest obstacle pixel
  q found so far, ``(dx, dy) = p - q`` in (rows, columns); so the nearest
  obstacle (the NNT) is ``p - (dx, dy)`` and ``d2 = dx^2 + dy^2``.
* ``delta``: the paper's delta (section III).  Invariant: a pixel that is done
  at the end of iteration k holds ``delta_k(p) = k^2 + k - d2(p) >= 0``; the
  obstacles start with ``delta_0 = 0`` (k = 0, d2 = 0) and every done pixel
  adds 2k in iteration k (eq. 4), so ``delta`` never needs squares.
* ``di``: the integer distance, the iteration k in which p became done
  (section III: "p can be assigned an integer distance d_i which is equal to
  k").  With exact propagation it is the smallest k with ``d2 <= k^2 + k``,
  i.e. ``d = sqrt(d2)`` rounded to the nearest integer (``d`` is never a
  half-integer, since ``k^2 + k + 1/4`` is not an integer); obstacles hold 0.

Iteration k of the EDT (algorithm Parallel_Path_Plan, step 2; Fig. 2)
----------------------------------------------------------------------
For a pixel p that is not done, each *done* neighbour p_i proposes its own
nearest obstacle: with ``(sr, sc) = p - p_i`` (each -1, 0 or 1),

    dx_i = dx(p_i) + sr,  dy_i = dy(p_i) + sc                        (eq. 1)
    DX_i = 2 sr dx(p_i) + 1 if sr != 0 else 0, DY_i likewise         (eq. 2)
    delta_i = delta_{k-1}(p_i) - DX_i - DY_i                          (eq. 3)
            = (k-1)^2 + (k-1) - (dx_i^2 + dy_i^2)

The signs make eq. (1)-(2) exact for any direction (the paper's |dx| + 1 is
the case where p lies farther from the obstacle than p_i).  The MAX tree takes
the largest delta_i over done neighbours; **ties go to the smallest neighbour
index** (the seven CMP-MUX of Fig. 2 pair (1,2) (3,4) (5,6) (7,8), then
(12,34) (56,78), then the two halves, and each keeps its left, lower-indexed,
input unless the right one is valid and strictly greater).  The adder gives
``delta_m + 2k = k^2 + k - d2_m``; p becomes done, with that delta, the
vector (dx_m, dy_m) and di = k, when at least one neighbour is done and that
sum is >= 0 (the paper's three clock-enable conditions, section IV).  A done
pixel adds 2k to its delta.  All pixels update from the same old values.

Termination: the EDT stops after the first iteration in which no pixel
becomes done (that iteration is counted in ``iterations``).  This never stops
early: a pixel 4-adjacent to one done in iteration j has a candidate with
``d < (j + 1/2) + 1`` and so is done by iteration j + 1; if iteration k makes
no pixel done, every done pixel's 8 neighbours are done.  So with at least one
obstacle every pixel is reached; in an image **without obstacles** no pixel
ever is: there ``distance`` is -1, ``nearest`` is (-1, -1), and such pixels
count as infinitely far from any obstacle, i.e. they are in the cfr.

8-neighbour propagation is not an exact EDT (a pixel inherits only its
neighbours' nearest obstacles); tb/edt_bfs/test_edt_model.py measures how
often di and d2 differ from scipy's exact EDT.

cfr (step 3) and BFS (step 4)
-----------------------------
``cfr(p) = 1`` where ``di(p) > dfar`` or p was never reached (no obstacle);
obstacles (di = 0) are never in it.  BFS roots: the goal pixels that are in
the cfr (a goal outside the cfr is dropped).  BFS iteration: a cfr pixel that
is not visited and has a visited 8-neighbour becomes visited with ``parent``
= the smallest such neighbour index (0 = none, a root or never visited).
Several goals grow at once, so the path goes to the nearest one.  BFS stops
after the first iteration that visits nothing (counted).  Step 5: the path
follows parents from the start to a root; it exists when the start is visited.

Cycle count of one job on the RTL (hdl/edt_bfs/edt_bfs.py), with the image
stream always valid and the result stream always ready, counted from the
cycle the command is accepted (exclusive) to the last result beat (inclusive):

    cycles = W (load) + iterations_edt + 1 (cfr) + iterations_bfs
             + len(path) + H * W (cell read-out)
"""

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "OFFSETS", "EdtResult", "EdtBfsResult", "widths", "edt", "edt_step",
    "cfr_map", "bfs", "bfs_step", "trace_path", "plan_path", "job_cycles",
]

# Fig. 1: neighbour index -> (row, column) offset of p_i from p.
OFFSETS = {1: (0, 1), 2: (-1, 0), 3: (0, -1), 4: (1, 0),
           5: (-1, 1), 6: (-1, -1), 7: (1, -1), 8: (1, 1)}


def _bits(n):
    """Bits of an unsigned number up to n (at least 1)."""
    return max(1, int(n).bit_length())


def widths(height, width):
    """Register widths of an ``height`` x ``width`` array, with their bounds.

    * d2_max = (H-1)^2 + (W-1)^2, the largest squared distance in the array.
    * k_di = the smallest k with k^2 + k >= d2_max: the largest di.
    * k_max = k_di + 1: the largest iteration number (the last EDT iteration
      finds nothing new).  ``k`` holds 1..k_max.
    * delta <= k_max^2 + k_max (done pixels, d2 >= 0); delta >= 0.
    * |dx| <= H - 1, |dy| <= W - 1: signed, one sign bit more.
    * a candidate delta_i lies in [-(2(H-1)+1) - (2(W-1)+1), delta_max + 2(H-1)+1 + 2(W-1)+1]
      (DX_i = 2 sr dx + 1 may be negative).
    """
    if height < 1 or width < 1:
        raise ValueError(f"array size {height}x{width}: both must be >= 1")
    d2_max = (height - 1) ** 2 + (width - 1) ** 2
    k_di = 0
    while k_di * k_di + k_di < d2_max:
        k_di += 1
    k_max = k_di + 1
    delta_max = k_max * k_max + k_max
    spread = 2 * (height - 1) + 1 + 2 * (width - 1) + 1
    cand_hi = delta_max + spread
    return {
        "d2_max": d2_max, "k_di": k_di, "k_max": k_max, "delta_max": delta_max,
        "k": _bits(k_max), "di": _bits(k_di), "delta": _bits(delta_max),
        "dx": _bits(height - 1) + 1, "dy": _bits(width - 1) + 1,
        "cand": _bits(max(cand_hi, spread)) + 1,          # signed
        "row": _bits(height - 1), "col": _bits(width - 1),
        "bfs_max": height * width + 1,                    # BFS iterations bound
    }


@dataclass
class EdtResult:
    distance: np.ndarray      # H x W int: di, 0 on obstacles, -1 never reached
    vector: np.ndarray        # H x W x 2 int: (dx, dy) = p - nearest, 0 where never reached
    nearest: np.ndarray       # H x W x 2 int: [r, c] of the nearest obstacle, -1 where none
    sqdist: np.ndarray        # H x W int: dx^2 + dy^2, -1 never reached
    done: np.ndarray          # H x W bool
    delta: np.ndarray         # H x W int: delta after the last iteration
    iterations: int


@dataclass
class EdtBfsResult:
    distance: np.ndarray
    nearest: np.ndarray
    vector: np.ndarray
    sqdist: np.ndarray
    done: np.ndarray
    cfr: np.ndarray           # H x W bool
    visited: np.ndarray       # H x W bool
    parent: np.ndarray        # H x W int 0..8
    path: list = field(default_factory=list)
    path_found: bool = False
    iterations_edt: int = 0
    iterations_bfs: int = 0
    cycles: int = 0


def _shift(a, off, fill):
    """``out[p] = a[p + off]`` (the neighbour at ``off``), ``fill`` outside."""
    dr, dc = off
    h, w = a.shape
    out = np.full_like(a, fill)
    rs, re_ = max(0, -dr), min(h, h - dr)
    cs, ce = max(0, -dc), min(w, w - dc)
    if rs < re_ and cs < ce:
        out[rs:re_, cs:ce] = a[rs + dr:re_ + dr, cs + dc:ce + dc]
    return out


def edt_step(k, done, delta, dx, dy, di, nb):
    """One EDT iteration of a cell (or of arrays of cells, elementwise).

    ``nb[i]`` for i = 1..8 is ``(done_i, delta_i, dx_i, dy_i)`` of neighbour
    p_i (done_i = 0 outside the array).  Returns
    ``(done, delta, dx, dy, di, changed)`` after the iteration.  This is the
    cell of Fig. 2: ADD-SUB + INC per neighbour, the MAX tree with its
    tie-break, the +2k adder and the three enable conditions.
    """
    cands = []
    for i in range(1, 9):
        nd, ndelta, ndx, ndy = nb[i]
        sr, sc = -OFFSETS[i][0], -OFFSETS[i][1]
        cx = ndx + sr
        cy = ndy + sc
        big_x = (2 * sr * ndx + 1) if sr else 0
        big_y = (2 * sc * ndy + 1) if sc else 0
        cands.append((np.asarray(nd, dtype=bool), ndelta - big_x - big_y, cx, cy))

    def cmp_mux(a, b):
        # keep a (lower indices) unless b is valid and (a invalid or b > a)
        va, da, xa, ya = a
        vb, db, xb, yb = b
        sel = vb & (~va | (db > da))
        return (va | vb, np.where(sel, db, da), np.where(sel, xb, xa), np.where(sel, yb, ya))

    lvl1 = [cmp_mux(cands[j], cands[j + 1]) for j in (0, 2, 4, 6)]
    lvl2 = [cmp_mux(lvl1[0], lvl1[1]), cmp_mux(lvl1[2], lvl1[3])]
    vm, dm, xm, ym = cmp_mux(lvl2[0], lvl2[1])
    dnew = dm + 2 * k
    done = np.asarray(done, dtype=bool)
    enable = ~done & vm & (dnew >= 0)
    out_delta = np.where(enable, dnew, np.where(done, delta + 2 * k, delta))
    return (done | enable, out_delta, np.where(enable, xm, dx), np.where(enable, ym, dy),
            np.where(enable, k, di), enable)


def edt(obstacle, progress=None):
    """EDT and NNT of a bool image (True = obstacle) by step 2 of Parallel_Path_Plan.

    ``progress(k)``: called after every iteration k (a command's progress line)."""
    obstacle = np.asarray(obstacle, dtype=bool)
    if obstacle.ndim != 2 or obstacle.size == 0:
        raise ValueError(f"obstacle must be a non-empty 2-D array, got shape {obstacle.shape}")
    h, w = obstacle.shape
    done = obstacle.copy()
    zero = np.zeros((h, w), dtype=np.int64)
    delta, dx, dy, di = zero.copy(), zero.copy(), zero.copy(), zero.copy()
    k = 0
    while True:
        k += 1
        nb = {i: (_shift(done, OFFSETS[i], False), _shift(delta, OFFSETS[i], 0),
                  _shift(dx, OFFSETS[i], 0), _shift(dy, OFFSETS[i], 0)) for i in range(1, 9)}
        done, delta, dx, dy, di, changed = edt_step(k, done, delta, dx, dy, di, nb)
        if progress is not None:
            progress(k)
        if not changed.any():
            break
    rows, cols = np.indices((h, w))
    nearest = np.stack([rows - dx, cols - dy], axis=-1)
    nearest[~done] = -1
    distance = np.where(done, di, -1)
    sq = np.where(done, dx * dx + dy * dy, -1)
    return EdtResult(distance=distance, vector=np.stack([dx, dy], axis=-1), nearest=nearest,
                     sqdist=sq, done=done, delta=delta, iterations=k)


def cfr_map(done, distance, dfar):
    """Step 3: di > dfar, or never reached (no obstacle in the image)."""
    if dfar < 0:
        raise ValueError(f"dfar {dfar} must be >= 0")
    return ~np.asarray(done, dtype=bool) | (np.asarray(distance) > dfar)


def bfs_step(cfr, visited, parent, nb_visited):
    """One BFS iteration (step 4) of a cell or of arrays of cells.

    ``nb_visited[i]`` (i = 1..8) is the visited flag of neighbour p_i.
    Returns ``(visited, parent, changed)``.
    """
    any_v = np.zeros_like(np.asarray(visited, dtype=bool))
    first = np.zeros_like(np.asarray(parent))
    for i in range(8, 0, -1):       # the smallest index wins: assign it last
        v = np.asarray(nb_visited[i], dtype=bool)
        first = np.where(v, i, first)
        any_v = any_v | v
    visited = np.asarray(visited, dtype=bool)
    enable = np.asarray(cfr, dtype=bool) & ~visited & any_v
    return visited | enable, np.where(enable, first, parent), enable


def bfs(cfr, goals, progress=None):
    """BFS forest over 8-connected cfr pixels from the goals inside the cfr.

    Returns ``(visited, parent, iterations)``; ``progress(k)`` after every iteration k.
    """
    cfr = np.asarray(cfr, dtype=bool)
    visited = np.zeros_like(cfr)
    for r, c in goals:
        visited[r, c] = True
    visited &= cfr
    parent = np.zeros(cfr.shape, dtype=np.int64)
    k = 0
    while True:
        k += 1
        nb = {i: _shift(visited, OFFSETS[i], False) for i in range(1, 9)}
        visited, parent, changed = bfs_step(cfr, visited, parent, nb)
        if progress is not None:
            progress(k)
        if not changed.any():
            return visited, parent, k


def trace_path(visited, parent, start):
    """Step 5: pixels from ``start`` along the parents to a root; [] if not visited."""
    if start is None:
        return []
    r, c = start
    if not visited[r, c]:
        return []
    path = [(r, c)]
    while parent[r, c]:
        dr, dc = OFFSETS[int(parent[r, c])]
        r, c = r + dr, c + dc
        path.append((r, c))
        if len(path) > parent.size:
            raise AssertionError("parent chain has a cycle")
    return path


def job_cycles(height, width, iterations_edt, iterations_bfs, path_len):
    """The RTL's cycle count of one job (module docstring)."""
    return width + iterations_edt + 1 + iterations_bfs + path_len + height * width


def _check_cell(shape, cell, what):
    r, c = cell
    if not (0 <= r < shape[0] and 0 <= c < shape[1]):
        raise ValueError(f"{what} ({r}, {c}) is outside the {shape[0]}x{shape[1]} image")
    return int(r), int(c)


def plan_path(obstacle, goals, start, dfar, progress=None):
    """Parallel_Path_Plan: EDT, cfr, BFS from ``goals`` and the path from ``start``.

    ``obstacle``: bool H x W (True = obstacle); ``goals``: list of (r, c);
    ``start``: (r, c) or None (no path read-out); ``dfar``: integer >= 0.
    ``progress(stage, k)``: after every iteration k of stage "EDT" / "BFS".
    """
    obstacle = np.asarray(obstacle, dtype=bool)
    goals = [_check_cell(obstacle.shape, g, "goal") for g in goals]
    if start is not None:
        start = _check_cell(obstacle.shape, start, "start")
    e = edt(obstacle, progress and (lambda k: progress("EDT", k)))
    cfr = cfr_map(e.done, e.distance, int(dfar))
    visited, parent, it_bfs = bfs(cfr, goals, progress and (lambda k: progress("BFS", k)))
    path = trace_path(visited, parent, start)
    h, w = obstacle.shape
    return EdtBfsResult(
        distance=e.distance, nearest=e.nearest, vector=e.vector, sqdist=e.sqdist, done=e.done,
        cfr=cfr, visited=visited, parent=parent, path=path, path_found=bool(path),
        iterations_edt=e.iterations, iterations_bfs=it_bfs,
        cycles=job_cycles(h, w, e.iterations, it_bfs, len(path)))
