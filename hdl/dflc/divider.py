"""Divider of the DFLC (paper 003 Fig. 8 div_array, Table 2 div_type)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .mf_gen import bits_for

__all__ = ["Divider", "DIV_TYPES"]

DIV_TYPES = ("array", "lut")


class Divider(wiring.Component):
    """Weighted average y = round(2^f * Swc / Sw), or the zero-strength code.

    div_type "lut" (Table 2 div_type 1): ``R = round(2^r / Sw)`` from a ROM of
    2^n full + 1 words (r + 1 bits), ``y = (2^f Swc R + 2^(r-1)) >> r``.
    div_type "array" (div_type 0): a combinational restoring array of op_sz
    stages computing ``floor((2^(f+1) Swc + Sw) / (2 Sw))``.  Both are exactly
    ``models.dflc.Dflc.divide``.  ``Sw = 0`` gives ``zero_code`` and ``zero``.

    Timing: ``v_in`` with the sums at t; ``y``, ``zero`` and ``v_out`` at t+3
    for both types (lut: ROM read, multiply, round; array: register, array,
    select).

    Ports
    -----
    sw, swc, v_in : In
    y : Out(op_sz), zero : Out(1), v_out : Out(1)
    """

    def __init__(self, config, sw_w, swc_w):
        if config.div_type not in DIV_TYPES:
            raise ValueError(f"div_type = {config.div_type!r}: expected one of {DIV_TYPES}")
        self.config, self.sw_w, self.swc_w = config, sw_w, swc_w
        super().__init__({"sw": In(sw_w), "swc": In(swc_w), "v_in": In(1),
                          "y": Out(config.op_sz), "zero": Out(1), "v_out": Out(1)})

    def elaborate(self, platform):
        m = Module()
        c = self.config
        f = c.frac
        v1, v2 = Signal(), Signal()
        m.d.sync += [v1.eq(self.v_in), v2.eq(v1), self.v_out.eq(v2)]
        sw1, swc1 = Signal(self.sw_w), Signal(self.swc_w)
        with m.If(self.v_in):
            m.d.sync += [sw1.eq(self.sw), swc1.eq(self.swc)]
        z2 = Signal()
        q2 = Signal(c.op_sz)
        if c.div_type == "lut":
            r = c.recip_bits
            init = [0] + [c.recip(s) for s in range(1, c.s_max + 1)]
            m.submodules.recip_rom = rom = Memory(shape=r + 1, depth=c.s_max + 1, init=init)
            rp = rom.read_port()
            m.d.comb += rp.addr.eq(self.sw)              # R arrives with sw1, swc1
            prod = Signal(self.swc_w + f + r + 1)
            with m.If(v1):
                m.d.sync += [prod.eq((swc1 << f) * rp.data), z2.eq(sw1 == 0)]
            m.d.comb += q2.eq((prod + (1 << (r - 1))) >> r)
        else:
            num = Signal(self.swc_w + f + 2)
            den = Signal(self.sw_w + 1)
            m.d.comb += [num.eq((swc1 << (f + 1)) + sw1), den.eq(sw1 << 1)]
            rem = num
            bits = []
            for i in reversed(range(c.op_sz)):       # restoring array, MSB first
                trial = Signal(max(len(num), len(den) + i) + 1, name=f"trial{i}")
                nrem = Signal(len(num), name=f"rem{i}")
                m.d.comb += trial.eq(rem - (den << i))
                ok = ~trial[-1]
                m.d.comb += nrem.eq(Mux(ok, trial, rem))
                bits.append(ok)
                rem = nrem
            q1 = Signal(c.op_sz)
            m.d.comb += q1.eq(sum(b << i for b, i in zip(bits, reversed(range(c.op_sz)))))
            with m.If(v1):
                m.d.sync += [q2.eq(q1), z2.eq(sw1 == 0)]
        with m.If(v2):
            m.d.sync += [self.y.eq(Mux(z2, c.zero_code, q2)), self.zero.eq(z2)]
        return m
