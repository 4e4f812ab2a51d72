"""Board tops: a :class:`~.serial_top.SerialTop` on a real board's pins
(amaranth-boards platforms), and the boards and configurations
``make bitstream`` builds (docs/boards.md).

======================  ================  ===========  ===========================================
board (BOARD=)          part              clock        cores (CORE=) and their configurations
======================  ================  ===========  ===========================================
``ulx3s-85f``           LFE5U-85F-6       25 MHz       harmonic, dflc, edt_bfs (:data:`CONFIGS`)
                        CABGA381
``icebreaker``          iCE40UP5K SG48    12 MHz       dflc
======================  ================  ===========  ===========================================

The UART is the board's USB serial port (the FT231X of the ULX3S, the
FT2232H's second channel of the iCEBreaker), 8N1 at ``baud`` (default
115200; 1000000 works on both: 25 and 12 clocks a bit).  The LEDs:
:data:`BOARDS`' ``leds``.
"""

import importlib
from dataclasses import dataclass

from amaranth.hdl import Cat, Elaboratable, Module, Signal

from .serial_top import SerialTop
from .uart_rx import MIN_DIVISOR

__all__ = ["Board", "BOARDS", "CONFIGS", "BAUDS", "BoardTop", "divisor_for"]


@dataclass(frozen=True)
class Board:
    """A board: its amaranth-boards platform (module, class), the part the
    fit flow names (scripts/fmax.py PARTS), its clock, and what its LEDs show
    (index -> ``heartbeat`` (about 1 Hz: the bitstream runs), ``ok`` (a
    request executed), ``error`` (a request refused: NAK), ``rx`` (the
    line from the host is active)), each lit for about 0.1 s."""

    name: str
    module: str
    platform: str
    part: str
    clock_hz: int
    leds: tuple

    def platform_class(self):
        """The amaranth-boards platform class (ImportError without amaranth-boards)."""
        return getattr(importlib.import_module(self.module), self.platform)


BOARDS = {
    "ulx3s-85f": Board("ulx3s-85f", "amaranth_boards.ulx3s", "ULX3S_85F_Platform", "LFE5U-85F", 25_000_000,
                       ("heartbeat", "ok", "error", "rx")),
    "icebreaker": Board("icebreaker", "amaranth_boards.icebreaker", "ICEBreakerPlatform", "iCE40-UP5K",
                        12_000_000, ("error", "heartbeat")),     # led 0 red, led 1 green
}

# The configuration of each core on each board (hdl.emit's parameters).
# ULX3S-85F: the planner at 6x12 blocks (4 clusters) over 6x3 blocks (a
# 36x36 map: the bundled 32x32 maps fit), precisions up to p = 254 (the
# bit-serial Decision has no multipliers: ~2,000 LUT4 at 254), cluster RAMs
# of 8,192 words (18 blocks x 256).  A stated smaller size: the 85F's 208
# EBRs are what limits it, and 11x6 blocks (the 64x64 maps, which need p =
# 160) at p_max 254 took 353 (the four border stores of 16,896 words, each
# RAM doubled for its third port, and 32,768-word cluster RAMs); 6x3
# takes 97.  The EDT/BFS array at 8x8, also a stated smaller size (33,509
# LUT4 with the bridge, 40 % of the 85F: 12x12 would be about 90 %, 16x16
# does not fit; a size is an hour's build on this machine).  The iCEBreaker's UP5K (5,280 logic
# cells) holds the DFLC only.
CONFIGS = {
    ("ulx3s-85f", "harmonic"): {"n": 6, "m": 12, "br": 6, "bc": 3, "p_max": 254, "depth": 8192},
    ("ulx3s-85f", "dflc"): {"fll": "table1"},
    ("ulx3s-85f", "edt_bfs"): {"height": 8, "width": 8},
    ("icebreaker", "dflc"): {"fll": "table1"},
}

BAUDS = (9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600, 1000000, 2000000, 3000000)
MAX_BAUD_ERROR = 0.02       # the UART samples mid-bit: 2 % over ten bits leaves a fifth of a bit


def divisor_for(clock_hz, baud):
    """Clocks per bit for ``baud`` on ``clock_hz`` (ValueError beyond 2 % error)."""
    def error(b):
        d = round(clock_hz / b)
        return abs(clock_hz / d - b) / b if d >= MIN_DIVISOR else None

    err = error(baud)
    if err is None or err > MAX_BAUD_ERROR:
        why = (f"fewer than {MIN_DIVISOR} clocks a bit" if err is None
               else f"{clock_hz / round(clock_hz / baud):.0f} Bd, {err:.1%} off")
        fine = [str(b) for b in BAUDS if (e := error(b)) is not None and e <= MAX_BAUD_ERROR]
        raise ValueError(f"baud {baud}: a {clock_hz / 1e6:g} MHz clock divides it {clock_hz / baud:.2f} times "
                         f"({why}); pick one of {', '.join(fine)}")
    return round(clock_hz / baud)


class BoardTop(Elaboratable):
    """``core`` at ``params`` behind the UART on ``board``'s pins.

    The clock is the board's oscillator (no PLL), the reset the platform's
    (power-on); the host resets the core with the RESET request."""

    def __init__(self, board, core, baud=115200, **params):
        if board not in BOARDS:
            raise ValueError(f"unknown board {board!r}; boards: {', '.join(BOARDS)}")
        self.board = BOARDS[board]
        self.divisor = divisor_for(self.board.clock_hz, baud)
        self.top = SerialTop(core, self.divisor, clock_hz=self.board.clock_hz, **params)

    def elaborate(self, platform):
        m = Module()
        m.submodules.top = top = self.top
        uart = platform.request("uart", 0)
        m.d.comb += [top.rx.eq(uart.rx.i), uart.tx.o.eq(top.tx)]
        clock = self.board.clock_hz
        beat = Signal(range(clock))                     # the heartbeat: 1 Hz
        heart = Signal()
        with m.If(beat == clock // 2 - 1):
            m.d.sync += [beat.eq(0), heart.eq(~heart)]
        with m.Else():
            m.d.sync += beat.eq(beat + 1)
        shows = {"heartbeat": heart}
        rx_sync = Signal(2, init=3)                     # the line, synchronized for the rx LED
        m.d.sync += rx_sync.eq(Cat(uart.rx.i, rx_sync[0]))
        for what, strobe in (("ok", top.frame_ok), ("error", top.frame_error), ("rx", ~rx_sync[1])):
            left = Signal(range(clock // 10 + 1), name=f"{what}_led")     # lit 0.1 s
            with m.If(strobe):
                m.d.sync += left.eq(clock // 10)
            with m.Elif(left != 0):
                m.d.sync += left.eq(left - 1)
            shows[what] = left != 0
        for i, what in enumerate(self.board.leds):
            m.d.comb += platform.request("led", i).o.eq(shows[what])
        return m
