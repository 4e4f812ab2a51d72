"""A DRAM behind a native user port, under cocotb: what sits on the tile engine's ``dram`` port.

The tile engine with ``store="dram"`` (hdl/edt_bfs/tile_engine.py) keeps
the map's per-pixel state in a DRAM through
:class:`~hdl.edt_bfs.dram_store.DramStore` and a controller's native port
(:func:`~hdl.edt_bfs.dram_store.NativePortSignature`: LiteDRAM's ``cmd``,
``wdata``, ``rdata``).  :class:`NativeDram` plays controller and DRAM on the
stream driver (sim/rtl/stream.py): a sink on ``dram__cmd``, a sink on
``dram__wdata``, a source on ``dram__rdata``; the words in a dict.  It
keeps the port's contract and nothing more:

* a write command takes the next ``wdata`` beat, whose byte enables say
  which bytes change; ``wdata.ready`` is high only while a write waits for
  its beat (LiteDRAM's native port asks for the data after the command)
  and no command is accepted meanwhile (the controller's back-pressure),
  so a read sees every write accepted before it;
* a word never written reads as random bits;
* answers come in command order, ``latency`` cycles after the command at
  least, plus a random extra (``extra``: geometric per cycle), and
  ``stall`` holds ``cmd.ready`` and ``wdata.ready`` low at random (a
  DRAM's row misses and refresh).
"""

import itertools

from .state_store import AnswerTiming
from .stream import Streams, pauses

__all__ = ["NativeDram"]


class NativeDram:
    """The DRAM on ``dut``'s ``dram`` port: ``data_width`` bits a word, ``addr_width`` address bits,
    clocked by ``clock`` (default ``dut.clk``).

    ``rng``: a ``random.Random``.  ``reads`` / ``writes`` count the commands
    served, ``late`` the answers that waited beyond ``latency``.  Its
    streams have a :class:`~.stream.Streams` of their own without a reset:
    the controller and the DRAM are not reset with the engine (the answers
    in flight still come, a write's data beat is still taken)."""

    def __init__(self, dut, data_width, addr_width, rng, clock=None):
        self.dw, self.rng = data_width, rng
        self.streams = streams = Streams(dut, clock=clock, reset=None)
        self.words = {}
        self.timing = AnswerTiming(streams, rng, 4)
        self.reads = self.writes = 0
        self.stall = 0.0
        self._awaiting = []             # addresses of accepted writes whose beat has not come
        self._addr_mask = (1 << addr_width) - 1
        self._stall_cmd = self._stall_data = itertools.repeat(False)
        self.cmd = streams.sink("dram__cmd", pause=self._cmd_pause())
        self.wdata = streams.sink("dram__wdata", pause=self._data_pause())
        self.rdata = streams.source("dram__rdata", pause=self.timing.pause())
        self.cmd.callback = self._on_cmd
        self.wdata.callback = self._on_data

    def set_timing(self, latency=4, extra=0.0, stall=0.0):
        """Answers ``latency`` cycles after the command (at least 1), plus with
        probability ``extra`` per cycle one more; ``cmd`` and ``wdata`` not ready
        with probability ``stall`` each cycle."""
        self.timing.set(latency, extra)
        self.stall = stall
        self._stall_cmd = pauses(self.rng, stall) or itertools.repeat(False)
        self._stall_data = pauses(self.rng, stall) or itertools.repeat(False)

    def _cmd_pause(self):
        while True:
            yield bool(self._awaiting) | next(self._stall_cmd)

    def _data_pause(self):
        while True:
            yield (not self._awaiting) | next(self._stall_data)

    @property
    def late(self):
        return self.timing.late

    def _word(self, addr):
        if addr not in self.words:
            self.words[addr] = self.rng.getrandbits(self.dw)
        return self.words[addr]

    def _on_cmd(self, cycle, value):
        addr, we = value & self._addr_mask, value >> self._addr_mask.bit_length()
        if we:
            self.writes += 1
            self._awaiting.append(addr)
            return
        self.timing.schedule(cycle)
        self.rdata.put(self._word(addr))
        self.reads += 1

    def _on_data(self, cycle, value):
        assert self._awaiting, f"a write data beat at cycle {cycle} before its command"
        addr = self._awaiting.pop(0)
        data, we = value & ((1 << self.dw) - 1), value >> self.dw
        mask = sum(0xFF << (8 * i) for i in range(self.dw // 8) if we >> i & 1)
        self.words[addr] = (self._word(addr) & ~mask) | (data & mask)

    def reset(self):
        """The engine was reset: nothing here is (see the class)."""
