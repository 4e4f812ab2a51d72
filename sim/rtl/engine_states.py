"""The tile engine's cycles by state, counted from its FSM under cocotb (issue 18: where a visit's time goes).

:class:`EngineStates` samples the engine's ``state`` register
(hdl/edt_bfs/tile_engine.py, ``STATES``) at every rising edge of the
engine's clock while ``on``.  The register is internal: the top must be
built with every signal visible (Verilator: ``NAVCORES_VERILATOR_PUBLIC=1``,
sim/rtl/runner.py), which makes the build several times larger; the
benches use it on request only (scripts/bench_dram.py ``--states``).
"""

import cocotb
from cocotb.triggers import ReadOnly, RisingEdge

from navcores.hdl.edt_bfs.tile_engine import STATES

__all__ = ["EngineStates", "TERMS"]

# The tiled model's cycle terms (models/edt_bfs_tiled.py, cycle model: result.stats["cycle_terms"]) and
# the engine's states that spend them; at StateRam's timing each term's cycles are its states' cycles
TERMS = {"load": ("LOAD",), "scan": ("SCAN",), "level": ("LEVEL",), "sched": ("SCHED0", "SCHED1"),
         "read": ("READ",), "iterate": ("ITER",), "store": ("STORE",), "goals": ("GOAL0", "GOAL1"),
         "path": ("PATH",), "readout": ("READOUT",)}
# every state but IDLE spends one term's cycles: a state added to the engine must be placed here
assert sorted(n for names in TERMS.values() for n in names) == sorted(set(STATES) - {"IDLE"}), STATES


class EngineStates:
    """``cycles``: {state name: engine cycles in it while ``on``} of the tile engine in ``dut`` (the top
    itself or its ``engine``), :meth:`terms` the same by the model's terms; started with :meth:`start`
    (a coroutine sampling every cycle)."""

    def __init__(self, dut):
        engine = getattr(dut, "engine", dut)
        try:
            self.state = engine.state
        except AttributeError:
            raise ValueError("the tile engine's state register is not visible: build the top with "
                             "NAVCORES_VERILATOR_PUBLIC=1") from None
        self.clk, self.on = dut.clk, False
        self.cycles = dict.fromkeys(STATES, 0)

    def start(self):
        """Count from the next cycle (``on`` set)."""
        self.on = True
        self._task = cocotb.start_soon(self._count())

    def stop(self):
        """Stop counting and sampling."""
        self.on = False
        self._task.cancel()

    async def _count(self):
        while True:
            await RisingEdge(self.clk)
            await ReadOnly()                # the state the next rising edge leaves
            if self.on:
                self.cycles[STATES[self.state.value.to_unsigned()]] += 1

    def terms(self):
        """{the model's cycle term (TERMS): the engine's cycles in its states}."""
        return {term: sum(self.cycles[n] for n in names) for term, names in TERMS.items()}
