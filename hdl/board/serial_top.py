"""A core behind a UART: the line pins, the UART, the bridge and the core."""

from amaranth.hdl import ClockDomain, ClockSignal, DomainRenamer, Module, ResetSignal, Shape, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..params import REQUIRED, Param, check
from . import protocol as P
from .bridge import StreamBridge
from .cores import CORES
from .uart_rx import MAX_DIVISOR, MIN_DIVISOR, UartRx
from .uart_tx import UartTx

__all__ = ["SerialTop"]


class SerialTop(wiring.Component):
    """One of the project's cores (``core``: harmonic, dflc, edt_bfs;
    :mod:`.cores`) behind a UART at ``divisor`` clocks a bit and the
    :class:`~.bridge.StreamBridge` (protocol: :mod:`.protocol`,
    docs/protocol.md).  What a board top (:mod:`.board_top`) puts on its
    pins, and what the tests simulate (at a small divisor).

    Ports
    -----
    rx : In(1)
        The UART line from the host (idle high; synchronized inside).
    tx : Out(1)
        The UART line to the host (idle high, from a flip-flop).
    frame_ok, frame_error : Out(1)
        One-cycle strobes: a request was executed / refused (for LEDs).

    The core runs in its own clock domain on the same clock; its reset is
    ``rst`` or the bridge's RESET request, so a RESET never disturbs the
    bridge or a frame on the line.

    Parameters
    ----------
    core : str
        The core; its own parameters follow as keywords (hdl.emit's, e.g.
        ``fll``, ``n``, ``height``).
    divisor : int
        Clocks per bit (the board's clock / the baud rate).
    fifo : int
        The receive FIFO's bytes: how much a host may send ahead.
    gap_bits : int
        Bit times without a byte inside a frame before it counts as
        truncated (NAK TRUNCATED).
    accept_bits : int
        Bit times a core may hold off a beat before the bridge drops it
        (NAK CORE_TIMEOUT).
    clock_hz : int
        The board's clock, for INFO (0 in a simulation).
    """

    PARAMS = (
        Param("core", str, REQUIRED, choices=tuple(CORES), doc="the core behind the bridge"),
        Param("divisor", int, REQUIRED, lo=MIN_DIVISOR, hi=MAX_DIVISOR, doc="clocks per bit"),
        Param("fifo", int, 256, lo=16, hi=65536, doc="receive FIFO bytes (the host's window)"),
        Param("gap_bits", int, 10_000, lo=20, hi=1 << 24, doc="truncation timeout in bit times"),
        Param("accept_bits", int, 100_000, lo=1, hi=1 << 24, doc="how long the core may hold off a beat, bit times"),
        Param("clock_hz", int, 0, lo=0, hi=10**10, doc="the board's clock (INFO; 0: unknown)"),
    )

    def __init__(self, core, divisor, fifo=256, gap_bits=10_000, accept_bits=100_000, clock_hz=0, **core_params):
        check(self.PARAMS, core=core, divisor=divisor, fifo=fifo, gap_bits=gap_bits, accept_bits=accept_bits,
              clock_hz=clock_hz)
        self.spec = CORES[core]
        self.core = self.spec.build(**core_params)
        self.divisor, self.clock_hz = divisor, clock_hz
        sinks = [Shape.cast(getattr(self.core, s).payload.shape()).width for s in self.spec.sinks]
        sources = [Shape.cast(getattr(self.core, s).payload.shape()).width for s in self.spec.sources]
        layout = self.spec.status_layout and self.spec.status_layout(self.core)
        status_width = Shape.cast(layout).width if layout else 0
        self.status_layout = layout
        info = P.info_text(core, self.spec.info(self.core, core_params), sinks, sources, status_width, fifo,
                           max(16, *(P.beat_bytes(w) for w in sinks)), gap_bits, accept_bits, divisor, clock_hz)
        self.bridge = StreamBridge(sinks, sources, info, gap_cycles=gap_bits * divisor,
                                   accept_cycles=accept_bits * divisor, fifo_depth=fifo, status_width=status_width)
        self.info = info
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "frame_ok": Out(1), "frame_error": Out(1)})

    def timing(self):
        return {"divisor": self.divisor, "frame": "see docs/protocol.md"}

    def instance_modules(self):
        """The modules the core instantiates by name (the EDT/BFS cells)."""
        return getattr(self.core, "instance_modules", dict)()

    def elaborate(self, platform):
        m = Module()
        m.submodules.uart_rx = urx = UartRx(self.divisor)
        m.submodules.uart_tx = utx = UartTx(self.divisor)
        m.submodules.bridge = br = self.bridge
        m.d.comb += [urx.rx.eq(self.rx), self.tx.eq(utx.tx), br.rx_error.eq(urx.error),
                     self.frame_ok.eq(br.frame_ok), self.frame_error.eq(br.frame_error)]
        wiring.connect(m, urx.o_stream, br.rx)
        wiring.connect(m, br.tx, utx.i_stream)

        # The core: same clock, reset also by the bridge's RESET.
        m.domains.core = core_cd = ClockDomain("core", local=True)
        m.d.comb += [core_cd.clk.eq(ClockSignal("sync")), core_cd.rst.eq(ResetSignal("sync", allow_reset_less=True) | br.core_rst)]
        core = self.core
        m.submodules.core = DomainRenamer("core")(core)
        for k, name in enumerate(self.spec.sinks):
            sink, into = getattr(br, f"sink_{k}"), getattr(core, name)
            m.d.comb += [into.valid.eq(sink.valid), into.payload.eq(sink.payload), sink.ready.eq(into.ready)]
        for k, name in enumerate(self.spec.sources):
            source, out = getattr(br, f"source_{k}"), getattr(core, name)
            m.d.comb += [source.valid.eq(out.valid), source.payload.eq(out.payload), out.ready.eq(source.ready)]
        if self.status_layout is not None:
            word = Signal(self.status_layout)
            self.spec.status(m, core, word)
            m.d.comb += br.status.eq(word)
        return m
