# amaranth: UnusedElaboratable=no
"""The Decision module (bit-serial, section 5.3) against models.harmonic, bit-exact.

``Decision(p_max=12)`` alone (the ``harmonic_decision`` top), one build per
simulator:

* every (h, h_N, h_E, h_S, h_W) in {0..3}^5 at p = 2 (every tie pattern of
  the four terms: equal rows, equal columns, both, flat);
* random fields (p = 2 .. p_max, values drawn from a few levels so that
  equal values and equal slopes are frequent, goals at 2^p, zeros): every
  node against :func:`models.harmonic.decision` (outside the map reads 0);
* random block-exponent fields: every node against
  :func:`models.harmonic.decision_exponents`, fed the neighbours as the
  Planner's DIRECTION gives them, converted into the centre's units
  (:func:`models.harmonic.convert_mantissa`: left and right shifts, clamps
  at 2^(p+1) - 1).

Each decision: triangle, g_row, g_col equal the model's; ``done`` comes
exactly 2p+5 cycles after ``start`` (the timing table), is one cycle long,
and the outputs hold through random idle gaps.  The test counts the tie
kinds, clamps and shifts it drove and asserts each occurred.
"""

import itertools
import os
import random

import cocotb
import numpy as np
import pytest
from cocotb.triggers import FallingEdge, ReadOnly

from navcores.models.harmonic import convert_mantissa, decision, decision_exponents
from tb.harmonic.harmonic_fields import tie_kinds
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run

P_MAX = 12
FIELDS = int(os.environ.get("DECISION_FIELDS", "12"))


def latency(p):
    """Cycles from ``start`` to ``done`` (Decision's timing table)."""
    return 2 * p + 5


def _signed(v, width):
    v = int(v)
    return v - (1 << width) if v >> (width - 1) else v


class DecisionBench:
    def __init__(self, dut, rng):
        from navcores.hdl.harmonic.decision import neighbourhood_layout
        self.dut, self.rng = dut, rng
        self.layout = neighbourhood_layout(P_MAX)
        self.width = P_MAX + 2
        dut.start.value = 0
        dut.p.value = 2
        dut.h.value = 0

    async def decide(self, p, v):
        """v = {"c", "N", "E", "S", "W": value}: the Decision's answer
        (triangle, (g_row, g_col)), its latency checked."""
        d = self.dut
        for _ in range(self.rng.choice((0, 0, 1, 3))):     # idle cycles, outputs held
            await FallingEdge(d.clk)
        d.p.value = p
        d.h.value = self.layout.const(v).as_value().value
        d.start.value = 1
        await FallingEdge(d.clk)
        d.start.value = 0
        cycles = 1
        while not int(d.done.value):
            await FallingEdge(d.clk)
            cycles += 1
            assert cycles <= latency(p), f"p={p} {v}: no done after {cycles} cycles"
        assert cycles == latency(p), f"p={p} {v}: done after {cycles} cycles, expected {latency(p)}"
        got = (int(d.triangle.value), (_signed(d.g_row.value, self.width), _signed(d.g_col.value, self.width)))
        await FallingEdge(d.clk)
        await ReadOnly()
        assert not int(d.done.value), "done longer than one cycle"
        held = (int(d.triangle.value), (_signed(d.g_row.value, self.width), _signed(d.g_col.value, self.width)))
        assert held == got, f"outputs changed after done: {got} -> {held}"
        await FallingEdge(d.clk)
        return got


def _field(rng, shape, p):
    """Values from a few levels (ties), some goals (2^p) and zeros."""
    levels = [0, 1 << p] + [rng.randrange(0, (1 << p) + 1) for _ in range(rng.choice((1, 2, 4)))]
    h = np.array([[rng.choice(levels) if rng.random() < 0.7 else rng.randrange(0, (1 << p) + 1)
                   for _ in range(shape[1])] for _ in range(shape[0])], dtype=object)
    return h


def _neighbours(h, r, c, value):
    rows, cols = h.shape
    out = {"c": value(r, c)}
    for d, (dr, dc) in (("N", (-1, 0)), ("E", (0, 1)), ("S", (1, 0)), ("W", (0, -1))):
        rr, cc = r + dr, c + dc
        out[d] = value(rr, cc) if 0 <= rr < rows and 0 <= cc < cols else 0
    return out


@cocotb.test()
async def decision_against_model(dut):
    rng = random.Random(cocotb.RANDOM_SEED)
    await start(dut)
    bench = DecisionBench(dut, rng)
    seen = dict.fromkeys(("exhaustive", "fixed", "exponents", "row_tie", "col_tie", "both_ties", "flat",
                          "left", "right", "clamped", "edge", "triangle_0", "triangle_1", "triangle_2",
                          "triangle_3"), 0)

    def count(v, t):
        for k, hit in tie_kinds(v).items():
            seen[k] += hit
        seen[f"triangle_{t}"] += 1

    # Every neighbourhood of values 0..3 at p = 2 (values below 2^(p+1)).
    for vals in itertools.product(range(4), repeat=5):
        v = dict(zip("cNESW", vals))
        got = await bench.decide(2, v)
        want = decision(np.array([[0, v["N"], 0], [v["W"], v["c"], v["E"]], [0, v["S"], 0]], dtype=object), 1, 1)
        assert got == want, f"p=2 {v}: RTL {got} model {want}"
        count(v, got[0])
        seen["exhaustive"] += 1

    # Fixed-point fields: every node, the map's edges read 0.
    for k in range(FIELDS):
        p = rng.randrange(2, P_MAX + 1)
        h = _field(rng, (rng.randrange(2, 6), rng.randrange(2, 6)), p)
        for r, c in np.ndindex(h.shape):
            v = _neighbours(h, r, c, lambda rr, cc: int(h[rr, cc]))
            got = await bench.decide(p, v)
            want = decision(h, r, c)
            assert got == want, f"field {k} p={p} ({r}, {c}) {v}: RTL {got} model {want}\n{h}"
            count(v, got[0])
            seen["fixed"] += 1
            seen["edge"] += r in (0, h.shape[0] - 1) or c in (0, h.shape[1] - 1)

    # Block-exponent fields: 2x2 blocks of 2x3 nodes, mantissas below
    # 2^(p+1), exponents 0..4; the neighbours converted into the centre's units.
    n, m = 2, 3
    for k in range(FIELDS):
        p = rng.randrange(2, P_MAX + 1)
        E = np.array([[rng.randrange(0, 5) for _ in range(2)] for _ in range(2)], dtype=np.int64)
        mant = np.array([[rng.choice((0, 1, (1 << (p + 1)) - 1, rng.randrange(0, 1 << (p + 1))))
                          for _ in range(2 * m)] for _ in range(2 * n)], dtype=object)
        for r, c in np.ndindex(mant.shape):
            e = int(E[r // n, c // m])

            def conv(rr, cc):
                s = e - int(E[rr // n, cc // m])
                out, clamped = convert_mantissa(int(mant[rr, cc]), s, p)
                seen["left"] += s > 0
                seen["right"] += s < 0
                seen["clamped"] += clamped
                return out
            v = _neighbours(mant, r, c, conv)
            got = await bench.decide(p, v)
            t, g, _ = decision_exponents(mant, E, (n, m), p, r, c)
            assert got == (t, g), f"exponent field {k} p={p} ({r}, {c}) {v}: RTL {got} model {(t, g)}"
            count(v, got[0])
            seen["exponents"] += 1
    dut._log.info(f"compared: {seen}")
    assert all(seen.values()), f"not exercised: {[k for k, n in seen.items() if not n]}"


@pytest.mark.parametrize("sim", SIMULATORS)
def test_decision(sim):
    run("harmonic_decision", {"p_max": P_MAX}, sim, "test_decision")


def test_decision_refuses_p_max():
    from navcores.hdl.harmonic.decision import Decision
    with pytest.raises(ValueError, match="p_max=1 is not supported"):
        Decision(1)
