"""Address generator of the DFLC (paper 003 Fig. 8 addr_gen_p)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import checked_init

__all__ = ["AddrGen"]


class AddrGen(wiring.Component):
    """Counter over the 2^n active-rule combinations, and the input pacing.

    One active rule per clock (section 5): ``start`` (the sample's degrees
    are ready) gives k = 0 in that same cycle, then k = 1 .. 2^n - 1 in the
    following cycles; ``first`` / ``last`` mark k = 0 / k = 2^n - 1.  The
    input side accepts at most one sample every 2^n cycles: ``ready`` is low
    for the 2^n - 1 cycles after an ``accept``.

    Ports
    -----
    start : In(1), accept : In(1)
    k : Out(n), active : Out(1), first : Out(1), last : Out(1), ready : Out(1)
    """

    @checked_init
    def __init__(self, n):
        if not 1 <= n <= 4:
            raise ValueError(f"ip_no = {n}: must be 1 to 4")
        self.n = n
        super().__init__({"start": In(1), "accept": In(1), "k": Out(n), "active": Out(1),
                          "first": Out(1), "last": Out(1), "ready": Out(1)})

    def elaborate(self, platform):
        m = Module()
        last_k = (1 << self.n) - 1
        k_reg = Signal(self.n)
        busy = Signal()
        m.d.comb += [
            self.k.eq(Mux(self.start, 0, k_reg)),
            self.active.eq(self.start | busy),
            self.first.eq(self.start),
            self.last.eq(self.active & (self.k == last_k)),
        ]
        with m.If(self.active):
            m.d.sync += [k_reg.eq(self.k + 1), busy.eq(~self.last)]
        gap = Signal(self.n)
        m.d.comb += self.ready.eq(gap == 0)
        with m.If(self.accept):
            m.d.sync += gap.eq(last_k)
        with m.Elif(gap != 0):
            m.d.sync += gap.eq(gap - 1)
        return m
