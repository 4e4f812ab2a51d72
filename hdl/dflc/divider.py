"""Divider of the DFLC (paper 003 Fig. 8 div_array, Table 2 div_type)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .pipe import check_pipe

__all__ = ["Divider", "DIV_TYPES"]

DIV_TYPES = ("array", "lut")


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
        v1, v_last = vs[1], vs[-1]
        sw1, swc1 = Signal(self.sw_w), Signal(self.swc_w)
        with m.If(self.v_in):
            m.d.sync += [sw1.eq(self.sw), swc1.eq(self.swc)]
        if c.div_type == "lut":
            r = c.recip_bits
            init = [0] + [c.recip(s) for s in range(1, c.s_max + 1)]
            m.submodules.recip_rom = rom = Memory(shape=r + 1, depth=c.s_max + 1, init=init)
            rp = rom.read_port()
            m.d.comb += rp.addr.eq(self.sw)              # R arrives with sw1, swc1
            prod = Signal(self.swc_w + f + r + 1)
            z = Signal()
            if self.cpr == 0:
                m.d.comb += [prod.eq((swc1 << f) * rp.data), z.eq(sw1 == 0)]
            else:
                with m.If(v1):
                    m.d.sync += [prod.eq((swc1 << f) * rp.data), z.eq(sw1 == 0)]
            for k in range(self.cpr - 1):                # cpr9: registers after the multiplier
                prod_d, z_d = Signal.like(prod, name=f"prod_d{k}"), Signal(name=f"z_d{k}")
                m.d.sync += [prod_d.eq(prod), z_d.eq(z)]
                prod, z = prod_d, z_d
            q = Signal(c.op_sz)
            m.d.comb += q.eq((prod + (1 << (r - 1))) >> r)
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
                rq, rr, rd, rz = (Signal(c.op_sz, name=f"q_r{g}"), Signal(len(num), name=f"rem_r{g}"),
                                  Signal(len(den), name=f"den_r{g}"), Signal(name=f"z_r{g}"))
                m.d.sync += [rq.eq(nq), rr.eq(rem), rd.eq(den), rz.eq(z)]
                q, rem, den, z = rq, rr, rd, rz
        with m.If(v_last):
            m.d.sync += [self.y.eq(Mux(z, c.zero_code, q)), self.zero.eq(z)]
        return m
