"""Frame transmitter: a frame request -> line bytes (CRC-16, SLIP escaping)."""

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..params import Param, check
from . import protocol as P
from .frame_rx import crc16_next

__all__ = ["FrameTx", "request_layout"]


def request_layout(word_bytes, rom_bytes):
    """A frame to send: ``kind`` and ``seq`` (the body's first two bytes),
    ``length`` payload bytes taken from ``word`` (byte i at bits 8i..8i+7)
    or, with ``rom``, from the ROM."""
    return data.StructLayout({"kind": 8, "seq": 8, "length": range(max(word_bytes, rom_bytes) + 1),
                              "rom": 1, "word": 8 * word_bytes})


class FrameTx(wiring.Component):
    """Sends one frame per request: ``END``, the body (kind, seq, payload)
    and its CRC-16 with ``END`` / ``ESC`` escaped, ``END``
    (:mod:`.protocol`).

    Ports
    -----
    i_stream : In(stream of :func:`request_layout`)
        Taken (and latched whole) when the previous frame's last byte has
        been handed to ``o_stream``.
    o_stream : Out(stream of 8 bits)
        The line bytes, for the UART transmitter.
    busy : Out(1)
        A frame is being sent.

    Parameters: ``word_bytes`` (the largest payload from ``word``), ``rom``
    (the bytes of the ROM payload, e.g. the INFO text).
    """

    PARAMS = (Param("word_bytes", int, lo=1, hi=4096, doc="largest payload from the request's word"),)

    def __init__(self, word_bytes, rom=b""):
        check(self.PARAMS, word_bytes=word_bytes)
        self.word_bytes, self.rom = word_bytes, bytes(rom) or b"\0"
        super().__init__({
            "i_stream": In(stream.Signature(request_layout(word_bytes, len(self.rom)))),
            "o_stream": Out(stream.Signature(8)),
            "busy": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        req = Signal(self.i_stream.payload.shape())
        word = Signal(8 * self.word_bytes)
        crc = Signal(16)
        index = Signal(range(max(self.word_bytes, len(self.rom)) + 6))   # the frame's byte (see below)
        esc = Signal()                   # the ESC of an escaped byte has gone: its code is next
        m.submodules.rom = rom = Memory(shape=8, depth=len(self.rom), init=list(self.rom))
        rd = rom.read_port()             # synchronous: addressed a cycle ahead (see ``done``)

        cur, raw = Signal(8), Signal()
        m.d.comb += self.i_stream.ready.eq(~self.busy)
        with m.If(self.i_stream.valid & self.i_stream.ready):
            m.d.sync += [req.eq(self.i_stream.payload), word.eq(self.i_stream.payload.word),
                         crc.eq(P.CRC_INIT), index.eq(0), esc.eq(0), self.busy.eq(1)]

        need_esc = ~raw & ((cur == P.END) | (cur == P.ESC))
        m.d.comb += [
            self.o_stream.payload.eq(Mux(esc, Mux(cur == P.END, P.ESC_END, P.ESC_ESC), Mux(need_esc, P.ESC, cur))),
        ]
        sent = self.o_stream.valid & self.o_stream.ready
        done = Signal()                  # the current byte has gone (with its escape)
        m.d.comb += done.eq(sent & (esc | ~need_esc))
        with m.If(sent):
            m.d.sync += esc.eq(need_esc & ~esc)

        # The frame as a sequence: 0 END, 1 kind, 2 seq, 3 .. L+2 payload,
        # L+3 / L+4 the CRC's bytes, L+5 END.
        last = req.length + 5
        payload_i = index - 3            # the payload byte's number while 3 <= index < L + 3
        m.d.comb += rd.addr.eq(Mux(done, payload_i + 1, payload_i))
        with m.If(index == 0):
            m.d.comb += [cur.eq(P.END), raw.eq(1)]
        with m.Elif(index == 1):
            m.d.comb += cur.eq(req.kind)
        with m.Elif(index == 2):
            m.d.comb += cur.eq(req.seq)
        with m.Elif(index < req.length + 3):
            m.d.comb += cur.eq(Mux(req.rom, rd.data, word[:8]))
        with m.Elif(index == req.length + 3):
            m.d.comb += cur.eq(crc[8:])
        with m.Elif(index == req.length + 4):
            m.d.comb += cur.eq(crc[:8])
        with m.Else():
            m.d.comb += [cur.eq(P.END), raw.eq(1)]
        m.d.comb += self.o_stream.valid.eq(self.busy)

        with m.If(done):
            m.d.sync += index.eq(index + 1)
            with m.If((index >= 1) & (index < req.length + 3)):
                m.d.sync += crc.eq(crc16_next(crc, cur))
            with m.If((index >= 3) & (index < req.length + 3)):
                m.d.sync += word.eq(word >> 8)
            with m.If(index == last):
                m.d.sync += self.busy.eq(0)
        return m
