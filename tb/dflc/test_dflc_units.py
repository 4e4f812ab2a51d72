"""The DFLC's pipelined arithmetic units in the Amaranth simulator, against
the model, at every depth their pipeline generics allow: the fabric adder
trees and products (hdl/dflc/arith.py), the divider (cpr9_no 0 .. 8, both
div_types), the MF degree generator (psr1_no / cpr3_no).  Each unit's outputs
must be the model's and come exactly as many cycles after its inputs as its
docstring says.  Randomized: SEED= replays (the seed is printed)."""

import random

import numpy as np
import pytest
from amaranth.hdl import Const, Module, Signal, signed
from amaranth.sim import Simulator

from navcores.hdl.dflc.arith import Term, const_terms, csd, mul_terms, tree_levels, tree_sum
from navcores.hdl.dflc.divider import Divider
from navcores.hdl.dflc.mf_gen import MfGen, bits_for
from navcores.hdl.dflc.pipe import PIPE_RANGE
from navcores.hdl.dflc.top import config_for
from navcores.models.dflc import Dflc
from navcores.sim.rtl.runner import seed_from_env

FIXTURES = "tb/dflc/fll"


@pytest.fixture
def rng():
    seed = int(seed_from_env())
    print(f"SEED={seed}")
    return random.Random(seed)


def _simulate(dut, drive, sample, n_in, latency):
    """Drive ``n_in`` input cycles (``drive(ctx, i)``), then idle; return what
    ``sample(ctx)`` reads at the cycle ``latency`` after each input."""
    got = []

    async def bench(ctx):
        for i in range(n_in + latency + 1):
            drive(ctx, i if i < n_in else None)
            if i >= latency:
                got.append(sample(ctx))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return got[:n_in]


def test_csd(rng):
    for k in [0, 1, 3, 255, -255, 340, 1020, *(rng.randrange(-1 << 20, 1 << 20) for _ in range(200))]:
        digits = csd(k)
        assert sum(d << i for d, i in digits) == k
        assert all(b[1] - a[1] >= 2 for a, b in zip(digits, digits[1:])), "no two adjacent digits"


@pytest.mark.parametrize("regs,pre,last", [(0, 0, True), (1, 0, True), (2, 0, False), (3, 1, True), (7, 0, True)])
def test_tree_sum(rng, regs, pre, last):
    """Signed and unsigned terms, shifted and negated, constants among them:
    the tree's sum, ``regs`` (``regs - 1`` with last=False) cycles later."""
    m = Module()
    ins = [Signal(signed(9), name="s0"), Signal(7, name="u0"), Signal(5, name="u1"), Signal(signed(4), name="s1")]
    terms = ([Term(ins[0], -256, 255, 3), Term(ins[1], 0, 127, 0, -1)] + const_terms(Term(ins[2], 0, 31), -340)
             + [Term(ins[3], -8, 7, 1), Term(Const(1), 1, 1, 5)])
    total = tree_sum(m, terms, regs, "t", pre=pre, last=last)
    tick = Signal()
    m.d.sync += tick.eq(~tick)          # a clock domain also when the tree has no register
    out = Signal(signed(20))
    m.d.comb += out.eq(total.value << total.shift if total.sign > 0 else -(total.value << total.shift))
    lat = regs - (0 if last or regs == 0 else 1)
    vals = [(rng.randrange(-256, 256), rng.randrange(128), rng.randrange(32), rng.randrange(-8, 8))
            for _ in range(60)] + [(-256, 127, 31, -8), (255, 0, 0, 7)]

    def drive(ctx, i):
        for s, v in zip(ins, vals[i] if i is not None else (0, 0, 0, 0)):
            ctx.set(s, v)

    got = _simulate(m, drive, lambda ctx: ctx.get(out), len(vals), lat)
    want = [(a << 3) - b - 340 * c + (d << 1) + (1 << 5) for a, b, c, d in vals]
    assert got == want
    assert tree_levels(len(terms)) == 3


@pytest.mark.parametrize("wa,wb", [(8, 12), (22, 24), (1, 5)])
def test_mul_terms(rng, wa, wb):
    m = Module()
    a, b = Signal(wa), Signal(wb)
    total = tree_sum(m, mul_terms(Term(a, 0, (1 << wa) - 1), Term(b, 0, (1 << wb) - 1, 2)), 2, "p")
    out = Signal(wa + wb + 2)
    m.d.comb += out.eq(total.value << total.shift)
    vals = [(rng.randrange(1 << wa), rng.randrange(1 << wb)) for _ in range(40)] + [((1 << wa) - 1, (1 << wb) - 1)]

    def drive(ctx, i):
        ctx.set(a, vals[i][0] if i is not None else 0)
        ctx.set(b, vals[i][1] if i is not None else 0)

    assert _simulate(m, drive, lambda ctx: ctx.get(out), len(vals), 2) == [x * y << 2 for x, y in vals]


@pytest.mark.parametrize("div", ["lut", "array"])
@pytest.mark.parametrize("fll", ["table1", f"{FIXTURES}/n4.fll"])
def test_divider_every_depth(rng, fll, div):
    """y and zero of Dflc.divide at cpr9_no = 0 .. 8, 2 + cpr9_no cycles after v_in,
    one division per cycle; the extremes Sw = 0, 1, s_max and Swc = 0, Sw * cmax included."""
    c = config_for(fll=fll, div=div)
    model = Dflc(c)
    cmax = (1 << c.mf_op_sz) - 1
    sw_w, swc_w = bits_for(c.s_max), bits_for(c.s_max * cmax)
    pairs = [(0, 0), (1, 0), (1, cmax), (c.s_max, c.s_max * cmax), (c.s_max, 0), (2, 1)]
    for _ in range(150):
        sw = rng.choice([rng.randrange(1, 8), rng.randrange(c.s_max + 1)])
        pairs.append((sw, rng.randrange(sw * cmax + 1)))
    sw = np.array([p[0] for p in pairs])
    y = np.where(sw == 0, c.zero_code, model.divide(np.array([p[1] for p in pairs]), sw))
    want = [(int(a), int(s == 0), 1) for a, s in zip(y, sw)]
    lo, hi = PIPE_RANGE["cpr9_no"]
    assert (lo, hi) == (0, 8)
    for cpr in range(lo, hi + 1):
        dut = Divider(c, sw_w, swc_w, cpr=cpr)

        def drive(ctx, i):
            ctx.set(dut.v_in, i is not None)
            ctx.set(dut.sw, pairs[i][0] if i is not None else 0)
            ctx.set(dut.swc, pairs[i][1] if i is not None else 0)

        got = _simulate(dut, drive, lambda ctx: (ctx.get(dut.y), ctx.get(dut.zero), ctx.get(dut.v_out)),
                        len(pairs), 2 + cpr)
        assert got == want, f"cpr9_no = {cpr}: first difference at {next(i for i, (g, w) in enumerate(zip(got, want)) if g != w)}"


@pytest.mark.parametrize("fll", ["table1", f"{FIXTURES}/trap_max.fll", f"{FIXTURES}/mf5_or.fll"])
@pytest.mark.parametrize("psr,cpr", [(0, 1), (1, 1), (3, 1), (1, 4), (0, 3)])
def test_mf_gen_depths(rng, fll, psr, cpr):
    """Every segment boundary and its neighbours, the extremes and random codes:
    the rule-address shares and degrees of InputSpec (the model's degree
    generator, checked against pyfuzzylite in test_dflc_model), psr + cpr
    cycles after the code, one code per cycle."""
    c = config_for(fll=fll)
    top = (1 << c.ip_sz) - 1
    for j, spec in enumerate(c.inputs):
        dut = MfGen(spec, c.ip_sz, c.dy_ip, psr=psr, cpr=cpr, stride=c.strides[j])
        xs = sorted({0, top, *(p for s in spec.seg_start for p in (s - 1, s, s + 1) if 0 <= p <= top)})
        xs += [rng.randrange(top + 1) for _ in range(50)]

        def drive(ctx, i):
            ctx.set(dut.v_in, i is not None)
            ctx.set(dut.x, xs[i] if i is not None else 0)

        got = _simulate(dut, drive, lambda ctx: (ctx.get(dut.v_out), ctx.get(dut.r0), ctx.get(dut.r1),
                                                 ctx.get(dut.mu0), ctx.get(dut.mu1)), len(xs), psr + cpr)
        want = []
        for x in xs:
            q = max(i for i, s in enumerate(spec.seg_start) if x >= s)
            base = spec.seg_base[q]
            want.append((1, base * c.strides[j], (base + 1) * c.strides[j],
                         *((x * spec.seg_m[q][k] + spec.seg_b[q][k]) >> spec.shift for k in (0, 1))))
        assert got == want
