"""RowRouter (hdl/edt_bfs/row_router.py): the state store's interface over several stores, in order.

The top is a RowRouter over ``N`` stores, rows to stores by
hdl/edt_bfs/dram_store.port_of_row (as the tile engine with
``dram_ports=N`` has it).  cocotb plays the engine (bursts of random
writes then reads over a few rows and word columns, so reads often follow
writes of the same word; the writes back to back, as the engine's
crossing FIFO shows them, the reads with random idle cycles;
back-pressure on the answers) and the
stores (each a dict of words, applying a write when it takes it and
answering a read from what it holds when it takes it, after a random
latency; random back-pressure on commands, so one store holds the
writes behind it).  Checked: every command reaches the store of its row;
every answer, in the engine's order, is the word as the writes given
before the read left it (StateSignature's read-after-write:
a write handed to a slow store must not be overtaken by a later read
handed to a fast one); answers as many as reads; reads of words written
just before (in the same burst), and reads that waited, both happened.
"""

import random

import cocotb
import pytest
from cocotb.clock import Clock
from amaranth.hdl import Shape
from amaranth.lib import data

from navcores.hdl.edt_bfs.dram_store import BANK_AT, ROW_BITS_AT, port_of_row
from navcores.hdl.edt_bfs.row_router import RowRouter
from navcores.hdl.edt_bfs.state_ram import read_data_layout, read_layout, write_layout
from navcores.hdl.edt_bfs.tile_layouts import tile_widths
from navcores.sim.rtl.clock import PERIOD_NS
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env
from navcores.sim.rtl.state_store import AnswerTiming
from navcores.sim.rtl.stream import Streams, pauses

PARAMS = {"t_r": 4, "t_c": 8, "max_h": 21, "max_w": 35, "n": 4}
ROWS, WCOLS = 8, 3          # the words the test uses: rows 0..7 reach every store
OPS = 4000


def row_router(t_r, t_c, max_h, max_w, n):
    """The test's top: a RowRouter over ``n`` stores with the tile engine's row-to-store map."""
    return RowRouter(tile_widths(t_r, t_c, max_h, max_w), t_c, n, lambda row: port_of_row(row, n))


def _store_of(row, n):
    """Which store holds ``row``: the bank bits BANK_AT.. of its words, which are row bits from ROW_BITS_AT."""
    return (row >> (BANK_AT - ROW_BITS_AT)) & (n - 1)


class _Field:
    """A field of a raw payload: offset and width from a layout."""

    def __init__(self, layout, name):
        shape = layout[name].shape
        self.at = layout[name].offset
        self.width = shape.size if isinstance(shape, data.Layout) else Shape.cast(shape).width

    def get(self, raw):
        return (raw >> self.at) & ((1 << self.width) - 1)

    def put(self, value):
        return (value & ((1 << self.width) - 1)) << self.at


@cocotb.test()
async def row_router_order(dut):
    seed = seed_from_env()
    rng = random.Random(seed)
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    n = PARAMS["n"]
    w = tile_widths(*(PARAMS[k] for k in ("t_r", "t_c", "max_h", "max_w")))
    p = PARAMS["t_c"]
    rl, wl, al = read_layout(w), write_layout(w, p), read_data_layout(w, p)
    r_row, r_wcol = _Field(rl, "row"), _Field(rl, "wcol")
    w_row, w_wcol, w_word = _Field(wl, "row"), _Field(wl, "wcol"), _Field(wl, "word")
    a_word = _Field(al, "word")
    word_bits = w_word.width

    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())
    streams = Streams(dut)
    await streams.apply_reset(2)
    # the stores: commands taken with random back-pressure, answers after a random latency
    words = [dict() for _ in range(n)]
    initial = {(r, c): rng.getrandbits(word_bits) for r in range(ROWS) for c in range(WCOLS)}
    misrouted = []
    stores = []
    for i in range(n):
        timing = AnswerTiming(streams, rng, 2)
        timing.set(2, 0.4)
        answers = streams.source(f"stores__{i}__rd_data", pause=timing.pause())
        # the write sink first: a store that takes a write and a read in one cycle applies the write first
        swr = streams.sink(f"stores__{i}__wr", pause=pauses(rng, 0.6 if i % 2 else 0.1))
        srd = streams.sink(f"stores__{i}__rd", pause=pauses(rng, 0.3))

        def on_wr(cycle, raw, i=i):
            row, wcol = w_row.get(raw), w_wcol.get(raw)
            if _store_of(row, n) != i:
                misrouted.append(("wr", row, i))
            words[i][(row, wcol)] = w_word.get(raw)

        def on_rd(cycle, raw, i=i, timing=timing, answers=answers):
            row, wcol = r_row.get(raw), r_wcol.get(raw)
            if _store_of(row, n) != i:
                misrouted.append(("rd", row, i))
            timing.schedule(cycle)
            answers.put(a_word.put(words[i].get((row, wcol), initial[(row, wcol)])))

        swr.callback, srd.callback = on_wr, on_rd
        stores.append((swr, srd, answers))

    # the engine: bursts of writes, then reads, of a few words; what each read must return follows the
    # order they are given in (the engine's crossing FIFOs show a write no later than a read given after
    # it: here the writes are valid back to back, the reads behind them with random idle cycles)
    rd = streams.source("rd", pause=pauses(rng, 0.2))
    wr = streams.source("wr")
    got = streams.sink("rd_data", pause=pauses(rng, 0.3))
    state = dict(initial)
    want, close = [], 0
    for _ in range(OPS // 6):
        fresh = set()
        for _ in range(rng.randrange(0, 6)):
            key, word = (rng.randrange(ROWS), rng.randrange(WCOLS)), rng.getrandbits(word_bits)
            wr.put(w_row.put(key[0]) | w_wcol.put(key[1]) | w_word.put(word))
            state[key] = word
            fresh.add(key)
        for _ in range(rng.randrange(1, 6)):
            key = (rng.randrange(ROWS), rng.randrange(WCOLS))
            rd.put(r_row.put(key[0]) | r_wcol.put(key[1]))
            want.append((key, state[key]))
            close += key in fresh
        await got.wait_beats(len(want), timeout_cycles=20000)
    for k, ((key, word), (_, av)) in enumerate(zip(want, got.beats)):
        assert a_word.get(av) == word, f"read {k} of word {key}: {a_word.get(av):#x}, want {word:#x}"
    reads, writes = len(want), len(wr.beats)
    assert not misrouted, f"commands at the wrong store: {misrouted[:5]}"
    assert len(got.beats) == reads == len(rd.beats), (len(got.beats), reads, len(rd.beats))
    assert len(got.beats) > 1000 and close > 100, (len(got.beats), close)
    assert rd.stalls > 100, rd.stalls           # reads waited (behind writes, or for their store)
    assert all(len(s.beats) > 100 for st in stores for s in st), [len(s.beats) for st in stores for s in st]
    dut._log.info(f"{reads} reads, {writes} writes; {close} reads of a word written in their burst, "
                  f"{rd.stalls} cycles a read waited")


@pytest.mark.parametrize("sim", SIMULATORS)
def test_row_router(sim):
    assert run("edt_row_router", PARAMS, sim, "test_row_router", factory=row_router) == 1
