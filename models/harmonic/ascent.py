"""Trajectories: gradient ascent on a computed field (paper 000, sections 2.2, 5.3).

Number format: any integer field (fixed point v / 2**p, or the block-exponent
field on one scale 2**-frac_bits: ``PlanResult.h`` either way); only the
order of the values matters, compared exactly (Python integers), no rounding.

The paper's Decision module (5.3) picks a continuous direction from the
steepest of the four triangles around the robot's node.  A planner that
returns a *path of cells* needs the discrete version of that ascent: from a
cell, step to the 4-neighbour (N, E, W, S: the node's own neighbours, eq. 2)
with the largest value, provided it is strictly larger than the cell's own
value.  Ties go to the first of N, E, W, S in that order, so the path is a
function of the field alone.  4-connected on purpose: the field's
"no local maximum" property (the stop criterion of the planner, 4.1) is a
statement about 4-neighbours, and a diagonal step could cut between two
obstacle corners.

Why this reaches a goal from every free cell of a converged field: converged
means no free cell is >= all of its 4 neighbours, so every free cell has a
strictly higher neighbour; that neighbour is not an obstacle (obstacles
hold 0 and no value is below 0) and not outside the grid (ignored), so it is
free or a goal.  Values strictly increase along the path, so no cell repeats
and the path ends, which can only happen on a constant node above every
free value: a goal.  The path has at most (free cells + 1) cells.
"""

import numpy as np

__all__ = ["ASCENT_MOVES", "ascent_next", "Trajectory", "trajectory", "ascent_reaches"]

ASCENT_MOVES = ((-1, 0), (0, 1), (0, -1), (1, 0))    # N, E, W, S: tie-break order


def ascent_next(h):
    """For every cell, the cell the steepest 4-neighbour ascent moves to.

    Returns ``(rows, cols)`` integer arrays; a cell with no strictly higher
    neighbour (a goal, an obstacle, a local maximum or plateau) maps to itself.
    Ties between equal highest neighbours go to the first of N, E, W, S.
    """
    h = np.asarray(h, dtype=object)
    rows, cols = h.shape
    pad = np.full((rows + 2, cols + 2), -1, dtype=object)      # outside: never chosen
    pad[1:-1, 1:-1] = h
    best = h.copy()
    rr, cc = np.indices((rows, cols))
    nr, nc = rr.copy(), cc.copy()
    for dr, dc in ASCENT_MOVES:
        nb = pad[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
        higher = np.asarray(nb > best, dtype=bool)              # strict: the first of a tie wins
        best = np.where(higher, nb, best)
        nr = np.where(higher, rr + dr, nr)
        nc = np.where(higher, cc + dc, nc)
    return nr, nc


def _ascent_goals(goals, shape):
    if isinstance(goals, np.ndarray) and goals.dtype == bool:
        if goals.shape != shape:
            raise ValueError(f"goal mask is {goals.shape}, the field is {shape}")
        return goals
    mask = np.zeros(shape, dtype=bool)
    for r, c in goals:
        mask[r, c] = True
    return mask


class Trajectory:
    """A gradient-ascent path: ``start``, ``path`` (list of (r, c), the start
    first), ``reached_goal`` (False: the ascent stopped on a local maximum or
    plateau, e.g. a cell no goal can reach or a field computed with too little
    precision)."""

    __slots__ = ("start", "path", "reached_goal")

    def __init__(self, start, path, reached_goal):
        self.start, self.path, self.reached_goal = tuple(start), [tuple(c) for c in path], bool(reached_goal)

    def as_dict(self):
        return {"start": list(self.start), "path": [list(c) for c in self.path],
                "reached_goal": self.reached_goal}

    def __repr__(self):
        return f"Trajectory(start={self.start}, steps={len(self.path) - 1}, reached_goal={self.reached_goal})"


def trajectory(h, goals, start, nxt=None):
    """Steepest 4-neighbour ascent of field ``h`` from ``start`` until a goal.

    ``goals``: a bool mask or a list of (r, c).  ``nxt``: :func:`ascent_next`
    of ``h`` when the caller already has it (many starts on one field).
    Stops at a goal (``reached_goal`` True) or where no neighbour is strictly
    higher (False).  The values along the path strictly increase, so it always
    ends, after at most ``h.size`` steps.
    """
    h = np.asarray(h, dtype=object)
    goal = _ascent_goals(goals, h.shape)
    r, c = (int(x) for x in start)
    if not (0 <= r < h.shape[0] and 0 <= c < h.shape[1]):
        raise ValueError(f"start ({r}, {c}) outside the {h.shape[0]}x{h.shape[1]} field")
    nr, nc = ascent_next(h) if nxt is None else nxt
    path = [(r, c)]
    while not goal[r, c]:
        r2, c2 = int(nr[r, c]), int(nc[r, c])
        if (r2, c2) == (r, c):
            break
        r, c = r2, c2
        path.append((r, c))
    return Trajectory(start, path, goal[r, c])


def ascent_reaches(h, goals, cells=None):
    """Bool array: True where the ascent from that cell ends on a goal.

    Follows :func:`ascent_next` once for all cells (memoized along the paths),
    so checking every free cell of a map costs one pass.  ``cells`` (bool
    mask) limits the answer to those cells; the others are False.
    """
    h = np.asarray(h, dtype=object)
    goal = _ascent_goals(goals, h.shape)
    nr, nc = ascent_next(h)
    rows, cols = h.shape
    known = np.full(h.shape, -1, dtype=np.int8)          # -1 unknown, 0 no, 1 yes
    known[goal] = 1
    todo = np.argwhere(np.ones(h.shape, dtype=bool) if cells is None else cells)
    for r0, c0 in todo:
        chain, r, c = [], int(r0), int(c0)
        while known[r, c] < 0:
            chain.append((r, c))
            r2, c2 = int(nr[r, c]), int(nc[r, c])
            if (r2, c2) == (r, c):
                known[r, c] = 0
                break
            r, c = r2, c2
        for cell in chain:
            known[cell] = known[r, c]
    out = known == 1
    return out if cells is None else out & cells
