"""Arithmetic by constants, built for the FPGA's LUTs rather than its DSPs or carry chains.

yosys' ``synth_ecp5`` maps every ``$mul`` wider than a bit, constant operand
or not, onto a MULT18X18D, and a ``$div`` / ``$mod`` by a constant onto a
divider's carry chains: both sat on the planner's and the tile engine's
address paths (issue 17); so did ``x & -x`` (a subtraction) as a priority
choice.  Shared by every core's RTL.
"""

from amaranth.hdl import Const, Value

__all__ = ["times", "divmod_const", "prefix_or", "lowest_one"]

TABLE_BITS = 6      # up to 64 entries: each result bit is one LUT6 (a LUT4 tree on the ECP5 / iCE40)


def times(value, c):
    """``value * c`` for a constant ``c >= 0`` as shifts and adds (one adder
    per set bit past the first, summed as a balanced tree: ceil(log2(terms))
    carry chains deep): faster than a MULT18X18D for small constants and
    costs no DSP."""
    value = Value.cast(value)
    c = int(c)
    if c < 0:
        raise ValueError(f"times: constant {c} must be >= 0")
    terms = [value << i for i in range(c.bit_length()) if (c >> i) & 1]
    if not terms:
        return Const(0, 1)
    while len(terms) > 1:
        terms = [terms[i] + terms[i + 1] if i + 1 < len(terms) else terms[i] for i in range(0, len(terms), 2)]
    return terms[0]


def divmod_const(value, d, table_bits=TABLE_BITS):
    """``(value // d, value % d)`` for a constant ``d >= 1``: slices when ``d``
    is a power of two, a lookup table when ``value`` is unsigned with at most
    ``table_bits`` bits (LUTs, no carry chain; a bit more than
    :data:`TABLE_BITS` buys a short path with LUTs), a product by the
    reciprocal when it is wider and unsigned, else Amaranth's operators
    (floor division, as Python's: a signed value).

    The reciprocal (Granlund and Montgomery, PLDI 1994, Theorem 4.2): for
    ``x < 2^N`` and ``l = ceil(log2 d)``, ``m = ceil(2^(N+l) / d)`` is
    ``2^(N+l)/d + e/d`` with ``0 <= e < d <= 2^l``, so ``x m / 2^(N+l)`` exceeds
    ``x/d`` by ``x e / (d 2^(N+l)) < 1/d``, which never crosses the next
    integer: ``floor(x m / 2^(N+l)) = floor(x / d)`` for every such ``x``.  The
    product is :func:`times` (a few carry chains), where yosys' ``$div``
    by a constant is N carry chains in series (the 6x6 tile engine's 68
    levels at 13.6 MHz, issue 18).  The remainder needs only its low bits:
    ``x - q d`` modulo ``2^ceil(log2 d)``."""
    value = Value.cast(value)
    d = int(d)
    if d < 1:
        raise ValueError(f"divmod_const: divisor {d} must be >= 1")
    if d & (d - 1) == 0:
        s = d.bit_length() - 1
        return value >> s, value[:s] if s else Const(0, 1)
    w = len(value)
    if w <= table_bits and not value.shape().signed:
        # a constant word indexed by the value (continuous assignments, no
        # process: defined from time 0 in every simulator)
        n = 1 << w
        qw, rw = ((n - 1) // d).bit_length() or 1, (d - 1).bit_length() or 1
        q = Const(sum((i // d) << (i * qw) for i in range(n)), n * qw)
        r = Const(sum((i % d) << (i * rw) for i in range(n)), n * rw)
        return q.word_select(value, qw), r.word_select(value, rw)
    if not value.shape().signed:
        l = (d - 1).bit_length()
        s = w + l
        mul = -(-(1 << s) // d)
        qw, rw = (((1 << w) - 1) // d).bit_length() or 1, l
        q = (times(value, mul) >> s)[:qw]
        return q, (value[:rw] - times(q[:rw], d)[:rw])[:rw]
    return value // d, value % d


def prefix_or(value):
    """Bit i is ``value[0] | ... | value[i]``: ceil(log2(width)) levels of
    two-input ORs (a Kogge-Stone prefix; yosys packs them into LUT4s), no
    carry chain."""
    value = Value.cast(value)
    w, p, s = len(value), value, 1
    while s < w:
        p = (p | (p << s))[:w]
        s *= 2
    return p


def lowest_one(value):
    """The lowest set bit of ``value`` alone (0 when none): ``x & -x``
    without the subtraction's carry chain (the still blocks' next-block
    choice was the 6x3-block planner's critical path, issue 17)."""
    value = Value.cast(value)
    return value & ~(prefix_or(value) << 1)[:len(value)]
