"""Counters unit shared by the 18 nodes of a cluster (paper 000, section 5.2)."""

from amaranth.hdl import Module, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, check, checked_init
from .limits import MAX_DEPTH

__all__ = ["Counters"]


class Counters(wiring.Component):
    """RAM address counters and cycle strobes of one iteration (p+2 cycles).

    With a synchronous RAM the data of an address appears one cycle after it
    is presented, so each counter presents, in iteration cycle c, the address
    whose bit the nodes need at c+1 (see :class:`~hdl.harmonic.node.Node` for
    the cycle numbering and :mod:`models.harmonic.ram` for the word layout).

    * ``cntR`` (port A, LSB first): ``p+1-c``, a down counter p+1 .. 0, so the
      nodes read the flag at c = 0 and value bit k at c = k+1.
    * ``r_cnt`` (port B read, MSB first): ``(c-1) mod (p+2)``, the reverse
      counter, so check iterations stream value bit p at c = 3 down to bit 0
      at cycle 1 of the next iteration.
    * ``cntW`` (port B write): ``(p+4-c) mod (p+2)``, two bit positions behind
      the data read on port A: that is the division by four of eq. (2).

    Parameters
    ----------
    p_max : int
        Largest precision; sets the counter widths.

    Ports
    -----
    p : In(range(p_max+1))
        Precision of the run; must be held while ``advance`` is high.
    start : In(1)
        Load the lead-in state (c = p+1: the flag address is presented, so
        the next cycle is c = 0).
    advance : In(1)
        Step to the next cycle.
    cntR, r_cnt, cntW : Out(address width)
        The three RAM address offsets.
    ph0, ph1, ph2 : Out(1)
        High in cycles c = 0, 1, 2 (decoded from cntW, which is 2, 1, 0
        there whatever p is; held while ``advance`` is low).
    """

    PARAMS = (Param("p_max", int, lo=2, hi=MAX_DEPTH - 2,
                    doc="largest precision; sets the counter widths (p_max + 2 <= the RAM depth <= 2**20)",
                    message="p_max must be an integer in 2..{hi} (a word of p_max + 2 bits fills at most a "
                            "2**20-word RAM), not {value!r}"),)

    @checked_init
    def __init__(self, p_max):
        check(self.PARAMS, p_max=p_max)
        self.p_max = p_max
        addr = unsigned((p_max + 1).bit_length())
        super().__init__({
            "p": In(range(p_max + 1)),
            "start": In(1),
            "advance": In(1),
            "cntR": Out(addr),
            "r_cnt": Out(addr),
            "cntW": Out(addr),
            "ph0": Out(1),
            "ph1": Out(1),
            "ph2": Out(1),
        })

    def timing(self):
        """The cycle figures hdl.emit puts in the manifest."""
        return {"iteration_cycles": "p+2", "strobe_cycles": "ph0/ph1/ph2 at c = 0, 1, 2 of each iteration"}

    def elaborate(self, platform):
        m = Module()
        last = self.p + 1
        m.d.comb += [
            self.ph0.eq(self.cntW == 2),
            self.ph1.eq(self.cntW == 1),
            self.ph2.eq(self.cntW == 0),
        ]
        with m.If(self.start):
            m.d.sync += [
                self.cntR.eq(0),
                self.r_cnt.eq(self.p),
                self.cntW.eq(3),
            ]
        with m.Elif(self.advance):
            m.d.sync += [
                self.cntR.eq(self.cntR - 1),
                self.r_cnt.eq(self.r_cnt + 1),
                self.cntW.eq(self.cntW - 1),
            ]
            with m.If(self.cntR == 0):
                m.d.sync += self.cntR.eq(last)
            with m.If(self.r_cnt == last):
                m.d.sync += self.r_cnt.eq(0)
            with m.If(self.cntW == 0):
                m.d.sync += self.cntW.eq(last)
        return m
