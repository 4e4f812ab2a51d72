"""Schedule exploration (benches: the choices section 4.5 of paper 000 leaves
open): the block order and skipping still blocks, on the one schedule loop
(:func:`models.harmonic.schedule.run`).

Number format and rounding: those of the fixed-point field
(:mod:`models.harmonic.grid`: v / 2**p, eq. 2 floored); only the order and
the number of block visits change, never a value's arithmetic.

:func:`~models.harmonic.plan` is the planner as the RTL runs it.
:func:`plan_explore` runs the same algorithm with the schedule choices
section 4.5 leaves open, for the benches.  With its defaults it is plan()
exactly (same values, sweeps, iterations and cycles: tested), and from below
every variant ends in the same field (the least fixed point of the floored
map: tb/harmonic/test_model_blocks_bound.py); only the cost differs.

order:  "raster" (plan's: row-major), "serpentine" (row-major, every other
        block row reversed), "alternate" (raster, reversed on every other
        sweep), "goal" (blocks by their BFS distance to the nearest goal,
        nearest first: the values flow outward from the goals).
skip:   a block is visited in a sweep only while "dirty": all blocks are
        dirty at the start of a level; a visit that changes the block makes
        dirty the neighbouring blocks whose facing border row/column changed,
        and the block itself if it used up its I iterations.  A skipped
        block costs SKIP_CYCLES (the Control module's decision cycle); the
        level's update phase ends when no block is dirty, which is again a
        fixed point of the whole map (every block stable against its
        neighbours' current values).  Hardware cost: one dirty bit per block.
"""

from collections import deque

import numpy as np

from .grid import BlockGrid
from .schedule import EveryBlock, run

__all__ = ["SKIP_CYCLES", "ORDERS", "block_order", "StillBlocks", "plan_explore"]

SKIP_CYCLES = 1
ORDERS = ("raster", "serpentine", "alternate", "goal")

# A block's edges (N, E, W, S) and the neighbour block each one faces.
_EDGES = ((-1, 0), (0, 1), (0, -1), (1, 0))


def _check_order(order):
    if order not in ORDERS:
        raise ValueError(f"order {order!r}: raster, serpentine, alternate or goal")


def block_order(grid, order):
    """``order(sweep)`` for :func:`~models.harmonic.schedule.run`: the
    blocks of ``grid`` in the named visit order (see the module docstring)."""
    _check_order(order)
    raster = grid.blocks
    if order == "serpentine":
        base = [(br, bc if br % 2 == 0 else grid.BC - 1 - bc) for br, bc in raster]
    elif order == "goal":
        base = sorted(raster, key=_goal_distance(grid))
    else:
        base = raster
    if order == "alternate":
        return lambda sweep: base[::-1] if sweep % 2 else base
    return lambda sweep: base


def _goal_distance(grid):
    """Sort key of a block: the 4-connected BFS distance of its nearest cell
    to a goal (through the padded map's free cells), then the block."""
    n, m = grid.n, grid.m
    dist = np.full(grid.obst.shape, np.inf)
    queue = deque(map(tuple, np.argwhere(grid.goal)))
    for q in queue:
        dist[q] = 0
    while queue:
        r, c = queue.popleft()
        for rr, cc in ((r - 1, c), (r, c + 1), (r, c - 1), (r + 1, c)):
            if 0 <= rr < grid.rows and 0 <= cc < grid.cols and not grid.obst[rr, cc] and dist[rr, cc] == np.inf:
                dist[rr, cc] = dist[r, c] + 1
                queue.append((rr, cc))
    return lambda b: (dist[b[0] * n:b[0] * n + n, b[1] * m:b[1] * m + m].min(), b)


class StillBlocks(EveryBlock):
    """The ``visits`` policy ``skip=True``: one dirty bit per block (see the
    module docstring); a skipped visit costs :data:`SKIP_CYCLES`."""

    skip_cycles = SKIP_CYCLES

    def __init__(self, grid):
        self.grid = grid
        self.dirty = dict.fromkeys(grid.blocks, True)

    def reset(self):
        for b in self.dirty:
            self.dirty[b] = True

    def skip(self, b):
        return not self.dirty[b]

    def before(self, b):
        self.dirty[b] = False
        blk = self.grid.block(b)
        self.edges = (blk[0].copy(), blk[:, -1].copy(), blk[:, 0].copy(), blk[-1].copy())

    def after(self, b, stable, changed):
        if not changed:
            return
        self.dirty[b] = not stable
        blk = self.grid.block(b)
        for (dr, dc), now, was in zip(_EDGES, (blk[0], blk[:, -1], blk[:, 0], blk[-1]), self.edges):
            nb = (b[0] + dr, b[1] + dc)
            if nb in self.dirty and not (now == was).all():
                self.dirty[nb] = True

    def again(self, changed):
        return any(self.dirty.values())


def plan_explore(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), order="raster", skip=False):
    """:func:`~models.harmonic.plan` (without events) with a block ``order``
    and optional skipping of still blocks; returns a
    :class:`~models.harmonic.PlanResult` (``skipped`` visits are counted in
    ``levels``, 0 without skipping)."""
    _check_order(order)
    grid = BlockGrid(obstacle, goals, block, iters, schedule)
    return run(grid, order=block_order(grid, order), visits=StillBlocks(grid) if skip else EveryBlock())
