"""The one valid/ready stream driver of the project: every core's cocotb driver is built on it.

A core's streams are ``amaranth.lib.stream`` interfaces, flattened in the
emitted Verilog to ``<name>__valid``, ``<name>__ready`` and
``<name>__payload`` (the payload a ``data.Layout``: a StructLayout, an
ArrayLayout or a plain shape).  This module drives them from cocotb::

    from navcores.sim.rtl.stream import Streams, pauses
    streams = Streams(dut)                          # clock dut.clk, reset dut.rst
    cmd = streams.source("c_stream", command_layout, pause=pauses(rng, 0.3))
    res = streams.sink("o_stream", result_layout, pause=pauses(rng, 0.5))
    cmd.put({"op": Op.START, "iters": 3})           # queue (packed by the layout)
    beat = await res.recv()                         # {"code": Code.OK, ...}
    res.beats                                       # [(cycle, value)] of every handshake
    res.stalls, cmd.idle                            # cycles valid & !ready, idle cycles

* :class:`StreamSource` presents the values queued with ``put`` / ``extend``
  one after the other and holds each (valid high, payload stable) until the
  handshake; its pause generator inserts idle cycles (valid low) before a
  value; its ``beats`` record what was taken, with the cycle.
* :class:`StreamSink` drives ``ready``: high unless its pause generator
  says pause (random back-pressure); it queues what it takes for ``recv`` /
  ``take``, which wait for it.
* :class:`StreamMonitor` watches a stream it does not drive.  Sources and
  sinks are monitors too: each records ``beats``, the (cycle, value) of every
  handshake, and counts ``stalls``, the cycles with valid high and ready low.
  On a stream the DUT drives, a stalled beat that is dropped or changed
  before its handshake fails the test (:class:`StreamProtocolError`).
* A pause generator is any iterator of booleans, one per cycle (True:
  pause), as in cocotbext-axi; :func:`pauses` makes the seeded random one.
* Reset: while ``reset`` is high nothing is recorded, a source drops the
  value it is presenting (valid goes low; the rest of its queue waits for
  the end of the reset; ``clear`` drops it too) and a sink keeps going.
  :meth:`Streams.apply_reset` pulses the reset and starts every stream afresh.
* Cycles: :attr:`Streams.cycle` counts the rising edges of the clock since
  the :class:`Streams` was made (from the simulation time: no coroutine
  runs for it).  A beat's cycle is the cycle in which valid and ready were
  both high; the handshake takes effect at the rising edge that ends it, and
  ``recv`` / ``take`` / ``wait_beats`` return just after that edge.
* :func:`pack` / :func:`unpack`: values <-> payload words by any
  ``data.Layout`` (dicts for structs, lists for arrays, enum members for
  enum fields, signed fields signed): one packing for every core.

One coroutine runs all streams of a :class:`Streams` (two triggers per
cycle however many streams, as cheap as a hand-written loop), and only while
a source has something to send or a valid is high; otherwise it sleeps
until a value is queued or a valid rises, and the DUT runs with no Python in
the loop (a sink's ready holds its last value meanwhile).  So one
:class:`Streams` serves long sweeps at full rate, closed loops one sample at
a time, and long runs polled now and then.

Imports only cocotb and amaranth (a part of navcores.sim.rtl).
"""

import enum
import itertools
from collections import deque

import cocotb
from amaranth.hdl import Shape
from amaranth.lib import data
from cocotb.simtime import get_sim_time
from cocotb.triggers import ClockCycles, Event, First, ReadOnly, RisingEdge, Timer, current_gpi_trigger

from .clock import PERIOD_NS

__all__ = ["Streams", "StreamSource", "StreamSink", "StreamMonitor", "StreamProtocolError", "pauses", "pack",
           "unpack"]


# --- payloads -----------------------------------------------------------------

def pack(shape, value):
    """``value`` as the payload word of ``shape`` (a ``data.Layout`` or any
    shape-castable).  A struct takes a dict of its fields (fields left out
    are 0), an array a sequence of its elements, an enum field an enum
    member or its integer; an ``int`` is taken as the word itself.  Every
    field is cut to its width (two's complement for negative values)."""
    if isinstance(shape, data.Layout) and not isinstance(value, int):
        items = enumerate(value) if isinstance(shape, data.ArrayLayout) else value.items()
        word = 0
        for key, v in items:
            try:
                field = shape[key]
            except (KeyError, IndexError, TypeError):
                raise KeyError(f"{key!r} is not a field of {shape!r}") from None
            word |= pack(field.shape, v) << field.offset
        return word
    if isinstance(value, enum.Enum):
        value = value.value
    return int(value) & ((1 << Shape.cast(shape).width) - 1)


def unpack(shape, word):
    """The payload word of ``shape`` as values (:func:`pack`'s inverse): a
    dict for a struct, a list for an array, an enum member for an enum field
    (its integer when it names no member), a signed field signed."""
    if isinstance(shape, data.Layout):
        fields = {key: unpack(f.shape, (word >> f.offset) & ((1 << f.width) - 1)) for key, f in shape}
        return list(fields.values()) if isinstance(shape, data.ArrayLayout) else fields
    s = Shape.cast(shape)
    word &= (1 << s.width) - 1
    if s.signed and s.width and word >> (s.width - 1):
        word -= 1 << s.width
    if isinstance(shape, type) and issubclass(shape, enum.Enum):
        try:
            return shape(word)
        except ValueError:
            return word
    return word


def pauses(rng, p):
    """A pause generator: each cycle True (pause) with probability ``p``,
    drawn from ``rng`` (``random.Random`` or a numpy ``Generator``); None
    (never pause) for ``p`` = 0."""
    if not p:
        return None
    if p >= 1:
        return itertools.repeat(True)
    draw = rng.random
    return (draw() < p for _ in itertools.count())


# --- the streams of one DUT -----------------------------------------------------

class Streams:
    """The valid/ready streams of one DUT on one clock, run by one coroutine.

    ``dut``: the cocotb top; ``clock`` (default ``dut.clk``) and ``reset``
    (default ``dut.rst`` if there is one; None: no reset handling);
    ``prefix`` goes before every stream name (an instance of a test top with
    several cores).  Make the endpoints with :meth:`source`, :meth:`sink`
    and :meth:`monitor`; :meth:`stop` ends the coroutine (before another
    driver takes the same ports).
    """

    def __init__(self, dut, clock=None, reset=False, prefix="", period_ns=PERIOD_NS):
        self.dut, self.prefix, self.period_ns = dut, prefix, period_ns
        self.clock = dut.clk if clock is None else clock
        self.reset = getattr(dut, "rst", None) if reset is False else reset
        self.endpoints = []
        self.in_reset = False
        self._t0 = None                 # time of the first rising edge (cycle 1)
        self._wake = Event()
        self._notify = set()            # endpoints with a handshake to announce at the next edge
        self._sampled_at = None
        self._sleeping = False
        self._tasks = [cocotb.start_soon(self._run())]

    @property
    def cycle(self):
        """Rising edges of the clock since this object was made."""
        if self._t0 is None:
            return 0
        return int((get_sim_time("ns") - self._t0) / self.period_ns + 1e-6) + 1

    def source(self, name, layout=None, pause=None):
        """A :class:`StreamSource` on stream ``name`` (``i_stream`` ...)."""
        return self._add(StreamSource(self, name, layout, pause))

    def sink(self, name, layout=None, pause=None):
        """A :class:`StreamSink` on stream ``name``."""
        return self._add(StreamSink(self, name, layout, pause))

    def monitor(self, name, layout=None, callback=None):
        """A :class:`StreamMonitor` on stream ``name`` (driven by someone else)."""
        mon = self._add(StreamMonitor(self, name, layout))
        mon.callback = callback
        return mon

    async def apply_reset(self, cycles=2):
        """Pulse the synchronous reset: ``reset`` high for ``cycles`` clock
        cycles (a source presenting a value drops it, as at any reset), then
        every queue dropped and the records and counts started afresh;
        returns just after the first rising edge with ``reset`` low."""
        self.reset.value = 1
        await ClockCycles(self.clock, cycles)
        for e in self.endpoints:
            e.clear()
        self.reset.value = 0
        await RisingEdge(self.clock)

    def stop(self):
        """End the coroutines; sources drop everything (valid low)."""
        for task in self._tasks:
            task.cancel()
        for e in self.endpoints:
            e.clear()

    def _add(self, endpoint):
        self.endpoints.append(endpoint)
        if not isinstance(endpoint, StreamSource):      # a valid the DUT drives wakes the loop
            self._tasks.append(cocotb.start_soon(self._watch(endpoint.valid)))
        return endpoint

    async def _watch(self, valid):
        while True:
            await RisingEdge(valid)
            if self._sleeping:
                self._wake.set()

    async def _run(self):
        await RisingEdge(self.clock)
        self._t0 = get_sim_time("ns")
        while True:
            for e in self._notify:                  # handshakes of the cycle that just ended
                e._announce()
            self._notify.clear()
            for e in self.endpoints:
                e._drive(self.in_reset)
            while True:
                if not isinstance(current_gpi_trigger(), ReadOnly):
                    await ReadOnly()
                if self._sample() or self._notify:
                    break
                # Nothing to send and no valid high: sleep until a value is
                # queued or a valid rises, then sample that cycle at once (a
                # sink's ready holds its last value meanwhile).
                self._wake.clear()
                self._sleeping = True
                await self._wake.wait()
                self._sleeping = False
            await RisingEdge(self.clock)

    def _sample(self):
        now = get_sim_time("step")
        if now == self._sampled_at:                 # woken again in the same read-only phase
            return any(e._pending() for e in self.endpoints)
        self._sampled_at = now
        self.in_reset = self.reset is not None and self.reset.value == 1
        cycle = self.cycle
        busy = False
        for e in self.endpoints:
            busy |= e._sample(cycle, self.in_reset)
        return busy


class StreamProtocolError(AssertionError):
    """The DUT broke the stream rules: a stalled beat (valid high, ready
    low) must stay presented, payload unchanged, until its handshake."""


class StreamMonitor:
    """Watches one stream: ``beats`` holds (cycle, value) of every handshake
    (the payload unpacked by ``layout`` if one is given, else the word),
    ``stalls`` counts the cycles with valid high and ready low, ``callback``
    (if set) is called with (cycle, value) at each handshake.  A beat the
    DUT drops or changes while stalled raises :class:`StreamProtocolError`
    (outside reset), which fails the running cocotb test."""

    def __init__(self, streams, name, layout=None):
        dut, full = streams.dut, f"{streams.prefix}{name}"
        self.streams, self.name, self.layout = streams, full, layout
        self.valid = getattr(dut, f"{full}__valid")
        self.ready = getattr(dut, f"{full}__ready")
        self.payload = getattr(dut, f"{full}__payload")
        self.beats = []
        self.starts = []                            # cycle each beat's valid first rose (<= its beat's)
        self.stalls = 0
        self.callback = None
        self._start = None                          # cycle valid rose for the beat presented now
        self._waiters = []                          # (count, Event): until len(beats) >= count
        self._high = False
        self._held = None                           # (cycle, word) of a beat stalled in that cycle

    def clear(self):
        """Forget the beats and the counts."""
        self.beats.clear()
        self.starts.clear()
        self.stalls = 0
        self._start = None

    def _drive(self, in_reset):
        pass

    def _pending(self):
        return self._high

    def _ready_now(self):
        return self.ready.value == 1

    def _take(self, cycle, word):
        self._record(cycle, unpack(self.layout, word) if self.layout is not None else word)

    def _sample(self, cycle, in_reset):
        high = self.valid.value == 1
        held, self._held = self._held, None
        if high and not in_reset:
            if self._start is None:
                self._start = cycle
            word = int(self.payload.value)
            if held is not None and held[0] == cycle - 1 and word != held[1]:
                raise StreamProtocolError(f"{self.name}: payload changed at cycle {cycle} "
                                          f"while stalled ({held[1]:#x} -> {word:#x})")
            if self._ready_now():
                self.starts.append(self._start)
                self._start = None
                self._take(cycle, word)
            else:
                self.stalls += 1
                self._held = (cycle, word)
        elif held is not None and held[0] == cycle - 1 and not in_reset:
            raise StreamProtocolError(f"{self.name}: valid dropped at cycle {cycle} without a handshake")
        if not high or in_reset:
            self._start = None
        self._high = high
        return high

    def _record(self, cycle, value):
        self.beats.append((cycle, value))
        if self.callback is not None:
            self.callback(cycle, value)
        if self._waiters:
            self.streams._notify.add(self)

    def _announce(self):
        done = [w for w in self._waiters if len(self.beats) >= w[0]]
        for w in done:
            self._waiters.remove(w)
            w[1].set()

    async def wait_beats(self, count, timeout_cycles=None):
        """Until ``count`` handshakes have been recorded in all (returns just
        after the edge that takes the last); TimeoutError after
        ``timeout_cycles`` (None: no limit)."""
        if len(self.beats) >= count:
            return
        ev = Event()
        self._waiters.append((count, ev))
        if timeout_cycles is None:
            await ev.wait()
            return
        await First(ev.wait(), Timer(timeout_cycles * self.streams.period_ns, unit="ns"))
        if not ev.is_set():
            self._waiters.remove((count, ev))
            raise TimeoutError(f"{self.name}: {len(self.beats)} of {count} handshakes "
                               f"after {timeout_cycles} cycles")


class StreamSink(StreamMonitor):
    """Takes a stream: ``ready`` high unless the pause generator says pause
    (random back-pressure; None: always ready).  ``paused`` counts the
    cycles it held ready low.  What it takes queues for :meth:`recv` /
    :meth:`take` (and is in ``beats`` with its cycle)."""

    def __init__(self, streams, name, layout=None, pause=None):
        super().__init__(streams, name, layout)
        self.pause = pause
        self.paused = 0
        self.queue = deque()
        self._ready = True
        self.ready.value = 1

    def set_pause(self, pause):
        """Another pause generator (None: ready from now on)."""
        self.pause = pause
        if pause is None and not self._ready:
            self.ready.value = 1
            self._ready = True

    def clear(self):
        """Forget the beats, the values not taken yet and the counts."""
        super().clear()
        self.queue.clear()
        self.paused = 0

    def _drive(self, in_reset):
        if self.pause is None:
            return
        ready = not next(self.pause)
        self.paused += not ready
        if ready != self._ready:
            self.ready.value = int(ready)
            self._ready = ready

    def _ready_now(self):
        return self._ready

    def _take(self, cycle, word):
        value = unpack(self.layout, word) if self.layout is not None else word
        self.queue.append(value)
        self._record(cycle, value)

    async def take(self, n, timeout_cycles=None):
        """The next ``n`` values taken, in order (waits for them)."""
        await self.wait_beats(len(self.beats) - len(self.queue) + n, timeout_cycles)
        return [self.queue.popleft() for _ in range(n)]

    async def recv(self, timeout_cycles=None):
        """The next value taken (waits for it)."""
        return (await self.take(1, timeout_cycles))[0]


class StreamSource(StreamMonitor):
    """Sends on a stream: each queued value is presented (valid high,
    payload packed by ``layout``) and held until the handshake.  Before a
    value, the pause generator may hold valid low: ``idle`` counts those
    cycles, ``starved`` those of them in which the DUT was ready (cycles the
    DUT lost to the source)."""

    def __init__(self, streams, name, layout=None, pause=None):
        super().__init__(streams, name, layout)
        self.pause = pause
        self.queue = deque()
        self.idle = self.starved = 0
        self._current = None                        # the value being presented
        self._paused_now = False
        self._valid = False
        self.valid.value = 0

    def put(self, value):
        """Queue ``value`` (a dict / list for the layout, or the word); the
        handshake lands in ``beats``."""
        self.queue.append(value)
        self.streams._wake.set()

    def extend(self, values):
        """Queue every value of ``values``."""
        self.queue.extend(values)
        self.streams._wake.set()

    @property
    def busy(self):
        """Something queued or being presented."""
        return self._current is not None or bool(self.queue)

    def clear(self):
        """Drop the queue and the value being presented (valid low), forget the counts."""
        self.queue.clear()
        self._current = None
        self._set_valid(False)
        super().clear()
        self.idle = self.starved = 0

    def _set_valid(self, valid):
        if valid != self._valid:
            self.valid.value = int(valid)
            self._valid = valid

    def _pending(self):
        return self.busy or self._valid             # valid still to be driven low

    def _drive(self, in_reset):
        self._paused_now = False
        if self._current is None and self.queue and not in_reset:
            if self.pause is not None and next(self.pause):
                self.idle += 1
                self._paused_now = True
            else:
                self._current = self.queue.popleft()
                self.payload.value = pack(self.layout, self._current) if self.layout is not None \
                    else int(self._current)
        self._set_valid(self._current is not None and not in_reset)

    def _sample(self, cycle, in_reset):
        if in_reset:
            self._current = None                    # dropped: the DUT is in reset
        elif self._current is not None:
            if self.ready.value == 1:
                self._record(cycle, self._current)
                self._current = None
            else:
                self.stalls += 1
        elif self._paused_now and self.ready.value == 1:
            self.starved += 1
        return self._pending()
