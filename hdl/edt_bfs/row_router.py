"""The state store's interface spread over several stores by map row, answers kept in order."""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In

from .state_ram import StateSignature

__all__ = ["RowRouter"]


class RowRouter(wiring.Component):
    """:class:`~hdl.edt_bfs.state_ram.StateSignature` served by ``n`` stores,
    word (``row``, ``wcol``) by store ``select(row)``: with
    :class:`~hdl.edt_bfs.dram_store.DramStore` s on the native ports of one
    DRAM controller, the stores work at once (each issues one native command
    a cycle, and collects its answers, for its own rows).

    Parameters
    ----------
    w, p : the store's widths (:class:`~hdl.edt_bfs.state_ram.StateSignature`).
    n : int
        Stores, 2..8.
    select : callable
        ``select(row)`` -> the store of a map row (an Amaranth value of
        ``n`` values at most; a word and the neighbours whose edge copies
        its write updates, :func:`~hdl.edt_bfs.dram_store.dram_layout`, are
        in one row, so one store holds every copy of a pixel).
    changed : bool
        The writes carry the pixels they change (:func:`~hdl.edt_bfs.state_ram.write_layout`).
    depth : int
        Reads unanswered at most (the FIFO of their stores; the engine's
        crossing allows :data:`~hdl.edt_bfs.dram_stores.DRAM_FIFO`).

    Ports
    -----
    ``rd``, ``rd_data``, ``wr``: a store, as the engine sees it; ``stores``
    : In(StateSignature).array(n): the stores.

    Order: a read goes only while no write waits (a write taken earlier is
    in its store before any later read reaches a store: the contract's
    read-after-write, as the stores keep it for their own commands), and
    once shown to its store it stays valid until taken; the
    answers are taken from the stores in the reads' order (the FIFO of
    their stores).  Combinational from command to store (valid and ready
    pass through), so it adds no cycle.
    """

    def __init__(self, w, p, n, select, depth=16, changed=False):
        if not 2 <= n <= 8:
            raise ValueError(f"stores {n!r}: must be 2..8")
        if not 2 <= depth <= 256:
            raise ValueError(f"depth {depth!r}: must be 2..256")
        self.n, self.select, self.depth = n, select, depth
        sig = StateSignature(w, p, changed)
        super().__init__({**sig.members, "stores": In(sig).array(n)})

    def elaborate(self, platform):
        m = Module()
        rsel, wsel = Signal(range(self.n)), Signal(range(self.n))
        m.d.comb += [rsel.eq(self.select(self.rd.payload.row)), wsel.eq(self.select(self.wr.payload.row))]
        m.submodules.order = order = SyncFIFO(width=len(rsel), depth=self.depth)   # stores of reads unanswered
        head = order.r_data
        # A read goes while no write waits; once shown to its store it stays until taken (a stream's
        # valid does not fall before its handshake), whatever write comes meanwhile (one given later).
        shown = Signal()
        rd_go = self.rd.valid & (shown | ~self.wr.valid) & order.w_rdy
        rd_ready = Signal()
        for i, s in enumerate(self.stores):
            m.d.comb += [s.wr.payload.eq(self.wr.payload), s.wr.valid.eq(self.wr.valid & (wsel == i)),
                         s.rd.payload.eq(self.rd.payload), s.rd.valid.eq(rd_go & (rsel == i)),
                         s.rd_data.ready.eq(self.rd_data.ready & order.r_rdy & (head == i))]
            with m.If(wsel == i):
                m.d.comb += self.wr.ready.eq(s.wr.ready)
            with m.If(rsel == i):
                m.d.comb += rd_ready.eq(s.rd.ready)
            with m.If(head == i):
                m.d.comb += [self.rd_data.valid.eq(order.r_rdy & s.rd_data.valid),
                             self.rd_data.payload.eq(s.rd_data.payload)]
        m.d.sync += shown.eq(rd_go & ~rd_ready)
        m.d.comb += [self.rd.ready.eq(rd_ready & (shown | ~self.wr.valid) & order.w_rdy),
                     order.w_en.eq(self.rd.valid & self.rd.ready), order.w_data.eq(rsel),
                     order.r_en.eq(self.rd_data.valid & self.rd_data.ready)]
        return m
