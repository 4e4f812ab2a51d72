"""A DRAM controller's native port carried across clock domains: the engine's clock to the controller's."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import In, Out

from .dram_store import NativePortSignature

__all__ = ["NativeCdc"]


class NativeCdc(wiring.Component):
    """Three asynchronous FIFOs (``cmd``, ``wdata`` out, ``rdata`` back) between
    the user of a native port (:class:`~hdl.edt_bfs.dram_store.DramStore`, in
    ``user_domain``) and the controller (in ``ctrl_domain``, its own clock:
    the engine's clock is set by the tile array's timing, the controller's by
    the DRAM's).

    Parameters
    ----------
    addr_width, data_width : int
        The port's (:func:`~hdl.edt_bfs.dram_store.NativePortSignature`).
    user_domain, ctrl_domain : str
        The two clock domains.  The user's should have no reset (the
        DramStore's port-side registers have none): a command in a FIFO
        still reaches the controller after the engine's reset, as its
        answer or its data beat must (the DramStore drops the answers of
        reads made before the reset by count).  A reset of
        ``ctrl_domain`` (the controller's) empties the ``rdata`` FIFO.
    depth : int
        Each FIFO's depth (a power of two): enough for the answers in
        flight while the crossing's synchronizers catch up.

    Ports
    -----
    user : In(NativePortSignature)
        The user's port (cmd and wdata in, rdata out).
    ctrl : Out(NativePortSignature)
        The controller's.

    Each direction is an :class:`amaranth.lib.fifo.AsyncFIFO` (Gray-coded
    pointers, two-flop synchronizers): valid is the FIFO's non-empty flag,
    ready its non-full flag, so neither depends on the other.
    """

    def __init__(self, addr_width, data_width, user_domain="sync", ctrl_domain="dram", depth=16):
        if depth < 4 or depth & (depth - 1):
            raise ValueError(f"FIFO depth {depth}: must be a power of two, at least 4")
        self.user_domain, self.ctrl_domain, self.depth = user_domain, ctrl_domain, depth
        sig = NativePortSignature(addr_width, data_width)
        super().__init__({"user": In(sig), "ctrl": Out(sig)})

    def elaborate(self, platform):
        m = Module()
        for name, src, dst, w, r in (("cmd", self.user.cmd, self.ctrl.cmd, self.user_domain, self.ctrl_domain),
                                     ("wdata", self.user.wdata, self.ctrl.wdata, self.user_domain, self.ctrl_domain),
                                     ("rdata", self.ctrl.rdata, self.user.rdata, self.ctrl_domain, self.user_domain)):
            fifo = AsyncFIFO(width=src.payload.shape().size, depth=self.depth, w_domain=w, r_domain=r)
            m.submodules[name] = fifo
            m.d.comb += [fifo.w_data.eq(src.payload), fifo.w_en.eq(src.valid), src.ready.eq(fifo.w_rdy),
                         dst.payload.eq(fifo.r_data), dst.valid.eq(fifo.r_rdy), fifo.r_en.eq(dst.ready)]
        return m
