"""Consequent map of the DFLC (paper 003 Fig. 8 cons_map_p and the singleton ROM s_rom)."""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .mf_gen import bits_for

__all__ = ["ConsMap"]


class ConsMap(wiring.Component):
    """Rule index -> singleton index (ROM) -> singleton code (ROM).

    The first ROM has one word per rule of the full rule table (the 81 rules
    of Table 1): the singleton index, or MF_op_no where the .fll has no rule
    for that antecedent combination.  The second ROM holds the MF_op_no
    singleton codes (MF_op_sz bits) and a 0 for "no rule".

    Timing: ``rule`` at cycle t; ``none`` and ``c`` at t+2 (two synchronous
    ROM reads).

    Ports
    -----
    rule : In(bits(rules - 1))
    c : Out(MF_op_sz)     singleton code
    none : Out(1)         no rule for this combination (its weight must be 0)
    """

    def __init__(self, config):
        self.config = config
        self.idx_w = bits_for(config.mf_op_no)
        super().__init__({"rule": In(bits_for(len(config.rules) - 1)),
                          "c": Out(config.mf_op_sz), "none": Out(1)})

    def elaborate(self, platform):
        m = Module()
        c = self.config
        m.submodules.rule_rom = rule_rom = Memory(shape=self.idx_w, depth=len(c.rules), init=list(c.rules))
        m.submodules.s_rom = s_rom = Memory(shape=c.mf_op_sz, depth=c.mf_op_no + 1,
                                            init=list(c.singletons) + [0])
        rp = rule_rom.read_port()
        sp = s_rom.read_port()
        m.d.comb += [rp.addr.eq(self.rule), sp.addr.eq(rp.data), self.c.eq(sp.data)]
        m.d.sync += self.none.eq(rp.data == c.mf_op_no)
        return m
