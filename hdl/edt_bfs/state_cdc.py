"""The state store's interface carried across clock domains: the engine's clock to the store's."""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import In

from .state_ram import StateSignature

__all__ = ["StateCdc"]


class StateCdc(wiring.Component):
    """Three asynchronous FIFOs between the tile engine (its ``state`` side)
    and a store in another clock domain
    (:class:`~hdl.edt_bfs.dram_store.DramStore` on the DRAM controller's
    clock, which is 3-4 times the engine's: the store issues several native
    commands per engine cycle).

    Parameters
    ----------
    w, p : the store's widths (:class:`~hdl.edt_bfs.state_ram.StateSignature`).
    user_domain : str
        The engine's clock, in a domain without a reset: what the engine
        gave before its reset still reaches the store (a write is carried
        out, a read answered), since the store is not reset with the engine.
    reset_domain : str
        The engine's own domain (same clock, with its reset): the reads
        made before a reset are counted there, and their answers dropped.
    store_domain : str
        The store's clock.
    changed : bool
        The writes carry the pixels they change (:func:`~hdl.edt_bfs.state_ram.write_layout`).
    depth : int
        Each FIFO's depth (a power of two, 4..256); also the engine's reads
        unanswered at most, so the answer FIFO always has room for what the
        store sends.

    Ports
    -----
    :class:`~hdl.edt_bfs.state_ram.StateSignature` (``rd``, ``rd_data``,
    ``wr``): a store, as the engine sees it; ``store`` :
    In(StateSignature): the store's side (the engine's view of it).
    Valid is a FIFO's non-empty flag, ready its non-full flag (and, for
    ``rd``, the read credit); answers in command order.
    """

    def __init__(self, w, p, user_domain="port", reset_domain="sync", store_domain="dram", depth=16,
                 changed=False):
        if not 4 <= depth <= 256 or depth & (depth - 1):
            raise ValueError(f"FIFO depth {depth}: must be a power of two in 4..256")
        self.user_domain, self.reset_domain, self.store_domain, self.depth = \
            user_domain, reset_domain, store_domain, depth
        sig = StateSignature(w, p, changed)
        super().__init__({**sig.members, "store": In(sig)})

    def elaborate(self, platform):
        m = Module()
        u, s = self.user_domain, self.store_domain
        fifos = {}
        for name, src, dst, wd, rd in (("rd", self.rd, self.store.rd, u, s), ("wr", self.wr, self.store.wr, u, s),
                                       ("rd_data", self.store.rd_data, self.rd_data, s, u)):
            fifo = fifos[name] = AsyncFIFO(width=src.payload.shape().size, depth=self.depth, w_domain=wd, r_domain=rd)
            m.submodules[name] = fifo
            m.d.comb += [fifo.w_data.eq(src.payload), dst.payload.eq(fifo.r_data), dst.valid.eq(fifo.r_rdy),
                         fifo.r_en.eq(dst.ready)]
            if name != "rd":
                m.d.comb += [fifo.w_en.eq(src.valid), src.ready.eq(fifo.w_rdy)]
        # Reads unanswered: ``in_flight`` (no reset) counts every read given and not answered,
        # ``owned`` those given since the engine's last reset; answers come in order, so the
        # first in_flight - owned are the old ones: taken from the FIFO and dropped.  A read is
        # taken only while fewer than ``depth`` are unanswered (the answer FIFO's room).
        rdf, ans = fifos["rd"], fifos["rd_data"]
        in_flight = Signal(range(self.depth + 1))
        owned = Signal(range(self.depth + 1))
        discard = in_flight != owned
        credit = in_flight < self.depth
        given = self.rd.valid & self.rd.ready
        popped = ans.r_rdy & ans.r_en
        m.d.comb += [rdf.w_en.eq(self.rd.valid & credit), self.rd.ready.eq(rdf.w_rdy & credit),
                     self.rd_data.valid.eq(ans.r_rdy & ~discard), ans.r_en.eq(self.rd_data.ready | discard)]
        m.d[u] += in_flight.eq(in_flight + given - popped)
        m.d[self.reset_domain] += owned.eq(owned + given - (popped & ~discard))
        return m
