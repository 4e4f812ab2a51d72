"""UART transmitter: 8 data bits, no parity, one stop bit (8N1), LSB first."""

from amaranth.hdl import Cat, Const, Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..params import check
from .uart_rx import UartRx

__all__ = ["UartTx"]


class UartTx(wiring.Component):
    """UART transmitter (8N1) of ``divisor`` clocks a bit.

    Ports
    -----
    i_stream : In(stream of 8 bits)
        A byte is taken when the previous one's stop bit has been sent
        (``ready`` high while idle); bytes given back to back leave back to
        back, 10 bits each.
    tx : Out(1)
        The line, from a flip-flop; high (idle) after reset.
    """

    PARAMS = UartRx.PARAMS

    def __init__(self, divisor):
        check(self.PARAMS, divisor=divisor)
        self.divisor = divisor
        super().__init__({"i_stream": In(stream.Signature(8)), "tx": Out(1, init=1)})

    def elaborate(self, platform):
        m = Module()
        d = self.divisor
        timer = Signal(range(d))
        bits = Signal(range(11))            # bits still to send, the one on the line included
        shift = Signal(9, init=0x1FF)       # the bits after the one on the line (LSB next)
        m.d.comb += self.i_stream.ready.eq(bits == 0)
        with m.If(self.i_stream.valid & self.i_stream.ready):
            m.d.sync += [self.tx.eq(0), shift.eq(Cat(self.i_stream.payload, Const(1, 1))),
                         bits.eq(10), timer.eq(d - 1)]
        with m.Elif(bits != 0):
            m.d.sync += timer.eq(timer - 1)
            with m.If(timer == 0):
                m.d.sync += [self.tx.eq(shift[0]), shift.eq(Cat(shift[1:], Const(1, 1))),
                             bits.eq(bits - 1), timer.eq(d - 1)]
        return m
