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

from collections import deque
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "one", "neighbours", "update", "local_max", "step", "relax",
    "pad_to_blocks", "reachable", "PlanResult", "plan", "decision", "steepest_triangle", "visit_cycles",
    "VISIT_OVERHEAD", "RUN_OVERHEAD", "SET_OVERHEAD", "TRIANGLES",
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


# --- the block-synchronous planner (section 4 pseudo-code, 3.3, 4.5, 5.1) ---
#
# Timing of the Control module (hdl/harmonic/controller.py), in clock cycles,
# measured on the RTL and asserted by tb/harmonic/test_planner.py.  A block
# visit running K iterations of p+2 cycles takes K*(p+2) + VISIT_OVERHEAD:
#
#   ==================  ======================================================
#   cycle of a visit    what happens
#   ==================  ======================================================
#   t                   VSTART: the clusters get ``run`` (start request)
#   t+1                 the clusters' lead-in (first addresses presented)
#   t+2 .. t+1+K(p+2)   K iterations (update, check or clear)
#   +1, +2              cycles 0 and 1 of the stop iteration: the last
#                       iteration's top two bits are written (the write runs
#                       two bit positions behind the read, eq. 2's /4)
#   t+4+K(p+2)          the last iteration's Stable / Maximum flags
#   t+5+K(p+2)          VEND: next block, pass, precision or end decided
#   ==================  ======================================================
#
#   ==================  ======================================================
#   phase               cycles
#   ==================  ======================================================
#   update visit        K = min(i + 1, I) if iteration i (1-based) was the
#                       first stable one, else K = I.  The flags of an
#                       iteration come at cycle 2 of the next one, after that
#                       one's command was taken at its cycle 1, so an early
#                       stop costs one confirmation iteration; it reads the
#                       same words and borders, so it changes nothing, and it
#                       is not counted in ``block_iterations``
#   check visit         K = 1 (one check iteration: the Maximum flags)
#   clear visit         K = 1 (free nodes write 0, Sel/Sat of the order)
#   pass / level        0: decided in the last visit's VEND cycle; a precision
#                       change moves no data (MSB-first words, LSB addresses
#                       zeroed at load)
#   run                 RUN_OVERHEAD: START's own cycle is not counted, the
#                       last VEND is
#   dynamic order       SET_OVERHEAD + one clear pass (B clear visits); an
#                       order sent while idle runs outside any run
#   ==================  ======================================================

VISIT_OVERHEAD = 6
RUN_OVERHEAD = 0
SET_OVERHEAD = 0

_INT64_P_MAX = 60       # 4 * 2**60 < 2**63: int64 arithmetic is exact up to here


def visit_cycles(k, p):
    """Cycles of one block visit running ``k`` iterations at precision ``p``."""
    return k * (p + 2) + VISIT_OVERHEAD


def pad_to_blocks(obstacle, block):
    """Pad ``obstacle`` (bool, True = obstacle) at the bottom and right with
    obstacles to multiples of ``block = (n, m)``."""
    obstacle = np.asarray(obstacle, dtype=bool)
    n, m = _check_block(block)
    rows = -(-obstacle.shape[0] // n) * n
    cols = -(-obstacle.shape[1] // m) * m
    out = np.ones((rows, cols), dtype=bool)
    out[:obstacle.shape[0], :obstacle.shape[1]] = obstacle
    return out


def _check_block(block):
    try:
        n, m = (int(x) for x in block)
    except (TypeError, ValueError):
        raise ValueError(f"block must be (n, m), not {block!r}") from None
    if n < 1 or m < 1:
        raise ValueError(f"block ({n}, {m}): n and m must be at least 1")
    return n, m


def _goal_mask(goals, shape):
    mask = np.zeros(shape, dtype=bool)
    if isinstance(goals, np.ndarray) and goals.dtype == bool:
        mask[:goals.shape[0], :goals.shape[1]] = goals
        return mask
    for r, c in goals:
        if not (0 <= r < shape[0] and 0 <= c < shape[1]):
            raise ValueError(f"goal ({r}, {c}) is outside the {shape[0]}x{shape[1]} map")
        mask[r, c] = True
    return mask


def reachable(obstacle, goals):
    """Free cells 4-connected to a goal (goals included): a bool mask.

    ``goals``: a bool mask or a list of (row, col)."""
    free = ~np.asarray(obstacle, dtype=bool)
    goal = _goal_mask(goals, free.shape) & free
    seen = goal.copy()
    queue = deque(map(tuple, np.argwhere(goal)))
    rows, cols = free.shape
    while queue:
        r, c = queue.popleft()
        for rr, cc in ((r - 1, c), (r, c + 1), (r, c - 1), (r + 1, c)):
            if 0 <= rr < rows and 0 <= cc < cols and free[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                queue.append((rr, cc))
    return seen


@dataclass
class PlanResult:
    """Outcome of :func:`plan` on an H x W map (values cropped to H x W).

    ``h``: values at precision ``p`` (object ints, goal = 2**p); ``const``:
    goals, obstacles and walled-off cells.  ``maxima``: local maxima among
    the free (non-constant) nodes at the last check pass (0 when converged).
    ``unreachable``: free cells of the input map no goal reaches; they were
    loaded as constant-0 obstacles.  ``sweeps``: update passes over all
    blocks; ``block_iterations``: update iterations counted as the pseudo-code
    counts them (i, the stable one included), summed over block visits;
    ``check_iterations``: check iterations (one per block per check pass);
    ``node_updates``: block_iterations * n*m (every node of a block is
    updated in an iteration, obstacles and padding included);
    ``clear_passes``: passes that restarted the free nodes from 0 after a
    dynamic order; ``cycles``: the clock cycles the RTL spends from its START
    command to idle (see the timing table above); ``levels``: per precision
    level, dicts with p, sweeps, block_iterations, maxima (None if the level
    ended without a check); ``events_applied``: events that were due.
    """
    h: np.ndarray
    const: np.ndarray
    p: int
    converged: bool
    maxima: int
    unreachable: np.ndarray
    sweeps: int = 0
    block_iterations: int = 0
    check_iterations: int = 0
    node_updates: int = 0
    clear_passes: int = 0
    cycles: int = 0
    levels: list = field(default_factory=list)
    events_applied: int = 0
    block: tuple = (1, 1)
    blocks: tuple = (1, 1)
    padded_h: np.ndarray = None
    padded_const: np.ndarray = None
    # block exponents only (plan(..., block_exponents=True)); None otherwise
    exponents: np.ndarray = None
    frac_bits: int = None
    mantissa: np.ndarray = None
    repicks: int = 0
    saturated: int = 0

    def potential(self):
        """Values as floats in [0, 1]."""
        unit = one(self.p if self.frac_bits is None else self.frac_bits)
        return np.array([[int(v) / unit for v in row] for row in self.h], dtype=float)


def _schedule(schedule):
    sched = [int(p) for p in schedule]
    if not sched or sched[0] < 2 or any(b <= a for a, b in zip(sched, sched[1:])):
        raise ValueError(f"schedule {tuple(schedule)}: needs increasing precisions, the first >= 2")
    return sched


class _Grid:
    """What :func:`plan` and :func:`plan_explore` share: the padded map, the
    walled-off cells, the field with its 0 ring (outside the map), the block
    visit and the result's final figures."""

    def __init__(self, obstacle, goals, block, iters, schedule):
        self.n, self.m = n, m = _check_block(block)
        self.iters = int(iters)
        if self.iters < 1:
            raise ValueError(f"iters={self.iters}: at least 1 iteration per block")
        self.sched = _schedule(schedule)
        obstacle = np.asarray(obstacle, dtype=bool)
        self.H, self.W = obstacle.shape
        self.obst = obst = pad_to_blocks(obstacle, (n, m))
        self.goal = goal = _goal_mask(goals, obst.shape)
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
        self.p = self.sched[0]
        dtype = np.int64 if self.sched[-1] <= _INT64_P_MAX else object
        self.pad = np.zeros((self.rows + 2, self.cols + 2), dtype=dtype)   # a 0 ring: outside the map
        self.hv = self.pad[1:-1, 1:-1]
        self.hv[goal] = one(self.p)
        self.res = PlanResult(h=None, const=None, p=self.p, converged=False, maxima=0,
                              unreachable=unreachable[:self.H, :self.W], block=(n, m),
                              blocks=(self.BR, self.BC))

    def visit(self, br, bc):
        """Up to I Jacobi iterations of block (br, bc); returns (counted i, stable)."""
        n, m, pad, hv = self.n, self.m, self.pad, self.hv
        r0, c0 = br * n, bc * m
        fixed = self.const[r0:r0 + n, c0:c0 + m]
        for i in range(1, self.iters + 1):
            old = hv[r0:r0 + n, c0:c0 + m]
            s = (pad[r0:r0 + n, c0 + 1:c0 + m + 1] + pad[r0 + 2:r0 + n + 2, c0 + 1:c0 + m + 1]
                 + pad[r0 + 1:r0 + n + 1, c0:c0 + m] + pad[r0 + 1:r0 + n + 1, c0 + 2:c0 + m + 2])
            new = np.where(fixed, old, s >> 2)
            if (new == old).all():
                return i, True
            hv[r0:r0 + n, c0:c0 + m] = new
        return self.iters, False

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

    def maxima(self):
        """Local maxima of the free nodes (the check pass's Maximum flags)."""
        pad = self.pad
        nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
        return int(local_max(self.hv, self.const, nb).sum())

    def raise_precision(self):
        """The schedule's next p (the new low bits 0); False after the last."""
        later = [q for q in self.sched if q > self.p]
        if not later:
            return False
        self.pad <<= later[0] - self.p
        self.p = later[0]
        return True

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


def plan(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), events=(),
         block_exponents=False, **exponent_options):
    """Block-synchronous relaxation with increasing precision (section 4).

    The map (``obstacle``: bool H x W, True = obstacle; ``goals``: mask or
    (row, col) list) is padded with obstacles to whole blocks of ``block =
    (n, m)`` nodes (:func:`pad_to_blocks`).  Free cells no goal reaches are
    walled off (constant 0) before the run.  Block b = br*BC + bc (row-major)
    covers rows br*n .. br*n+n-1 and columns bc*m .. bc*m+m-1; blocks are
    visited in order b = 0 .. B-1.

    A *pass* visits every block once.  In an update pass (sweep) each block
    runs up to ``iters`` (I) Jacobi iterations, stopping early after the
    first iteration in which no node of the block changed (it counts);
    neighbours in other blocks read their latest stored values (the border
    storage), outside the map reads 0.  Sweeps repeat until one changes
    nothing, i.e. every block is stable in its first iteration.  (The
    pseudo-code's ``block_cvg`` alone would also accept a block that changed
    in its first iterations and then was stable: its neighbours' borders
    changed, so the map need not be a fixed point; we require no change.)
    Then a check pass: one check iteration per block, the Maximum
    flags.  No local maximum: converged.  Otherwise the next precision of
    ``schedule`` (the new low bits start at 0, i.e. values shift left); after
    the last one: not converged, ``maxima`` left.

    ``events``: dynamic orders ``(s, (r, c), kind)``, kind ``"obstacle"`` or
    ``"goal"``.  Passes are numbered 0, 1, ... from the start of the run
    (update and check passes alike).  An event with s >= 1 is applied at the
    end of pass s-1 (the Control module takes a host order at the next pass
    boundary); s = 0: before the run, as a SET command sent while idle (its
    cycles are not part of the run).  Applying an order is a clear pass: node
    (r, c) becomes constant (goal 2**p or obstacle 0) and every free node
    restarts from 0 at the current precision.  From 0 the floored iteration
    rises monotonically to its fixed point, whereas started above it (a new
    obstacle lowers values) it may oscillate with period 2 (see the module
    docstring), so every run terminates.  The next pass is an update sweep
    at the same precision.  Free cells a new obstacle cuts off from every
    goal are not walled off by the planner: they stay a zero plateau and
    count as maxima; the host walls them off with more obstacle orders.

    ``block_exponents=True``: the block-exponent variant, see
    :func:`plan_exponents` (``exponent_options`` go there).
    """
    if block_exponents:
        return plan_exponents(obstacle, goals, block=block, iters=iters, schedule=schedule, events=events,
                              **exponent_options)
    if exponent_options:
        raise ValueError(f"{sorted(exponent_options)}: options of block_exponents=True only")
    g = _Grid(obstacle, goals, block, iters, schedule)
    res, B, iters = g.res, g.B, g.iters
    due = g.orders(events)
    g.apply_due(due, 0)

    blocks = [(br, bc) for br in range(g.BR) for bc in range(g.BC)]
    level = {"p": g.p, "sweeps": 0, "block_iterations": 0, "maxima": None}
    passes = 0
    cycles = RUN_OVERHEAD
    mode = "update"
    while True:
        if mode == "update":
            changed = False
            for br, bc in blocks:
                i, stable = g.visit(br, bc)
                res.block_iterations += i
                level["block_iterations"] += i
                k = min(i + 1, iters) if stable else iters
                cycles += visit_cycles(k, g.p)
                changed |= i > 1 or not stable     # the block changed
            res.sweeps += 1
            level["sweeps"] += 1
        else:   # check pass: the Maximum flags of every block, nothing written
            cycles += B * visit_cycles(1, g.p)
            res.check_iterations += B
            maxima = g.maxima()
            level["maxima"] = maxima
        passes += 1
        applied = g.apply_due(due, passes)      # pending orders: a clear pass each
        if applied:
            cycles += applied * (SET_OVERHEAD + B * visit_cycles(1, g.p))
            mode = "update"
            continue
        if mode == "update":
            mode = "check" if not changed else "update"
            continue
        mode = "update"
        if maxima == 0:
            res.converged = True
            break
        if not g.raise_precision():
            break
        res.levels.append(level)
        level = {"p": g.p, "sweeps": 0, "block_iterations": 0, "maxima": None}
    res.levels.append(level)
    return g.result(cycles, maxima)


# Decision module (5.3): the four triangles of a node and two consecutive
# neighbours, in this order (the tie-break: the first of equal slopes wins).
TRIANGLES = (("N", "E"), ("E", "S"), ("S", "W"), ("W", "N"))
_OFFSET = {"N": (-1, 0), "E": (0, 1), "S": (1, 0), "W": (0, -1)}


def decision(h, r, c):
    """The steepest of the four triangles at node (r, c) of ``h`` (section 5.3).

    The triangle of two consecutive neighbours (X', Y'), (X'', Y'') that
    maximizes (h - h')**2 + (h - h'')**2 (outside the map reads 0); ties go to
    the first in :data:`TRIANGLES` order (NE, ES, SW, WN).  Returns
    ``(t, (g_row, g_col))``: the triangle's index and the gradient of its
    plane in grid axes (row down, column right): g_col = h_E - h or h - h_W,
    g_row = h_S - h or h - h_N: the direction of steepest ascent.
    """
    h = np.asarray(h, dtype=object)
    _check_node(h.shape, r, c)
    cells = _neighbour_cells(h.shape, r, c)
    return steepest_triangle(int(h[r, c]), {d: int(h[x]) if x else 0 for d, x in cells.items()})


def _check_node(shape, r, c):
    rows, cols = shape
    if not (0 <= r < rows and 0 <= c < cols):
        raise ValueError(f"node ({r}, {c}) is outside the {rows}x{cols} map")


def _neighbour_cells(shape, r, c):
    """{d: the N, E, S, W neighbour (rr, cc) of (r, c), None outside the map}."""
    out = {}
    for d in "NESW":
        rr, cc = r + _OFFSET[d][0], c + _OFFSET[d][1]
        out[d] = (rr, cc) if 0 <= rr < shape[0] and 0 <= cc < shape[1] else None
    return out


def steepest_triangle(centre, v):
    """The Decision module's rule (5.3) on one node: ``centre`` and its
    neighbours ``v`` = {"N", "E", "S", "W": value}; returns
    ``(t, (g_row, g_col))`` as :func:`decision`."""
    best, best_t = -1, 0
    for t, (a, b) in enumerate(TRIANGLES):
        score = (centre - v[a]) ** 2 + (centre - v[b]) ** 2
        if score > best:
            best, best_t = score, t
    pair = TRIANGLES[best_t]
    g_row = v["S"] - centre if "S" in pair else centre - v["N"]
    g_col = v["E"] - centre if "E" in pair else centre - v["W"]
    return best_t, (g_row, g_col)


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


__all__ += ["ASCENT_MOVES", "ascent_next", "Trajectory", "trajectory", "ascent_reaches"]


# --- schedule exploration (benches: the choices the paper leaves open, 4.5) -
#
# plan() is the planner as the RTL runs it.  plan_explore() runs the same
# algorithm with the schedule choices section 4.5 leaves open, for the
# benches: the block order and skipping still blocks.  With its defaults it
# is plan() exactly (same values, sweeps, iterations and cycles: tested), and
# from below every variant ends in the same field (the least fixed point of
# the floored map: tb/harmonic/test_model_blocks_bound.py); only the cost
# differs.
#
# order:  "raster" (plan's: row-major), "serpentine" (row-major, every other
#         block row reversed), "alternate" (raster, reversed on every other
#         sweep), "goal" (blocks by their BFS distance to the nearest goal,
#         nearest first: the values flow outward from the goals).
# skip:   a block is visited in a sweep only while "dirty": all blocks are
#         dirty at the start of a level; a visit that changes the block makes
#         dirty the neighbouring blocks whose facing border row/column changed,
#         and the block itself if it used up its I iterations.  A skipped
#         block costs SKIP_CYCLES (the Control module's decision cycle); the
#         level's update phase ends when no block is dirty, which is again a
#         fixed point of the whole map (every block stable against its
#         neighbours' current values).  Hardware cost: one dirty bit per block.

SKIP_CYCLES = 1


def plan_explore(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), order="raster", skip=False):
    """:func:`plan` (without events) with a block ``order`` and optional
    skipping of still blocks; returns a :class:`PlanResult` (``skipped``
    visits are counted in ``levels``)."""
    if order not in ("raster", "serpentine", "alternate", "goal"):
        raise ValueError(f"order {order!r}: raster, serpentine, alternate or goal")
    g = _Grid(obstacle, goals, block, iters, schedule)
    res, n, m, BR, BC, iters = g.res, g.n, g.m, g.BR, g.BC, g.iters
    raster = [(br, bc) for br in range(BR) for bc in range(BC)]
    if order == "serpentine":
        base = [(br, bc if br % 2 == 0 else BC - 1 - bc) for br, bc in raster]
    elif order == "goal":
        dist = np.full(g.obst.shape, np.inf)
        queue = deque(map(tuple, np.argwhere(g.goal)))
        for q in queue:
            dist[q] = 0
        while queue:
            r, c = queue.popleft()
            for rr, cc in ((r - 1, c), (r, c + 1), (r, c - 1), (r + 1, c)):
                if 0 <= rr < g.rows and 0 <= cc < g.cols and not g.obst[rr, cc] and dist[rr, cc] == np.inf:
                    dist[rr, cc] = dist[r, c] + 1
                    queue.append((rr, cc))
        base = sorted(raster, key=lambda b: (dist[b[0] * n:b[0] * n + n, b[1] * m:b[1] * m + m].min(), b))
    else:
        base = raster

    def visit(br, bc):
        """g.visit, and which of the block's edges (N, E, W, S) changed."""
        before = g.hv[br * n:br * n + n, bc * m:bc * m + m].copy()
        i, stable = g.visit(br, bc)
        after = g.hv[br * n:br * n + n, bc * m:bc * m + m]
        edges = (not (after[0] == before[0]).all(), not (after[:, -1] == before[:, -1]).all(),
                 not (after[:, 0] == before[:, 0]).all(), not (after[-1] == before[-1]).all())
        return i, stable, edges

    cycles = RUN_OVERHEAD
    while True:
        level = {"p": g.p, "sweeps": 0, "block_iterations": 0, "maxima": None, "skipped": 0}
        dirty = {b: True for b in raster}
        while True:                                   # update sweeps
            blocks = base[::-1] if order == "alternate" and level["sweeps"] % 2 else base
            changed = False
            for br, bc in blocks:
                if skip and not dirty[(br, bc)]:
                    cycles += SKIP_CYCLES
                    level["skipped"] += 1
                    continue
                dirty[(br, bc)] = False
                i, stable, edges = visit(br, bc)
                res.block_iterations += i
                level["block_iterations"] += i
                cycles += visit_cycles(min(i + 1, iters) if stable else iters, g.p)
                if i > 1 or not stable:
                    changed = True
                    dirty[(br, bc)] = not stable
                    for (dr, dc), moved in zip(((-1, 0), (0, 1), (0, -1), (1, 0)), edges):
                        if moved and (br + dr, bc + dc) in dirty:
                            dirty[(br + dr, bc + dc)] = True
            res.sweeps += 1
            level["sweeps"] += 1
            if not (any(dirty.values()) if skip else changed):
                break
        cycles += g.B * visit_cycles(1, g.p)          # check pass
        res.check_iterations += g.B
        maxima = level["maxima"] = g.maxima()
        res.levels.append(level)
        if maxima == 0:
            res.converged = True
            break
        if not g.raise_precision():
            break
    return g.result(cycles, maxima)


__all__ += ["SKIP_CYCLES", "plan_explore"]


# --- block exponents (issue 10: beyond the paper) ---------------------------
#
# Fig. 3 / 3.2.2: the potential decays exponentially with the distance to the
# goal, so one fixed-point word for the whole map needs bits in proportion to
# the longest path, and the 1K-deep node RAM caps B * (p+2).  With block
# exponents the word length follows the block instead: block b keeps an
# exponent e_b, and a stored mantissa v of block b stands for v / 2**(p+e_b).
# The nodes, the serial adder and the word layout are unchanged (p+2 bits);
# what changes is how a value crosses a block border and the exponent
# re-pick.  plan_exponents() is the algorithm; plan(..., block_exponents=True)
# calls it.  Everything is exact integer arithmetic.

E_MAX = 255             # default exponent bound: an 8-bit exponent register per block
REPICK_HEADROOM = 1     # default h: a re-pick leaves the top h mantissa bits empty


def convert_mantissa(v, s, p):
    """A neighbour block's mantissa ``v`` seen from a block whose exponent is
    ``s`` larger (``s < 0``: smaller), both at word precision ``p``.

    ``s > 0`` (the reader is finer): ``v << s``, the LSB-first stream delayed
    by s cycles, saturated at the word's top ``2**(p+1) - 1`` (a clamp);
    ``s < 0``: ``v >> -s``, the stream read -s bits late (floor, the dropped
    bits are lost); ``s = 0``: ``v``.  Works on ints and on integer numpy
    arrays.  Returns ``(value, clamped)``, ``clamped`` True if any value hit
    the top.  Both branches are monotone in ``v``, which the termination
    argument of :func:`plan_exponents` needs."""
    cap = (1 << (p + 1)) - 1
    scalar = not isinstance(v, np.ndarray)
    arr = np.asarray(v, dtype=object) if scalar else v
    if s == 0:
        out, clamped = arr, False
    elif s < 0:
        out = arr >> -s if -s <= p + 1 else arr * 0
        clamped = False
    else:
        lim = cap >> s if s <= p + 1 else 0
        over = np.asarray(arr > lim, dtype=bool)
        safe = np.where(over, 0, arr)
        out = np.where(over, cap, safe << s if s <= p + 1 else safe)
        out = out.astype(arr.dtype) if not scalar else out
        clamped = bool(over.any())
    return (int(out) if scalar else out), clamped


def decision_exponents(mantissa, exponents, block, p, r, c):
    """The Decision module (5.3) on a block-exponent field, as the planner
    RTL's exponent option computes it: node (r, c) of the padded
    ``mantissa`` field (BR*n x BC*m), ``exponents`` (BR x BC), ``block`` =
    (n, m), word precision ``p``.

    Each neighbour in another block is first seen in the centre's units,
    2**-(p + e_c), through the border conversion the node's update uses
    (:func:`convert_mantissa`, s = e_c - e_neighbour); then the rule of
    :func:`steepest_triangle`.  Returns ``(t, (g_row, g_col), e_c)``: the
    gradient is in the centre's units, so its direction needs no exponent.

    Error bound (what the conversion loses): a neighbour's converted value
    v' and its exact value x (in the centre's units) satisfy
    v' <= x < v' + 1 unless it was clamped (then v' = 2**(p+1)-1 <= x): a
    finer neighbour (s < 0) loses its bits below the centre's LSB (floor),
    a coarser one (s > 0) is exact below the clamp.  So each gradient
    component is within one unit of the exact plane's, and the triangle can
    differ from the exact one's only where scores are that close or a
    neighbour clamps (tested against exact fractions on converged fields).
    """
    mantissa = np.asarray(mantissa, dtype=object)
    n, m = block
    _check_node(mantissa.shape, r, c)
    e = int(exponents[r // n][c // m])
    v = {d: convert_mantissa(int(mantissa[x]), e - int(exponents[x[0] // n][x[1] // m]), p)[0] if x else 0
         for d, x in _neighbour_cells(mantissa.shape, r, c).items()}
    t, g = steepest_triangle(int(mantissa[r, c]), v)
    return t, g, e


class _ExpGrid(_Grid):
    """The padded map with mantissas (``pad``/``hv``) and one exponent per
    block (``E``); ``visit`` converts the border ring into the block's units."""

    def __init__(self, obstacle, goals, block, iters, schedule, headroom, e_max, ceiling=False, rtl=False):
        super().__init__(obstacle, goals, block, iters, schedule)
        self.use_ceiling = bool(ceiling)
        self.rtl = bool(rtl)
        self.headroom, self.e_max = int(headroom), int(e_max)
        if self.headroom < 0:
            raise ValueError(f"headroom={self.headroom}: must be >= 0")
        if self.e_max < 0:
            raise ValueError(f"e_max={self.e_max}: must be >= 0")
        self.E = np.zeros((self.BR, self.BC), dtype=np.int64)
        self.sat = np.zeros((self.BR, self.BC), dtype=bool)
        self.ceiling = np.full((self.BR, self.BC), self.e_max, dtype=np.int64)
        self._block_masks()
        self._dtype_for_p()

    def _block_masks(self):
        n, m = self.n, self.m
        self.goal_block = self.goal.reshape(self.BR, n, self.BC, m).any(axis=(1, 3))
        self.free_block = (~self.const).reshape(self.BR, n, self.BC, m).any(axis=(1, 3))

    def apply(self, r, c, kind):
        """An order's clear pass with exponents: as in fixed point, and every
        e_b back to 0 (no clamp, no ceiling): the state a run starts from,
        at the current p.  (The goals keep 2**p: their blocks were at e = 0.)"""
        super().apply(r, c, kind)
        self.E[...] = 0
        self.sat[...] = False
        self.ceiling[...] = self.e_max
        self._block_masks()

    def _dtype_for_p(self):
        """int64 while p <= 60 (sums of four (p+1)-bit mantissas fit), Python
        ints above: the same values, only faster where the schedule starts low."""
        want = np.int64 if self.p <= _INT64_P_MAX else object
        if self.pad.dtype != want:
            self.pad = self.pad.astype(want)
            self.hv = self.pad[1:-1, 1:-1]

    def _ring(self, br, bc):
        """The block's four border rings (N, S, W, E): (mantissas, neighbour
        exponent) in the neighbour's own units, or None outside the map."""
        n, m, hv = self.n, self.m, self.hv
        r0, c0 = br * n, bc * m
        out = []
        for dr, dc, sl in ((-1, 0, (r0 - 1, slice(c0, c0 + m))), (1, 0, (r0 + n, slice(c0, c0 + m))),
                           (0, -1, (slice(r0, r0 + n), c0 - 1)), (0, 1, (slice(r0, r0 + n), c0 + m))):
            nb, nc = br + dr, bc + dc
            if 0 <= nb < self.BR and 0 <= nc < self.BC:
                out.append((hv[sl], int(self.E[nb, nc])))
            else:
                out.append(None)
        return out

    def visit(self, br, bc):
        """Up to I Jacobi iterations of block (br, bc) against its ring
        converted to the block's exponent; returns (counted i, stable)."""
        n, m, p = self.n, self.m, self.p
        r0, c0 = br * n, bc * m
        e = int(self.E[br, bc])
        loc = np.zeros((n + 2, m + 2), dtype=self.pad.dtype)
        loc[1:-1, 1:-1] = self.hv[r0:r0 + n, c0:c0 + m]
        for side, ring in zip(((0, slice(1, -1)), (-1, slice(1, -1)), (slice(1, -1), 0), (slice(1, -1), -1)),
                              self._ring(br, bc)):
            if ring is not None:
                vals, clamped = convert_mantissa(ring[0], e - ring[1], p)
                loc[side] = vals
                self.sat[br, bc] |= clamped
        fixed = self.const[r0:r0 + n, c0:c0 + m]
        stable, count = False, self.iters
        for i in range(1, self.iters + 1):
            old = loc[1:-1, 1:-1]
            s = loc[:-2, 1:-1] + loc[2:, 1:-1] + loc[1:-1, :-2] + loc[1:-1, 2:]
            new = np.where(fixed, old, s >> 2)
            if (new == old).all():
                stable, count = True, i
                break
            loc[1:-1, 1:-1] = new
        self.hv[r0:r0 + n, c0:c0 + m] = loc[1:-1, 1:-1]
        return count, stable

    def repick_amount(self, br, bc):
        """The exponent rule: by how much e_b rises now (0: unchanged).

        d = the largest d >= 0 with every value the block holds or sees (its
        nodes and its ring, exact, in each owner's units) below
        2**(p+1-h) in the block's units after the shift, capped at
        e_max - e_b; 0 for a goal block (its goal is 2**p at e = 0), a block
        with no free node, or a block whose nodes and ring are all 0."""
        if self.goal_block[br, bc] or not self.free_block[br, bc]:
            return 0
        n, m, p = self.n, self.m, self.p
        e = int(self.E[br, bc])
        top = p + 1 - self.headroom
        own = int(self.hv[br * n:br * n + n, bc * m:bc * m + m].max())
        d = top - own.bit_length() if own else None
        for ring in self._ring(br, bc):
            if ring is None:
                continue
            big = int(ring[0].max())
            if big:
                dr = top - big.bit_length() - e + ring[1]
                d = dr if d is None else min(d, dr)
        if d is None:
            return 0
        return max(0, min(d, int(self.ceiling[br, bc]) - e))

    def repick(self, br, bc):
        """Apply the rule: shift the block's mantissas left by d (exact,
        they fit by construction); returns d."""
        d = self.repick_amount(br, bc)
        if d:
            n, m = self.n, self.m
            self.hv[br * n:br * n + n, bc * m:bc * m + m] <<= d
            self.E[br, bc] += d
        return d

    def frac_bits(self):
        return self.p + int(self.E.max())

    def common(self):
        """The padded field on one scale, 2**-frac_bits (object ints, exact):
        mantissa << (frac_bits - p - e_b)."""
        F = self.frac_bits()
        n, m = self.n, self.m
        out = np.array(self.hv, dtype=object)
        for br in range(self.BR):
            for bc in range(self.BC):
                out[br * n:br * n + n, bc * m:bc * m + m] <<= F - self.p - int(self.E[br, bc])
        return out

    def scan_cycles(self, br, bc):
        """The RTL's clamp scan before a visit of block (br, bc) (``rtl=True``):
        L = max over the neighbour blocks of clip(e_b - e_b', 0, p+1) border
        offsets read MSB first, plus the strobe cycle; 0 when L = 0
        (:class:`hdl.harmonic.border.Border`)."""
        e, L = int(self.E[br, bc]), 0
        for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            nb, nc = br + dr, bc + dc
            if 0 <= nb < self.BR and 0 <= nc < self.BC:
                L = max(L, min(max(e - int(self.E[nb, nc]), 0), self.p + 1))
        return L + 1 if L else 0

    def maxima_converted(self):
        """Local maxima as the RTL's Maximum sees them (``rtl=True``): a
        neighbour in another block is compared after the border conversion
        (:func:`convert_mantissa`: floor, clamp), exactly the stream the
        node's MSB-first comparison gets.  Conservative: a free node's
        mantissa never reaches the clamp value 2^(p+1)-1 (it would need
        all four neighbours there), so a clamped neighbour is greater, as
        exactly; a floored one can only look equal where it is greater.
        Hence every exact local maximum is one here too, and a field
        without converted maxima has no exact one."""
        n, m, p = self.n, self.m, self.p
        total = 0
        for br in range(self.BR):
            for bc in range(self.BC):
                r0, c0 = br * n, bc * m
                e = int(self.E[br, bc])
                loc = np.zeros((n + 2, m + 2), dtype=object)
                loc[1:-1, 1:-1] = self.hv[r0:r0 + n, c0:c0 + m]
                for side, ring in zip(((0, slice(1, -1)), (-1, slice(1, -1)), (slice(1, -1), 0),
                                       (slice(1, -1), -1)), self._ring(br, bc)):
                    if ring is not None:
                        loc[side] = convert_mantissa(np.array(ring[0], dtype=object), e - ring[1], p)[0]
                h = loc[1:-1, 1:-1]
                nb = (loc[:-2, 1:-1], loc[1:-1, 2:], loc[1:-1, :-2], loc[2:, 1:-1])
                total += int(local_max(h, self.const[r0:r0 + n, c0:c0 + m], nb).sum())
        return total

    def maxima(self):
        """Local maxima of the free nodes, comparing exact values across
        block borders (the common scale); ``rtl=True``: :meth:`maxima_converted`."""
        if self.rtl:
            return self.maxima_converted()
        h = self.common()
        pad = np.zeros((self.rows + 2, self.cols + 2), dtype=object)
        pad[1:-1, 1:-1] = h
        nb = (pad[:-2, 1:-1], pad[1:-1, 2:], pad[1:-1, :-2], pad[2:, 1:-1])
        return int(local_max(h, self.const, nb).sum())

    def raise_precision_exp(self):
        """The schedule's next p.  A block that clamped a ring value in this
        level coarsens its exponent by up to the step (p + e_b kept: no
        resolution lost, the word gains top bits: its mantissas shift by
        step - δ, which moves its words: returned in ``moved``); every other
        block keeps e_b and its mantissas shift left by the step (appended
        LSB addresses, free, as in fixed point).  Returns None after the
        last precision, else the list of moved blocks."""
        later = [q for q in self.sched if q > self.p]
        if not later:
            return None
        step = later[0] - self.p
        n, m = self.n, self.m
        if later[0] > _INT64_P_MAX:
            self.pad = self.pad.astype(object)
            self.hv = self.pad[1:-1, 1:-1]
        moved = []
        for br in range(self.BR):
            for bc in range(self.BC):
                delta = min(int(self.E[br, bc]), step) if self.sat[br, bc] else 0
                self.hv[br * n:br * n + n, bc * m:bc * m + m] <<= step - delta
                if delta:
                    self.E[br, bc] -= delta
                    moved.append((br, bc))
                if self.sat[br, bc] and self.use_ceiling:
                    self.ceiling[br, bc] = self.E[br, bc]
        self.p = later[0]
        self.sat[...] = False
        self._dtype_for_p()
        return moved


SHIFT_STEP = 3          # the RTL's in-place rotation per iteration (rtl=True)


def shift_iterations(d):
    """Iterations of the RTL's shift visit that rotates a block's words by d
    value positions (rtl=True): an iteration reads LSB first and writes each
    bit three positions behind the read, so a rotation by at most 3 never
    overwrites a bit before it is read; a rotation by d takes ceil(d/3)
    iterations (3, 3, ..., the rest last: see hdl/harmonic/cluster.py)."""
    return max(1, -(-int(d) // SHIFT_STEP))


def plan_exponents(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), headroom=REPICK_HEADROOM,
                   e_max=E_MAX, repick="visit", ceiling=False, trace=None, rtl=False, events=()):
    """The block-synchronous planner (:func:`plan`) with one exponent per block.

    Number format: block b's node with stored mantissa v (p+1 bits, the word
    and the serial adder of the fixed-point design) stands for
    v / 2**(p + e_b); 0 <= e_b <= ``e_max``; goal = 2**p in its block, whose
    exponent stays 0.  All exponents start at 0, so the run begins as the
    fixed-point planner.

    Update (eq. 2): inside a block nothing changes, floor((N+E+W+S)/4).  A
    neighbour in another block b' is converted with s = e_b - e_b'
    (:func:`convert_mantissa`): s < 0 shifts right (floor), s > 0 shifts left
    saturating at the word's top 2**(p+1)-1 (a clamp, recorded: the block is
    *saturated* in this level).  Serially both are timing: read the border
    stream -s bits late, or delay it by s cycles.

    Exponent rule (re-pick).  After every update visit of block b (``repick
    ="visit"``, the default; ``"stable"``: only after a visit whose first
    iteration changed nothing; ``"check"``: only at check passes; "visit" is
    the cheapest on the bundled maps) and at every check pass
    that finds local maxima, e_b rises by the largest d >= 0 such that every
    value block b holds or sees (its nodes and its four border rings, exact)
    stays below 2**(p+1-h) in its units (h = ``headroom``), at most up to
    ``e_max``; the block's mantissas shift left by d (exact).  A goal block, a
    block without free node and a block whose nodes and ring are all 0 keep
    their exponent.  So within a precision level e_b only rises.
    ``ceiling=True`` (an option, measured worse on room-32-32-4): a block
    saturated in a level may not rise above its lowered exponent again.  When the
    precision rises by a step (no re-pick possible at a check pass that
    found maxima), a block saturated in the ending level lowers e_b by
    δ = min(e_b, step) so that p + e_b stays (its words gain top bits, no
    resolution is lost); every other block keeps e_b.  Hence p + e_b (the
    block's resolution) never falls during a run.

    Termination (and why the field is right).  Let x be the exact values
    v / 2**(p+e_b).  (1) The update with conversions is a monotone map F of
    x for fixed exponents (floor, shifts and the clamp are monotone).  (2) The
    start (free nodes 0, goals 1) is a sub-solution x <= F(x), and a block
    update of a sub-solution is a larger sub-solution (as for plan()).  (3) A
    re-pick keeps x and makes block b's grid finer; its ring fits below the
    new top, so no new clamp: the new F_b(x) >= the old one, and the other
    blocks' view of b depends only on x: x is still a sub-solution.  The same
    holds for a precision rise (p + e_b never falls, the clamp's top never
    falls).  So x never decreases over the whole run and stays below the
    exact solution.  Within a level there are at most B * e_max re-picks, and
    between re-picks x rises in a finite set, so every level ends; the
    number of levels at one precision is bounded (each one re-picks, raising
    the sum of e_b), the schedule is finite: every run ends.  ``events``
    (dynamic orders, as in :func:`plan`: at the end of pass s-1, a sweep or
    a check pass; a clear pass each): the clear pass also sets every e_b
    back to 0 and forgets the clamps, so the run restarts from the state a
    run starts in, at the current p; finitely many orders, so every run
    still ends.  Tested by
    :mod:`test_model_exponents` (x never falls, exponents in bounds, the end a
    fixed point of F).

    Cycles: the timing model of :func:`plan` at word precision p (a visit of
    K iterations is K*(p+2) + VISIT_OVERHEAD; a check pass is B visits of
    K = 1).  A re-pick that changes e_b costs one shift visit of K = 1 (one
    iteration reads the block's words and writes them d positions earlier:
    the write counter's offset; the leading-one positions come free from the
    LSB-first streams of the update iterations, the last 1 written, and from
    the MSB-first streams of a check iteration); a precision rise that
    coarsens a saturated block costs it the same shift visit; a precision
    rise without coarsening moves nothing, as in fixed point.

    Local maxima compare exact values across borders; the result's ``h`` is
    the field on one scale 2**-frac_bits (frac_bits = p + max e_b), so
    :func:`trajectory`, :func:`ascent_next` and :func:`decision` work on it
    unchanged.  ``mantissa`` (padded) and ``exponents`` (BR x BC) are the
    stored state; ``repicks`` counts exponent changes, ``saturated`` the
    blocks saturated in the last level.  ``trace``: None or a list that
    receives a tuple after every visit,
    re-pick, check and precision rise, with the cycles counted so far
    (event, p, exponents copy, mantissa copy, cycles; for the tests).

    ``rtl=True``: what the planner RTL's option (``Planner(...,
    block_exponents=True)``) does, needing ``repick="visit"`` and no
    ceiling: (1) the Maximum compares a neighbour in another block after the
    border conversion (:meth:`_ExpGrid.maxima_converted`: conservative, a
    converged field has no exact local maximum either); (2) every update and
    check visit of a block finer than a neighbour first scans the clamp bits
    (:meth:`_ExpGrid.scan_cycles`: L+1 cycles, L = the largest positive
    exponent difference, at most p+1); (2b) a shift visit rotates the words
    in place by at most 3 positions per iteration, so a re-pick by d costs
    :func:`shift_iterations` (min(d, p)) iterations and a coarsening by δ at a
    precision rise (a left rotation by p+1-δ: the low step bits are 0)
    shift_iterations(p+1-δ); (3) the check pass's re-pick is
    skipped (with ``repick="visit"`` it never moves: the sweep before it
    re-picked every block and changed nothing; asserted here).
    """
    if rtl and (repick != "visit" or ceiling):
        raise ValueError("rtl=True: the RTL re-picks after every visit (repick='visit'), no ceiling")
    if repick not in ("visit", "stable", "check"):
        raise ValueError(f"repick {repick!r}: 'visit', 'stable' or 'check'")
    g = _ExpGrid(obstacle, goals, block, iters, schedule, headroom, e_max, ceiling, rtl)
    res, B, iters = g.res, g.B, g.iters
    blocks = [(br, bc) for br in range(g.BR) for bc in range(g.BC)]
    due = g.orders(events)
    g.apply_due(due, 0)
    passes = 0

    def clear_due():
        """After a pass: the orders due now, each a clear pass; True if any."""
        nonlocal cycles
        k = g.apply_due(due, passes)
        cycles += k * (SET_OVERHEAD + B * visit_cycles(1, g.p))
        if k:
            note("clear")
        return k > 0

    def note(event):
        if trace is not None:
            trace.append((event, g.p, g.E.copy(), np.array(g.hv, dtype=object), cycles))

    def new_level():
        return {"p": g.p, "sweeps": 0, "block_iterations": 0, "maxima": None, "repicks": 0,
                "saturated": 0}

    level = new_level()
    cycles = RUN_OVERHEAD
    maxima = 0
    note("start")
    while True:
        changed = False
        for br, bc in blocks:
            if rtl:
                cycles += g.scan_cycles(br, bc)
            i, stable = g.visit(br, bc)
            res.block_iterations += i
            level["block_iterations"] += i
            cycles += visit_cycles(min(i + 1, iters) if stable else iters, g.p)
            changed |= i > 1 or not stable
            note("visit")
            d = (repick == "visit" or (repick == "stable" and stable and i == 1)) and g.repick(br, bc)
            if d:
                cycles += visit_cycles(shift_iterations(min(d, g.p)) if rtl else 1, g.p)
                res.repicks += 1
                level["repicks"] += 1
                changed = True
                note("repick")
        res.sweeps += 1
        level["sweeps"] += 1
        passes += 1
        if clear_due() or changed:
            continue
        cycles += B * visit_cycles(1, g.p)             # check pass
        if rtl:
            cycles += sum(g.scan_cycles(br, bc) for br, bc in blocks)
        res.check_iterations += B
        maxima = level["maxima"] = g.maxima()
        level["saturated"] = int(g.sat.sum())
        note("check")
        passes += 1
        if clear_due():
            continue
        if maxima == 0:
            res.converged = True
            break
        moved = 0
        for br, bc in blocks:
            if g.repick(br, bc):
                moved += 1
        if rtl:
            assert moved == 0, "repick='visit': a check pass cannot re-pick"
        if moved:                                     # a new level at the same p
            cycles += moved * visit_cycles(1, g.p)
            res.repicks += moved
            level["repicks"] += moved
            res.levels.append(level)
            level = new_level()
            note("repick")
            continue
        before = g.E.copy()
        shifted = g.raise_precision_exp()
        if shifted is None:
            break
        for br, bc in shifted:
            # rtl: the right shift by δ is a left rotation by p+1-δ
            k = shift_iterations(g.p + 1 - int(before[br, bc] - g.E[br, bc])) if rtl else 1
            cycles += visit_cycles(k, g.p)
        res.levels.append(level)
        level = new_level()
        note("raise")
    res.levels.append(level)
    res.saturated = int(g.sat.sum())
    out = g.result(cycles, maxima)
    out.mantissa = np.array(g.hv, dtype=object)
    out.exponents = g.E.copy()
    out.frac_bits = g.frac_bits()
    out.padded_h = g.common()
    out.h = out.padded_h[:g.H, :g.W].copy()
    return out


__all__ += ["E_MAX", "REPICK_HEADROOM", "SHIFT_STEP", "convert_mantissa", "decision_exponents", "plan_exponents",
            "shift_iterations"]
