"""MF degree generator of one input (paper 003 Fig. 8 trap_gen_p)."""

from amaranth.hdl import Array, Const, Module, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .pipe import check_pipe, delay

__all__ = ["MfGen", "bits_for"]


def bits_for(v):
    """Unsigned width that holds 0 .. v."""
    return max(1, int(v).bit_length())


class MfGen(wiring.Component):
    """Degrees of truth of the two active MFs (slots) of one input.

    Arithmetic, not ROM-based: the input range is cut into segments at the MF
    breakpoints (``models.dflc.InputSpec``); in segment q the slots are MFs
    ``base = seg_base[q]`` and ``base + 1`` with degrees
    ``mu_slot = (x * M[q][slot] + B[q][slot]) >> shift``, which the loader has
    verified to equal round(full * MF(x)) at every code.  Cost per input: one
    ip_sz-bit comparator per segment boundary (9 triangles: 7, constant
    operands), a constant table of (base, M0, B0, M1, B1) per segment and two
    small multipliers (ip_sz x |M| bits).  A ROM over all codes would need
    2^ip_sz words of 2*dy_ip + bits(MF_ip_no) bits per input (4096 x 20 bits
    for Table 1), far beyond the paper's ROM budget.

    Timing: ``psr + cpr`` register stages (default 1 + 1), the segment and
    degree registers loaded only when their valid input is high, so the result
    stays put while the rule selector walks its 2^n combinations.

    ==========  ==============================================================
    cycle       what happens
    ==========  ==============================================================
    t           ``x`` with ``v_in`` high
    t+psr       psr >= 1: ``psr - 1`` plain delays of ``x`` / ``v_in``, then
                the code and its segment registered (comparators + table)
    t+psr+1     ``base``, ``mu0``, ``mu1`` registered (the degree register,
                loaded by the valid), then ``cpr - 1`` plain delays;
    t+psr+cpr   ``v_out`` high for 1 cycle
    ==========  ==============================================================

    ``psr`` = Table 2 psr1_no (route ip_set -> psr1 -> trap_gen_p), 0 .. 4;
    0: the comparators and the table feed the multiply-add combinationally.
    ``cpr`` = Table 2 cpr3_no (trap_gen_p), 1 .. 4: the degree register is
    mandatory (it holds the sample's degrees for its 2^n combinations while
    the input stream moves on); the others follow the multiply-add (plain
    registers that synthesis may retime into it).

    Ports
    -----
    x : In(ip_sz)          input code
    v_in : In(1)           ``x`` is a new sample
    base : Out(bits)       MF index of slot 0 (slot 1 is base + 1)
    mu0, mu1 : Out(dy_ip)  degrees of truth of the slots
    v_out : Out(1)         new degrees this cycle
    """

    @checked_init
    def __init__(self, spec, ip_sz, dy_ip, psr=1, cpr=1):
        check_pipe({"psr1_no": psr, "cpr3_no": cpr})
        self.spec, self.ip_sz, self.dy_ip, self.psr, self.cpr = spec, ip_sz, dy_ip, psr, cpr
        if len(spec.seg_start) < 1 or spec.seg_start[0] != 0:
            raise ValueError(f"input {spec.name}: segment table must start at code 0")
        self.base_w = bits_for(len(spec.mfs) - 2)
        super().__init__({
            "x": In(ip_sz), "v_in": In(1),
            "base": Out(self.base_w), "mu0": Out(dy_ip), "mu1": Out(dy_ip), "v_out": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        spec, top = self.spec, (1 << self.ip_sz) - 1
        nseg = len(spec.seg_start)
        ms = [v for pair in spec.seg_m for v in pair]
        bs = [v for pair in spec.seg_b for v in pair]
        m_w = max(abs(v) for v in ms).bit_length() + 1
        b_w = max(abs(v) for v in bs).bit_length() + 1
        p_w = max(abs(a) * top + abs(b) for a, b in zip(ms, bs)).bit_length() + 1

        # Stage 1: which segment (thermometer count of the boundaries passed).
        seg = Signal(range(max(nseg, 2)))      # >= 1 bit: no zero-width wire for one segment
        # Tables padded to a power of two (the last segment repeated) so that
        # every value of ``seg`` selects an entry (a complete case in Verilog).
        pad = (1 << len(seg)) - nseg
        seg_base = list(spec.seg_base) + [spec.seg_base[-1]] * pad
        seg_m = list(spec.seg_m) + [spec.seg_m[-1]] * pad
        seg_b = list(spec.seg_b) + [spec.seg_b[-1]] * pad
        t_base = Array(Const(v, self.base_w) for v in seg_base)
        t_m = [Array(Const(p[k], signed(m_w)) for p in seg_m) for k in (0, 1)]
        t_b = [Array(Const(p[k], signed(b_w)) for p in seg_b) for k in (0, 1)]
        x1 = Signal(self.ip_sz)
        base1 = Signal(self.base_w)
        m1 = [Signal(signed(m_w), name=f"m{k}_1") for k in (0, 1)]
        b1 = [Signal(signed(b_w), name=f"b{k}_1") for k in (0, 1)]
        v1 = Signal()
        if self.psr == 0:       # no psr1 register: segment lookup straight from the input
            x0, v0 = self.x, self.v_in
            dom = m.d.comb
        else:                   # psr1 - 1 plain delays, then the segment register
            x0, v0 = delay(m, [self.x, self.v_in], self.psr - 1, "psr")
            dom = m.d.sync
        m.d.comb += seg.eq(sum((x0 >= s).as_unsigned() for s in spec.seg_start[1:])
                           if nseg > 1 else 0)
        dom += v1.eq(v0)
        if self.psr == 0:
            m.d.comb += [x1.eq(x0), base1.eq(t_base[seg])]
            m.d.comb += [m1[k].eq(t_m[k][seg]) for k in (0, 1)]
            m.d.comb += [b1[k].eq(t_b[k][seg]) for k in (0, 1)]
        else:
            with m.If(v0):
                m.d.sync += [x1.eq(x0), base1.eq(t_base[seg])]
                m.d.sync += [m1[k].eq(t_m[k][seg]) for k in (0, 1)]
                m.d.sync += [b1[k].eq(t_b[k][seg]) for k in (0, 1)]

        # Stage 2: mu = (x * M + B) >> shift (exact by construction, see above).
        v2 = Signal()
        base2, mu2 = Signal(self.base_w), [Signal(self.dy_ip, name=f"mu{k}_2") for k in (0, 1)]
        m.d.sync += v2.eq(v1)
        with m.If(v1):
            m.d.sync += base2.eq(base1)
            for k in (0, 1):
                p = Signal(signed(p_w), name=f"p{k}")
                m.d.comb += p.eq(x1 * m1[k] + b1[k])
                m.d.sync += mu2[k].eq(p[spec.shift:spec.shift + self.dy_ip])
        # cpr3 - 1 plain delay registers (the held stage-2 value passes unchanged).
        outs = delay(m, [v2, base2, *mu2], self.cpr - 1, "d")
        m.d.comb += [self.v_out.eq(outs[0]), self.base.eq(outs[1]), self.mu0.eq(outs[2]),
                     self.mu1.eq(outs[3])]
        return m
