"""Fabric arithmetic of the DFLC: products as partial-product terms summed in a
pipelined adder tree (no ``*`` operator, so no DSP block).

Why not ``a * b``: yosys maps every multiplication to a DSP block, and on the
ECP5 it cannot absorb the MULT18X18D's input, pipeline or output registers
(``synth_ecp5`` has no DSP register packing; only the Nexus flow has), so a
product costs a combinational 3.9 ns block plus ~1.2 ns of routing on each
side (measured with nextpnr-ecp5 0.11: register -> MULT18X18D -> register
reaches 141 MHz on the LFE5U-85F, speed 6).  Written as partial products in
ripple adders (the CCU2C carry chains), a product can have a register after
every adder level, which is what the CPR generics of paper 003 Table 2 ask
for: the component's pipeline registers.

A summand is a :class:`Term`: ``sign * (value << shift)`` with integer
bounds on ``value``, so every adder and register is exactly as wide as its
range needs.  When two terms with different shifts are added, the low bits of
the less-shifted one pass beside the adder (a row of an array multiplier adds
only where it overlaps the next), which keeps the carry chains short.
"""

from dataclasses import dataclass

from amaranth.hdl import Cat, Const, Shape, Signal, Value

__all__ = ["Term", "term", "const_terms", "mul_terms", "csd", "tree_levels", "tree_sum", "register"]


@dataclass(frozen=True)
class Term:
    """The summand ``sign * (value << shift)``, ``lo <= value <= hi``."""

    value: Value
    lo: int
    hi: int
    shift: int = 0
    sign: int = 1

    @property
    def min(self):
        return (self.lo if self.sign > 0 else -self.hi) << self.shift

    @property
    def max(self):
        return (self.hi if self.sign > 0 else -self.lo) << self.shift


def term(value, lo=None, hi=None, shift=0, sign=1):
    """A Term of ``value`` (bounds default to its shape's range)."""
    value = Value.cast(value)
    shape = value.shape()
    if lo is None:
        lo = -(1 << (shape.width - 1)) if shape.signed else 0
    if hi is None:
        hi = (1 << (shape.width - (1 if shape.signed else 0))) - 1
    return Term(value, lo, hi, shift, sign)


def csd(k):
    """Canonical signed digits of the integer k: [(sign, position)], fewest nonzero digits."""
    digits, i = [], 0
    while k:
        if k & 1:
            d = 2 - (k & 3)          # +1 if k = 1 (mod 4), -1 if k = 3 (mod 4)
            digits.append((d, i))
            k -= d
        k >>= 1
        i += 1
    return digits


def const_terms(t, k):
    """The terms of ``k * t`` for a constant k (shift-add over its signed digits)."""
    return [Term(t.value, t.lo, t.hi, t.shift + i, t.sign * d) for d, i in csd(k)]


def mul_terms(a, b):
    """The partial products of ``a * b`` (unsigned Terms with sign +1): one row
    per bit of the narrower operand, ``(wide AND bit j) << j``."""
    for t in (a, b):
        if t.lo < 0 or t.sign < 0:
            raise ValueError("mul_terms: unsigned operands only")
    if len(b.value) > len(a.value):
        a, b = b, a
    return [Term(a.value & b.value[j].replicate(len(a.value)), 0, a.hi, a.shift + b.shift + j)
            for j in range(len(b.value)) if b.hi >> j]


def _shape(lo, hi):
    return Shape.cast(range(lo, hi + 1)) if lo < hi else Shape.cast(range(lo, lo + 2))


def _signed(v):
    """``v`` as a signed value of the same numeric value."""
    return v if v.shape().signed else Cat(v, Const(0, 1)).as_signed()


def _add(m, a, b, name):
    """a + b as one Term (one adder, the low bits of the less-shifted one passing beside it)."""
    if a.shift > b.shift:
        a, b = b, a
    d = b.shift - a.shift
    same = a.sign == b.sign
    # value = a.value + (+-b.value << d), in a's sign frame
    lo = a.lo + ((b.lo if same else -b.hi) << d)
    hi = a.hi + ((b.hi if same else -b.lo) << d)
    high = Signal(_shape(lo >> d, hi >> d), name=name)
    low = a.value
    if d and len(low) <= d:         # too narrow to slice at d: extend it first
        low = Signal(Shape(d + 1, low.shape().signed), name=f"{name}_x")
        m.d.comb += low.eq(a.value)
    top = low >> d if d else low
    if same:
        m.d.comb += high.eq(top + b.value)
    else:
        m.d.comb += high.eq(_signed(top) - _signed(b.value))
    if d:
        value = Cat(low[:d], high)
        value = value.as_signed() if high.shape().signed else value
    else:
        value = high
    return Term(value, lo, hi, a.shift, a.sign)


def register(m, t, name):
    """``t`` through one register (as wide as its range)."""
    r = Signal(_shape(t.lo, t.hi), name=name, reset_less=True)
    m.d.sync += r.eq(t.value)
    return Term(r, t.lo, t.hi, t.shift, t.sign)


def tree_levels(n):
    """Adder levels of a balanced tree over n terms."""
    return max(n - 1, 0).bit_length()


def tree_sum(m, terms, regs, name, pre=0, last=True):
    """The sum of ``terms`` through a balanced tree of two-input adders with
    ``regs`` register layers: the levels are cut into ``regs`` groups (earlier
    groups, whose adders are narrower, take the extra level), each followed by
    a register; layers beyond the number of levels register the sum again.
    ``pre`` (<= regs) of the layers come before the first level instead
    (registering the terms themselves).  regs = 0: combinational.  Returns one
    Term, ``regs`` cycles after its inputs; with ``last=False`` the final
    register is left to the caller (the levels are still cut into ``regs``
    groups, the sum comes ``regs - 1`` cycles after the inputs)."""
    terms = sorted(terms, key=lambda t: t.shift)
    if not terms:
        raise ValueError(f"{name}: nothing to sum")
    for i in range(pre):
        terms = [register(m, t, f"{name}_in{i}_{j}") for j, t in enumerate(terms)]
    regs -= pre
    levels = tree_levels(len(terms))
    groups = [levels // regs + (g < levels % regs) for g in range(regs)] if regs else [levels]
    k = 0
    for g, size in enumerate(groups):
        for _ in range(size):
            nxt = []
            for i in range(0, len(terms) - 1, 2):
                nxt.append(_add(m, terms[i], terms[i + 1], f"{name}_s{k}_{i // 2}"))
            if len(terms) % 2:
                nxt.append(terms[-1])
            terms, k = nxt, k + 1
        if regs and (last or g < regs - 1):
            terms = [register(m, t, f"{name}_r{g}_{j}") for j, t in enumerate(terms)]
    assert len(terms) == 1
    return terms[0]
