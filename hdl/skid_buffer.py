"""A stream register stage that keeps full throughput: valid, payload and ready all from flip-flops."""

from amaranth.hdl import Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

__all__ = ["SkidBuffer"]


class SkidBuffer(wiring.Component):
    """One register stage on a stream, for a path between two blocks placed
    apart (the tile engine's DRAM stores and LiteDRAM's native ports): ``o``'s
    valid and payload are registers, and so is ``i``'s ready, so no logic
    path runs through it; a beat a cycle while ``o`` is ready, one cycle of
    latency.

    Parameters
    ----------
    shape : the payload's shape.

    Ports
    -----
    i : In(stream.Signature(shape))
    o : Out(stream.Signature(shape))

    How: an output register and a skid register.  ``i.ready`` is "the skid
    is empty"; a beat taken while the output register holds one that
    ``o`` does not take waits in the skid, and the output register takes
    the skid's beat before ``i``'s next.  Order is kept, no beat is lost or
    doubled; valid never depends on ready.  Reset: both empty.
    """

    def __init__(self, shape):
        super().__init__({"i": In(stream.Signature(shape)), "o": Out(stream.Signature(shape))})

    def elaborate(self, platform):
        m = Module()
        skid = Signal(self.i.payload.shape(), name="skid")
        full = Signal(name="skid_full")
        m.d.comb += self.i.ready.eq(~full)
        with m.If(self.o.ready | ~self.o.valid):            # the output register is free
            with m.If(full):
                m.d.sync += [self.o.payload.eq(skid), self.o.valid.eq(1), full.eq(0)]
            with m.Else():
                m.d.sync += [self.o.payload.eq(self.i.payload), self.o.valid.eq(self.i.valid)]
        with m.Elif(self.i.valid & ~full):                    # held: the beat taken waits in the skid
            m.d.sync += [skid.eq(self.i.payload), full.eq(1)]
        return m
