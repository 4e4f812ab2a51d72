"""Rule selector of the DFLC (paper 003 Fig. 8 rule_sel_p)."""

from amaranth.hdl import Module, Mux
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .mf_gen import bits_for

__all__ = ["RuleSel"]


class RuleSel(wiring.Component):
    """One active rule out of the 2^n slot combinations (combinational).

    Combination ``k``: bit j selects slot 0 or 1 of input j, i.e. MF
    ``m_j = base_j + k_j`` with degree ``mu{k_j}_j``.  The rule index is
    ``sum m_j * stride_j`` (input 0 most significant, the FLL rule table's
    row-major order, ``DflcConfig.strides``).

    Ports (arrays over the inputs j = 0 .. n-1)
    -----
    k : In(n)                         combination (the address generator's count)
    base[j], mu0[j], mu1[j] : In      input j's slots, from its MF degree generator
                                      (``base`` as wide as the input with the most MFs)
    rule : Out(bits(rules - 1))       rule index for the consequent map
    deg[j] : Out(dy_ip)               the selected degree of input j
    """

    def __init__(self, config):
        self.config = config
        n, dy = config.n, config.dy_ip
        super().__init__({
            "k": In(n),
            "base": In(bits_for(max(config.mf_ip_no) - 2)).array(n),
            "mu0": In(dy).array(n), "mu1": In(dy).array(n),
            "rule": Out(bits_for(len(config.rules) - 1)),
            "deg": Out(dy).array(n),
        })

    def elaborate(self, platform):
        m = Module()
        c = self.config
        terms = []
        for j, stride in enumerate(c.strides):
            bit = self.k[j]
            mj = self.base[j] + bit
            terms.append(mj * stride)
            m.d.comb += self.deg[j].eq(Mux(bit, self.mu1[j], self.mu0[j]))
        m.d.comb += self.rule.eq(sum(terms))
        return m
