"""One TileCell (hdl/edt_bfs/tile_cell.py) against the paper's cell (models.edt_bfs.edt_step) and the BFS, every cycle.

The cell holds the squared distance d2 where paper 004's cell holds delta;
this test drives it with what the tile engine's loader gives it and checks
it against :func:`models.edt_bfs.edt_step`, the paper's delta form (eq. 1-4,
the MAX tree), fed ``delta(p_i) = k(k-1) - d2(p_i)``: the change of variable
the cell's docstring proves.  Each cycle draws a random cell position p in
the largest map, and for each neighbour p_i (inside the map, else absent) a
nearest obstacle q_i, its vector p_i - q_i and d2; obstacles are shared
between neighbours and drawn near p or anywhere in the map, so ties (equal
d2_i, also from two obstacles mirrored about p, so different vectors: the
smallest index must win), candidates up to d2_max (the widths'
bound) and both sides of the third enable (k around |p - q|) all occur.
BFS cycles draw hop counts with ties and unvisited neighbours (hop = NONE)
and random vectors, which the neighbours' ``edt`` bit (0 where visited;
random elsewhere, as in an EDT step where not done) keeps out of the keys;
the model is the relaxation of models.edt_bfs_tiled.TileEngine.bfs_visit:
the smallest visited neighbour hop m, ``hop = m + 1`` where lower, the
parent the smallest index with ``hop = m + 1``.  Modes: clear, load (a
random register), EDT step, BFS step, idle; ``upd`` and ``smark`` are
checked in the cycle, the register after it.  Counts of enables, refusals,
winners that are not the first done neighbour, ties between different
vectors, far candidates and parents are asserted.  With CELL_SELECT=1 the
cell registers its MIN's winner (``select_reg``): each step follows a
select cycle with the same inputs and no step (in which nothing changes).
"""

import os

import cocotb
import numpy as np
import pytest
from cocotb.triggers import ReadOnly, RisingEdge, Timer

from navcores.hdl.edt_bfs.tile_cell import TileCell
from navcores.hdl.edt_bfs.tile_layouts import cell_layout, nb_layout, tile_widths
from navcores.models.edt_bfs import OFFSETS, edt_step, k_square
from navcores.sim.rtl.clock import start
from navcores.sim.rtl.runner import SIMULATORS, run, seed_from_env
from navcores.sim.rtl.stream import pack, unpack

PARAMS = {"t_r": 8, "t_c": 8, "max_h": 64, "max_w": 64}
CYCLES = 3000
SELECT = os.environ.get("CELL_SELECT") == "1"      # the MIN's winner registered (select_reg)


def tile_cell(t_r, t_c, max_h, max_w, select_reg=False):
    """The test's top: one TileCell with the widths of that engine."""
    return TileCell(tile_widths(t_r, t_c, max_h, max_w), select_reg=select_reg)


def _edt_model(reg, nb, k):
    """Iteration k of the paper's cell (delta form) on the loaded register: (register after, changed)."""
    base = k * (k - 1)                      # delta_{k-1} = K(k-1) - d2 (the untiled invariant)
    nbm = {i: (np.bool_(v["flag"]), base - v["val"], v["dx"], v["dy"]) for i, v in nb.items()}
    done = np.bool_(reg["flag"] or not reg["present"])
    _, _, dx, dy, _, en = edt_step(k, done, 0, reg["dx"], reg["dy"], reg["aux"], nbm)
    if not en:
        return reg, False
    return {**reg, "flag": 1, "chg": 1, "aux": k, "dx": int(dx), "dy": int(dy)}, True


def _bfs_model(reg, nb, hb):
    """One relaxation: (register after, changed)."""
    hops = [nb[i]["val"] & ((1 << hb) - 1) if nb[i]["flag"] else None for i in OFFSETS]
    vis = [h for h in hops if h is not None]
    hop = reg["val"] & ((1 << hb) - 1)
    out = dict(reg)
    if not vis:
        out["aux"] = 0
        return out, False
    m1 = min(vis) + 1
    # the parent of the old values: the smallest index with hop = m + 1
    out["aux"] = hops.index(m1 - 1) + 1 if reg["flag"] and hop == m1 else 0
    en = bool(reg["cfr"]) and (not reg["flag"] or m1 < hop)
    if en:
        out.update(flag=1, chg=1, val=m1)
    return out, en


@cocotb.test()
async def random_cycles(dut):
    seed = seed_from_env()
    dut._log.info(f"seed {seed} (replay with SEED={seed})")
    rng = np.random.default_rng(seed)
    w = tile_widths(**PARAMS)
    H, W, hb = PARAMS["max_h"], PARAMS["max_w"], w["hop"]
    cl, nl = cell_layout(w), nb_layout(w)
    none_hop = (1 << hb) - 1
    for name in ("phase", "step", "clear", "load"):
        getattr(dut, name).value = 0
    await start(dut)
    reg = unpack(cl, int(dut.state.value))
    counts = {"edt_en": 0, "edt_refused": 0, "not_first": 0, "ties": 0, "far": 0, "bfs_en": 0, "parent": 0, "smark": 0}
    for cyc in range(CYCLES):
        mode = rng.choice(["clear", "load", "edt", "bfs", "idle"], p=[0.05, 0.25, 0.4, 0.25, 0.05])
        phase = int(mode == "bfs") if mode in ("edt", "bfs") else int(rng.integers(2))
        p = (int(rng.integers(H)), int(rng.integers(W)))
        nb = {}
        if phase == 0:
            # nearest obstacles: a few shared ones, near p, or p near a corner and
            # the obstacles near the opposite one (candidates close to d2_max)
            far = rng.random() < 0.2
            if far:
                p = (int(rng.integers(3)), int(rng.integers(3)))
                p = (p[0] if rng.random() < 0.5 else H - 1 - p[0], p[1] if rng.random() < 0.5 else W - 1 - p[1])
            obst = [(int(np.clip(H - 1 - p[0] + rng.integers(-2, 3), 0, H - 1)),
                     int(np.clip(W - 1 - p[1] + rng.integers(-2, 3), 0, W - 1))) if far else
                    (int(np.clip(p[0] + rng.integers(-6, 7), 0, H - 1)),
                     int(np.clip(p[1] + rng.integers(-6, 7), 0, W - 1))) for _ in range(3)]
            mirror = (2 * p[0] - obst[0][0], 2 * p[1] - obst[0][1])
            if rng.random() < 0.5 and 0 <= mirror[0] < H and 0 <= mirror[1] < W:
                obst[1] = mirror            # as far from p as obst[0], another vector: a tie that shows
            for i, (dr, dc) in OFFSETS.items():
                r, c = p[0] + dr, p[1] + dc
                q = obst[int(rng.integers(3))]
                inside = 0 <= r < H and 0 <= c < W
                done = inside and rng.random() < 0.6
                x, y = (r - q[0], c - q[1]) if done else (int(rng.integers(-H + 1, H)), int(rng.integers(-W + 1, W)))
                nb[i] = {"flag": int(done), "ram": int(done or rng.random() < 0.1), "dx": x, "dy": y,
                         "val": x * x + y * y if done else int(rng.integers(1 << w["val"])),
                         "edt": int(done or rng.random() < 0.5)}    # the gate: any value where not done
            d = [nb[i]["val"] + (2 * -dr * nb[i]["dx"] + 1 if dr else 0) + (2 * -dc * nb[i]["dy"] + 1 if dc else 0)
                 for i, (dr, dc) in OFFSETS.items() if nb[i]["flag"]]
            # k around the nearest candidate's distance: the third enable both ways
            k = int(np.clip(round(np.sqrt(min(d))) + rng.integers(-2, 3), 1, w["k_di"] + 1)) if d else \
                int(rng.integers(1, w["k_di"] + 2))
        else:
            # often around the cell's own hop, so that hop = m + 1 (a parent) occurs
            own = reg["val"] & none_hop
            base = own - int(rng.integers(1, 3)) if own < 45 and rng.random() < 0.6 else int(rng.integers(0, 40))
            base = max(base, 0)
            for i in OFFSETS:
                vis = rng.random() < 0.6
                nb[i] = {"flag": int(vis), "ram": int(rng.random() < 0.3),
                         "dx": int(rng.integers(-H + 1, H)), "dy": int(rng.integers(-W + 1, W)),
                         "val": base + int(rng.integers(0, 3)) if vis else none_hop,
                         "edt": int(not vis and rng.random() < 0.5)}
            k = int(rng.integers(1, w["k_di"] + 2))
        for i, v in nb.items():
            getattr(dut, f"n{i}").value = pack(nl, v)
        ld = {"present": int(rng.random() < 0.9), "flag": int(rng.random() < 0.3), "fresh": int(rng.random() < 0.1),
              "cfr": int(rng.random() < 0.8), "chg": int(rng.random() < 0.2),
              "val": int(rng.integers(0, 45)) if rng.random() < 0.8 else none_hop,
              "dx": int(rng.integers(-H + 1, H)), "dy": int(rng.integers(-W + 1, W)),
              "aux": int(rng.integers(0, 9)), "edt": int(rng.integers(2))}
        dut.phase.value = phase
        dut.k.value = k
        dut.kk.value = k_square(k)
        dut.clear.value = int(mode == "clear")
        dut.load.value = int(mode == "load")
        dut.ld.value = pack(cl, ld)
        dut.step.value = int(mode in ("edt", "bfs"))
        if SELECT and mode in ("edt", "bfs"):
            # the select cycle: the same inputs without the step; nothing changes
            dut.step.value = 0
            await ReadOnly()
            assert int(dut.upd.value) == 0, f"cycle {cyc}: upd in the select cycle"
            await RisingEdge(dut.clk)
            await ReadOnly()
            assert unpack(cl, int(dut.state.value)) == reg, f"cycle {cyc}: the select cycle changed the register"
            await Timer(1, unit="ns")
            dut.step.value = 1
        # model
        changed = False
        if mode == "clear":
            new = {**reg, "present": 0, "flag": 0, "fresh": 0, "cfr": 0, "chg": 0}
        elif mode == "load":
            new = unpack(cl, pack(cl, ld))
        elif mode == "edt":
            new, changed = _edt_model(reg, nb, k)
            valid = [i for i in OFFSETS if nb[i]["flag"]]
            if reg["present"] and not reg["flag"] and valid:
                counts["edt_en" if changed else "edt_refused"] += 1
                d2_max = (H - 1) ** 2 + (W - 1) ** 2
                counts["far"] += changed and min(nb[i]["val"] for i in valid) > d2_max - 8 * (H + W)
                if changed:
                    cand = {i: (nb[i]["dx"] - OFFSETS[i][0], nb[i]["dy"] - OFFSETS[i][1]) for i in valid}
                    best = min(x * x + y * y for x, y in cand.values())
                    first = min(i for i in valid if sum(v * v for v in cand[i]) == best)
                    counts["not_first"] += first != valid[0]
                    counts["ties"] += len({cand[i] for i in valid if sum(v * v for v in cand[i]) == best}) > 1
        elif mode == "bfs":
            new, changed = _bfs_model(reg, nb, hb)
            counts["bfs_en"] += changed
            counts["parent"] += new["aux"] != 0
        else:
            new = reg
        smark = bool(reg["present"] and not reg["flag"] and any(v["ram"] for v in nb.values()))
        counts["smark"] += smark
        await ReadOnly()
        assert int(dut.upd.value) == changed, f"cycle {cyc} ({mode}, k={k}): upd"
        assert int(dut.smark.value) == smark, f"cycle {cyc}: smark"
        await RisingEdge(dut.clk)
        await ReadOnly()
        got = unpack(cl, int(dut.state.value))
        assert got == new, f"cycle {cyc} ({mode}, phase {phase}, k={k}): rtl {got} model {new}; was {reg}, nb {nb}"
        reg = new
        await Timer(1, unit="ns")      # leave the read-only phase before driving
    dut._log.info(f"{CYCLES} cycles: {counts}")
    assert counts["edt_en"] > 100 and counts["edt_refused"] > 50 and counts["not_first"] > 20, counts
    assert counts["ties"] > 10, counts
    assert counts["far"] > 5 and counts["bfs_en"] > 50 and counts["parent"] > 50 and counts["smark"] > 100, counts


# Icarus only: the cell runs on Verilator inside every tile engine of test_edt_tile_engine.
@pytest.mark.parametrize("select_reg", [False, True], ids=["comb", "select_reg"])
@pytest.mark.parametrize("sim", [s for s in SIMULATORS if s == "icarus"])
def test_edt_tile_cell(sim, select_reg):
    params = {**PARAMS, "select_reg": True} if select_reg else PARAMS
    run("edt_tile_cell", params, sim, "test_edt_tile_cell", factory=tile_cell, env={"CELL_SELECT": int(select_reg)})
