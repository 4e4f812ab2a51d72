"""A DRAM behind a native user port, under cocotb: what sits on the tile engine's ``dram`` port.

The tile engine with ``store="dram"`` (hdl/edt_bfs/tile_engine.py) keeps
the map's per-pixel state in a DRAM through
:class:`~hdl.edt_bfs.dram_store.DramStore` and a controller's native port
(:func:`~hdl.edt_bfs.dram_store.NativePortSignature`: LiteDRAM's ``cmd``,
``wdata``, ``rdata``; ``dram_ports`` of them).  :class:`NativeDram` plays
controller and DRAM on the stream driver (sim/rtl/stream.py): on each port
``dram__<i>`` a sink on ``cmd``, a sink on ``wdata``, a source on
``rdata``, each port with its own timing; the words in one dict.  It keeps
the ports' contract and nothing more:

* a write command takes the next ``wdata`` beat, whose byte enables say
  which bytes change; ``wdata.ready`` is high only while a write waits for
  its beat (LiteDRAM's native port asks for the data after the command)
  and no command is accepted meanwhile (the controller's back-pressure),
  so a read sees every write accepted before it;
* a word never written reads as random bits;
* a word is served by one port only: the port its address's bank bits
  name (:data:`~hdl.edt_bfs.dram_store.BANK_AT`; the store's routing,
  checked), so a read sees every write to its word before it;
* a port's answers come in its command order, ``latency`` cycles after the command at
  least, plus a random extra (``extra``: geometric per cycle), and
  ``stall`` holds ``cmd.ready`` and ``wdata.ready`` low at random (a
  DRAM's row misses and refresh).
"""

import itertools
from collections import Counter

from navcores.hdl.edt_bfs.dram_store import BANK_AT

from .state_store import AnswerTiming
from .stream import Streams, pauses

__all__ = ["NativeDram", "native_ports"]


def native_ports(dut):
    """The native user ports on ``dut``'s top: ``dram__0__cmd`` ... (0 if none)."""
    return next(i for i in itertools.count() if not hasattr(dut, f"dram__{i}__cmd__valid"))


class _Port:
    """One native port ``name`` of the DRAM: its streams, its answers' timing, its stalls."""

    def __init__(self, dram, streams, name, index):
        self.dram, self.index = dram, index
        self.timing = AnswerTiming(streams, dram.rng, 4)
        self._awaiting = []             # addresses of accepted writes whose beat has not come
        self._stall_cmd = self._stall_data = itertools.repeat(False)
        self.cmd = streams.sink(f"{name}__cmd", pause=self._cmd_pause())
        self.wdata = streams.sink(f"{name}__wdata", pause=self._data_pause())
        self.rdata = streams.source(f"{name}__rdata", pause=self.timing.pause())
        self.cmd.callback = self._on_cmd
        self.wdata.callback = self._on_data

    def set_timing(self, latency, extra, stall):
        self.timing.set(latency, extra)
        self._stall_cmd = pauses(self.dram.rng, stall) or itertools.repeat(False)
        self._stall_data = pauses(self.dram.rng, stall) or itertools.repeat(False)

    def _cmd_pause(self):
        while True:
            yield bool(self._awaiting) | next(self._stall_cmd)

    def _data_pause(self):
        while True:
            yield (not self._awaiting) | next(self._stall_data)

    def _on_cmd(self, cycle, value):
        d = self.dram
        addr, we = value & d.addr_mask, value >> d.addr_mask.bit_length()
        port = (addr >> BANK_AT) & (len(d.ports) - 1)
        assert port == self.index, f"word {addr:#x} (port {port}) came on port {self.index} at cycle {cycle}"
        if we:
            d.writes += 1
            d.write_at[addr] += 1
            self._awaiting.append(addr)
            return
        self.timing.schedule(cycle)
        self.rdata.put(d.word(addr))
        d.reads += 1
        d.read_at[addr] += 1

    def _on_data(self, cycle, value):
        assert self._awaiting, f"a write data beat at cycle {cycle} before its command"
        self.dram.write(self._awaiting.pop(0), value)


class NativeDram:
    """The DRAM on ``dut``'s ``dram`` ports (``ports`` of them): ``data_width``
    bits a word, ``addr_width`` address bits, clocked by ``clock`` (default
    ``dut.clk``).

    ``rng``: a ``random.Random``.  ``reads`` / ``writes`` count the commands
    served (``read_at``, ``write_at``: by address), ``late`` the answers that waited beyond ``latency``, ``paused``
    the cycles a port held ``cmd`` or ``wdata`` back, ``held_back`` those it
    found an answer not taken, ``answered`` the answers taken.  Its streams
    have a :class:`~.stream.Streams` of their own without a reset: the
    controller and the DRAM are not reset with the engine (the answers in
    flight still come, a write's data beat is still taken)."""

    def __init__(self, dut, data_width, addr_width, rng, clock=None, ports=1):
        assert ports & (ports - 1) == 0, ports
        self.dw, self.rng = data_width, rng
        self.streams = streams = Streams(dut, clock=clock, reset=None)
        self.words = {}
        self.reads = self.writes = 0
        self.read_at = Counter()
        self.write_at = Counter()
        self.addr_mask = (1 << addr_width) - 1
        self.ports = [_Port(self, streams, f"dram__{i}", i) for i in range(ports)]

    def set_timing(self, latency=4, extra=0.0, stall=0.0):
        """Answers ``latency`` cycles after the command (at least 1), plus with
        probability ``extra`` per cycle one more; ``cmd`` and ``wdata`` not ready
        with probability ``stall`` each cycle; on every port."""
        for p in self.ports:
            p.set_timing(latency, extra, stall)

    @property
    def late(self):
        return sum(p.timing.late for p in self.ports)

    @property
    def paused(self):
        return sum(p.cmd.paused + p.wdata.paused for p in self.ports)

    @property
    def held_back(self):
        return sum(p.rdata.stalls for p in self.ports)

    @property
    def answered(self):
        return sum(len(p.rdata.beats) for p in self.ports)

    def word(self, addr):
        if addr not in self.words:
            self.words[addr] = self.rng.getrandbits(self.dw)
        return self.words[addr]

    def write(self, addr, value):
        """A write's data beat ``value`` (data, then a byte enable each byte) to word ``addr``."""
        data, we = value & ((1 << self.dw) - 1), value >> self.dw
        mask = sum(0xFF << (8 * i) for i in range(self.dw // 8) if we >> i & 1)
        self.words[addr] = (self.word(addr) & ~mask) | (data & mask)

    def reset(self):
        """The engine was reset: nothing here is (see the class)."""
