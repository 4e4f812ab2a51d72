"""The Node module's rule on a whole grid (paper 000, eq. 2, sections 2.2.1, 5.1, 5.2).

Number format
-------------
A node value is an unsigned fixed-point number of p+1 bits with p fraction bits
(section 5.1): the integer ``v`` stands for ``v / 2**p``.  A goal is 1.0
(``v = 2**p``, :func:`one`), an obstacle is 0.  Values are Python integers held
in numpy ``object`` arrays, so any precision works (p = 1022, the deepest word a
1024-deep RAM holds, included) with no silent overflow.  Out-of-grid neighbours
read as 0 (an obstacle wall around the map), unless a fixed boundary ring is
given (:func:`neighbours`).

Rounding
--------
Update (eq. 2, Jacobi): every free node of the grid is replaced, from the same
old values, by ``floor((hN + hE + hW + hS) / 4)``; the floor is exact
truncation, which is what the hardware gets by dropping the two low bits of
the serial sum (writing the result two bit-positions late, section 5.2).  The
floored iteration is monotone, so from below (free space at 0, as the planner
starts, goals added later) it rises to a fixed point in finitely many
iterations.  Started above a fixed point, e.g. after a new obstacle lowered
values, it may instead fall into a period-2 oscillation (paper section 4.3.1:
a contraction mixed with round-off need not stabilize); restarting the free
nodes from 0 restores convergence.

Flags (the node's Saturation, Stable and Maximum sub-modules, 5.2)
-----------------------------------------------------------------
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

__all__ = ["one", "neighbours", "update", "local_max", "step", "relax"]


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
    """Iterate :func:`step` on the whole grid until every node is stable
    (plain Jacobi, no blocks: the reference the block schedule is held
    against); returns ``(h, iterations)``.

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
