"""Schedule exploration (benches: the choices section 4.5 of paper 000 leaves
open): the block order, with still blocks or the paper's visits, on the one schedule loop
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
paper_schedule: the paper's visits (every block in every sweep, the
        confirmation iteration, a check pass) instead of the default still
        blocks (:class:`~models.harmonic.schedule.StillBlocks`).
"""

from collections import deque

import numpy as np

from .grid import BlockGrid
from .schedule import control, run

__all__ = ["ORDERS", "block_order", "plan_explore"]

ORDERS = ("raster", "serpentine", "alternate", "goal")


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


def plan_explore(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), order="raster",
                 paper_schedule=False):
    """:func:`~models.harmonic.plan` (without events) with a block ``order``;
    returns a :class:`~models.harmonic.PlanResult` (``skipped`` visits are
    counted, 0 in the paper's schedule)."""
    _check_order(order)
    grid = BlockGrid(obstacle, goals, block, iters, schedule)
    grid.res.paper_schedule = bool(paper_schedule)
    visits, timing = control(grid, paper_schedule)
    return run(grid, order=block_order(grid, order), visits=visits, timing=timing)
