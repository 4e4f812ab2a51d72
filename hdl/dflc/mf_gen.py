"""MF degree generator of one input (paper 003 Fig. 8 trap_gen_p)."""

from functools import reduce
from operator import or_

from amaranth.hdl import Cat, Const, Module, Mux, Shape, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .arith import Term, const_terms, tree_sum
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
    operands), a constant table per segment, and one constant product
    ``x * M`` per distinct slope M (shift-adds over its signed digits: Table 1
    has M = +-255 = +-(2^8 - 1), one subtraction each), no multiplier.  A ROM
    over all codes would need 2^ip_sz words of 2*dy_ip + bits(MF_ip_no) bits
    per input (4096 x 20 bits for Table 1), far beyond the paper's ROM budget.

    The segment table also holds each slot's share of the rule address,
    ``(base + slot) * stride`` (``stride``: the input's step in the rule
    table, ``DflcConfig.strides``), so the rule selector only chooses and adds
    them.

    Timing: ``psr + cpr`` register stages (default 1 + 1); the degree
    register is loaded only when its valid input is high, so the result stays
    put while the rule selector walks its 2^n combinations.

    ==============  ==========================================================
    cycle           what happens
    ==============  ==========================================================
    t               ``x`` with ``v_in`` high
    t+psr           psr >= 1: ``psr - 1`` plain delays of ``x`` / ``v_in``,
                    then the segment's constants registered (comparators to a
                    one-hot segment, OR-ed table bits); the products x * M
                    registered beside them
    t+psr+cpr-1     cpr - 1 more registers: the constants delayed, the
                    products' adder trees pipelined
    t+psr+cpr       ``r0``, ``r1``, ``mu0``, ``mu1`` in the degree register
                    (x * M + B, loaded by the valid), ``v_out`` high for 1 cycle
    ==============  ==========================================================

    ``psr`` = Table 2 psr1_no (route ip_set -> psr1 -> trap_gen_p), 0 .. 4;
    0: the comparators and the table feed the multiply-add combinationally.
    ``cpr`` = Table 2 cpr3_no (trap_gen_p), 1 .. 4: the degree register is
    mandatory (it holds the sample's degrees for its 2^n combinations while
    the input stream moves on); the others are pipeline registers before it.

    Ports
    -----
    x : In(ip_sz)          input code
    v_in : In(1)           ``x`` is a new sample
    r0, r1 : Out(bits)     the slots' shares of the rule address: base * stride,
                           (base + 1) * stride (base: MF index of slot 0)
    mu0, mu1 : Out(dy_ip)  degrees of truth of the slots
    v_out : Out(1)         new degrees this cycle
    """

    @checked_init
    def __init__(self, spec, ip_sz, dy_ip, psr=1, cpr=1, stride=1):
        check_pipe({"psr1_no": psr, "cpr3_no": cpr})
        self.spec, self.ip_sz, self.dy_ip, self.psr, self.cpr = spec, ip_sz, dy_ip, psr, cpr
        if len(spec.seg_start) < 1 or spec.seg_start[0] != 0:
            raise ValueError(f"input {spec.name}: segment table must start at code 0")
        if not isinstance(stride, int) or stride < 1:
            raise ValueError(f"input {spec.name}: stride = {stride!r}: must be a positive integer")
        self.stride = stride
        self.r_w = bits_for((len(spec.mfs) - 1) * stride)
        super().__init__({
            "x": In(ip_sz), "v_in": In(1),
            "r0": Out(self.r_w), "r1": Out(self.r_w), "mu0": Out(dy_ip), "mu1": Out(dy_ip),
            "v_out": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        spec, top = self.spec, (1 << self.ip_sz) - 1
        nseg = len(spec.seg_start)
        slots = (0, 1)
        # The distinct nonzero slopes M (signed); each gets its own constant
        # product x * M (shift-add over its signed digits, no multiplier).
        slopes = sorted({p[k] for p in spec.seg_m for k in slots} - {0})
        b_lo = min(p[k] for p in spec.seg_b for k in slots)
        b_hi = max(p[k] for p in spec.seg_b for k in slots)

        # Stage 1 (psr1): which segment, as a one-hot vector from the
        # thermometer code of the boundaries passed, and the segment's
        # constants as OR-ed one-hot bits (no adder, no index).
        if self.psr:
            x0, = delay(m, [self.x], self.psr - 1, "psr", reset_less=True)
            v0, = delay(m, [self.v_in], self.psr - 1, "psr")
        else:
            x0, v0 = self.x, self.v_in
        therm = [Const(1)] + [x0 >= s for s in spec.seg_start[1:]] + [Const(0)]
        hot = [therm[q] & ~therm[q + 1] for q in range(nseg)]

        def table(values, shape):
            """The segment's entry of ``values`` (one constant per segment)."""
            shape = Shape.cast(shape)
            bits = [v & ((1 << shape.width) - 1) for v in values]
            out = []
            for i in range(shape.width):
                on = [hot[q] for q in range(nseg) if bits[q] >> i & 1]
                out.append(reduce(or_, on) if on else Const(0))
            v = Cat(*out)
            return v.as_signed() if shape.signed else v

        b_shape = Shape.cast(range(min(b_lo, 0), max(b_hi, 0) + 1))
        fields = {f"r{k}": table([(b + k) * self.stride for b in spec.seg_base], self.r_w) for k in slots}
        for k in slots:
            fields[f"b{k}"] = table([p[k] for p in spec.seg_b], b_shape)
            for i, mv in enumerate(slopes):
                used = [p[k] == mv for p in spec.seg_m]
                if any(used) and not all(used):     # a slope only some segments use
                    fields[f"sel{k}_{i}"] = table([int(u) for u in used], 1)
        names = list(fields)
        seg = [Signal(Value.cast(v).shape(), name=f"{k}_1", reset_less=True) for k, v in fields.items()]
        v1 = Signal()
        dom = m.d.sync if self.psr else m.d.comb
        dom += [v1.eq(v0), *(r.eq(fields[k]) for r, k in zip(seg, names))]
        # cpr3 - 1 registers in trap_gen_p before the degree register: the
        # segment's constants are delayed, the products pipelined.
        seg = dict(zip(names, delay(m, seg, self.cpr - 1, "seg", reset_less=True)))
        v2, = delay(m, [v1], self.cpr - 1, "v")

        # The products x * M, through psr1 + cpr3 - 1 register layers from the input.
        x_t = Term(self.x, 0, top)
        prod = [tree_sum(m, const_terms(x_t, mv), self.psr + self.cpr - 1, f"xm{i}")
                for i, mv in enumerate(slopes)]

        # The degree register: mu = (x * M + B) >> shift (exact by construction,
        # see above), loaded by the valid and held for the 2^n combinations.
        r2 = [Signal(self.r_w, name=f"r{k}_2", reset_less=True) for k in slots]
        mu2 = [Signal(self.dy_ip, name=f"mu{k}_2", reset_less=True) for k in slots]
        m.d.sync += self.v_out.eq(v2)
        with m.If(v2):
            m.d.sync += [r2[k].eq(seg[f"r{k}"]) for k in slots]
            for k in slots:
                terms = [Term(seg[f"b{k}"], b_lo, b_hi)]
                for i, mv in enumerate(slopes):
                    used = [p[k] == mv for p in spec.seg_m]
                    if not any(used):
                        continue
                    t = prod[i]
                    if not all(used):               # zero where the segment has another slope
                        sel = seg[f"sel{k}_{i}"]
                        t = Term(Mux(sel, t.value, 0), min(t.lo, 0), max(t.hi, 0), t.shift, t.sign)
                    terms.append(t)
                p = tree_sum(m, terms, 0, f"mu{k}")
                val = Signal(Shape.cast(range(p.min, p.max + 1)), name=f"p{k}")
                m.d.comb += val.eq(p.value << p.shift if p.sign > 0 else -(p.value << p.shift))
                m.d.sync += mu2[k].eq(val[spec.shift:spec.shift + self.dy_ip])
        m.d.comb += [self.r0.eq(r2[0]), self.r1.eq(r2[1]), self.mu0.eq(mu2[0]), self.mu1.eq(mu2[1])]
        return m
