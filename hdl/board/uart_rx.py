"""UART receiver: 8 data bits, no parity, one stop bit (8N1), LSB first."""

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..params import Param, check

__all__ = ["UartRx", "MIN_DIVISOR", "MAX_DIVISOR"]

MIN_DIVISOR = 4             # mid-bit sampling needs a few clocks a bit
MAX_DIVISOR = 1 << 20       # 1 Mbit/s and 9600 Bd on any board clock below 10 GHz


class UartRx(wiring.Component):
    """UART receiver (8N1) of ``divisor`` clocks a bit.

    Ports
    -----
    rx : In(1)
        The line (idle high), asynchronous: two flip-flops synchronize it.
    o_stream : Out(stream of 8 bits)
        One beat per byte received; ``valid`` holds until ``ready``.
    error : Out(1)
        One-cycle strobe: a byte was lost, because its stop bit was low
        (framing error, also a break) or because the previous byte had not
        been taken when it ended (overrun: the new byte is dropped).

    Timing: a start bit is a low level seen half a bit after the falling
    edge (a shorter glitch is ignored); each data bit is sampled in its
    middle; the byte is offered at the middle of the stop bit, and the
    receiver looks for the next start bit from there (half a bit of slack
    for a transmitter that runs up to 5 % faster).  After a framing error it
    waits for the line to go high again, so a break gives one error.
    """

    PARAMS = (Param("divisor", int, lo=MIN_DIVISOR, hi=MAX_DIVISOR, doc="clocks per bit"),)

    def __init__(self, divisor):
        check(self.PARAMS, divisor=divisor)
        self.divisor = divisor
        super().__init__({"rx": In(1, init=1), "o_stream": Out(stream.Signature(8)), "error": Out(1)})

    def elaborate(self, platform):
        m = Module()
        d = self.divisor
        sync1, line = Signal(init=1), Signal(init=1)
        m.d.sync += [sync1.eq(self.rx), line.eq(sync1)]
        timer = Signal(range(d))
        bit = Signal(range(9))
        shift = Signal(8)
        with m.If(self.o_stream.ready):
            m.d.sync += self.o_stream.valid.eq(0)
        m.d.sync += self.error.eq(0)
        with m.FSM():
            with m.State("IDLE"):
                with m.If(~line):
                    m.d.sync += timer.eq(d // 2 - 1)
                    m.next = "START"
            with m.State("START"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    with m.If(line):
                        m.next = "IDLE"                 # a glitch, not a start bit
                    with m.Else():
                        m.d.sync += [timer.eq(d - 1), bit.eq(0)]
                        m.next = "DATA"
            with m.State("DATA"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    m.d.sync += [timer.eq(d - 1), shift.eq(Cat(shift[1:], line)), bit.eq(bit + 1)]
                    with m.If(bit == 7):
                        m.next = "STOP"
            with m.State("STOP"):
                m.d.sync += timer.eq(timer - 1)
                with m.If(timer == 0):
                    with m.If(~line):
                        m.d.sync += self.error.eq(1)   # framing error: the byte is dropped
                        m.next = "BREAK"
                    with m.Elif(self.o_stream.valid & ~self.o_stream.ready):
                        m.d.sync += self.error.eq(1)   # overrun: the byte before is still there
                        m.next = "IDLE"
                    with m.Else():
                        m.d.sync += [self.o_stream.valid.eq(1), self.o_stream.payload.eq(shift)]
                        m.next = "IDLE"
            with m.State("BREAK"):
                with m.If(line):
                    m.next = "IDLE"
        return m
