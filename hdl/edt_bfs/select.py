"""The cells' ADD-SUB / INC and flat MIN selection (Fig. 2 in the squared-distance form).

Paper 004's cell takes the largest delta_i of its done neighbours through a
tree of seven CMP-MUX in three levels, each keeping its left (lower-indexed)
input unless the right one is valid and strictly greater, so the winner is
the smallest index among the largest.  The cells here hold ``d2`` (or a BFS
hop) where the paper holds delta = k^2 + k - d2 (:func:`models.edt_bfs.edt_step_d2`),
so the tree is a MIN with the same tie-break, and it is built flat: the 28
pairwise comparisons of the eight candidates at once, a one-hot winner, an
AND-OR multiplexer.  The logic between the neighbours' registers and the
cell's is then one comparator and a few LUT levels instead of seven
comparators and multiplexers in series.  :class:`~hdl.edt_bfs.cell.EdtCell`
uses it so; :class:`~hdl.edt_bfs.tile_cell.TileCell` in two levels
(:func:`min_select_halves`: 13 comparators instead of 28, one comparator
more on the path) with INC on the winner only (:func:`winner_offset`); both
share the ADD-SUB and INC (:func:`candidate`, :func:`inc`).
"""

from functools import reduce
from operator import or_

from amaranth.hdl import C, Cat, Mux, Signal, Value, signed

from navcores.models.edt_bfs import OFFSETS

__all__ = ["candidate", "inc", "min_select", "min_select_halves", "pick", "winner_offset"]


def candidate(m, i, d2, dx, dy, d2_shape, gate=None):
    """ADD-SUB: neighbour p_i's squared distance to its obstacle seen from the cell p (eq. 2-3 in the d2 form).

    With ``(sr, sc) = p - p_i``: ``d2_i = d2(p_i) + DX_i + DY_i`` with
    ``DX_i = 2 sr dx(p_i) + 1`` (0 when sr = 0), DY_i likewise (eq. 2), so
    ``d2_i = dx_i^2 + dy_i^2`` (:func:`inc`'s vector) = ``K(k-1) - delta_i``
    of eq. 3.  Computed in ``d2_shape`` (the caller states why it cannot wrap).
    ``gate``: where 0, DX_i and DY_i are 0 and ``d2_i = d2(p_i)`` (a cell
    whose comparators also serve another key, the tile cell's BFS hop).
    """
    sr, sc = -OFFSETS[i][0], -OFFSETS[i][1]
    # 2 sr dx + 1 without a multiplier: {dx, 1} or 1 - {dx, 0}
    big_x = (Cat(C(1, 1), dx).as_signed() if sr > 0 else 1 - Cat(C(0, 1), dx).as_signed()) if sr else 0
    big_y = (Cat(C(1, 1), dy).as_signed() if sc > 0 else 1 - Cat(C(0, 1), dy).as_signed()) if sc else 0
    d = Signal(d2_shape, name=f"d2_{i}")
    m.d.comb += d.eq(d2 + big_x + big_y if gate is None else d2 + Mux(gate, big_x + big_y, 0))
    return d


def inc(m, name, dx, dy, sr, sc, dx_bits, dy_bits):
    """INC: the vector ``(dx + sr, dy + sc)`` (eq. 1); ``sr``, ``sc``: -1, 0, 1 or a signal holding one."""
    x = Signal(signed(dx_bits), name=f"dx_{name}")
    y = Signal(signed(dy_bits), name=f"dy_{name}")

    def plus(v, step):
        return v if isinstance(step, int) and step == 0 else v + step
    m.d.comb += [x.eq(plus(dx, sr)), y.eq(plus(dy, sc))]
    return x, y


def min_select(m, valid, keys, first=0):
    """The one-hot winner of the MIN over the valid candidates, ties to the smallest index.

    ``valid[i]``, ``keys[i]`` (unsigned, or all of one signedness) for
    candidates i = 0 .. n-1 (neighbours 1 .. n).  Candidate i wins when it is
    valid and no valid candidate beats it: one of lower index with a key <=
    its own, or one of higher index with a smaller key (the CMP-MUX tree's
    result).  Returns the list of ``win`` signals (all 0 when none is valid).
    ``first``: the index of candidate 0 in the signals' names.
    """
    n = len(keys)
    better = {}             # better[a, b], a < b: candidate b's key is smaller than a's
    for a in range(n):
        for b in range(a + 1, n):
            better[a, b] = Signal(name=f"lt_{first + b + 1}_{first + a + 1}")
            m.d.comb += better[a, b].eq(keys[b] < keys[a])
    win = []
    for i in range(n):
        beaten = [valid[j] & ~better[j, i] for j in range(i)] + \
                 [valid[j] & better[i, j] for j in range(i + 1, n)]
        wi = Signal(name=f"win_{first + i + 1}")
        m.d.comb += wi.eq(valid[i] & ~Cat(*beaten).any())
        win.append(wi)
    return win


def min_select_halves(m, valid, keys, shape):
    """:func:`min_select` in two levels: each half of the candidates flat, then
    the halves' smallest keys compared.  Returns (``win``, the winner's key
    in ``shape``; 0 when none is valid).

    The same winner: the lower half's, unless the upper half has a valid
    candidate and its smallest key is smaller (strictly: ties go to the
    lower indices).  Two flat MINs of n/2 and one comparator instead of
    n(n-1)/2 comparators: 13 instead of 28 for eight, half a cell's carry
    chains, for one comparator and a 4:1 multiplexer more on the path.
    """
    h = len(keys) // 2
    halves = []
    for lo, hi, tag in ((0, h, "a"), (h, len(keys), "b")):
        win = min_select(m, valid[lo:hi], keys[lo:hi], first=lo)
        some = Signal(name=f"some_{tag}")
        m.d.comb += some.eq(Cat(*valid[lo:hi]).any())
        halves.append((win, pick(m, win, keys[lo:hi], shape, f"key_{tag}"), some))
    (win_a, key_a, some_a), (win_b, key_b, some_b) = halves
    upper = Signal(name="take_b")
    m.d.comb += upper.eq(some_b & (~some_a | (key_b < key_a)))
    key = Signal(shape, name="key_min")
    m.d.comb += key.eq(Mux(upper, key_b, key_a))
    return [w & ~upper for w in win_a] + [w & upper for w in win_b], key


def pick(m, win, values, shape, name):
    """The winner's value: an AND-OR multiplexer of ``values`` on the one-hot ``win`` (0 when none wins)."""
    out = Signal(shape, name=name)
    terms = [Mux(w, Value.cast(v).as_unsigned()[:len(out)], 0) for w, v in zip(win, values)]
    m.d.comb += out.eq(reduce(or_, terms))
    return out


def winner_offset(m, win, axis):
    """The cell's offset from the winning neighbour along ``axis`` (0: rows, 1: columns), -1, 0 or 1.

    ``win``: the one-hot winner over neighbours 1..8 (:func:`min_select`);
    the offset ``p - p_i`` is ``-OFFSETS[i][axis]`` (0 when none wins).
    """
    pos = reduce(or_, [w for w, i in zip(win, OFFSETS) if -OFFSETS[i][axis] == 1])
    neg = reduce(or_, [w for w, i in zip(win, OFFSETS) if -OFFSETS[i][axis] == -1])
    out = Signal(signed(2), name=f"{'rc'[axis]}_m")
    m.d.comb += out.eq(Cat(pos | neg, neg))     # 01: +1, 11: -1, 00: 0
    return out
