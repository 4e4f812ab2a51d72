"""The bridge between a UART and a core's valid/ready streams (docs/protocol.md)."""

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from ..params import Param, check
from . import protocol as P
from .frame_rx import FrameRx
from .frame_tx import FrameTx

__all__ = ["StreamBridge"]


class StreamBridge(wiring.Component):
    """Frames from the host -> beats into the core's sink streams; the core's
    source streams' beats -> DATA frames to the host (:mod:`.protocol`).

    The receive path never pushes back on the line (a UART cannot): bytes go
    into a FIFO of ``fifo_depth`` bytes (the host's window, given in INFO),
    a :class:`FrameRx` checks each frame, and one request is executed at a
    time.  Every request gets one reply frame, ACK or NAK, in order.  A WRITE
    offers its beat to the sink stream (valid held, payload stable) until the
    core takes it, for at most ``accept_cycles``: then the beat is dropped
    and the reply is NAK CORE_TIMEOUT, so a core that never takes a beat
    never wedges the bridge.  The transmit path takes a source beat only
    when the line is free for its frame (the core sees back-pressure,
    nothing is dropped); replies go before DATA frames, and the source
    streams are served lowest number first.

    Ports
    -----
    rx : In(stream of 8 bits)
        Bytes from the UART receiver.
    rx_error : In(1)
        The receiver's strobe: a byte was lost (framing error, overrun); the
        frame it fell in gets NAK LINE.
    tx : Out(stream of 8 bits)
        Bytes for the UART transmitter.
    sink_<k> : Out(stream of ``sinks[k]`` bits)
        Into the core (WRITE 0x10+k).
    source_<k> : In(stream of ``sources[k]`` bits)
        From the core (DATA 0x40+k).
    status : In(``status_width``)
        The core's status word, sampled when a STATUS request is executed
        (absent when 0 bits wide).
    core_rst : Out(1)
        One-cycle strobe after a RESET request: reset the core with it.
    frame_ok, frame_error : Out(1)
        One-cycle strobes: a request was executed / refused (for LEDs).

    Parameters: ``sinks``, ``sources`` (widths, at most 16 each),
    ``status_width``, ``info`` (the INFO reply's bytes), ``fifo_depth``,
    ``gap_cycles`` (truncation timeout), ``accept_cycles``, ``echo_bytes``
    (the largest ECHO payload at least; the buffer also holds the widest
    sink's beat).
    """

    PARAMS = (
        Param("fifo_depth", int, 64, lo=16, hi=65536, doc="receive FIFO bytes (the host's window)"),
        Param("gap_cycles", int, lo=2, hi=1 << 32, doc="truncation timeout in clocks"),
        Param("accept_cycles", int, lo=1, hi=1 << 32, doc="how long a sink may hold off a beat"),
        Param("echo_bytes", int, 16, lo=1, hi=255, doc="largest ECHO payload"),
        Param("status_width", int, 0, lo=0, hi=8 * 255, doc="status word bits"),
    )

    def __init__(self, sinks, sources, info, gap_cycles, accept_cycles, fifo_depth=64, echo_bytes=16,
                 status_width=0):
        check(self.PARAMS, fifo_depth=fifo_depth, gap_cycles=gap_cycles, accept_cycles=accept_cycles,
              echo_bytes=echo_bytes, status_width=status_width)
        for what, widths in (("sinks", sinks), ("sources", sources)):
            if not 1 <= len(widths) <= P.MAX_STREAMS or any(not 1 <= w <= 8 * 255 for w in widths):
                raise ValueError(f"{what} = {widths!r}: 1..{P.MAX_STREAMS} streams of 1..2040 bits")
        self.sinks, self.sources = tuple(sinks), tuple(sources)
        self.info, self.fifo_depth = bytes(info), fifo_depth
        self.gap_cycles, self.accept_cycles = gap_cycles, accept_cycles
        self.status_width = status_width
        # The payload buffer: the widest sink beat, and ECHO's.
        self.payload_bytes = max(echo_bytes, *map(P.beat_bytes, self.sinks))
        self.echo_bytes = self.payload_bytes
        members = {"rx": In(stream.Signature(8)), "rx_error": In(1), "tx": Out(stream.Signature(8)),
                   "core_rst": Out(1), "frame_ok": Out(1), "frame_error": Out(1)}
        for k, w in enumerate(self.sinks):
            members[f"sink_{k}"] = Out(stream.Signature(w))
        for k, w in enumerate(self.sources):
            members[f"source_{k}"] = In(stream.Signature(w))
        if status_width:
            members["status"] = In(status_width)
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        PB = self.payload_bytes
        status_bytes = P.beat_bytes(self.status_width)
        word_bytes = max(PB, status_bytes, 2, *map(P.beat_bytes, self.sources))

        # Receive: UART -> FIFO (a lost byte marks the next one) -> frames.
        # (buffered: a synchronous read port, so the FIFO maps to block RAM)
        m.submodules.fifo = fifo = SyncFIFOBuffered(width=9, depth=self.fifo_depth)
        m.submodules.frx = frx = FrameRx(PB, self.gap_cycles)
        lost = Signal()
        with m.If(self.rx_error):
            m.d.sync += lost.eq(1)
        with m.If(fifo.w_en & fifo.w_rdy):
            m.d.sync += lost.eq(self.rx_error)
        m.d.comb += [fifo.w_data.eq(Cat(self.rx.payload, lost)), fifo.w_en.eq(self.rx.valid),
                     self.rx.ready.eq(fifo.w_rdy),
                     frx.i_stream.valid.eq(fifo.r_rdy), frx.i_stream.payload.eq(fifo.r_data),
                     fifo.r_en.eq(frx.i_stream.ready)]

        # Transmit: replies first, then the sources' beats, as frames.
        m.submodules.ftx = ftx = FrameTx(word_bytes, self.info)
        wiring.connect(m, ftx.o_stream, wiring.flipped(self.tx))
        # The reply: its kind and length in registers; its payload straight
        # from the held frame (ECHO), the status word or the NAK's code and
        # command (the frame stays held until the transmitter took the reply).
        reply_valid = Signal()
        reply_kind, reply_rom = Signal(8), Signal()
        reply_len = Signal.like(ftx.i_stream.payload.length)
        reply_src = Signal(2)                   # the payload: 0 none / ROM, 1 ECHO, 2 status, 3 NAK
        nak_code = Signal(8)
        f = frx.o_stream.payload
        words = [0, frx.payload, self.status if self.status_width else 0, Cat(nak_code, f.cmd)]
        data_seq = [Signal(8, name=f"data_seq_{k}") for k in range(len(self.sources))]
        req = ftx.i_stream.payload
        m.d.comb += ftx.i_stream.valid.eq(reply_valid)
        with m.If(reply_valid):
            m.d.comb += [req.kind.eq(reply_kind), req.seq.eq(f.seq), req.length.eq(reply_len), req.rom.eq(reply_rom)]
            with m.Switch(reply_src):
                for i, word in enumerate(words):
                    with m.Case(i):
                        m.d.comb += req.word.eq(word)
        for k in reversed(range(len(self.sources))):     # the lowest number wins
            src = getattr(self, f"source_{k}")
            with m.If(~reply_valid & src.valid & ~Cat(getattr(self, f"source_{j}").valid for j in range(k)).any()):
                m.d.comb += [ftx.i_stream.valid.eq(1), req.kind.eq(P.DATA + k), req.seq.eq(data_seq[k]),
                             req.length.eq(P.beat_bytes(self.sources[k])), req.word.eq(src.payload),
                             src.ready.eq(ftx.i_stream.ready)]
                with m.If(ftx.i_stream.ready):
                    m.d.sync += data_seq[k].eq(data_seq[k] + 1)
        with m.If(ftx.i_stream.ready):
            m.d.sync += reply_valid.eq(0)

        # Execute one request at a time.
        sink_k = Signal(range(max(2, len(self.sinks))))     # (a zero-width signal is not Verilog)
        timer = Signal(range(self.accept_cycles + 1))

        def answer(kind, length=0, src=0, rom=0):
            m.d.sync += [reply_valid.eq(1), reply_kind.eq(kind), reply_len.eq(length), reply_src.eq(src),
                         reply_rom.eq(rom)]

        def ack(**kw):
            answer(P.ACK | f.cmd, **kw)
            m.d.sync += self.frame_ok.eq(1)

        def nak(error):
            answer(P.NAK, length=2, src=3)
            m.d.sync += [nak_code.eq(error), self.frame_error.eq(1)]

        m.d.sync += [self.core_rst.eq(0), self.frame_ok.eq(0), self.frame_error.eq(0)]
        with m.FSM():
            with m.State("IDLE"):
                with m.If(frx.o_stream.valid):
                    m.next = "REPLY"
                    with m.If(f.error != 0):
                        nak(f.error)
                    with m.Elif(f.cmd == P.Cmd.INFO):
                        with m.If(f.length == 0):
                            ack(length=len(self.info), rom=1)
                        with m.Else():
                            nak(P.Error.BAD_LENGTH)
                    with m.Elif(f.cmd == P.Cmd.ECHO):
                        with m.If(f.length <= PB):
                            ack(length=f.length, src=1)
                        with m.Else():
                            nak(P.Error.BAD_LENGTH)
                    with m.Elif(f.cmd == P.Cmd.STATUS):
                        with m.If(f.length == 0):
                            ack(length=status_bytes, src=2)
                        with m.Else():
                            nak(P.Error.BAD_LENGTH)
                    with m.Elif(f.cmd == P.Cmd.RESET):
                        with m.If(f.length == 0):
                            ack()
                            m.d.sync += [self.core_rst.eq(1), *(s.eq(0) for s in data_seq)]
                        with m.Else():
                            nak(P.Error.BAD_LENGTH)
                    for k, w in enumerate(self.sinks):
                        with m.Elif(f.cmd == P.WRITE + k):
                            with m.If(f.length == P.beat_bytes(w)):
                                m.d.sync += [sink_k.eq(k), timer.eq(self.accept_cycles - 1)]
                                m.next = "DELIVER"
                            with m.Else():
                                nak(P.Error.BAD_LENGTH)
                    with m.Else():
                        nak(P.Error.UNKNOWN_CMD)
            with m.State("DELIVER"):
                # The beat is held on the sink until taken or the timeout.
                m.d.sync += timer.eq(timer - 1)
                taken = Signal()
                with m.Switch(sink_k):
                    for k, w in enumerate(self.sinks):
                        with m.Case(k):
                            sink = getattr(self, f"sink_{k}")
                            m.d.comb += [sink.valid.eq(1), sink.payload.eq(frx.payload[:w]),
                                         taken.eq(sink.ready)]
                with m.If(taken):
                    ack()
                    m.next = "REPLY"
                with m.Elif(timer == 0):
                    nak(P.Error.CORE_TIMEOUT)
                    m.next = "REPLY"
            with m.State("REPLY"):
                # The transmitter latched the reply (the buffer is free): next frame.
                with m.If(~reply_valid):
                    m.d.comb += frx.o_stream.ready.eq(1)
                    m.next = "IDLE"
        return m
