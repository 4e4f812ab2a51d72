"""Integrators of the DFLC (paper 003 Fig. 8 int_uns / int_sig)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .pipe import check_pipe, delay

__all__ = ["Integrator"]


class Integrator(wiring.Component):
    """Accumulate ``sum w`` and ``sum w*c`` over the 2^n active rules of a sample.

    Aggregation SUM (Table 3).  ``first`` restarts both sums; with ``last`` the
    sums are final one cycle later, when ``done`` is high.  Exact: the widths
    hold 2^n * full and 2^n * full * (2^MF_op_sz - 1).

    ``cpr_uns`` / ``cpr_sig`` = Table 2 cpr7_no (int_uns, the Sigma w
    integrator) / cpr8_no (int_sig, Sigma w c), 0 .. 4 plain registers after
    each sum.  The divider takes both sums in the same cycle, so the shorter
    chain gets the difference as path synchronization registers: ``done``
    comes max(cpr_uns, cpr_sig) cycles after the sums are final.

    Ports
    -----
    w : In(dy_ip), wc : In(dy_ip + MF_op_sz), valid, first, last : In(1)
    sw : Out(bits(2^n full)), swc : Out(...), done : Out(1)
    """

    @checked_init
    def __init__(self, w_w, wc_w, sw_w, swc_w, cpr_uns=0, cpr_sig=0):
        check_pipe({"cpr7_no": cpr_uns, "cpr8_no": cpr_sig})
        self.sw_w, self.swc_w, self.cpr_uns, self.cpr_sig = sw_w, swc_w, cpr_uns, cpr_sig
        super().__init__({"w": In(w_w), "wc": In(wc_w), "valid": In(1), "first": In(1), "last": In(1),
                          "sw": Out(sw_w), "swc": Out(swc_w), "done": Out(1)})

    def elaborate(self, platform):
        m = Module()
        if self.cpr_uns == self.cpr_sig == 0:      # the accumulators are the outputs
            sw, swc, done = self.sw, self.swc, self.done
        else:
            sw, swc, done = Signal(self.sw_w, name="acc_w"), Signal(self.swc_w, name="acc_wc"), Signal()
        m.d.sync += done.eq(self.valid & self.last)
        with m.If(self.valid):
            m.d.sync += [sw.eq(Mux(self.first, 0, sw) + self.w),
                         swc.eq(Mux(self.first, 0, swc) + self.wc)]
        if sw is not self.sw:
            d = max(self.cpr_uns, self.cpr_sig)
            sw_o, = delay(m, [sw], d, "cpr")            # cpr7 + (d - cpr7) sync
            swc_o, = delay(m, [swc], d, "cpr")
            done_o, = delay(m, [done], d, "cpr")
            m.d.comb += [self.sw.eq(sw_o), self.swc.eq(swc_o), self.done.eq(done_o)]
        return m
