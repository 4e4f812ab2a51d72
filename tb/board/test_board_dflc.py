"""The DFLC board top (hdl/board/serial_top.py: UART, bridge, DflcStream)
in simulation, driven through the host's protocol module and job.

* ``protocol``: tb/board/board_checks.py's suite (INFO, ECHO of every byte
  value, a bad CRC, truncated and short frames, garbage between frames,
  unknown commands and sinks, wrong lengths, a framing error, a burst of
  requests back to back): each bad frame gets its NAK, the next good frame
  works.
* ``samples``: the Table 1 controller's segment boundaries and random codes
  through the board (up to the bridge's window of samples in flight, so
  the DFLC's output FIFO fills and the bridge's transmitter holds it
  back): every (y, zero) equals models.dflc bit for bit; a RESET in
  between, after which the next batch is exact too.

The same build runs on Icarus and Verilator, at 4 clocks a bit.
"""

import cocotb
import numpy as np
import pytest

from board_checks import connect, protocol_suite, rng_from_env
from navcores.hdl.board.serial_top import SerialTop
from navcores.hdl.dflc.top import config_for
from navcores.models.dflc import Dflc
from navcores.sim.rtl.board_driver import UartLine, perform, start
from navcores.sim.rtl.board_jobs import dflc
from navcores.sim.rtl.runner import SIMULATORS, run

# A simulation-friendly line: 4 clocks a bit, short timeouts, a small FIFO.
PARAMS = {"core": "dflc", "fll": "table1", "divisor": 4, "fifo": 32, "gap_bits": 40, "accept_bits": 400}


async def _open(dut):
    await start(dut)
    line = UartLine(dut, PARAMS["divisor"], timeout_bits=4000)
    link, info = await connect(line, "dflc")
    return line, link, info


@cocotb.test()
async def protocol(dut):
    line, link, info = await _open(dut)
    assert (info["core"], info["fll"], info["fifo"], info["div"]) == ("dflc", "table1", 32, 4), info
    n = await protocol_suite(line, info, rng_from_env())
    dut._log.info(f"{n} frames checked")


def _codes(config, rng, n):
    """Every input's segment boundaries (with their neighbours) and random codes."""
    top = (1 << config.ip_sz) - 1
    edges = sorted({max(0, min(top, int(v) + d)) for v in np.linspace(0, top, 9) for d in (-1, 0, 1)})
    rows = [[edges[(i + 3 * j) % len(edges)] for j in range(config.n)] for i in range(len(edges))]
    rows += rng.integers(0, top + 1, size=(n, config.n)).tolist()
    return rows


@cocotb.test()
async def samples(dut):
    line, link, info = await _open(dut)
    config = config_for(fll="table1")
    model = Dflc(config)
    rng = np.random.default_rng(rng_from_env().randrange(1 << 30))
    for batch in range(2):
        rows = _codes(config, rng, 12)
        got = await perform(dflc(link, rows, config.ip_sz, config.op_sz), line)
        y, zero = model.infer(np.array(rows))
        want = [(int(a), bool(b)) for a, b in zip(y, zero)]
        assert got == want, [(i, g, w) for i, (g, w) in enumerate(zip(got, want)) if g != w][:5]
        await perform(link.reset(), line)
    assert link.bad_frames == 0 and line.framing_errors == 0
    dut._log.info(f"{2 * len(rows)} samples bit-exact through the board top")


@pytest.mark.parametrize("sim", SIMULATORS)
def test_board_dflc(sim):
    assert run("board_dflc", PARAMS, sim, "test_board_dflc", factory=SerialTop) == 2
