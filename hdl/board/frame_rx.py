"""Frame receiver: line bytes -> checked frames (SLIP, CRC-16, gap timeout)."""

from amaranth.hdl import Cat, Module, Mux, Signal, Value
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, check
from . import protocol as P

__all__ = ["FrameRx", "byte_layout", "frame_layout", "crc16_next"]


def crc16_next(crc, byte):
    """CRC-16/CCITT-FALSE of ``crc`` after ``byte`` (:func:`protocol.crc16_update`):
    the register's eight shifts are linear, so each new bit is the XOR of
    the bits of ``crc ^ byte << 8`` in its row of the matrix whose columns
    are :func:`protocol.crc16_shift8` of the unit vectors."""
    c = Value.cast(crc ^ (byte << 8))[:16]
    cols = [P.crc16_shift8(1 << i) for i in range(16)]
    return Cat(*[Cat(*[c[i] for i in range(16) if cols[i] >> j & 1]).xor() for j in range(16)])


def byte_layout():
    """A received byte; ``lost``: bytes were lost on the line just before it."""
    return data.StructLayout({"data": 8, "lost": 1})


def frame_layout(payload_bytes):
    """A frame's descriptor: ``error`` (0 or a :class:`protocol.Error`),
    ``cmd`` and ``seq`` as received, ``length`` the payload's bytes
    (``payload_bytes + 1``: longer than the buffer)."""
    return data.StructLayout({"error": 3, "cmd": 8, "seq": 8, "length": range(payload_bytes + 2)})


class FrameRx(wiring.Component):
    """Turns line bytes into frames: SLIP unescaping, CRC check, length,
    and a gap timeout inside a frame.

    Ports
    -----
    i_stream : In(stream of :func:`byte_layout`)
        Bytes from the UART (through the bridge's FIFO).  Taken one a cycle
        while no frame is held.
    o_stream : Out(stream of :func:`frame_layout`)
        One beat per frame, held until taken; ``error``: LINE (a byte before
        or in it was lost), TRUNCATED (fewer than 4 body bytes, or no byte for
        ``gap_cycles`` inside it), BAD_CRC, else 0.  Empty frames (``END
        END``) give no beat.
    payload : Out(8 * payload_bytes)
        The frame's payload bytes (byte i at bits 8i..8i+7, little-endian
        for a beat; beyond ``length`` undefined), stable while the frame is
        held.

    Parameters: ``payload_bytes`` (the buffer; a longer payload sets
    ``length = payload_bytes + 1``), ``gap_cycles`` (the truncation timeout).
    """

    PARAMS = (Param("payload_bytes", int, lo=1, hi=4096, doc="payload buffer bytes"),
              Param("gap_cycles", int, lo=2, hi=1 << 32, doc="truncation timeout (clocks without a byte)"))

    def __init__(self, payload_bytes, gap_cycles):
        check(self.PARAMS, payload_bytes=payload_bytes, gap_cycles=gap_cycles)
        self.payload_bytes, self.gap_cycles = payload_bytes, gap_cycles
        super().__init__({
            "i_stream": In(stream.Signature(byte_layout())),
            "o_stream": Out(stream.Signature(frame_layout(payload_bytes))),
            "payload": Out(8 * payload_bytes),
        })

    def elaborate(self, platform):
        m = Module()
        PB = self.payload_bytes
        store = PB + 2                          # the payload and the CRC's two bytes
        count = Signal(range(store + 4))        # body bytes so far; saturates at store + 3 (too long)
        esc, lost = Signal(), Signal()
        crc = Signal(16, init=P.CRC_INIT)
        cmd, seq = Signal(8), Signal(8)
        buf = [Signal(8, name=f"buf{i}") for i in range(store)]
        gap = Signal(range(self.gap_cycles))
        m.d.comb += self.payload.eq(Cat(*buf[:PB]))

        beat, out = self.i_stream.payload, self.o_stream.payload
        take = Signal()
        m.d.comb += [self.i_stream.ready.eq(~self.o_stream.valid),
                     take.eq(self.i_stream.valid & self.i_stream.ready)]
        with m.If(self.o_stream.ready):
            m.d.sync += self.o_stream.valid.eq(0)
        open_ = (count != 0) | esc | lost       # inside a frame
        lost_now = lost | (take & beat.lost)

        def finish(timed_out=False):
            """Hand the frame over and start afresh."""
            short = count < P.MIN_BODY
            error = Mux(lost_now, P.Error.LINE,
                        Mux(short | timed_out, P.Error.TRUNCATED, Mux(crc != 0, P.Error.BAD_CRC, 0)))
            m.d.sync += [
                self.o_stream.valid.eq(1), out.error.eq(error), out.cmd.eq(cmd), out.seq.eq(seq),
                out.length.eq(Mux(short, 0, Mux(count > store + 2, PB + 1, count - P.MIN_BODY))),
                count.eq(0), esc.eq(0), lost.eq(0), crc.eq(P.CRC_INIT), gap.eq(0),
            ]

        with m.If(take):
            m.d.sync += [gap.eq(0), lost.eq(lost_now)]
            with m.If(beat.data == P.END):
                with m.If(open_ | beat.lost):
                    finish()
            with m.Elif(beat.data == P.ESC):
                m.d.sync += esc.eq(1)
            with m.Else():
                byte = Mux(esc & (beat.data == P.ESC_END), P.END,
                           Mux(esc & (beat.data == P.ESC_ESC), P.ESC, beat.data))
                m.d.sync += [esc.eq(0), crc.eq(crc16_next(crc, byte))]
                with m.If(count != store + 3):
                    m.d.sync += count.eq(count + 1)
                with m.Switch(count):
                    with m.Case(0):
                        m.d.sync += cmd.eq(byte)
                    with m.Case(1):
                        m.d.sync += seq.eq(byte)
                    for i in range(store):
                        with m.Case(i + 2):
                            m.d.sync += buf[i].eq(byte)
        with m.Elif(open_ & ~self.o_stream.valid):
            m.d.sync += gap.eq(gap + 1)
            with m.If(gap == self.gap_cycles - 1):
                finish(timed_out=True)
        return m
