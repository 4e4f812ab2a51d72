"""Golden model of the harmonic planner's node grid (paper 000, sections 2.2.1, 5.1, 5.2).

Number format
-------------
A node value is an unsigned fixed-point number of p+1 bits with p fraction bits
(section 5.1): the integer ``v`` stands for ``v / 2**p``.  A goal is 1.0
(``v = 2**p``), an obstacle is 0.  Values are Python integers held in numpy
``object`` arrays, so any precision works (p = 1022, the deepest word a
1024-deep RAM holds, included) with no silent overflow.  Out-of-grid
neighbours read as 0 (an obstacle wall around the map), unless a fixed
boundary ring is given.

Rounding
--------
Update (eq. 2, Jacobi): every free node of the grid is replaced, from the same
old values, by ``floor((hN + hE + hW + hS) / 4)``; the floor is exact
truncation, which is what the hardware gets by dropping the two low bits of
the serial sum (writing the result two bit-positions late).  The floored
iteration is monotone, so from below (free space at 0, as the planner starts,
goals added later) it rises to a fixed point in finitely many iterations.
Started above a fixed point, e.g. after a new obstacle lowered values, it may
instead fall into a period-2 oscillation (paper section 4.3.1: a contraction
mixed with round-off need not stabilize); restarting the free nodes from 0
restores convergence.

Flags
-----
* constant (Saturation): the extra bit stored above the value; a constant node
  keeps its value.  ``Sel`` with ``Sat`` in an update iteration makes the node
  constant with value ``Sat * 2**p`` (0: obstacle, 1: goal) from the next
  iteration on; the node's neighbours still see its old value in that
  iteration (Jacobi).
* stable: the node's stored word (value and constant bit) is unchanged by the
  iteration.
* local maximum: a *free* node whose value is ``>=`` each of its 4 neighbours.
  The comparison is non-strict, so a plateau of equal free values counts as
  maxima: a plateau has a null gradient, which is exactly the precision failure
  the increasing-precision loop must detect (section 3.2.2).  Constant nodes
  (goals and obstacles) are never reported.

An iteration with ``enable`` false is a hold ("check") iteration: nothing is
written, every node is stable, and the local-maximum flags are computed on the
unchanged values.
"""

import numpy as np

__all__ = [
    "one", "neighbours", "update", "local_max", "step", "relax",
    "word_bits", "ram_image", "from_ram_image", "counters",
]


def one(p):
    """The fixed-point 1.0 (goal value) at precision ``p``."""
    return 1 << p


def neighbours(h, ring=None):
    """The (N, E, W, S) neighbour arrays of grid ``h``.

    ``ring`` is an optional (R+2)x(C+2) array whose outer ring gives the values
    around the grid (its interior is ignored); without it the outside reads 0.
    North is row - 1, west is column - 1.
    """
    h = np.asarray(h, dtype=object)
    rows, cols = h.shape
    pad = np.zeros((rows + 2, cols + 2), dtype=object)
    if ring is not None:
        ring = np.asarray(ring, dtype=object)
        if ring.shape != pad.shape:
            raise ValueError(f"ring must be {pad.shape}, got {ring.shape}")
        pad[...] = ring
    pad[1:-1, 1:-1] = h
    return (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])


def update(nbrs):
    """Eq. (2) with truncation: ``floor((hN + hE + hW + hS) / 4)``."""
    n, e, w, s = nbrs
    return (n + e + w + s) >> 2


def local_max(h, const, nbrs):
    """Free nodes whose value is >= each neighbour (plateaus included)."""
    ge = np.ones(np.shape(h), dtype=bool)
    for nb in nbrs:
        ge &= np.asarray(h >= nb, dtype=bool)
    return ge & ~np.asarray(const, dtype=bool)


def step(h, const, p, nbrs, enable=True, sel=None, sat=0):
    """One iteration of every node, as the node module does it in p+2 cycles.

    ``h``: values (object array); ``const``: constant flags (bool array);
    ``nbrs``: (N, E, W, S) old neighbour values; ``sel``: bool array of nodes
    saturated in this iteration (ignored unless ``enable``); ``sat``: their
    value, 0 (obstacle) or 1 (goal), a scalar or an array.

    Returns ``(h_new, const_new, stable, maximum)``; ``maximum`` is the
    local-maximum flag of the old values, with a node saturated in this
    iteration counted as constant.
    """
    h = np.asarray(h, dtype=object)
    const = np.asarray(const, dtype=bool)
    sel = np.zeros(h.shape, dtype=bool) if sel is None else np.asarray(sel, dtype=bool)
    sat = np.broadcast_to(np.asarray(sat, dtype=bool), h.shape)
    if not enable:
        return h.copy(), const.copy(), np.ones(h.shape, dtype=bool), local_max(h, const, nbrs)
    const_next = const | sel
    h_new = np.where(const, h, update(nbrs))
    saturated = np.where(sat, np.full(h.shape, one(p), dtype=object), np.zeros(h.shape, dtype=object))
    h_new = np.where(sel, saturated, h_new)
    stable = np.asarray(h_new == h, dtype=bool) & (const_next == const)
    return h_new, const_next, stable, local_max(h, const_next, nbrs)


def relax(h, const, p, ring=None, max_iter=1_000_000):
    """Iterate until every node is stable; returns ``(h, iterations)``.

    ``iterations`` counts the update iterations run, the last (stable) one
    included.  Raises ``RuntimeError`` if ``max_iter`` is reached first.
    """
    h = np.asarray(h, dtype=object)
    for it in range(1, max_iter + 1):
        h_new, const, stable, _ = step(h, const, p, neighbours(h, ring))
        h = h_new
        if stable.all():
            return h, it
    raise RuntimeError(f"not stable after {max_iter} iterations at p={p}")


# --- storage format and addressing (the cluster's RAM and Counters, 5.2) ---
#
# Word of p+2 bits per node, one bit per RAM address, most significant first
# from the word's base: offset 0 holds the constant flag (the extra MSB),
# offset 1 + (p - k) holds value bit k, so the integer bit sits at offset 1 and
# the LSB at offset p+1.  Raising the precision therefore only appends LSB
# addresses; the bits already stored keep their place.

def counters(c, p):
    """Addresses the Counters unit presents in iteration cycle c (0 .. p+1):
    ``(cntR, r_cnt, cntW)``.  A synchronous RAM answers one cycle later, so
    cntR = p+1-c makes the nodes see the flag at c = 0 and value bit k at
    c = k+1 (LSB first); r_cnt = (c-1) mod (p+2) streams bit p at c = 3 down
    to bit 0 at c = 1 of the next iteration (MSB first); cntW = (p+4-c) mod
    (p+2) writes each result bit two bit positions behind the data read."""
    if not 0 <= c <= p + 1:
        raise ValueError(f"cycle {c} outside 0 .. p+1 = {p + 1}")
    return p + 1 - c, (c - 1) % (p + 2), (p + 4 - c) % (p + 2)


def word_bits(v, flag, p):
    """The p+2 stored bits of one node, by address offset."""
    v = int(v)
    if not 0 <= v <= one(p):
        raise ValueError(f"value {v} outside [0, 2**{p}]")
    return [int(bool(flag))] + [(v >> (p - off)) & 1 for off in range(p + 1)]


def ram_image(h, const, p):
    """RAM words of a cluster: word ``a`` holds bit ``a`` of node ``r*cols + c``
    in bit ``r*cols + c`` (the 3x6 cluster packs its 18 nodes in one word)."""
    h = np.asarray(h, dtype=object)
    const = np.asarray(const, dtype=bool)
    words = [0] * (p + 2)
    for i, (v, f) in enumerate(zip(h.ravel(), const.ravel())):
        for a, bit in enumerate(word_bits(v, f, p)):
            words[a] |= bit << i
    return words


def from_ram_image(words, p, shape):
    """Inverse of :func:`ram_image`: ``(h, const)`` from p+2 RAM words."""
    n = shape[0] * shape[1]
    h = np.zeros(n, dtype=object)
    const = np.zeros(n, dtype=bool)
    for i in range(n):
        const[i] = bool((words[0] >> i) & 1)
        v = 0
        for off in range(1, p + 2):
            v = (v << 1) | ((words[off] >> i) & 1)
        h[i] = v
    return h.reshape(shape), const.reshape(shape)


# --- trajectory: gradient ascent on a computed field (paper 2.2, 5.3) -------
#
# The paper's Decision module (5.3) picks a continuous direction from the
# steepest of the four triangles around the robot's node.  A planner that
# returns a *path of cells* needs the discrete version of that ascent: from a
# cell, step to the 4-neighbour (N, E, W, S: the node's own neighbours, eq. 2)
# with the largest value, provided it is strictly larger than the cell's own
# value.  Ties go to the first of N, E, W, S in that order, so the path is a
# function of the field alone.  4-connected on purpose: the field's
# "no local maximum" property (the stop criterion of the planner, 4.1) is a
# statement about 4-neighbours, and a diagonal step could cut between two
# obstacle corners.
#
# Why this reaches a goal from every free cell of a converged field: converged
# means no free cell is >= all of its 4 neighbours, so every free cell has a
# strictly higher neighbour; that neighbour is not an obstacle (obstacles
# hold 0 and no value is below 0) and not outside the grid (ignored), so it is
# free or a goal.  Values strictly increase along the path, so no cell repeats
# and the path ends, which can only happen on a constant node above every
# free value: a goal.  The path has at most (free cells + 1) cells.

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


def _goal_mask(goals, shape):
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
    goal = _goal_mask(goals, h.shape)
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
    goal = _goal_mask(goals, h.shape)
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


__all__ += ["ASCENT_MOVES", "ascent_next", "Trajectory", "trajectory", "ascent_reaches"]
