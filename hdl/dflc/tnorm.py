"""Antecedent operator of the DFLC (paper 003 Fig. 8 minmax_p, Table 2 sel_op)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import checked_init

__all__ = ["Tnorm", "SEL_OPS"]

SEL_OPS = ("min", "prod", "max", "probor")


class Tnorm(wiring.Component):
    """The rule's firing strength from its n degrees (combinational).

    sel_op (Table 2): 0 min, 1 prod, 2 max, 3 probor, folded left over the
    inputs.  prod rounds each pairwise product to dy_ip bits:
    ``t = a*b + 2^(dy-1)``, ``p = (t + (t >> dy)) >> dy`` = round(a*b/full)
    (``models.dflc.prod_round``); probor is ``a + b - p``.

    Ports
    -----
    deg : In(dy_ip).array(n)   the degrees, deg[j] of input j = 0 .. n-1
    w : Out(dy_ip)             firing strength
    """

    @checked_init
    def __init__(self, n, dy_ip, sel_op):
        if sel_op not in SEL_OPS:
            raise ValueError(f"sel_op = {sel_op!r}: expected one of {SEL_OPS}")
        if not 1 <= n <= 4:
            raise ValueError(f"ip_no = {n}: must be 1 to 4")
        self.n, self.dy, self.sel_op = n, dy_ip, sel_op
        super().__init__({"deg": In(dy_ip).array(n), "w": Out(dy_ip)})

    def _prod(self, m, a, b, j):
        dy = self.dy
        t = Signal(2 * dy + 1, name=f"t{j}")
        p = Signal(dy, name=f"p{j}")
        m.d.comb += t.eq(a * b + (1 << (dy - 1)))
        m.d.comb += p.eq((t + (t >> dy)) >> dy)
        return p

    def elaborate(self, platform):
        m = Module()
        acc = self.deg[0]
        for j in range(1, self.n):
            d = self.deg[j]
            nxt = Signal(self.dy, name=f"w{j}")
            if self.sel_op == "min":
                m.d.comb += nxt.eq(Mux(d < acc, d, acc))
            elif self.sel_op == "max":
                m.d.comb += nxt.eq(Mux(d > acc, d, acc))
            elif self.sel_op == "prod":
                m.d.comb += nxt.eq(self._prod(m, acc, d, j))
            else:
                m.d.comb += nxt.eq(acc + d - self._prod(m, acc, d, j))
            acc = nxt
        m.d.comb += self.w.eq(acc)
        return m
