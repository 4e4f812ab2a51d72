"""Consequent map of the DFLC (paper 003 Fig. 8 cons_map_p and the singleton ROM s_rom)."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..params import checked_init
from .mf_gen import bits_for
from .pipe import check_pipe, delay

__all__ = ["ConsMap"]


class ConsMap(wiring.Component):
    """Rule index -> singleton index (ROM) -> singleton code (ROM).

    The first ROM has one word per rule of the full rule table (the 81 rules
    of Table 1): the singleton index, or MF_op_no where the .fll has no rule
    for that antecedent combination.  The second ROM holds the MF_op_no
    singleton codes (MF_op_sz bits) and a 0 for "no rule".

    Timing: ``rule`` at cycle t; ``none`` and ``c`` at t + cpr + 1.
    ``cpr`` = Table 2 cpr2_no (cons_map_p), 0 .. 4: 0 reads the rule ROM
    combinationally, 1 (default) synchronously, more add plain delays of the
    singleton index.  The singleton ROM (s_rom) read is one fixed synchronous
    read: Table 2 gives s_rom no CPR generic, only the path registers after it
    (psr2_no, in the core).

    Ports
    -----
    rule : In(bits(rules - 1))
    c : Out(MF_op_sz)     singleton code
    none : Out(1)         no rule for this combination (its weight must be 0)
    """

    @checked_init
    def __init__(self, config, cpr=1):
        check_pipe({"cpr2_no": cpr})
        self.config, self.cpr = config, cpr
        self.idx_w = bits_for(config.mf_op_no)
        super().__init__({"rule": In(bits_for(len(config.rules) - 1)),
                          "c": Out(config.mf_op_sz), "none": Out(1)})

    def elaborate(self, platform):
        m = Module()
        c = self.config
        m.submodules.rule_rom = rule_rom = Memory(shape=self.idx_w, depth=len(c.rules), init=list(c.rules))
        m.submodules.s_rom = s_rom = Memory(shape=c.mf_op_sz, depth=c.mf_op_no + 1,
                                            init=list(c.singletons) + [0])
        rp = rule_rom.read_port(domain="comb" if self.cpr == 0 else "sync")
        sp = s_rom.read_port()
        idx, = delay(m, [rp.data], max(self.cpr - 1, 0), "cpr")
        m.d.comb += [rp.addr.eq(self.rule), sp.addr.eq(idx), self.c.eq(sp.data)]
        m.d.sync += self.none.eq(idx == c.mf_op_no)
        return m
