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
* ``host_engine``: ``python -m sim dflc --engine serial:PORT`` with a
  pseudo-terminal as its port, carried to this board top's UART: the same
  JSON as the model engine, plus ``rtl_matches_model``; another core's
  command refused with one line, exit status 2; ``python -m sim board``
  (the bring-up test) passes every check.

The same build runs on Icarus and Verilator, at 4 clocks a bit.
"""

import os
from pathlib import Path

import cocotb
import numpy as np
import pytest

from board_checks import host_command, host_matches_model, open_board, protocol_suite, rng_from_env, run_board
from navcores.hdl.dflc.top import config_for
from navcores.models.dflc import Dflc
from navcores.sim.rtl.board_driver import UartLine, perform, start
from navcores.sim.rtl.board_jobs import dflc
from navcores.sim.rtl.runner import SIMULATORS

# A simulation-friendly line: 4 clocks a bit, short timeouts, a small FIFO.
PARAMS = {"core": "dflc", "fll": "table1", "divisor": 4, "fifo": 32, "gap_bits": 40, "accept_bits": 400}



@cocotb.test()
async def protocol(dut):
    line, link, info = await open_board(dut, PARAMS, timeout_bits=4_000)
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
    line, link, info = await open_board(dut, PARAMS, timeout_bits=4_000)
    config = config_for(fll="table1")
    model = Dflc(config)
    rng = np.random.default_rng(rng_from_env().randrange(1 << 30))
    for batch in range(2):
        rows = _codes(config, rng, 12)
        got = await perform(dflc(link, rows, config), line)
        y, zero = model.infer(np.array(rows))
        want = [(int(a), bool(b)) for a, b in zip(y, zero)]
        assert got == want, [(i, g, w) for i, (g, w) in enumerate(zip(got, want)) if g != w][:5]
        await perform(link.reset(), line)
    assert link.bad_frames == 0 and line.framing_errors == 0
    dut._log.info(f"{2 * len(rows)} samples bit-exact through the board top")


@cocotb.test()
async def host_engine(dut):
    """``python -m sim dflc --engine serial:PORT`` on this board top (its port
    a pseudo-terminal): the same JSON as the model engine, the outputs
    checked against the model; ``sim edt`` on it: refused (another core);
    ``sim board`` on it: every check passes."""
    await start(dut)
    line = UartLine(dut, PARAMS["divisor"], timeout_bits=4000)
    work = Path(os.environ["HOST_WORK"])
    rows = [(-170, 30), (0, 0), (12.5, -3), (90, 179), (400, -190)]
    (work / "in.csv").write_text("phi1,phi2\n" + "".join(f"{a},{b}\n" for a, b in rows))
    board = await host_matches_model(dut, line, ["dflc", "--input", str(work / "in.csv")], work)
    assert len(board["codes"]) == len(rows)
    rc, out, err = await host_command(dut, line, ["edt", "maps/room-32-32-4.map", "--goal", "3,3", "--dfar", "1"])
    assert rc == 2 and err.count("\n") == 1 and "the board runs 'dflc', not 'edt_bfs'" in err, (rc, err)
    # the bring-up test of docs/boards.md
    rc, out, err = await host_command(dut, line, ["board"], option=None)
    assert rc == 0 and not err and out.splitlines()[-1] == "8 of 8 checks passed", (rc, out, err)
    assert out.startswith("serial:") and ": dflc board, fll=table1 " in out.splitlines()[0], out


@pytest.mark.parametrize("sim", SIMULATORS)
def test_board_dflc(sim, tmp_path):
    run_board("dflc", PARAMS, sim, tmp_path, ('protocol', 'samples', 'host_engine'))
