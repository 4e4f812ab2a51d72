"""Rule selector of the DFLC (paper 003 Fig. 8 rule_sel_p)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .arith import Term, tree_sum
from .mf_gen import bits_for

__all__ = ["RuleSel"]


class RuleSel(wiring.Component):
    """One active rule out of the 2^n slot combinations (combinational).

    Combination ``k``: bit j selects slot 0 or 1 of input j, i.e. MF
    ``m_j = base_j + k_j`` with degree ``mu{k_j}_j``.  The rule index is
    ``sum m_j * stride_j`` (input 0 most significant, the FLL rule table's
    row-major order, ``DflcConfig.strides``); each degree generator gives its
    slots' shares ``m_j * stride_j`` (``r0``, ``r1``), so this is n
    multiplexers and an adder tree of n terms.

    Ports (arrays over the inputs j = 0 .. n-1)
    -----
    k : In(n)                         combination (the address generator's count)
    r0[j], r1[j] : In                 input j's slots' shares of the rule index
    mu0[j], mu1[j] : In(dy_ip)        input j's slot degrees
    rule : Out(bits(rules - 1))       rule index for the consequent map
    deg[j] : Out(dy_ip)               the selected degree of input j
    """

    def __init__(self, config):
        self.config = config
        n, dy = config.n, config.dy_ip
        self.rule_max = len(config.rules) - 1
        super().__init__({
            "k": In(n),
            "r0": In(bits_for(self.rule_max)).array(n), "r1": In(bits_for(self.rule_max)).array(n),
            "mu0": In(dy).array(n), "mu1": In(dy).array(n),
            "rule": Out(bits_for(self.rule_max)),
            "deg": Out(dy).array(n),
        })

    def elaborate(self, platform):
        m = Module()
        c = self.config
        terms = []
        for j, stride in enumerate(c.strides):
            share = Signal(len(self.rule), name=f"share{j}")
            m.d.comb += [share.eq(Mux(self.k[j], self.r1[j], self.r0[j])),
                         self.deg[j].eq(Mux(self.k[j], self.mu1[j], self.mu0[j]))]
            terms.append(Term(share, 0, (c.mf_ip_no[j] - 1) * stride))
        rule = tree_sum(m, terms, 0, "rule")
        m.d.comb += self.rule.eq(rule.value << rule.shift)
        return m
