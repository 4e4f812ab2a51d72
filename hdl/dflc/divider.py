"""Divider of the DFLC (paper 003 Fig. 8 div_array, Table 2 div_type)."""

from amaranth.hdl import Array, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .arith import Term, mul_terms, tree_sum
from .pipe import check_pipe, delay

__all__ = ["Divider", "DIV_TYPES"]

DIV_TYPES = ("array", "lut")
ROM_PAGE_BITS = 7       # the reciprocal ROM's pages: 128 words, 7-input functions


class Divider(wiring.Component):
    """Weighted average y = round(2^f * Swc / Sw), or the zero-strength code.

    div_type "lut" (Table 2 div_type 1): ``R = round(2^r / Sw)`` from a ROM of
    2^n full + 1 words (r + 1 bits), ``y = (2^f Swc R + 2^(r-1)) >> r``.
    div_type "array" (div_type 0): a combinational restoring array of op_sz
    stages computing ``floor((2^(f+1) Swc + Sw) / (2 Sw))``.  Both are exactly
    ``models.dflc.Dflc.divide``.  ``Sw = 0`` gives ``zero_code`` and ``zero``.

    Timing: ``v_in`` with the sums at t; ``y``, ``zero`` and ``v_out`` at
    t + 2 + cpr for both types.  ``cpr`` = Table 2 cpr9_no (div_array),
    0 .. min(4, op_sz), default 1: lut: the sums registered with the ROM read,
    the product through ``cpr`` registers, round and select into the output
    register; array: the sums registered, the array cut into max(cpr, 1)
    groups of rows each followed by a register (none for 0), select into the
    output register.  The input register is fixed (the integrators' sums
    change with the next sample's first rule, and the LUT's synchronous ROM
    read needs the address one cycle ahead); so is the output register (it
    holds y for the FIFO write).

    Ports
    -----
    sw, swc, v_in : In
    y : Out(op_sz), zero : Out(1), v_out : Out(1)
    """

    @checked_init
    def __init__(self, config, sw_w, swc_w, cpr=1):
        if config.div_type not in DIV_TYPES:
            raise ValueError(f"div_type = {config.div_type!r}: expected one of {DIV_TYPES}")
        check_pipe({"cpr9_no": cpr}, op_sz=config.op_sz)
        self.config, self.sw_w, self.swc_w, self.cpr = config, sw_w, swc_w, cpr
        super().__init__({"sw": In(sw_w), "swc": In(swc_w), "v_in": In(1),
                          "y": Out(config.op_sz), "zero": Out(1), "v_out": Out(1)})

    def elaborate(self, platform):
        m = Module()
        c = self.config
        f = c.frac
        # valid chain: v_in, v1 (+ cpr), then v_out
        vs = [self.v_in]
        for k in range(1 + self.cpr):
            v = Signal(name=f"v{k + 1}")
            m.d.sync += v.eq(vs[-1])
            vs.append(v)
        m.d.sync += self.v_out.eq(vs[-1])
        v_last = vs[-1]
        sw1, swc1 = Signal(self.sw_w, reset_less=True), Signal(self.swc_w, reset_less=True)
        with m.If(self.v_in):
            m.d.sync += [sw1.eq(self.sw), swc1.eq(self.swc)]
        if c.div_type == "lut":
            r = c.recip_bits
            z = Signal()
            m.d.comb += z.eq(sw1 == 0)
            # The reciprocal table R(Sw) in LUTs (a distributed ROM, as the
            # paper's 12 ROM64X1 + 54 ROM256X1), read from the input register:
            # pages of 256 words (one 8-input function per bit), then the
            # page selected by the address's top bits.  cpr9's first register
            # holds the pages' words, its second the selected R.  (A block RAM
            # is no faster: the ECP5 EBR's unregistered read takes 5.6 ns, and
            # yosys cannot use its output register, so it alone caps the core
            # at 150 MHz.)
            init = [0] + [c.recip(s) for s in range(1, c.s_max + 1)]
            page = 1 << min(ROM_PAGE_BITS, len(sw1))
            pages = []
            for i in range(-(-len(init) // page)):
                rom = Memory(shape=r + 1, depth=page, init=init[i * page:(i + 1) * page],
                             attrs={"rom_style": "logic"})
                m.submodules[f"recip_rom{i}"] = rom
                rp = rom.read_port(domain="comb")
                m.d.comb += rp.addr.eq(sw1)
                pages.append(rp.data)
            top = Signal(max(len(sw1) - len(rp.addr), 1))
            m.d.comb += top.eq(sw1 >> len(rp.addr))
            ops = min(self.cpr, 2)
            *pages, top, swc, z = delay(m, [*pages, top, swc1, z], min(ops, 1), "page", reset_less=True)
            big_r = Signal(r + 1)
            m.d.comb += big_r.eq(Array(pages)[top] if len(pages) > 1 else pages[0])
            big_r, swc, z = delay(m, [big_r, swc, z], ops - min(ops, 1), "op", reset_less=True)
            # y = (2^f Swc R + 2^(r-1)) >> r: the rows of the product and the
            # rounding constant in one adder tree cut into cpr9 - ops + 1
            # groups with a register between them; the last group ends in the
            # output register.
            swc_max = c.s_max * ((1 << c.mf_op_sz) - 1)
            rows = mul_terms(Term(swc, 0, swc_max, f), Term(big_r, 0, 1 << r))
            groups = self.cpr - ops + 1
            total = tree_sum(m, rows + [Term(Const(1), 1, 1, r - 1)], groups, "prod", last=False)
            z, = delay(m, [z], groups - 1, "z", reset_less=True)
            q = Signal(c.op_sz)
            m.d.comb += q.eq(total.value >> (r - total.shift))
        else:
            num = Signal(self.swc_w + f + 2)
            den = Signal(self.sw_w + 1)
            m.d.comb += [num.eq((swc1 << (f + 1)) + sw1), den.eq(sw1 << 1)]
            z = Signal()
            m.d.comb += z.eq(sw1 == 0)
            rem, q = num, Signal(c.op_sz, name="q_in")
            m.d.comb += q.eq(0)
            # Restoring array, MSB first, cut into max(cpr9, 1) groups of rows,
            # each followed by a register (cpr9 of them).
            rows = list(reversed(range(c.op_sz)))
            ng = max(self.cpr, 1)
            groups = [rows[len(rows) * g // ng: len(rows) * (g + 1) // ng] for g in range(ng)]
            for g, group in enumerate(groups):
                bits = []
                for i in group:
                    trial = Signal(max(len(num), len(den) + i) + 1, name=f"trial{i}")
                    nrem = Signal(len(num), name=f"rem{i}")
                    m.d.comb += trial.eq(rem - (den << i))
                    ok = ~trial[-1]
                    m.d.comb += nrem.eq(Mux(ok, trial, rem))
                    bits.append((ok, i))
                    rem = nrem
                nq = Signal(c.op_sz, name=f"q{g}")
                m.d.comb += nq.eq(q | sum(b << i for b, i in bits))
                if self.cpr == 0:
                    q = nq
                    break
                rq, rr, rd, rz = (Signal(c.op_sz, name=f"q_r{g}", reset_less=True),
                                  Signal(len(num), name=f"rem_r{g}", reset_less=True),
                                  Signal(len(den), name=f"den_r{g}", reset_less=True),
                                  Signal(name=f"z_r{g}", reset_less=True))
                m.d.sync += [rq.eq(nq), rr.eq(rem), rd.eq(den), rz.eq(z)]
                q, rem, den, z = rq, rr, rd, rz
        with m.If(v_last):
            m.d.sync += [self.y.eq(Mux(z, c.zero_code, q)), self.zero.eq(z)]
        return m
