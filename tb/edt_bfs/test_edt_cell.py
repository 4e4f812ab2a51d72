"""One EdtCell (hdl/edt_bfs/cell.py) against models.edt_bfs.edt_step / bfs_step, every cycle.

The test drives random neighbour registers (done, δ, Δx, Δy, visited) and
a random mode each cycle: a load shift (the west neighbour's marks), an EDT
iteration with a random k, the cfr step with a random d_far, a BFS step, or
nothing.  Neighbour values are drawn so that candidates stay within the
widths the array guarantees, with many ties (equal δ_i) so the MAX tree's
smallest-index rule is exercised; the cell's registers are compared with the
model after every cycle.  Counts of enables and ties are asserted.
"""

import cocotb
import numpy as np
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from navcores.hdl.edt_bfs.cell import cell_widths, result_layout, state_layout
from navcores.models.edt_bfs import OFFSETS, bfs_step, edt_step
from navcores.sim.rtl.stream import pack, unpack
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env

H = W = 16
CYCLES = 3000


@cocotb.test()
async def random_cycles(dut):
    seed = seed_from_env()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    rng = np.random.default_rng(seed)
    w = cell_widths(H, W)
    st_layout, res_layout = state_layout(w), result_layout(w)
    Clock(dut.clk, 10, unit="ns").start()
    for name in ("shift", "step_edt", "step_cfr", "step_bfs"):
        getattr(dut, name).value = 0
    dut.rst.value = 1
    await RisingEdge(dut.clk)
    dut.rst.value = 0
    st = {"done": False, "delta": 0, "dx": 0, "dy": 0, "di": 0, "visited": False, "cfr": False, "parent": 0}
    counts = {"edt_en": 0, "bfs_en": 0, "ties": 0, "shift": 0, "cfr": 0}
    lim = H - 2
    for cyc in range(CYCLES):
        mode = rng.choice(["shift", "edt", "cfr", "bfs", "none"], p=[0.15, 0.45, 0.1, 0.25, 0.05])
        if st["delta"] > w["delta_max"] - 4 * w["k_max"]:
            mode = "shift"                   # keep δ in the range a real array reaches
        k = int(rng.integers(1, w["k_max"] + 1))
        dfar = int(rng.integers(0, 1 << w["di"]))
        dfar = dfar if rng.random() < 0.3 else int(rng.integers(0, 3))
        # half of the cycles: every neighbour proposes the same candidate δ_i
        # (δ = T + ΔX_i + ΔY_i), so the MAX tree must break ties by index
        target = int(rng.integers(-2 * k, 2 * k + 1)) if rng.random() < 0.5 else None
        nb = {}
        for i in range(1, 9):
            x, y = int(rng.integers(-lim, lim + 1)), int(rng.integers(-lim, lim + 1))
            sr, sc = -OFFSETS[i][0], -OFFSETS[i][1]
            big = ((2 * sr * x + 1) if sr else 0) + ((2 * sc * y + 1) if sc else 0)
            delta = target + big if target is not None else int(rng.integers(0, 4 * k + 3))
            if delta < 0:
                delta = int(rng.integers(0, 4 * k + 3))
            nb[i] = (bool(rng.random() < 0.6), delta, x, y, bool(rng.random() < 0.3))
        dut.k.value = k
        dut.dfar.value = dfar
        dut.shift.value = int(mode == "shift")
        dut.step_edt.value = int(mode == "edt")
        dut.step_cfr.value = int(mode == "cfr")
        dut.step_bfs.value = int(mode == "bfs")
        for i, (d, de, x, y, v) in nb.items():
            getattr(dut, f"n{i}").value = pack(st_layout, {"done": d, "delta": de, "dx": x, "dy": y, "visited": v})
        # model
        changed = False
        if mode == "shift":
            st = {"done": nb[3][0], "delta": 0, "dx": 0, "dy": 0, "di": 0, "visited": nb[3][4],
                  "cfr": False, "parent": 0}
            counts["shift"] += 1
        elif mode == "edt":
            nbm = {i: (np.bool_(v[0]), v[1], v[2], v[3]) for i, v in nb.items()}
            done, delta, dx, dy, di, en = edt_step(k, np.bool_(st["done"]), st["delta"], st["dx"],
                                                   st["dy"], st["di"], nbm)
            changed = bool(en)
            if en:
                cands = [v[1] - ((2 * (-o[0]) * v[2] + 1) if o[0] else 0) - ((2 * (-o[1]) * v[3] + 1) if o[1] else 0)
                         for v, o in ((nb[i], OFFSETS[i]) for i in range(1, 9)) if v[0]]
                counts["ties"] += cands.count(max(cands)) > 1
            counts["edt_en"] += changed
            st.update(done=bool(done), delta=int(delta), dx=int(dx), dy=int(dy), di=int(di))
        elif mode == "cfr":
            cfr = (not st["done"]) or st["di"] > dfar
            st.update(cfr=cfr, visited=st["visited"] and cfr)
            counts["cfr"] += 1
        elif mode == "bfs":
            vis, par, en = bfs_step(st["cfr"], st["visited"], st["parent"], {i: v[4] for i, v in nb.items()})
            changed = bool(en)
            counts["bfs_en"] += changed
            st.update(visited=bool(vis), parent=int(par))
        await ReadOnly()
        assert int(dut.changed.value) == changed, f"cycle {cyc}: changed"
        await RisingEdge(dut.clk)
        await ReadOnly()
        got = {**unpack(st_layout, int(dut.state.value)), **unpack(res_layout, int(dut.result.value))}
        got = {k_: (bool(v) if k_ in ("done", "visited", "cfr") else v) for k_, v in got.items()}
        assert got == st, f"cycle {cyc} ({mode}, k={k}): rtl {got} model {st}"
        await Timer(1, unit="ns")      # leave the read-only phase before driving
    dut._log.info(f"{CYCLES} cycles: {counts}")
    assert counts["edt_en"] > 100 and counts["bfs_en"] > 15 and counts["ties"] > 4


# Icarus only: the cell is also checked on Verilator inside every array of
# test_edt_bfs_core, and a Verilator build of its own costs about a minute of
# the regression budget (hdl/edt_bfs/README.md).
@pytest.mark.parametrize("sim", [s for s in SIMULATORS if s == "icarus"])
def test_edt_cell(sim):
    run("edt_cell", {"height": H, "width": W}, sim, "test_edt_cell")
