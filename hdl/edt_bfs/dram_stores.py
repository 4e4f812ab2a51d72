"""The tile engine's DRAM side: a DramStore on each of a controller's native ports, the map rows spread over them."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import Out

from ..params import Constraint, Param, check, checked_init
from ..skid_buffer import SkidBuffer
from .dram_store import PORTS, DramStore, NativePortSignature, dram_layout, load_bits, port_of_row
from .row_router import RowRouter
from .state_ram import StateSignature
from .tile_layouts import TILE_CONSTRAINTS, TILE_PARAMS, tile_widths

__all__ = ["DramStores", "DRAM_PORTS_PARAM", "SKIP_CLEAN_PARAM", "BFS_SLOTS_PARAM", "DRAM_CONSTRAINTS", "DRAM_WIDTH",
           "DRAM_FIFO", "LOAD_BITS_MAX"]

DRAM_WIDTH = 128        # a native word of LiteDRAM's 1:2-rate PHY on a 16-bit DDR3 (a burst of 8)
DRAM_FIFO = 16          # engine reads unanswered at most (the engine's crossing FIFOs' depth), each store's
                        # native reads unanswered at most (its answer FIFO's depth), the reads the router orders
DRAM_PORTS_PARAM = Param("dram_ports", int, 1, choices=PORTS,
                         doc="store=dram: the controller's native ports used (a map row's port: its words' bank "
                             "bits)",
                         message="native ports dram_ports {value!r}: must be {allowed}")
SKIP_CLEAN_PARAM = Param("skip_clean", bool, False,
                         doc="a store outside: write back only what a visit changed (the tile rows; to a DRAM, "
                             "the native words holding a changed pixel; a BFS read without di's words, from a cfr bit "
                             "the EDT's writes keep; the load's obstacle bits on chip, a word no write changed "
                             "answered from them): the same cycles, less bandwidth",
                         message="skip_clean {value!r}: must be 0 or 1")
BFS_SLOTS_PARAM = Param("bfs_slots", bool, False,
                        doc="store=dram with skip_clean: the edge pixels' BFS fields and cfr in the B words' spare "
                            "bytes (DramStore's bfs_slots): a BFS read is b native words a row, not b + e",
                        message="bfs_slots {value!r}: must be 0 or 1")


# The stores' on-chip bits with skip_clean (DramStore: the load's obstacle bits, the edge slots' and the A, B
# and E words' written bits), at most: 2 Mbit, over half the LFE5U-85F's 3.7 Mbit of block RAM (maze512-1-0 on
# the 3x8 array, 4 ports: 480 Kbit).
LOAD_BITS_MAX = 2 << 20


def _load_bits(p):
    depth, width = load_bits(tile_widths(p["t_r"], p["t_c"], p["max_h"], p["max_w"]), p["t_c"], p["max_h"],
                             p["dram_ports"], DRAM_WIDTH, bool(p.get("bfs_slots")))
    return p["dram_ports"] * depth * width


DRAM_CONSTRAINTS = (
    Constraint(f"on-chip bits <= {LOAD_BITS_MAX} (skip_clean, store=dram)",
               lambda p: not p["skip_clean"] or p.get("store", "dram") != "dram" or _load_bits(p) <= LOAD_BITS_MAX,
               "largest map {max_h}x{max_w} with skip_clean: the DRAM stores' obstacle and written bits are {n} "
               "Kbit, at most " + str(LOAD_BITS_MAX >> 10) + " Kbit on chip (a smaller map, or skip_clean 0)",
               lambda p: {"n": _load_bits(p) >> 10}),
    Constraint("not bfs_slots or (skip_clean and store == 'dram')",
               lambda p: not p.get("bfs_slots") or (p["skip_clean"] and p.get("store", "dram") == "dram"),
               "bfs_slots needs store=dram and skip_clean 1 (the DRAM store's cfr bits and on-chip written bits)"),
)


class DramStores(wiring.Component):
    """What the tile engine with ``store="dram"`` puts on the controller's
    clock, behind its crossing (:class:`~hdl.edt_bfs.state_cdc.StateCdc`):
    a :class:`~hdl.edt_bfs.dram_store.DramStore` on each of ``dram_ports``
    native ports and, with more than one,
    :class:`~hdl.edt_bfs.row_router.RowRouter` giving map row r to the store
    on port :func:`~hdl.edt_bfs.dram_store.port_of_row` (r) (the bank bits of
    its words: each port in its own banks, the stores issuing and
    collecting a window's rows at once).  Also a top of its own
    (``edt_dram_stores``), so that the fit flow places it at its clock.

    Parameters
    ----------
    t_r, t_c, max_h, max_w : the tile engine's (the widths:
        :func:`~hdl.edt_bfs.tile_layouts.tile_widths`).
    dram_ports : 1, 2 or 4
    skip_clean : bool
        The engine's writes carry the pixels they change
        (:func:`~hdl.edt_bfs.state_ram.write_layout`): the stores issue
        only the native words holding one of them, and keep the load's
        obstacle bits on chip (:class:`~hdl.edt_bfs.dram_store.DramStore`:
        a word no write changed is answered from them, not read; the load
        issues no native command): :func:`~hdl.edt_bfs.dram_store.load_bits`
        a DRAM block, at most :data:`LOAD_BITS_MAX` over the stores.
    bfs_slots : bool
        With ``skip_clean``: the edge slots' BFS groups and cfr in the B
        words (:class:`~hdl.edt_bfs.dram_store.DramStore`'s ``bfs_slots``):
        a BFS read is ``b`` native words a row, not ``b + e``.

    Ports
    -----
    ``rd``, ``rd_data``, ``wr``: :class:`~hdl.edt_bfs.state_ram.StateSignature`
    (the engine's store); ``dram`` : Out(:func:`~hdl.edt_bfs.dram_store.NativePortSignature`)
    .array(``dram_ports``): the controller's ports (128-bit words,
    ``addr_width`` from :func:`~hdl.edt_bfs.dram_store.dram_layout`),
    each stream through a :class:`~hdl.skid_buffer.SkidBuffer`, and so
    are ``rd``, ``wr`` and ``rd_data``: the controller's ready, the stores'
    and the router's logic and the crossing's FIFO pointers meet only at
    flip-flops (in the whole top on the ECPIX-5's part the path from
    LiteDRAM's crossbar through a store's command logic into the
    crossing's read pointer set the controller's clock at 46 MHz); each
    stage a cycle more each way.
    One clock (``sync``: the controller's), reset with the controller.
    """

    PARAMS = TILE_PARAMS + (DRAM_PORTS_PARAM, SKIP_CLEAN_PARAM, BFS_SLOTS_PARAM)
    CONSTRAINTS = TILE_CONSTRAINTS + DRAM_CONSTRAINTS

    @checked_init
    def __init__(self, t_r, t_c, max_h, max_w, dram_ports=1, skip_clean=False, bfs_slots=False):
        check(self.PARAMS, self.CONSTRAINTS, t_r=t_r, t_c=t_c, max_h=max_h, max_w=max_w, dram_ports=dram_ports,
              skip_clean=skip_clean, bfs_slots=bfs_slots)
        self.w = w = tile_widths(t_r, t_c, max_h, max_w)
        self.t_c, self.max_h, self.ports, self.changed = t_c, max_h, dram_ports, bool(skip_clean)
        self.bfs_slots = bool(bfs_slots)
        super().__init__({
            **StateSignature(w, t_c, self.changed).members,
            "dram": Out(NativePortSignature(dram_layout(w, t_c, max_h, DRAM_WIDTH, self.bfs_slots)["addr_width"],
                                            DRAM_WIDTH)).array(dram_ports),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.ports
        stores = [DramStore(self.w, self.t_c, self.max_h, DRAM_WIDTH, max_reads=DRAM_FIFO, changed=self.changed,
                            ports=n, bfs_slots=self.bfs_slots) for _ in range(n)]
        for i, store in enumerate(stores):
            m.submodules[f"store{i}"] = store
        if n > 1:
            m.submodules.rows = rows = RowRouter(self.w, self.t_c, n, lambda row: port_of_row(row, n),
                                                 depth=DRAM_FIFO, changed=self.changed)
            for store, side in zip(stores, rows.stores):
                for name in ("rd", "rd_data", "wr"):
                    wiring.connect(m, getattr(side, name), getattr(store, name))
        # Every stream between the crossing and the stores, and between the stores and the controller's
        # ports, through a SkidBuffer: (producer, consumer) pairs.
        target = rows if n > 1 else stores[0]
        links = {f"{name}_buf": (wiring.flipped(getattr(self, name)), getattr(target, name)) for name in ("rd", "wr")}
        links["rd_data_buf"] = (target.rd_data, wiring.flipped(self.rd_data))
        for i, (store, port) in enumerate(zip(stores, self.dram)):
            links[f"cmd{i}"] = (store.dram.cmd, wiring.flipped(port.cmd))
            links[f"wdata{i}"] = (store.dram.wdata, wiring.flipped(port.wdata))
            links[f"rdata{i}"] = (wiring.flipped(port.rdata), store.dram.rdata)      # the controller's answers
        for name, (producer, consumer) in links.items():
            buf = m.submodules[name] = SkidBuffer(producer.payload.shape())
            wiring.connect(m, producer, buf.i)
            wiring.connect(m, buf.o, consumer)
        return m
