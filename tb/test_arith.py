"""hdl/arith.py: products and quotients by constants, every input value, against Python's."""

import pytest
from amaranth.hdl import Module, Signal
from amaranth.sim import Simulator

from navcores.hdl.arith import TABLE_BITS, divmod_const, lowest_one, prefix_or, times


def _check(width, build, want):
    m = Module()
    x = Signal(width)
    outs = [Signal(24) for _ in want(0)]
    m.d.comb += [o.eq(v) for o, v in zip(outs, build(x))]
    sim = Simulator(m)
    seen = []

    async def bench(ctx):
        for v in range(1 << width):
            ctx.set(x, v)
            got = tuple(ctx.get(o) for o in outs)
            assert got == want(v), (width, v, got, want(v))
            seen.append(v)

    sim.add_testbench(bench)
    sim.run()
    assert len(seen) == 1 << width


# (width, divisor): a table (<= TABLE_BITS bits), slices (powers of two), the reciprocal (wider)
@pytest.mark.parametrize("width,d", [(4, 3), (5, 6), (TABLE_BITS, 3), (TABLE_BITS + 1, 6), (5, 4), (3, 1), (2, 3),
                                     (10, 6), (11, 7), (9, 3), (10, 5), (8, 12), (10, 31)])
def test_divmod_const(width, d):
    _check(width, lambda x: divmod_const(x, d), lambda v: divmod(v, d))


@pytest.mark.parametrize("c", [0, 1, 3, 6, 11, 12, 1366])
def test_times(c):
    _check(6, lambda x: (times(x, c),), lambda v: (v * c,))


def test_reciprocal_has_no_divider():
    """Wider unsigned values take the reciprocal's adders: no ``//`` / ``%`` in the netlist."""
    from amaranth.back import rtlil
    m = Module()
    x, q, r = Signal(10), Signal(10), Signal(3)
    m.d.comb += [q.eq(divmod_const(x, 6)[0]), r.eq(divmod_const(x, 6)[1])]
    text = rtlil.convert(m, ports=[x, q, r])
    assert "$add" in text
    assert "$div" not in text and "$mod" not in text


def test_wider_table():
    """``table_bits`` 8: an 8-bit value by 3 from a lookup table (no adder, no divider), every value exact."""
    from amaranth.back import rtlil
    _check(8, lambda x: divmod_const(x, 3, table_bits=8), lambda v: divmod(v, 3))
    m = Module()
    x, q, r = Signal(8), Signal(8), Signal(2)
    m.d.comb += [q.eq(divmod_const(x, 3, table_bits=8)[0]), r.eq(divmod_const(x, 3, table_bits=8)[1])]
    text = rtlil.convert(m, ports=[x, q, r])
    assert "$add" not in text and "$div" not in text and "$mod" not in text


def test_signed_uses_the_operators():
    """A signed value (e.g. ``width - 1``) floors as Python does, negative values included."""
    _check(4, lambda x: divmod_const(x.as_signed(), 3), lambda v: tuple(t % (1 << 24) for t in divmod(v - 16 * (v >> 3), 3)))


def test_refusals():
    with pytest.raises(ValueError, match="divisor 0"):
        divmod_const(Signal(4), 0)
    with pytest.raises(ValueError, match="constant -1"):
        times(Signal(4), -1)


@pytest.mark.parametrize("width", [1, 2, 3, 5, 8, 9])
def test_lowest_one_and_prefix_or(width):
    def want(v):
        low = v & -v
        pre = 0
        for i in range(width):
            pre |= (1 << i) if v & ((2 << i) - 1) else 0
        return low, pre
    _check(width, lambda x: (lowest_one(x), prefix_or(x)), want)
