"""The map on the block grid and its fixed-point field: padding to whole
blocks, goals, walled-off cells, dynamic orders, and the block visit the
schedule runs (paper 000, sections 3.3.1, 4, 5.1, 5.2).

Number format
-------------
Node values as :mod:`models.harmonic.node` states them: an unsigned fixed-point
integer ``v`` standing for ``v / 2**p`` (goal ``2**p``, obstacle 0).  The field
is held in one padded array, the map plus a ring of 0 around it (outside the
map reads 0, as the Border's outer edges do); its interior is every block's
RAM contents and its ring cells between blocks are the border storage, so a
neighbour in another block reads its latest stored value.  The array is
int64 while p <= 60 (a sum of four (p+1)-bit values fits) and Python ints
(numpy ``object``) above: the same values, only faster at low p.

Rounding
--------
A visit's update is eq. 2 with truncation, ``floor((N+E+W+S)/4)``, exact (the
node's two dropped bits, 5.2).  Raising the precision shifts every value
left (the new low bits start at 0): exact, no data moved in hardware (the
words are MSB first, :mod:`models.harmonic.ram`).
"""

from collections import deque

import numpy as np

from .node import local_max, one
from .schedule import PlanResult, check_schedule

__all__ = ["pad_to_blocks", "distances", "reachable", "BlockGrid"]

_INT64_P_MAX = 60       # 4 * 2**60 < 2**63: int64 arithmetic is exact up to here


def _dtype(p):
    """The field's array type at precision ``p``: int64 while exact, else Python ints."""
    return np.int64 if p <= _INT64_P_MAX else object


def pad_to_blocks(obstacle, block):
    """Pad ``obstacle`` (bool, True = obstacle) at the bottom and right with
    obstacles to multiples of ``block = (n, m)``."""
    obstacle = np.asarray(obstacle, dtype=bool)
    n, m = check_block(block)
    rows = -(-obstacle.shape[0] // n) * n
    cols = -(-obstacle.shape[1] // m) * m
    out = np.ones((rows, cols), dtype=bool)
    out[:obstacle.shape[0], :obstacle.shape[1]] = obstacle
    return out


def check_block(block):
    """``(n, m)`` as ints, each at least 1."""
    try:
        n, m = (int(x) for x in block)
    except (TypeError, ValueError):
        raise ValueError(f"block must be (n, m), not {block!r}") from None
    if n < 1 or m < 1:
        raise ValueError(f"block ({n}, {m}): n and m must be at least 1")
    return n, m


def goal_mask(goals, shape):
    """A bool mask of ``shape`` from a mask (placed top-left) or (row, col) list."""
    mask = np.zeros(shape, dtype=bool)
    if isinstance(goals, np.ndarray) and goals.dtype == bool:
        mask[:goals.shape[0], :goals.shape[1]] = goals
        return mask
    for r, c in goals:
        if not (0 <= r < shape[0] and 0 <= c < shape[1]):
            raise ValueError(f"goal ({r}, {c}) is outside the {shape[0]}x{shape[1]} map")
        mask[r, c] = True
    return mask


def distances(obstacle, goals):
    """BFS distance (4-connected steps) of every free cell to its nearest
    goal, -1 where no goal reaches (obstacles included): an int array.

    ``goals``: a bool mask or a list of (row, col)."""
    free = ~np.asarray(obstacle, dtype=bool)
    goal = goal_mask(goals, free.shape) & free
    dist = np.where(goal, 0, -1)
    queue = deque(map(tuple, np.argwhere(goal)))
    rows, cols = free.shape
    while queue:
        r, c = queue.popleft()
        d = dist[r, c] + 1
        for rr, cc in ((r - 1, c), (r, c + 1), (r, c - 1), (r + 1, c)):
            if 0 <= rr < rows and 0 <= cc < cols and free[rr, cc] and dist[rr, cc] < 0:
                dist[rr, cc] = d
                queue.append((rr, cc))
    return dist


def reachable(obstacle, goals):
    """Free cells 4-connected to a goal (goals included): a bool mask.

    ``goals``: a bool mask or a list of (row, col)."""
    return distances(obstacle, goals) >= 0


class BlockGrid:
    """The fixed-point field the schedule (:func:`models.harmonic.schedule.run`)
    runs on, with its hooks: the padded map, the walled-off cells, the field
    with its 0 ring (outside the map), the block visit, the check pass, the
    precision rise, the dynamic orders and the result's final figures.

    Block b = br*BC + bc covers rows br*n .. br*n+n-1 and columns bc*m ..
    bc*m+m-1; ``blocks`` lists the (br, bc) in raster order (the RTL's)."""

    def __init__(self, obstacle, goals, block, iters, schedule):
        self.n, self.m = n, m = check_block(block)
        self.iters = int(iters)
        if self.iters < 1:
            raise ValueError(f"iters={self.iters}: at least 1 iteration per block")
        self.sched = check_schedule(schedule)
        obstacle = np.asarray(obstacle, dtype=bool)
        self.H, self.W = obstacle.shape
        self.obst = obst = pad_to_blocks(obstacle, (n, m))
        self.goal = goal = goal_mask(goals, obst.shape)
        if (goal & obst).any():
            r, c = np.argwhere(goal & obst)[0]
            raise ValueError(f"goal ({r}, {c}) is on an obstacle")
        if not goal.any():
            raise ValueError("no goal")
        unreachable = ~obst & ~reachable(obst, goal)
        self.const = obst | goal | unreachable
        self.rows, self.cols = obst.shape
        self.BR, self.BC = self.rows // n, self.cols // m
        self.B = self.BR * self.BC
        self.blocks = [(br, bc) for br in range(self.BR) for bc in range(self.BC)]
        self.p = self.sched[0]
        self._store(np.zeros((self.rows + 2, self.cols + 2), dtype=_dtype(self.p)))   # a 0 ring: outside the map
        self.hv[goal] = one(self.p)
        self.res = PlanResult(h=None, const=None, p=self.p, converged=False, maxima=0,
                              unreachable=unreachable[:self.H, :self.W], block=(n, m),
                              blocks=(self.BR, self.BC))

    # --- storage -----------------------------------------------------------

    def _store(self, pad):
        """Hold the padded field ``pad`` (the ring included) and its views."""
        self.pad = pad
        self.hv = pad[1:-1, 1:-1]
        self._views()

    def _dtype_for(self, p):
        """Python ints once ``p`` leaves int64's exact range (the same values)."""
        if self.pad.dtype != _dtype(p):
            self._store(self.pad.astype(_dtype(p)))

    def _views(self):
        """Per block: its values and its N, S, W, E neighbour windows in the
        padded field (views, so a visit slices nothing), and its constants."""
        n, m, pad = self.n, self.m, self.pad
        self.view = {}
        for br, bc in self.blocks:
            r0, c0 = br * n, bc * m
            self.view[br, bc] = (self.hv[r0:r0 + n, c0:c0 + m],
                                 pad[r0:r0 + n, c0 + 1:c0 + m + 1], pad[r0 + 2:r0 + n + 2, c0 + 1:c0 + m + 1],
                                 pad[r0 + 1:r0 + n + 1, c0:c0 + m], pad[r0 + 1:r0 + n + 1, c0 + 2:c0 + m + 2],
                                 self.const[r0:r0 + n, c0:c0 + m])

    def block(self, b):
        """The values of block ``b`` = (br, bc): a view."""
        return self.view[b][0]

    # --- the schedule's hooks ---------------------------------------------

    def new_level(self):
        return {"p": self.p, "sweeps": 0, "block_iterations": 0, "maxima": None}

    def visit(self, b):
        """Up to I iterations of block ``b`` (the Block module's visit): eq. 2
        floored, every node from the same old values (Jacobi), neighbours in
        other blocks at their stored values (the border storage), stopping
        after the first iteration that changes nothing; returns (counted i,
        stable)."""
        old, north, south, west, east, fixed = self.view[b]
        for i in range(1, self.iters + 1):
            new = north + south
            new += west
            new += east
            new >>= 2
            np.copyto(new, old, where=fixed)        # constant nodes keep their value
            if (new == old).all():
                return i, True
            old[...] = new
        return self.iters, False

    def scan_cycles(self, b):
        return 0

    def after_visit(self, b, i, stable, level):
        return 0

    def maxima(self):
        """Local maxima of the free nodes (the check pass's Maximum flags)."""
        pad = self.pad
        nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
        return int(local_max(self.hv, self.const, nb).sum())

    def check(self, level):
        """The check pass: (local maxima, extra cycles)."""
        return self.maxima(), 0

    def rescale(self, level):
        return 0

    def raise_precision(self):
        """The schedule's next p (values shift left, the new low bits 0):
        its cycles (0: no data moves); None after the last."""
        later = [q for q in self.sched if q > self.p]
        if not later:
            return None
        self._dtype_for(later[0])
        self.pad <<= later[0] - self.p
        self.p = later[0]
        return 0

    def orders(self, events):
        """The dynamic orders ``(s, (r, c), kind)`` checked, in pass order (a deque)."""
        evs = sorted(((int(s), (int(r), int(c)), str(kind)) for s, (r, c), kind in events),
                     key=lambda e: e[0])
        for s, (r, c), kind in evs:
            if kind not in ("obstacle", "goal"):
                raise ValueError(f"event kind {kind!r}: expected 'obstacle' or 'goal'")
            if not (0 <= r < self.rows and 0 <= c < self.cols) or s < 0:
                raise ValueError(f"event at pass {s} on ({r}, {c}): outside the {self.rows}x{self.cols} map")
        return deque(evs)

    def apply(self, r, c, kind):
        """One order's clear pass: (r, c) becomes constant (goal 2**p or
        obstacle 0), every free node restarts from 0."""
        self.const[r, c] = True
        self.goal[r, c] = kind == "goal"
        self.hv[~self.const] = 0
        self.hv[r, c] = one(self.p) if kind == "goal" else 0

    def apply_due(self, due, passes):
        """Apply the orders of ``due`` whose pass has come (s <= passes); how many."""
        k = 0
        while due and due[0][0] <= passes:
            _, (r, c), kind = due.popleft()
            self.apply(r, c, kind)
            k += 1
        self.res.events_applied += k
        if passes:                  # pass 0: sent while idle, before the run (not one of its passes)
            self.res.clear_passes += k
        return k

    def snapshot(self):
        """(exponents, values) for a trace: no exponents in fixed point."""
        return None, np.array(self.hv, dtype=object)

    def result(self, cycles, maxima):
        res = self.res
        res.p = self.p
        res.maxima = 0 if res.converged else maxima
        res.cycles = cycles
        res.node_updates = res.block_iterations * self.n * self.m
        res.padded_h = np.array(self.hv, dtype=object)
        res.padded_const = self.const.copy()
        res.h = res.padded_h[:self.H, :self.W].copy()
        res.const = self.const[:self.H, :self.W].copy()
        return res
