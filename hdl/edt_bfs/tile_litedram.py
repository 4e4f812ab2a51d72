"""The tile engine with its state in a DDR3 through LiteDRAM's controller (an instance of its generated core)."""

from amaranth.hdl import Cat, Const, Instance, IOPort, Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .tile_engine import TileEngine

__all__ = ["DDR3_PINS", "TileLiteDram", "WISHBONE"]

# LiteDRAM's control bus (wb_ctrl_*: a 32-bit Wishbone of word addresses), from the controller's side
WISHBONE = {"adr": (30, "i"), "dat_w": (32, "i"), "sel": (4, "i"), "cyc": (1, "i"), "stb": (1, "i"),
            "we": (1, "i"), "cti": (3, "i"), "bte": (2, "i"), "dat_r": (32, "o"), "ack": (1, "o"),
            "err": (1, "o")}

# The generated core's DDR3 pads without --sim (scripts/litedram_core.py's 16-bit DDR3): name: (width,
# direction).  Not here: ``clk_n`` and ``dqs_n``, the differential pads' other halves, which the PHY's
# SSTL15D buffers drive from ``clk_p`` and ``dqs_p`` (migen declares them unused inputs: tied to 0).
DDR3_PINS = {"a": (15, "o"), "ba": (3, "o"), "ras_n": (1, "o"), "cas_n": (1, "o"), "we_n": (1, "o"),
             "cs_n": (1, "o"), "dm": (2, "o"), "dq": (16, "io"), "dqs_p": (2, "io"), "clk_p": (1, "o"),
             "cke": (1, "o"), "odt": (1, "o"), "reset_n": (1, "o")}


class TileLiteDram(wiring.Component):
    """:class:`~hdl.edt_bfs.tile_engine.TileEngine` with ``store="dram"``
    and an instance of ``litedram_core`` (scripts/litedram_core.py: a
    16-bit DDR3 on ECP5DDRPHY, ``dram_ports`` 128-bit native user ports) on
    its ``dram`` ports.

    Parameters: the engine's ``t_r``, ``t_c``, ``max_h``, ``max_w``, ``dram_ports``, ``prefetch``,
    ``skip_clean``, ``iter_cycles``, ``bfs_slots``;
    ``addr_width``: the core's native address (25 for the 512 MB of one
    MT41K256M16 in 128-bit words: scripts/litedram_core.py's).

    Ports: the engine's (``c_stream``, ``m_stream``, ``g_stream``,
    ``o_stream``, ``busy``, ... ``visit``; in ``clk``'s domain, the
    engine's clock), and the controller's: ``sys_clk`` (its system clock;
    the native port and the crossing's far side run on its ``user_clk``),
    ``wb_ctrl_*`` (its control bus: start-up writes the DFII control
    register and ``init_done``, sim/rtl/litedram.py), ``init_done``,
    ``init_error``.  The DRAM's own pins are the generated core's: in
    simulation (``sim``, ``litedram_gen --sim``) the core holds LiteDRAM's
    model of the DRAM and has none; without, they are the top's
    ``ddram_*`` ports (:data:`DDR3_PINS`: its I/O buffers are the core's),
    ``sys_clk`` is the PLL's input (100 MHz on the ECPIX-5) and the core's
    reset is held low.
    """

    def __init__(self, t_r, t_c, max_h, max_w, dram_ports=1, prefetch=0, skip_clean=False, iter_cycles=1,
                 addr_width=25, sim=True, bfs_slots=False):
        self.engine = TileEngine(t_r, t_c, max_h, max_w, store="dram", dram_ports=dram_ports, prefetch=prefetch,
                                 skip_clean=skip_clean, iter_cycles=iter_cycles, bfs_slots=bfs_slots)
        used = len(self.engine.dram[0].cmd.payload.addr)
        if used > addr_width:
            raise ValueError(f"the store's {used} address bits exceed the controller's {addr_width}")
        self.addr_width, self.sim = addr_width, bool(sim)
        members = {k: v for k, v in self.engine.signature.members.items() if k not in ("dram", "dram_clk", "dram_rst")}
        members.update({"sys_clk": In(1), "init_done": Out(1), "init_error": Out(1)})
        members.update({f"wb_ctrl_{k}": (In if d == "i" else Out)(w) for k, (w, d) in WISHBONE.items()})
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        m.submodules.engine = e = self.engine
        for name, member in self.signature.members.items():
            if not hasattr(e, name):
                continue
            ours, theirs = getattr(self, name), getattr(e, name)
            if member.is_port:
                m.d.comb += (theirs.eq(ours) if member.flow == In else ours.eq(theirs))
            else:
                wiring.connect(m, wiring.flipped(ours), theirs)
        ports = {"i_clk": self.sys_clk, "o_user_clk": e.dram_clk, "o_user_rst": e.dram_rst,
                 "o_init_done": self.init_done, "o_init_error": self.init_error}
        if self.sim:
            ports["i_sim_trace"] = 0
        else:
            ports.update({"i_rst": 0, "i_ddram_clk_n": 0, "i_ddram_dqs_n": 0})
            ports.update({f"{d}_ddram_{k}": IOPort(w, name=f"ddram_{k}") for k, (w, d) in DDR3_PINS.items()})
        pad = self.addr_width - len(e.dram[0].cmd.payload.addr)
        for i, d in enumerate(e.dram):
            u = f"user_port_native_{i}"
            ports.update({
                f"i_{u}_cmd_valid": d.cmd.valid, f"o_{u}_cmd_ready": d.cmd.ready, f"i_{u}_cmd_we": d.cmd.payload.we,
                f"i_{u}_cmd_addr": Cat(d.cmd.payload.addr, Const(0, pad)),
                f"i_{u}_wdata_valid": d.wdata.valid, f"o_{u}_wdata_ready": d.wdata.ready,
                f"i_{u}_wdata_data": d.wdata.payload.data, f"i_{u}_wdata_we": d.wdata.payload.we,
                f"o_{u}_rdata_valid": d.rdata.valid, f"i_{u}_rdata_ready": d.rdata.ready,
                f"o_{u}_rdata_data": d.rdata.payload.data})
        ports.update({f"{dir_}_wb_ctrl_{k}": getattr(self, f"wb_ctrl_{k}") for k, (_, dir_) in WISHBONE.items()})
        m.submodules.dram = Instance("litedram_core", **ports)
        return m
