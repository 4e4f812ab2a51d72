"""Node exponents (issue 22): block exponents with blocks of one node, the
harmonic field as short floating-point words with a wide exponent, on the
whole node array at once (the paper's section 3 array, no blocks).

Why one node a block: one exponent serves a whole block, so a block's word
must span the distances inside it and its border rings, about 2 bits a step
(:func:`~models.harmonic.precision_estimate`).  On maze512-1-0 (corridors
one cell wide) that spread is 3,663 steps even for 2x2 blocks of the
256x256 crop (7,329 bits), 1 step for 1x1 blocks: only a node's own
exponent takes the precision wall away.  The exponent then costs bits per
node, ``e_max.bit_length()`` (14 on the whole 512x512 maze), beside a
mantissa of p+1 bits that no longer grows with the map.

Number format
-------------
Node c holds a mantissa v_c (p+1 bits) and an exponent e_c, 0 <= e_c <=
e_max, for x_c = v_c / 2**(p + e_c).  A goal is v = 2**p, e = 0 (1.0);
obstacles, the outside and cells no goal reaches read 0.  A non-zero free
node is *normalized*: its top h bits are empty (h = ``headroom``, the
re-pick headroom of block exponents), 2**(p-h) <= v < 2**(p+1-h), except at
e = e_max, where a smaller v is allowed (denormal), and at e = 0, where a
value at or above 2**-h (a goal's neighbours) uses the headroom bits (v <=
2**p: no value exceeds the goal's 1).  Why the headroom: the
exact field is at least a quarter of any neighbour (eq. 1), so with h = 2 a
neighbour converted into a node's units (the Decision's
:func:`~models.harmonic.convert_mantissa`) does not clamp on a converged
field.

Update (eq. 2) and rounding
---------------------------
Every free reachable node at once (Jacobi, as the node array runs): r = the
smallest e_j of its non-zero neighbours (the largest scale); each
neighbour's mantissa is aligned to r with G = 2 guard bits, floor((v_j <<
G) >> (e_j - r)); the four are summed exactly, S; the mean S / 4 is
normalized to p+1-h significant bits, flooring the bits shifted out, and
its exponent set to match (then clamped to e_max by a right shift, floor).
Both floors round down, so a node's new value y and the exact mean m of
its neighbours' current values satisfy 0 <= m - y < 2 ulp(y), ulp(y) =
2**-(p + e_y), for a normalized y (tested against exact fractions).

Stop (section 4.1's criterion): when no free node is a local maximum (its
value >= each neighbour's, compared exactly, plateaus included) and every
reachable node is non-zero, or when an iteration changes nothing (a fixed
point: converged only if no maximum is left), or after ``max_iter``.

All arithmetic is int64: p <= :data:`P_LIMIT` keeps S below 2**53 (its bit
length taken exactly through float64) and the order key (e_max - e) * 2**(p+1)
+ v below 2**62.
"""

import time

import numpy as np

from .grid import distances, goal_mask

__all__ = ["NODE_P", "NODE_HEADROOM", "GUARD", "P_LIMIT", "NodeExponentResult", "node_update", "order_key",
           "plan_node_exponents", "ENGINE_SLOTS", "UPDATE_LATENCY", "RAM_LATENCY", "WRITE_LATENCY",
           "ENGINE_HALF_EXTRA",
           "engine_cycles"]

NODE_P = 16             # default word precision: a 17-bit mantissa, the fixed-point node's p of the paper's tables
NODE_HEADROOM = 2       # empty top mantissa bits of a normalized node (see the module docstring)
GUARD = 2               # the mean's two bits: S holds 4x the mean, aligned with these below the largest operand
P_LIMIT = 48            # S < 2**(p + 5 - h) < 2**53: bit lengths exact through float64


def _bit_length(a):
    """Bit length of each non-negative int64 below 2**53 (float64's frexp is exact there)."""
    return np.frexp(a.astype(np.float64))[1].astype(np.int64)


def node_update(vn, en, p, e_max, headroom=NODE_HEADROOM):
    """The node's update (eq. 2) on arrays: ``vn``, ``en`` (N x 4) the four
    neighbours' mantissas and exponents; returns the new ``(v, e)`` (N,)
    as the module docstring's rule (zero: v = 0, e = e_max)."""
    vn = np.asarray(vn, dtype=np.int64)
    en = np.asarray(en, dtype=np.int64)
    nz = vn > 0
    r = np.where(nz, en, np.iinfo(np.int64).max).min(axis=1)
    r = np.where(nz.any(axis=1), r, 0)
    gap = np.where(nz, en - r[:, None], 0)                   # >= 0: r is the largest scale
    sh = np.minimum(gap, 62)
    S = np.where(nz, (vn << GUARD) >> sh, 0).sum(axis=1)
    b = _bit_length(S)
    # x = S / 2**(p + r + G + 2) = v / 2**(p + e): normalized, e = r + G + 2 + L - b puts v's top at
    # bit L - 1.  Clamped to [0, e_max] (a denormal at e_max; at 0 a mean of 2**-h or more, next to
    # goals, keeps the headroom bits: x <= 1 so v <= 2**p); then one shift of S, flooring.
    e = np.clip(r + GUARD + 2 + (p + 1 - headroom) - b, 0, e_max)
    k = e - r - GUARD - 2
    v = np.where(k >= 0, S << np.clip(k, 0, 62), S >> np.clip(-k, 0, 62))
    zero = v == 0
    return np.where(zero, 0, v), np.where(zero, e_max, e)


def order_key(v, e, p, e_max):
    """An int64 whose order is the values' order (normalized mantissas and
    denormals at e_max): (e_max - e) * 2**(p+1) + v; 0 for zero."""
    v = np.asarray(v, dtype=np.int64)
    return np.where(v > 0, (e_max - np.asarray(e, dtype=np.int64)) << (p + 1), 0) + v


class NodeExponentResult:
    """What :func:`plan_node_exponents` returns.

    ``mantissa``, ``exponents``: H x W int64 (0 / e_max where the field is
    0); ``key``: H x W int64 in the values' order (for the ascent,
    :func:`~models.harmonic.ascent_reaches`); ``converged`` (no local
    maximum, every reachable node non-zero); ``iterations``; ``maxima`` and
    ``zeros`` left (``maxima`` -1: not counted, zeros were left); ``fixed_point`` (the last iteration changed nothing);
    ``p``, ``headroom``, ``e_max`` and ``exponent_bits``; ``e_lo``, ``e_hi``
    (the range the free non-zero nodes use); ``seconds`` (model time)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def value(self, r, c):
        """The exact value of node (r, c) as (numerator, denominator exponent): v / 2**(p + e)."""
        return int(self.mantissa[r, c]), self.p + int(self.exponents[r, c])


def _check(p, headroom, e_max):
    if not (4 <= p <= P_LIMIT):
        raise ValueError(f"p = {p}: node exponents take 4 <= p <= {P_LIMIT} (int64 arithmetic)")
    if not (0 <= headroom <= p - 2):
        raise ValueError(f"headroom = {headroom}: take 0 <= headroom <= p - 2")
    if not (1 <= e_max < (1 << (61 - p - 1))):
        raise ValueError(f"e_max = {e_max}: take 1 <= e_max < 2**{61 - p - 1} at p = {p}")


def plan_node_exponents(obstacle, goals, p=NODE_P, headroom=NODE_HEADROOM, e_max="map", max_iter=None,
                        progress=None, until_fixed=False, order="jacobi"):
    """The harmonic field with one exponent per node (module docstring).

    ``e_max``: an int, or ``"map"``: :func:`~models.harmonic.exponent_bound`
    (2 x the longest BFS distance to a goal; the exact field needs no more).
    ``max_iter``: default 4 x (longest distance + 64 p).  ``progress(i,
    zeros, maxima)`` is called every 256 iterations.  ``until_fixed``: go
    on after convergence until an iteration changes nothing (the fixed point
    of the rounded update, for error measurements).  ``order``:
    ``"jacobi"`` (every node at once, the paper's node array) or
    ``"red-black"`` (the nodes with even row + column first, then the
    others from their new values: in place, the order a streaming engine
    over one state RAM would run; an iteration is both halves).  Returns
    :class:`NodeExponentResult`."""
    if order not in ("jacobi", "red-black"):
        raise ValueError(f"order {order!r}: 'jacobi' or 'red-black'")
    t0 = time.perf_counter()
    obstacle = np.asarray(obstacle, dtype=bool)
    dist = distances(obstacle, goals)
    goal = goal_mask(goals, obstacle.shape) & ~obstacle
    reach = dist >= 0
    if e_max == "map":
        e_max = max(1, 2 * int(dist.max()))
    e_max = int(e_max)
    _check(int(p), int(headroom), e_max)
    if max_iter is None:
        max_iter = 4 * (int(dist.max()) + 64 * p)
    rows, cols = obstacle.shape
    cells = np.argwhere(reach)
    R = len(cells)
    index = np.full((rows + 2, cols + 2), R, dtype=np.int64)          # R: the zero sentinel
    index[cells[:, 0] + 1, cells[:, 1] + 1] = np.arange(R)
    # Neighbours in N, E, W, S order (eq. 2's four; the order only matters for the Decision)
    nbr = np.stack([index[cells[:, 0] + 1 + dr, cells[:, 1] + 1 + dc]
                    for dr, dc in ((-1, 0), (0, 1), (0, -1), (1, 0))], axis=1)
    is_goal = goal[cells[:, 0], cells[:, 1]]
    v = np.zeros(R + 1, dtype=np.int64)
    e = np.full(R + 1, e_max, dtype=np.int64)
    v[:R][is_goal] = 1 << p
    e[:R][is_goal] = 0
    free = ~is_goal

    def tally():
        zeros = int((v[:R] == 0).sum())
        if zeros and not until_fixed:
            return zeros, -1            # not counted while the wave is out: a zero node next to zeros is one
        key = order_key(v, e, p, e_max)
        maxima = int((free & (key[:R] >= key[nbr].max(axis=1))).sum())
        return zeros, maxima

    it, fixed = 0, False
    zeros, maxima = tally()
    halves = [free] if order == "jacobi" else [free & (cells.sum(axis=1) % 2 == k) for k in (0, 1)]
    halves = [(np.flatnonzero(h), nbr[h]) for h in halves]
    while it < max_iter and (until_fixed or zeros or maxima):
        fixed = True
        for idx, nb in halves:
            nv, ne = node_update(v[nb], e[nb], p, e_max, headroom)
            fixed = fixed and np.array_equal(nv, v[idx]) and np.array_equal(ne, e[idx])
            v[idx], e[idx] = nv, ne
        it += 1
        zeros, maxima = tally()
        if progress and it % 256 == 0:
            progress(it, zeros, maxima)
        if fixed:
            break
    mant = np.zeros((rows, cols), dtype=np.int64)
    expo = np.full((rows, cols), e_max, dtype=np.int64)
    mant[cells[:, 0], cells[:, 1]] = v[:R]
    expo[cells[:, 0], cells[:, 1]] = e[:R]
    used = (v[:R] > 0) & free
    return NodeExponentResult(
        mantissa=mant, exponents=expo, key=order_key(mant, expo, p, e_max), p=int(p), headroom=int(headroom),
        e_max=e_max, exponent_bits=e_max.bit_length(), converged=not zeros and not maxima, iterations=it,
        maxima=maxima, zeros=zeros, fixed_point=bool(fixed),
        e_lo=int(e[:R][used].min()) if used.any() else 0, e_hi=int(e[:R][used].max()) if used.any() else 0,
        reachable=R, seconds=time.perf_counter() - t0)


# --- the engine's cycles (hdl/harmonic/node_exponent_engine.py) -----------------------------------

ENGINE_SLOTS = 5        # RAM reads a cell: its own word, then N, W, E, S (one read port)
UPDATE_LATENCY = 9      # the node update's pipeline (hdl/harmonic/node_exponents.py, NodeExponentUpdate.LATENCY)
RAM_LATENCY = 3         # the engine's state RAM read: address register, block RAM, register behind its multiplexer
WRITE_LATENCY = 1       # the engine's write port is registered
ENGINE_HALF_EXTRA = UPDATE_LATENCY + RAM_LATENCY + WRITE_LATENCY + 1   # a half-sweep's tail: data, push, write


def engine_cycles(height, width, iterations):
    """Cycles of the node-exponent engine's run (red-black, in place, to a
    fixed point): every iteration is two half-sweeps, the even cells (row +
    column) then the odd ones, each cell ENGINE_SLOTS reads; a half-sweep
    ends when its last cell is written (ENGINE_HALF_EXTRA more), so the next
    half reads the words just written; one cycle decides the next iteration.
    ``iterations`` as :func:`plan_node_exponents` (order="red-black",
    until_fixed=True) counts them."""
    return int(iterations) * (ENGINE_SLOTS * int(height) * int(width) + 2 * ENGINE_HALF_EXTRA + 1)
