"""Rule selector of the DFLC (paper 003 Fig. 8 rule_sel_p)."""

from amaranth.hdl import Module, Mux, Signal
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

    Ports
    -----
    k : In(n)                         combination (the address generator's count)
    base_j, mu0_j, mu1_j : In(...)    per input j, from the MF degree generators
    rule : Out(bits(rules - 1))       rule index for the consequent map
    deg_j : Out(dy_ip)                the selected degree of input j
    """

    def __init__(self, config):
        self.config = config
        n = config.n
        members = {"k": In(n), "rule": Out(bits_for(len(config.rules) - 1))}
        for j, cnt in enumerate(config.mf_ip_no):
            members[f"base_{j}"] = In(bits_for(cnt - 2))
            members[f"mu0_{j}"] = In(config.dy_ip)
            members[f"mu1_{j}"] = In(config.dy_ip)
            members[f"deg_{j}"] = Out(config.dy_ip)
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        c = self.config
        terms = []
        for j, stride in enumerate(c.strides):
            bit = self.k[j]
            mj = getattr(self, f"base_{j}") + bit
            terms.append(mj * stride)
            m.d.comb += getattr(self, f"deg_{j}").eq(
                Mux(bit, getattr(self, f"mu1_{j}"), getattr(self, f"mu0_{j}")))
        m.d.comb += self.rule.eq(sum(terms))
        return m
