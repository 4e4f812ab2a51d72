"""An external per-pixel state store under cocotb: what sits on a tile engine's ``state`` port.

The tile engine with ``store="external"`` (hdl/edt_bfs/tile_engine.py)
keeps the map's per-pixel state outside the FPGA (an SDRAM controller on a
board) and talks to it through
:class:`~hdl.edt_bfs.state_ram.StateSignature`'s three streams.
:class:`StateStore` plays that store on the stream driver (sim/rtl/stream.py):
a sink on ``state__rd`` (read commands), a source on ``state__rd_data``
(the answers, in command order) and a sink on ``state__wr`` (writes), and
keeps the words in a dict.  It honours the contract of StateSignature and
nothing more, so a test on it shows the engine relies on nothing more:

* an answer holds the word at the command's cycle with every write accepted
  in an earlier cycle applied (a write in the same cycle is not seen: the
  block RAM's read-before-write); the word's left and right neighbours'
  edge pixels beside it;
* a word never written (outside the map of every job so far, or beyond the
  widest map) reads as random bits: the engine must gate such pixels;
* the fields a read command does not ask for (its ``di`` / ``nnt`` /
  ``bfs`` bits) read as random bits: the engine must not use them;
* with :meth:`set_timing` ``latency`` 2 and no stalls it is
  :class:`~hdl.edt_bfs.state_ram.StateRam`'s timing (answers two cycles
  after the command, always ready), the cycle model's; ``extra`` adds a
  random latency to each answer and ``stall`` holds ``rd.ready`` and
  ``wr.ready`` low at random (an SDRAM's refresh and row misses).

Words are plain integers (no per-pixel unpacking: a job moves thousands of
them); field offsets come from the layouts in hdl/edt_bfs/state_ram.py.
"""

from navcores.hdl.edt_bfs.state_ram import read_data_layout, read_layout, write_layout
from navcores.hdl.edt_bfs.tile_layouts import EDT_FIELDS, BFS_FIELDS, pixel_layout

from .stream import pauses

__all__ = ["StateStore", "AnswerTiming"]


class AnswerTiming:
    """When a simulated store's answers may go (this store's, and
    sim/rtl/native_dram.py's): in command order, each ``latency`` cycles
    after its command at least, plus with probability ``extra`` per cycle
    one more (geometric); ``late`` counts the answers that waited beyond
    ``latency``.  :meth:`pause` is the answer source's pause generator
    (asked only when the source is about to present its next answer)."""

    def __init__(self, streams, rng, latency):
        self.streams, self.rng = streams, rng
        self.latency, self.extra, self.late = latency, 0.0, 0
        self._due = []                          # cycle each queued answer may be presented from

    def set(self, latency, extra):
        assert latency >= 1
        self.latency, self.extra = latency, extra

    def schedule(self, cycle):
        """An answer to a command of ``cycle``, queued behind the others."""
        delay = self.latency
        while self.extra and self.rng.random() < self.extra:
            delay += 1
        self.late += delay > self.latency
        self._due.append(max(cycle + delay, self._due[-1] if self._due else 0))

    def pause(self):
        while True:
            if self._due and self.streams.cycle < self._due[0]:
                yield True
            else:
                if self._due:
                    self._due.pop(0)
                yield False

    def clear(self):
        self._due.clear()


class StateStore:
    """The store on ``streams``' DUT's ``state`` port, for engine widths ``w`` and ``p`` pixels a word.

    ``rng``: a ``random.Random`` (the unwritten words' bits, the random
    timing).  ``reads`` / ``writes`` count the commands served
    (``full_reads`` the reads of every field: the path's and the read-out's);
    ``late`` the answers that waited beyond ``latency``."""

    def __init__(self, streams, w, p, rng):
        self.streams, self.p, self.rng = streams, p, rng
        px = pixel_layout(w)
        self.px = px.size
        self.word_bits = px.size * p
        wl = write_layout(w, p)
        self._wf = {name: (wl[name].offset, wl[name].width) for name in ("row", "wcol", "edt", "bfs", "word")}
        rl = read_layout(w)
        self._rf = {name: (rl[name].offset, rl[name].width) for name in ("row", "wcol", "di", "nnt", "bfs")}
        dl = read_data_layout(w, p)
        self._word_at, self._right_at = dl["word"].offset, dl["right"].offset
        assert dl["left"].offset == 0

        def group_mask(fields, pixels=p):
            one = sum(((1 << px[f].width) - 1) << px[f].offset for f in fields)
            return sum(one << (j * px.size) for j in range(pixels))
        self._mask = {"edt": group_mask(EDT_FIELDS), "bfs": group_mask(BFS_FIELDS)}
        # the fields of a read command's groups, over the answer's p + 2 pixels (left, word, right)
        self._read_mask = {g: group_mask(fields, p + 2)
                           for g, fields in (("di", ("di",)), ("nnt", ("dx", "dy")), ("bfs", BFS_FIELDS))}
        self.words = {}
        self._pending_writes = []               # (cycle, row, wcol, edt, bfs, word) not applied yet
        self.timing = AnswerTiming(streams, rng, 2)
        self.reads = self.writes = self.full_reads = 0
        self.stall = 0.0
        self.rd = streams.sink("state__rd")
        self.wr = streams.sink("state__wr")
        self.rd_data = streams.source("state__rd_data", pause=self.timing.pause())
        self.rd.callback = self._on_read
        self.wr.callback = self._on_write

    def set_timing(self, latency=2, extra=0.0, stall=0.0):
        """Answers ``latency`` cycles after the command (at least 1), plus
        with probability ``extra`` per cycle one more (geometric); ``rd``
        and ``wr`` not ready with probability ``stall`` each cycle."""
        self.timing.set(latency, extra)
        self.stall = stall
        self.rd.set_pause(pauses(self.rng, stall))
        self.wr.set_pause(pauses(self.rng, stall))

    @property
    def late(self):
        return self.timing.late

    def _field(self, word, where):
        off, width = where
        return (word >> off) & ((1 << width) - 1)

    def _word(self, row, wcol):
        if (row, wcol) not in self.words:           # never written: don't-care bits
            self.words[row, wcol] = self.rng.getrandbits(self.word_bits)
        return self.words[row, wcol]

    def _apply_writes(self, before):
        keep = []
        for item in self._pending_writes:
            cycle, row, wcol, edt, bfs, word = item
            if cycle >= before:
                keep.append(item)
                continue
            mask = (self._mask["edt"] if edt else 0) | (self._mask["bfs"] if bfs else 0)
            self.words[row, wcol] = (self._word(row, wcol) & ~mask) | (word & mask)
        self._pending_writes = keep

    def _on_write(self, cycle, value):
        f = {k: self._field(value, v) for k, v in self._wf.items()}
        self._pending_writes.append((cycle, f["row"], f["wcol"], f["edt"], f["bfs"], f["word"]))
        self.writes += 1

    def _on_read(self, cycle, value):
        self._apply_writes(cycle)
        row, wcol = self._field(value, self._rf["row"]), self._field(value, self._rf["wcol"])
        last = self.px * (self.p - 1)
        left = self._word(row, wcol - 1) >> last if wcol > 0 else self.rng.getrandbits(self.px)
        right = self._word(row, wcol + 1) & ((1 << self.px) - 1)
        answer = left | (self._word(row, wcol) << self._word_at) | (right << self._right_at)
        # the fields the command does not ask for are don't-care: random, so the engine's use of one fails
        asked = sum(m for g, m in self._read_mask.items() if self._field(value, self._rf[g]))
        answer = (answer & asked) | (self.rng.getrandbits(self.px * (self.p + 2)) & ~asked)
        self.timing.schedule(cycle)
        self.rd_data.put(answer)
        self.reads += 1
        self.full_reads += all(self._field(value, self._rf[g]) for g in ("di", "nnt", "bfs"))

    def reset(self):
        """The engine was reset: the answers in flight are dropped (the source's queue is cleared by
        the stream driver); accepted writes stay written."""
        self.timing.clear()
