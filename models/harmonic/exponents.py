"""Block exponents (issue 10: beyond the paper): the field with one exponent
per block, its exponent rule and its cycle costs, run by the section 4
schedule (:func:`models.harmonic.schedule.run`).

Fig. 3 / 3.2.2: the potential decays exponentially with the distance to the
goal, so one fixed-point word for the whole map needs bits in proportion to
the longest path, and the 1K-deep node RAM caps B * (p+2).  With block
exponents the word length follows the block instead.

Number format
-------------
Block b keeps an exponent e_b, 0 <= e_b <= e_max (an 8-bit register per
block by default, :data:`E_MAX`); a stored mantissa v of block b (p+1 bits:
the word, the serial adder and the word layout of the fixed-point design)
stands for v / 2**(p + e_b).  The goal is 2**p in its block, whose exponent
stays 0.  Everything is exact integer arithmetic (int64 while p <= 60,
Python ints above).

Rounding
--------
Inside a block, eq. 2's ``floor((N+E+W+S)/4)`` as in fixed point.  What
changes is how a value crosses a block border
(:func:`~models.harmonic.ram.convert_mantissa`: right shifts floor, left
shifts clamp at 2**(p+1)-1) and the exponent re-pick (a left shift of the
block's mantissas, exact by construction).
"""

import numpy as np

from .grid import BlockGrid, distances, pad_to_blocks
from .node import local_max
from .ram import SHIFT_STEP, convert_mantissa
from .schedule import control, run, visit_cycles

__all__ = ["E_MAX", "REPICK_HEADROOM", "SHIFT_STEP", "shift_iterations", "exponent_bound", "e_max_for",
           "precision_estimate", "ExponentGrid", "plan_exponents"]

E_MAX = 255             # default exponent bound: an 8-bit exponent register per block
REPICK_HEADROOM = 1     # default h: a re-pick leaves the top h mantissa bits empty

# A block's four border rings (N, S, W, E): the neighbour block's offset and
# where the ring sits in the visit's local (n+2) x (m+2) array.
_SIDES = (((-1, 0), (0, slice(1, -1))), ((1, 0), (-1, slice(1, -1))),
          ((0, -1), (slice(1, -1), 0)), ((0, 1), (slice(1, -1), -1)))


def shift_iterations(d):
    """Iterations of the RTL's shift visit that rotates a block's words by d
    value positions (rtl=True): an iteration reads LSB first and writes each
    bit rotated in place, at most :data:`SHIFT_STEP` (4) positions per
    iteration (:func:`~models.harmonic.ram.pads`), so a rotation by d takes
    ceil(d/4) iterations (4, 4, ..., the rest last: see
    hdl/harmonic/cluster.py), each one pad cycle longer than an update's."""
    return max(1, -(-int(d) // SHIFT_STEP))


def exponent_bound(obstacle, goals):
    """The e_max a map needs (issue 22): ``2 * d_max``, d_max the longest
    BFS distance (4-connected steps) from a reachable cell to its nearest
    goal; at least 1.

    Why it suffices: the exact potential of a free node is the mean of its
    four neighbours (eq. 1), so it is at least a quarter of its neighbour
    one step nearer the goal, and a node d steps from the goal holds at
    least 4**-d (the goal is 1).  The re-pick raises e_b only while the
    largest value block b holds or sees, in its units, stays below
    2**(p+1-h): at the exact field that value is at least 4**-d_max, so
    e_b <= 2 * d_max - h: the exponent never needs more, whatever p is
    (p only sets how many bits below a block's top it resolves).  A
    run's exponents can still reach e_max transiently (a block that first
    sees one LSB of its neighbour's word re-picks by about p); the cap is
    part of the rule and keeps every proof of :func:`plan_exponents`.
    The exponent register is ``e_max.bit_length()`` bits."""
    d = distances(obstacle, goals)
    return max(1, 2 * int(d.max()))


def e_max_for(obstacle, goals):
    """``e_max="map"``: :func:`exponent_bound`, at least :data:`E_MAX` (the
    8-bit default: a small map keeps the default registers, and the RTL
    build they share)."""
    return max(E_MAX, exponent_bound(obstacle, goals))


def precision_estimate(obstacle, goals, block, headroom=REPICK_HEADROOM):
    """The word precision p block exponents need on a map (an estimate to
    choose the schedule, issue 22): ``2 * spread + headroom + 2``, spread
    the largest difference, over the blocks of ``block``, between the BFS
    distance of a reachable cell of the block and the smallest distance of
    a reachable cell the block holds or sees (its nodes and its four border
    rings).  One exponent serves the whole block, whose top is set by the
    largest value it holds or sees and whose farthest node is about
    4**-spread below it (the exact field decays by at most 4 a step, by
    2 - sqrt(3) ~ 0.27 along a corridor: 1.9 bits a step), so its word
    needs about 2 bits a step of that spread: in a maze, two corridors of
    one block can be thousands of steps apart, and then no exponent helps.
    Returns (p, spread)."""
    n, m = block
    d = distances(obstacle, goals).astype(float)
    d[d < 0] = np.nan
    padded = np.full(pad_to_blocks(obstacle, block).shape, np.nan)
    padded[:d.shape[0], :d.shape[1]] = d
    rows, cols = padded.shape
    view = np.full((rows + 2, cols + 2), np.nan)
    view[1:-1, 1:-1] = padded
    spread = 0
    with np.errstate(all="ignore"):
        for r0 in range(0, rows, n):
            for c0 in range(0, cols, m):
                own = padded[r0:r0 + n, c0:c0 + m]
                if np.isnan(own).all():
                    continue
                ring = view[r0:r0 + n + 2, c0:c0 + m + 2].copy()
                ring[0, 0] = ring[0, -1] = ring[-1, 0] = ring[-1, -1] = np.nan   # corners: not seen
                spread = max(spread, int(np.nanmax(own) - np.nanmin(ring)))
    return 2 * spread + int(headroom) + 2, spread


class ExponentGrid(BlockGrid):
    """The padded map with mantissas (``pad``/``hv``) and one exponent per
    block (``E``): the schedule's hooks for :func:`plan_exponents`.  ``visit``
    converts the border ring into the block's units; ``after_visit`` and
    ``rescale`` re-pick exponents; ``raise_precision`` coarsens saturated
    blocks; with ``rtl`` the costs of the planner RTL's option."""

    def __init__(self, obstacle, goals, block, iters, schedule, headroom=REPICK_HEADROOM, e_max=E_MAX,
                 repick="visit", ceiling=False, rtl=False, fast=False):
        if rtl and (repick != "visit" or ceiling):
            raise ValueError("rtl=True: the RTL re-picks after every visit (repick='visit'), no ceiling")
        if repick not in ("visit", "stable", "check"):
            raise ValueError(f"repick {repick!r}: 'visit', 'stable' or 'check'")
        super().__init__(obstacle, goals, block, iters, schedule)
        self.repick_rule = repick
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
        self.fast = bool(fast)
        if self.fast:
            self.visit = self._visit_fast
            self._gathers()

    def _block_masks(self):
        n, m = self.n, self.m
        self.goal_block = self.goal.reshape(self.BR, n, self.BC, m).any(axis=(1, 3))
        self.free_block = (~self.const).reshape(self.BR, n, self.BC, m).any(axis=(1, 3))

    def _views(self):
        """As in fixed point, and per block its border rings: (a view of the
        neighbour's facing row or column, the neighbour block) or None
        outside the map."""
        super()._views()
        self.flat = self.pad.reshape(-1)        # the fast visit's gathers index it
        n, m, hv = self.n, self.m, self.hv
        self.rings = {}
        for br, bc in self.blocks:
            r0, c0 = br * n, bc * m
            rings = []
            for (dr, dc), _ in _SIDES:
                nb = (br + dr, bc + dc)
                if not (0 <= nb[0] < self.BR and 0 <= nb[1] < self.BC):
                    rings.append(None)
                elif dr:
                    rings.append((hv[r0 - 1 if dr < 0 else r0 + n, c0:c0 + m], nb))
                else:
                    rings.append((hv[r0:r0 + n, c0 - 1 if dc < 0 else c0 + m], nb))
            self.rings[br, bc] = rings

    def _ring(self, b):
        """The block's four border rings (N, S, W, E): (mantissas, neighbour
        exponent) in the neighbour's own units, or None outside the map."""
        return [None if ring is None else (ring[0], int(self.E[ring[1]])) for ring in self.rings[b]]

    def _local(self, b, dtype):
        """Block ``b``'s (n+2) x (m+2) window: its mantissas and its ring
        converted into its units (:func:`convert_mantissa`); which clamped."""
        e = int(self.E[b])
        loc = np.zeros((self.n + 2, self.m + 2), dtype=dtype)
        loc[1:-1, 1:-1] = self.block(b)
        clamped = False
        for (_, side), ring in zip(_SIDES, self._ring(b)):
            if ring is not None:
                vals, c = convert_mantissa(np.asarray(ring[0], dtype=dtype), e - ring[1], self.p)
                loc[side] = vals
                clamped |= c
        return loc, clamped

    # --- the schedule's hooks ---------------------------------------------

    def new_level(self):
        return {**super().new_level(), "repicks": 0, "saturated": 0}

    def apply(self, r, c, kind):
        """An order's clear pass with exponents: as in fixed point, and every
        e_b back to 0 (no clamp, no ceiling): the state a run starts from,
        at the current p.  (The goals keep 2**p: their blocks were at e = 0.)"""
        super().apply(r, c, kind)
        self.E[...] = 0
        self.sat[...] = False
        self.ceiling[...] = self.e_max
        self._block_masks()
        if self.fast:
            self._gathers()

    def visit(self, b):
        """Up to I Jacobi iterations of block ``b`` against its ring
        converted to the block's exponent; returns (counted i, stable)."""
        loc, clamped = self._local(b, self.pad.dtype)
        self.sat[b] |= clamped
        fixed = self.view[b][5]
        stable, count = False, self.iters
        for i in range(1, self.iters + 1):
            old = loc[1:-1, 1:-1]
            s = loc[:-2, 1:-1] + loc[2:, 1:-1] + loc[1:-1, :-2] + loc[1:-1, 2:]
            new = np.where(fixed, old, s >> 2)
            if (new == old).all():
                stable, count = True, i
                break
            loc[1:-1, 1:-1] = new
        self.block(b)[...] = loc[1:-1, 1:-1]
        return count, stable

    # --- the fast visit (fast=True): the same visit on the free nodes only --

    def _gathers(self):
        """Per block, the index arrays of :meth:`_visit_fast` into the flat
        padded field: its free nodes, the constants its free nodes read (its
        own constant nodes, the 0 ring outside the map), per side the ring
        cells its free nodes read, the whole ring (for the clamp flag) and
        the neighbour block, and per free node where its N, S, W, E
        neighbours sit in the visit's vector [free nodes, constants,
        converted ring]."""
        n, m, S = self.n, self.m, self.cols + 2
        const = self.const
        self.gather = {}
        for br, bc in self.blocks:
            r0, c0 = br * n, bc * m
            cells = [(r, c) for r in range(r0, r0 + n) for c in range(c0, c0 + m) if not const[r, c]]
            slot = {rc: k for k, rc in enumerate(cells)}
            const_slot, side_slot = {}, [{} for _ in _SIDES]
            refs = []                       # per free node, per direction: ("x"|"c"|side, key)
            for r, c in cells:
                row = []
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr, cc = r + dr, c + dc
                    inside = r0 <= rr < r0 + n and c0 <= cc < c0 + m
                    nb = (rr // n if 0 <= rr < self.rows else -1, cc // m if 0 <= cc < self.cols else -1)
                    if inside and not const[rr, cc]:
                        row.append(("x", slot[rr, cc]))
                    elif inside or min(nb) < 0:         # own constant, or outside the map: 0
                        row.append(("c", const_slot.setdefault((rr, cc), len(const_slot))))
                    else:
                        k = next(i for i, ((sr, sc), _) in enumerate(_SIDES)
                                 if (br + sr, bc + sc) == nb)
                        row.append((k, side_slot[k].setdefault((rr, cc), len(side_slot[k]))))
                refs.append(row)
            consts = sorted(const_slot, key=const_slot.get)
            sides = [sorted(d, key=d.get) for d in side_slot]
            f, base = len(cells), [len(cells) + len(consts)]
            for k in range(len(_SIDES) - 1):
                base.append(base[-1] + len(sides[k]))

            def flat(rcs):
                return np.array([(r + 1) * S + c + 1 for r, c in rcs], dtype=np.int64)

            def where(kind, key):
                return key if kind == "x" else f + key if kind == "c" else base[kind] + key
            rings = []
            for k, ring in enumerate(self.rings[br, bc]):
                if ring is None:
                    continue
                (dr, dc), _ = _SIDES[k]
                if dr:
                    rr = r0 - 1 if dr < 0 else r0 + n
                    full = [(rr, c) for c in range(c0, c0 + m)]
                else:
                    cc = c0 - 1 if dc < 0 else c0 + m
                    full = [(r, cc) for r in range(r0, r0 + n)]
                rings.append((flat(sides[k]), flat(full), ring[1]))
            quads = [tuple(where(*ref) for ref in row) for row in refs]
            self.gather[br, bc] = (flat(cells), flat(consts), rings, quads)

    def _visit_fast(self, b):
        """:meth:`visit` on the free nodes only, bit for bit (the constant
        nodes keep their values there anyway; tested against it): one
        vector holds the block's free nodes, then the constants they read,
        then the ring cells they read converted into the block's units
        (:func:`convert_mantissa`; the clamp flag from the whole ring, as
        the reference's), as Python integers; a Jacobi iteration sums each
        free node's four entries."""
        cells, consts, rings, quads = self.gather[b]
        flat, p, e = self.flat, self.p, int(self.E[b])
        parts = [flat[cells], flat[consts]]
        for seen, full, nb in rings:
            s = e - int(self.E[nb])
            vals = flat[seen]
            if s > 0:
                lim = ((1 << (p + 1)) - 1) >> s if s <= p + 1 else 0
                self.sat[b] |= bool(flat[full].max() > lim)
            parts.append(vals if s == 0 else convert_mantissa(vals, s, p)[0])
        vec = np.concatenate(parts).tolist()    # Python ints: faster than object arrays
        f = len(cells)
        stable, count = False, self.iters
        for i in range(1, self.iters + 1):
            new = [(vec[a] + vec[b] + vec[c] + vec[d]) >> 2 for a, b, c, d in quads]
            if new == vec[:f]:
                stable, count = True, i
                break
            vec[:f] = new
        if f:
            flat[cells] = vec[:f] if flat.dtype == object else np.array(vec[:f], dtype=flat.dtype)
        return count, stable

    def scan_cycles(self, b):
        """The RTL's clamp scan before a visit of block ``b`` (``rtl=True``):
        L = max over the neighbour blocks of clip(e_b - e_b', 0, p+1) border
        offsets read MSB first, plus the strobe cycle; 0 when L = 0
        (:class:`hdl.harmonic.border.Border`), always 0 without ``rtl``."""
        if not self.rtl:
            return 0
        e, L = int(self.E[b]), 0
        for ring in self.rings[b]:
            if ring is not None:
                L = max(L, min(max(e - int(self.E[ring[1]]), 0), self.p + 1))
        return L + 1 if L else 0

    def after_visit(self, b, i, stable, level):
        """The re-pick after an update visit (``repick="visit"``; "stable":
        only after a visit whose first iteration changed nothing): the
        cycles of its shift visit, 0 if e_b stayed."""
        if not (self.repick_rule == "visit" or (self.repick_rule == "stable" and stable and i == 1)):
            return 0
        d = self.repick(b)
        if not d:
            return 0
        self.res.repicks += 1
        level["repicks"] += 1
        if self.rtl:
            return visit_cycles(shift_iterations(min(d, self.p)), self.p, shift=True)
        return visit_cycles(1, self.p)

    def check(self, level):
        """The check pass: (local maxima, the RTL's clamp scans); records the
        blocks saturated in this level."""
        scans = sum(self.scan_cycles(b) for b in self.blocks) if self.rtl else 0
        maxima = self.maxima()
        level["saturated"] = int(self.sat.sum())
        return maxima, scans

    def rescale(self, level):
        """At a check pass that found maxima: re-pick every block; the cycles
        of the shift visits (one each), 0 if none moved (then p rises)."""
        moved = sum(1 for b in self.blocks if self.repick(b))
        if self.rtl:
            assert moved == 0, "repick='visit': a check pass cannot re-pick"
        self.res.repicks += moved
        level["repicks"] += moved
        return moved * visit_cycles(1, self.p)

    def raise_precision(self):
        """The schedule's next p.  A block that clamped a ring value in this
        level coarsens its exponent by up to the step (p + e_b kept: no
        resolution lost, the word gains top bits: its mantissas shift by
        step - δ, which moves its words: a shift visit, whose cycles are
        returned); every other block keeps e_b and its mantissas shift left
        by the step (appended LSB addresses, free, as in fixed point).
        Returns None after the last precision."""
        later = [q for q in self.sched if q > self.p]
        if not later:
            return None
        step = later[0] - self.p
        self._dtype_for(later[0])
        deltas = []
        for b in self.blocks:
            delta = min(int(self.E[b]), step) if self.sat[b] else 0
            self.block(b)[...] <<= step - delta
            if delta:
                self.E[b] -= delta
                deltas.append(delta)
            if self.sat[b] and self.use_ceiling:
                self.ceiling[b] = self.E[b]
        self.p = later[0]
        self.sat[...] = False
        # rtl: the right shift by δ is a left rotation by p+1-δ
        if self.rtl:
            return sum(visit_cycles(shift_iterations(self.p + 1 - delta), self.p, shift=True) for delta in deltas)
        return len(deltas) * visit_cycles(1, self.p)

    def snapshot(self):
        return self.E.copy(), np.array(self.hv, dtype=object)

    def result(self, cycles, maxima):
        self.res.saturated = int(self.sat.sum())
        out = super().result(cycles, maxima)
        out.mantissa = np.array(self.hv, dtype=object)
        out.exponents = self.E.copy()
        out.frac_bits = self.frac_bits()
        out.e_max = self.e_max
        out.at_e_max = int((self.E == self.e_max).sum())
        out.padded_h = self.common()
        out.h = out.padded_h[:self.H, :self.W].copy()
        return out

    # --- the exponent rule -------------------------------------------------

    def repick_amount(self, b):
        """The exponent rule: by how much e_b rises now (0: unchanged).

        d = the largest d >= 0 with every value the block holds or sees (its
        nodes and its ring, exact, in each owner's units) below
        2**(p+1-h) in the block's units after the shift, capped at
        e_max - e_b; 0 for a goal block (its goal is 2**p at e = 0), a block
        with no free node, or a block whose nodes and ring are all 0."""
        if self.goal_block[b] or not self.free_block[b]:
            return 0
        e = int(self.E[b])
        top = self.p + 1 - self.headroom
        own = int(self.block(b).max())
        d = top - own.bit_length() if own else None
        for ring in self._ring(b):
            if ring is None:
                continue
            big = int(ring[0].max())
            if big:
                dr = top - big.bit_length() - e + ring[1]
                d = dr if d is None else min(d, dr)
        if d is None:
            return 0
        return max(0, min(d, int(self.ceiling[b]) - e))

    def repick(self, b):
        """Apply the rule: shift the block's mantissas left by d (exact,
        they fit by construction); returns d."""
        d = self.repick_amount(b)
        if d:
            self.block(b)[...] <<= d
            self.E[b] += d
        return d

    # --- reading the field ---------------------------------------------------

    def frac_bits(self):
        return self.p + int(self.E.max())

    def common(self):
        """The padded field on one scale, 2**-frac_bits (object ints, exact):
        mantissa << (frac_bits - p - e_b)."""
        F = self.frac_bits()
        n, m = self.n, self.m
        out = np.array(self.hv, dtype=object)
        for br, bc in self.blocks:
            out[br * n:br * n + n, bc * m:bc * m + m] <<= F - self.p - int(self.E[br, bc])
        return out

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
        total = 0
        for b in self.blocks:
            loc, _ = self._local(b, object)
            nb = (loc[:-2, 1:-1], loc[1:-1, 2:], loc[1:-1, :-2], loc[2:, 1:-1])
            total += int(local_max(loc[1:-1, 1:-1], self.view[b][5], nb).sum())
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


def plan_exponents(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), headroom=REPICK_HEADROOM,
                   e_max=E_MAX, repick="visit", ceiling=False, trace=None, rtl=False, events=(),
                   progress=None, paper_schedule=False, fast=False):
    """The block-synchronous planner (:func:`~models.harmonic.plan`) with one exponent per block.

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
    (dynamic orders, as in :func:`~models.harmonic.plan`: at the end of pass
    s-1, a sweep or a check pass; a clear pass each): the clear pass also sets
    every e_b back to 0 and forgets the clamps, so the run restarts from the
    state a run starts in, at the current p; finitely many orders, so every
    run still ends.  Tested by :mod:`test_model_exponents` (x never falls,
    exponents in bounds, the end a fixed point of F).

    ``e_max``: an int, or ``"map"``: :func:`e_max_for` the map
    (:func:`exponent_bound`: 2 * its longest BFS distance to a goal, what
    the exact field can need; at least :data:`E_MAX`); the result's ``e_max`` is the bound used and ``at_e_max``
    counts the blocks that end at it (then the bound may have held the
    field back: a larger one is worth a try).

    ``fast=True``: the block visit on the free nodes only
    (:meth:`ExponentGrid._visit_fast`), the same field, exponents and
    cycles as the reference visit (tested), several times faster on mazes
    and at large p; no ``trace`` difference either.

    Cycles: the timing model of :func:`~models.harmonic.plan` at word
    precision p (a visit of K iterations is K*L + VISIT_OVERHEAD, L =
    iteration_cycles(p); a check
    pass is B visits of K = 1).  A re-pick that changes e_b costs one shift
    visit of K = 1 (one iteration reads the block's words and writes them d
    positions earlier: the write counter's offset; the leading-one positions
    come free from the LSB-first streams of the update iterations, the last 1
    written, and from the MSB-first streams of a check iteration); a
    precision rise that coarsens a saturated block costs it the same shift
    visit; a precision rise without coarsening moves nothing, as in fixed
    point.

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
    border conversion (:meth:`ExponentGrid.maxima_converted`: conservative, a
    converged field has no exact local maximum either); (2) every update and
    check visit of a block finer than a neighbour first scans the clamp bits
    (:meth:`ExponentGrid.scan_cycles`: L+1 cycles, L = the largest positive
    exponent difference, at most p+1); (2b) a shift visit rotates the words
    in place by at most 3 positions per iteration, so a re-pick by d costs
    :func:`shift_iterations` (min(d, p)) iterations and a coarsening by δ at a
    precision rise (a left rotation by p+1-δ: the low step bits are 0)
    shift_iterations(p+1-δ); (3) the check pass's re-pick is
    skipped (with ``repick="visit"`` it never moves: the sweep before it
    re-picked every block and changed nothing; asserted here).
    """
    if isinstance(e_max, str):
        if e_max != "map":
            raise ValueError(f"e_max={e_max!r}: an integer >= 0 or 'map'")
        e_max = e_max_for(obstacle, goals)
    grid = ExponentGrid(obstacle, goals, block, iters, schedule, headroom, e_max, repick, ceiling, rtl, fast)
    grid.res.paper_schedule = bool(paper_schedule)
    visits, timing = control(grid, paper_schedule)
    return run(grid, events=events, visits=visits, timing=timing, trace=trace, progress=progress)
