"""Integrators of the DFLC (paper 003 Fig. 8 int_uns / int_sig)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["Integrator"]


class Integrator(wiring.Component):
    """Accumulate ``sum w`` and ``sum w*c`` over the 2^n active rules of a sample.

    Aggregation SUM (Table 3).  ``first`` restarts both sums; with ``last`` the
    sums are final one cycle later, when ``done`` is high.  Exact: the widths
    hold 2^n * full and 2^n * full * (2^MF_op_sz - 1).

    Ports
    -----
    w : In(dy_ip), wc : In(dy_ip + MF_op_sz), valid, first, last : In(1)
    sw : Out(bits(2^n full)), swc : Out(...), done : Out(1)
    """

    def __init__(self, w_w, wc_w, sw_w, swc_w):
        self.sw_w, self.swc_w = sw_w, swc_w
        super().__init__({"w": In(w_w), "wc": In(wc_w), "valid": In(1), "first": In(1), "last": In(1),
                          "sw": Out(sw_w), "swc": Out(swc_w), "done": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.d.sync += self.done.eq(self.valid & self.last)
        with m.If(self.valid):
            m.d.sync += [self.sw.eq(Mux(self.first, 0, self.sw) + self.w),
                         self.swc.eq(Mux(self.first, 0, self.swc) + self.wc)]
        return m
