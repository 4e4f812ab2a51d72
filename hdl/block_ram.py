"""A simple dual-port RAM laid out on 18 Kbit block RAMs by their aspect ratios, its read registered."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .harmonic.limits import MAX_DEPTH
from .params import Param, check, checked_init

__all__ = ["BlockRam", "BLOCK_SHAPES", "ram_layout"]

# The port shapes (depth, width) of one 18 Kbit block RAM: the ECP5's DP16KD,
# like the Virtex-II / Spartan-3 RAMB16 of the papers.
BLOCK_SHAPES = ((512, 36), (1024, 18), (2048, 9), (4096, 4), (8192, 2), (16384, 1))
BANK_DEPTH = BLOCK_SHAPES[-1][0]
MAX_WIDTH = 1024        # elaboration limit: wider than any word here (the cluster's 18 bits, a border's few hundred)


def ram_layout(width, depth):
    """How :class:`BlockRam` splits ``width`` x ``depth``: a list of banks, each ``(depth, lanes)``.

    Banks of 16384 words split a deeper RAM (their multiplexer, behind the
    output registers, is the one left), the last bank holding the rest.  A
    bank's lanes are slices of the word, each in block RAMs of the widest
    shape that holds the bank's whole depth, so that no block's output goes
    through an address multiplexer.  ``lanes``: the slices.
    """
    banks = []
    for start in range(0, depth, BANK_DEPTH):
        d = min(BANK_DEPTH, depth - start)
        lane = next(w for bd, w in BLOCK_SHAPES if bd >= d)
        banks.append((d, [slice(s, min(s + lane, width)) for s in range(0, width, lane)]))
    return banks


class BlockRam(wiring.Component):
    """``width`` x ``depth`` simple dual-port RAM, read latency 2, as block RAMs place and route best.

    Synthesis maps a deep, wide memory onto blocks of the shape with the
    fewest blocks (1024 x 18 for 18 bits) and a multiplexer on the address's
    high bits behind them, and that multiplexer sits between the blocks'
    unregistered outputs (5.8 ns clock-to-out on an ECP5, speed 6) and the
    logic (issue 17: the 6x3 planner's cluster RAM, 8 blocks deep, 11.0 ns
    into the next cluster; the 11x6's, 32 deep, 14.5 ns).  Here the word is
    cut into lanes as wide as a block that holds the whole depth allows
    (:func:`ram_layout`: 8192 deep, 2 bits a lane: 9 blocks for 18 bits
    instead of 8), each lane's data go straight into a flip-flop that
    becomes the block's output register (scripts/ecp5_pack.py: REGMODE
    OUTREG), and only a depth beyond 16384 words keeps a bank multiplexer,
    behind those registers (the last bank laid out for the words it holds:
    17028 x 12 bits is 12 one-bit lanes of 16384 and one 644 x 12 block).
    At most 1024 words of up to 18 bits this is one memory, as before.  The
    same cycles as one memory with a read-data register.

    Parameters
    ----------
    width, depth : int
        Word width and depth.
    attrs : dict
        Attributes of every memory (the callers' ``no_rw_check``: a read and a
        write never meet on one address in one cycle).

    Ports
    -----
    r_addr : In(range(depth))
        Read address; its word appears on ``r_data`` two cycles later.
    r_data : Out(width)
        The registered read data (reset-less, as the RAM's contents).
    w_addr : In(range(depth)), w_data : In(width), w_en : In(1)
        Write port: ``w_data`` at ``w_addr`` when ``w_en`` (readable from the next cycle on).
    """

    PARAMS = (
        Param("width", int, lo=1, hi=MAX_WIDTH, doc="word width in bits",
              message="BlockRam width {value!r}: must be an integer in {lo}..{hi}"),
        Param("depth", int, lo=2, hi=MAX_DEPTH, doc="words",
              message="BlockRam depth {value!r}: must be an integer in {lo}..{hi} (the harmonic cluster's "
                      "limit: hdl/harmonic/limits.py)"),
    )

    @checked_init
    def __init__(self, width, depth, attrs=None):
        check(self.PARAMS, width=width, depth=depth)
        self.width, self.depth, self.attrs = width, depth, dict(attrs or {})
        super().__init__({"r_addr": In(range(depth)), "r_data": Out(width),
                          "w_addr": In(range(depth)), "w_data": In(width), "w_en": In(1)})

    def elaborate(self, platform):
        m = Module()
        banks = ram_layout(self.width, self.depth)
        bank_bits = (BANK_DEPTH - 1).bit_length()
        outs = []
        for b, (depth, lanes) in enumerate(banks):
            w_here = self.w_en if len(banks) == 1 else self.w_en & (self.w_addr[bank_bits:] == b)
            q = Signal(self.width, name=f"q{b}", reset_less=True)   # the blocks' output registers
            for k, sl in enumerate(lanes):
                mem = Memory(shape=sl.stop - sl.start, depth=depth, init=[], attrs=self.attrs)
                m.submodules[f"bank{b}_lane{k}" if len(banks) > 1 else f"lane{k}"] = mem
                rp, wp = mem.read_port(), mem.write_port()
                m.d.comb += [rp.addr.eq(self.r_addr), wp.addr.eq(self.w_addr),
                             wp.data.eq(self.w_data[sl]), wp.en.eq(w_here)]
                m.d.sync += q[sl].eq(rp.data)
            outs.append(q)
        if len(banks) == 1:
            m.d.comb += self.r_data.eq(outs[0])
        else:
            # the bank of the word on r_data: the read address's high bits, two cycles old
            sel1, sel2 = (Signal(range(len(banks)), name=n, reset_less=True) for n in ("bank1", "bank2"))
            m.d.sync += [sel1.eq(self.r_addr[bank_bits:]), sel2.eq(sel1)]
            data = outs[0]
            for b in range(1, len(banks)):
                data = Mux(sel2 == b, outs[b], data)
            m.d.comb += self.r_data.eq(data)
        return m
