"""Benchmark (issue 18): the EDT/BFS tile engine's whole job on the bundled maps, at its own clock, against scipy.

For each map and array (default: maze512-1-0, den312d, room-64-64-8,
random-64-64-10 and room-64-64-8 x4, a 256x256 map built from the bundled
room-64-64-8 by drawing each cell as 4 x 4 pixels (the same rooms at a
finer resolution; the job's goal and start are its scenario's, scaled);
arrays 8x8, 16x16 and any given with --arrays) one job of the tiled model
(models.edt_bfs_tiled.plan_path_tiled, the RTL's cycle model, which the
regression proves equal to the tile engine's RTL cycle for cycle; RAM words
of one tile row, 3 banks; d_far 0; the goal and start of the map's longest
scenario, else its last and first free cell): EDT levels, tile visits,
array iterations, cycles per visit, RAM words moved against the floor
(every visit reading and writing each pixel of its tile once), the job's
cycles (load + scan, EDT, goals + BFS, path; no map read-out) and the
model's own run time.  Beside it the software a user would run instead,
on the same machine in the same run: scipy.ndimage.distance_transform_edt
(return_indices=True) plus a scipy.sparse.csgraph BFS over the cfr
(scripts/software.py, median of 3 runs, graph construction included).

Clock: the tile engine's own, from place and route on the LFE5U-85F
(``make fit TOP=edt_tile_engine PARAMS="t_r=R t_c=C max_h=H max_w=W"
PART=lfe5u-85f``: build/fit/<module>--LFE5U-85F.json, read here only when
its verilog_sha256 is the hash of the top's Verilog emitted now, else it is
stale: not used, said on stderr with the command to re-run), of the
engine that runs the job: the smallest of RAMS (128x128, 224x224) that
holds the map (the cell's widths, hence its clock, follow the RAM's map
size).  224x224 is the largest: with 256x256 the engine needs 210 of the part's 208 EBRs
at 4x4, the state store 189..198 at T_c = 4..8 and the worklist, its queued
bits, the frontier flags and the line buffer about 21 more;
scripts/tile_engine_size.py --ram counts the store).  The job's time is
its cycles at that clock, only for an array whose engine fits the part
and a map whose state fits the part's block RAM; an array that does not
fit, or has no fit result, has no time (never the clock of another top,
e.g. the cell alone), only the break-even clock (cycles / software
seconds: any clock above it is faster than the software).  A map larger
than the RAM (maze512-1-0) says so, with the largest map the part holds,
and runs on the engine with its state outside (``store=external``, RAM
512x512: that engine's own clock): its time (and the issue's goal line
under the table) assumes a store of StateRam's timing, with the bandwidth
that takes beside it and the floor of the transfers through a 16-bit
SDRAM at 166 MHz (the model's ``store_bits_min`` at the SDRAM's peak);
the engine through a DDR3 controller is scripts/bench_dram.py's (simulated).

Memory: bits of state per pixel (models.edt_bfs_tiled.state_bits) times the
map, the EBRs that needs (8 pixels a word), and the largest square map the
LFE5U-85F's 208 EBRs hold.

    python scripts/bench_edt_tiled.py [--out build/bench/edt_tiled.md] [--maps NAME,...] [--arrays 8x8,16x16]
                                      [--md BENCHMARKS.md]

--md replaces the section "EDT/BFS tile engine" of that file with this
run's tables.  `section()` is that section's text (`make bench` includes
it); `comparison()` returns (its tables, rows as a list of dicts).
"""

import argparse
import functools
import json
import os
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import fmax  # noqa: E402
import kept  # noqa: E402
import software  # noqa: E402
import toolchain  # noqa: E402
from navcores.models.edt_bfs_tiled import (EBR_BITS, LFE5U_85F_EBR, largest_map, plan_path_tiled,  # noqa: E402
                                  ram_blocks, state_bits)
from navcores.hdl.catalog import PAPER_JOBS  # noqa: E402
from navcores.hdl.emit import top_name  # noqa: E402
from navcores.models.maps import load_map, longest_scenario  # noqa: E402

MAPS = ("maze512-1-0", "den312d", "room-64-64-8", "random-64-64-10", "room-64-64-8x4")
ARRAYS = ((8, 8), (16, 16))
# make bench: also the smallest array, 4x8 (the largest placed and routed on the LFE5U-85F) and 6x6 (hdl/edt_bfs/README.md)
BENCH_ARRAYS = ((4, 4), (4, 8), (6, 6), (8, 8), (16, 16))
DFAR = 0
PART = "LFE5U-85F"
RAMS = ((128, 128), (224, 224))     # the fitted engines' RAMs, smallest first (module docstring)
RAM = RAMS[-1]                      # the largest (256x256 overflows the part's EBRs)
EXT_RAM = (512, 512)                # the engine with an external store (store=external): maze512-1-0
# An external store's transfer rate: a 16-bit SDR SDRAM (the ULX3S's 32 MB is 16 bits wide) at 166 MHz, its
# peak (every beat a page hit, no refresh, no turnaround): a bound no such store beats.
SDRAM_BITS_PER_S = 16 * 166e6
SECTION = "EDT/BFS tile engine: whole jobs at its own clock against scipy (issue 18)"


def job(name):
    """(obstacle, goal, start) of maps/NAME.map: its job (models.maps.longest_scenario);
    NAMExF: that map with each cell drawn as F x F pixels, the job scaled."""
    scaled = re.fullmatch(r"(.+)x(\d+)", name)
    base, factor = (scaled[1], int(scaled[2])) if scaled else (name, 0)
    path = ROOT / "maps" / f"{base}.map"
    obstacle = load_map(path)
    s = longest_scenario(path, obstacle)
    goal, start = tuple(s.goal), tuple(s.start)
    if factor:
        f = factor
        obstacle = np.kron(obstacle, np.ones((f, f), dtype=bool)).astype(bool)
        goal, start = (tuple(f * v + f // 2 for v in p) for p in (goal, start))
    return obstacle, goal, start


def engine_ram(h, w):
    """The RAM of the engine that runs an ``h`` x ``w`` map: the smallest of RAMS holding it, else the largest."""
    return next((r for r in RAMS if h <= r[0] and w <= r[1]), RAM)


def fit_result(array, ram=RAM, part=PART, top="edt_tile_engine", store="bram", extra=None):
    """The fit flow's JSON for ``top`` (the tile engine, or its cell alone: ``edt_tile_cell``, from
    scripts/tile_engine_size.py --cell-fit, or its DRAM side: ``edt_dram_stores``, or the DRAM job's
    whole top: ``edt_tile_litedram``, scripts/fit_dram_top.py, store None) with ``array``,
    ``ram``, ``store`` and the parameters ``extra`` on ``part``, or None:
    None too when it is stale, its verilog_sha256 (absent: stale) not the hash of the top's Verilog
    emitted now (one line on stderr says so, with the command that places it again)."""
    params = {"t_r": array[0], "t_c": array[1], "max_h": ram[0], "max_w": ram[1],
              **({"store": store} if store not in ("bram", None) else {}), **(extra or {})}
    path = ROOT / "build" / "fit" / f"{top_name(top, params)}--{part}.json"
    if not path.exists():
        return None
    fit = json.loads(path.read_text())
    if fit.get("verilog_sha256") != verilog_sha256(top, tuple(sorted(params.items())), part):
        again = fit.get("generator") or (
            f"python scripts/tile_engine_size.py --cell-fit {array[0]}x{array[1]}:{ram[0]}x{ram[1]}"
            if top == "edt_tile_cell" else
            " ".join(["python scripts/fit.py", top, *(f"{k}={v}" for k, v in sorted(params.items())), "--part", part]))
        why = (f"its verilog_sha256 is not that of {top}'s Verilog now" if "verilog_sha256" in fit else
               "it records no verilog_sha256 to check against the Verilog now")
        warning = f"bench_edt_tiled: stale fit {os.path.relpath(path, ROOT)} ({why}), not used; re-run `{again}`"
        if warning not in _WARNED:          # once a run (fit_result is asked again for each map)
            _WARNED.add(warning)
            print(warning, file=sys.stderr, flush=True)
        return None
    return fit


_WARNED = set()


@functools.lru_cache(maxsize=None)
def verilog_sha256(top, params, part):
    """The toolchain.digest of ``top``'s Verilog at ``params`` (sorted (name, value) pairs) emitted now
    as the fit flow emits it (fmax.emitted; the cell alone: tile_engine_size.cell_verilog): what a
    current fit JSON records.  Once a run: an engine takes seconds to elaborate."""
    prt = fmax.part(part)
    if top == "edt_tile_cell":
        import tile_engine_size
        source = tile_engine_size.cell_verilog(dict(params), prt)
    elif top == "edt_tile_litedram":
        import fit_dram_top             # its parameters are the catalog's; the hash covers LiteDRAM's core
        return fit_dram_top.current_sha256(prt)
    else:
        source = fmax.emitted(top, dict(params), prt)
    return toolchain.digest(source)


def cell_bound(arrays):
    """The cell alone's fit (any of ``arrays``: the cell's widths follow the RAM), or None."""
    return next((c for c in (fit_result(a, top="edt_tile_cell") for a in (*arrays, (8, 8))) if c), None)


def measure(name, arrays=ARRAYS, repeats=3):
    obstacle, goal, start = job(name)
    h, w = obstacle.shape
    sw = software.edt_bfs(obstacle, [goal], DFAR, bfs=("csgraph",), repeats=repeats)
    bits = state_bits(h, w)
    ebr = ram_blocks(h, w, 8)["blocks"]
    rows = []
    in_ram = h <= RAM[0] and w <= RAM[1]
    ram = engine_ram(h, w)
    if not in_ram:                  # the state does not fit the part: the engine with an external store
        ram = EXT_RAM
    for array in arrays:
        fit = fit_result(array, ram, store="bram" if in_ram else "external")
        mhz = fit["fmax_mhz"] if fit and fit["fits"] else None      # the engine's own clock, or none
        t0, c0 = time.perf_counter(), time.process_time()
        res = plan_path_tiled(obstacle, [goal], start, DFAR, array=array)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        st = res.stats
        rows.append({
            "map": name, "shape": (h, w), "array": array, "goal": goal, "start": start,
            "path_steps": len(res.path) - 1 if res.path else None, "bfs_depth": res.iterations_bfs - 1,
            "levels": st["levels"], "tiles": st["tiles"],
            "visits_edt": st["visits_edt"], "visits_bfs": st["visits_bfs"],
            "iterations_edt": st["array_iterations_edt"], "iterations_bfs": st["array_iterations_bfs"],
            "words_moved": st["words_moved"], "words_floor": st["words_floor"], "cycles": res.cycles,
            "cycles_split": st["cycles"], "model_wall_s": wall, "model_cpu_s": cpu,
            "sw_seconds": sw["sw_seconds"], "sw_edt_s": sw["edt_seconds"], "sw_bfs_s": sw["bfs_csgraph_seconds"],
            "break_even_mhz": res.cycles / sw["sw_seconds"] / 1e6,
            "mhz": mhz,
            "hw_seconds": res.cycles / (mhz * 1e6) if mhz else None,
            "fit": fit, "in_ram": in_ram, "ram": ram,
            "cycles_per_visit": (st["cycles"]["edt"] + st["cycles"]["bfs"]) / max(1, st["visits_edt"] + st["visits_bfs"]),
            "state_bits": bits["total"], "ebr": ebr,
            "store_bits_min": st["store_bits_min"], "sdram_floor_s": st["store_bits_min"] / SDRAM_BITS_PER_S,
        })
    return rows


def comparison(maps=MAPS, arrays=ARRAYS, progress=print):
    rows = []
    for name in maps:
        progress(f"{name} ...")
        rows += measure(name, arrays)
    lines = [
        "| map | array | levels | visits EDT / BFS (tiles) | array iterations EDT / BFS | cycles / visit "
        "| words moved (floor) | cycles: load / EDT / goals+BFS / path = total | clock (LFE5U-85F) | job time "
        "| scipy EDT + csgraph BFS | speed-up | break-even | model s (CPU) |",
        "|---|---|---:|---|---|---:|---|---|---|---:|---|---:|---:|---|",
    ]
    for r in rows:
        held = _held(r)
        c = r["cycles_split"]
        clock = f"{r['mhz']:.1f} MHz" if r["mhz"] else _no_clock(r["fit"], r["array"])
        speedup = (f"{r['sw_seconds'] / r['hw_seconds']:.1f}x" + ("" if r["in_ram"] else " (ext.)")
                   if r["hw_seconds"] else "-")
        when = (f"{r['hw_seconds'] * 1e3:.3f} ms" if r["hw_seconds"] and r["in_ram"] else
                f"{held}; external store: {_ext(r)}" if r["hw_seconds"] else
                "-" if r["in_ram"] else
                held)
        lines.append(
            f"| {r['map']} ({r['shape'][0]}x{r['shape'][1]}) | {r['array'][0]}x{r['array'][1]} | {r['levels']} "
            f"| {r['visits_edt']:,} / {r['visits_bfs']:,} ({r['tiles']:,}) "
            f"| {r['iterations_edt']:,} / {r['iterations_bfs']:,} | {r['cycles_per_visit']:.1f} "
            f"| {r['words_moved']:,} ({r['words_floor']:,}) "
            f"| {c['load'] + c['scan']:,} / {c['edt']:,} / {c['goals'] + c['bfs']:,} / {c['path']:,} "
            f"= {r['cycles']:,} | {clock} | {when} "
            f"| {r['sw_seconds'] * 1e3:.2f} ms ({r['sw_edt_s'] * 1e3:.2f} + {r['sw_bfs_s'] * 1e3:.2f}) "
            f"| {speedup} | {r['break_even_mhz']:.1f} MHz | {r['model_wall_s']:.2f} ({r['model_cpu_s']:.2f}) |")
    lines += ["", f"The paper's own figure for its map: {PAPER_JOBS['edt_job']}.", ""]
    for r in rows:
        if r["map"] != "maze512-1-0":
            continue
        a = f"{r['array'][0]}x{r['array'][1]}"
        if r["hw_seconds"]:
            floor = r["sdram_floor_s"]
            lines.append(f"* Goal, maze512-1-0 at {a}: {r['cycles']:,} cycles at the external-store engine's own "
                         f"{r['mhz']:.1f} MHz ({PART}, RAM {r['ram'][0]}x{r['ram'][1]}, store=external) = "
                         f"{r['hw_seconds'] * 1e3:.2f} ms against {r['sw_seconds'] * 1e3:.0f} ms for scipy's EDT + "
                         f"csgraph BFS in this run, "
                         f"{'faster' if r['hw_seconds'] < r['sw_seconds'] else 'NOT faster'} "
                         f"({r['sw_seconds'] / r['hw_seconds']:.1f}x), with a store of StateRam's timing, which "
                         f"moves {r['store_bits_min'] / 1e6:.0f} Mbit at least: "
                         f"{r['store_bits_min'] / r['hw_seconds'] / 1e9:.1f} Gbit/s. The state ({r['ebr']} EBR) "
                         f"lives outside the part: on the ULX3S (this part's board) "
                         f"a 16-bit SDRAM, through which the transfers alone take {floor * 1e3:.1f} ms or more at "
                         f"its {SDRAM_BITS_PER_S / 16 / 1e6:.0f} MHz peak, so the job there takes at least "
                         f"{max(floor, r['hw_seconds']) * 1e3:.1f} ms: "
                         + ("below scipy's only at a peak no SDRAM controller sustains (row misses, refresh, "
                            "latency)" if max(floor, r['hw_seconds']) < r['sw_seconds'] else
                            "not below scipy's even at the SDRAM's peak")
                         + "; a board with "
                         f"a DDR3 has the bandwidth on paper: the engine through LiteDRAM's DDR3 controller "
                         f"(store=dram, simulated) is the next section's. "
                         f"Cost: {r['visits_edt'] + r['visits_bfs']:,} "
                         f"tile visits at {r['cycles_per_visit']:.1f} cycles each, {r['words_moved']:,} RAM words "
                         f"moved against a floor of {r['words_floor']:,} ({r['words_moved'] / r['words_floor']:.2f}x).")
        else:
            lines.append(f"* maze512-1-0 at {a}: {_no_clock(r['fit'], r['array'])}; no time.")
    lines.append("")
    fits = {(tuple(r["array"]), tuple(r["ram"])): r["fit"] for r in rows}
    cell = cell_bound(arrays)
    lines += [f"| tile engine on the {PART} (array, RAM) | fits | LUT4 | FF | EBR | DSP | clock "
              "| critical path |", "|---|---|---:|---:|---:|---:|---|---|"]
    if cell:
        cp = cell["critical_path"]
        lines.append(f"| one cell alone ({cell['generator']}) | - | {cell['resources']['lut4']:,} "
                     f"| {cell['resources']['ff']} | 0 | 0 | {cell['fmax_mhz']:.1f} MHz (a bound on the engine's) "
                     f"| {cp['from']['cell']} -> {cp['to']['cell']} ({cp['to']['port']}), {cp['delay_ns']} ns, "
                     f"{cp['logic_levels']} levels |")
    for (array, ram), fit in sorted(fits.items()):
        name = f"{array[0]}x{array[1]}, RAM {ram[0]}x{ram[1]}" + (", store=external" if ram == EXT_RAM else "")
        if fit is None:
            lines.append(f"| {name} | {_no_clock(None, array)} | | | | | | |")
            continue
        cp = fit.get("critical_path") or {}
        path = (f"{cp['from']['cell']} -> {cp['to']['cell']}, {cp.get('delay_ns', '?')} ns, "
                f"{cp.get('logic_levels', '?')} levels" if cp else "-")
        clock = (f"{fit['fmax_mhz']:.1f} MHz (seeds " + ", ".join(f"{x['fmax_mhz']:.1f}" for x in fit["seeds"]) + ")"
                 if fit["fits"] else "-")
        lines.append(f"| {name} | {'yes' if fit['fits'] else _no_clock(fit)} | {fit['lut4']:,} | {fit['ff']:,} "
                     f"| {fit['bram']} | {fit['dsp']} | {clock} | {path} |")
    n = largest_map(LFE5U_85F_EBR, 8)
    lines += ["", f"| map | bits / pixel | state | EBRs (model's count, 8 pixels a word) | fits the {PART}'s "
              f"{LFE5U_85F_EBR} EBR: the count / the engine placed there (RAM {RAM[0]}x{RAM[1]}) |",
              "|---|---:|---:|---:|---|"]
    seen = set()
    for r in rows:
        if r["map"] in seen:
            continue
        seen.add(r["map"])
        h, w = r["shape"]
        lines.append(f"| {r['map']} | {r['state_bits']} | {h * w * r['state_bits'] / 8192:,.0f} KiB "
                     f"| {r['ebr']} | {'yes' if r['ebr'] <= LFE5U_85F_EBR else 'no'} / {'yes' if r['in_ram'] else 'no'} |")
    lines += ["", f"Largest square map whose state fits the LFE5U-85F's {LFE5U_85F_EBR} EBRs "
              f"({LFE5U_85F_EBR * EBR_BITS:,} bits): {n}x{n} at {state_bits(n, n)['total']} bits a pixel "
              f"(worklist FIFOs and line buffers not counted); this RTL's store (3 banks x 2 field groups) holds "
              f"264x264 at T_c = 8 (scripts/tile_engine_size.py --ram), and the whole engine (worklist, queued "
              f"bits, frontier flags, line buffer: about 21 EBR more) was placed with a {RAM[0]}x{RAM[1]} RAM: "
              f"with 256x256 the 4x4 engine needs 210 EBR (make fit, does not fit)."]
    return "\n".join(lines), rows


def _ext(r):
    """A map whose state is outside: its time with a store of StateRam's timing, the bandwidth that takes,
    and the transfers' floor through a 16-bit SDRAM at its peak."""
    return (f"{r['hw_seconds'] * 1e3:.3f} ms at StateRam's timing "
            f"({r['store_bits_min'] / r['hw_seconds'] / 1e9:.1f} Gbit/s); a 16-bit SDRAM: >= "
            f"{r['sdram_floor_s'] * 1e3:.1f} ms of transfers")


def _held(r):
    """A map beyond the fitted engines' RAM: what the part holds (the RTL's store packs less densely
    than the model's count of EBRs)."""
    return (f"state does not fit: map beyond the engine's RAM, {RAM[0]}x{RAM[1]}, the largest that fits the "
            f"part with this store (the model's count for this map: {r['ebr']} EBR of {LFE5U_85F_EBR})")


def estimate(array):
    """(LUT4, available) of an engine not placed: the cell alone's LUT4 times the cells plus the rest
    (lanes, controller, worklist) as measured in the smallest placed engine, or None without both.
    The rest grows a little with T_c (T_c + 2 lanes): an estimate, said so where it is shown."""
    cell = cell_bound([array])
    placed = next((f for f in (fit_result(a, r) for r in reversed(RAMS) for a in BENCH_ARRAYS) if f), None)
    if not cell or not placed:
        return None
    t_r, t_c = placed["params"]["t_r"], placed["params"]["t_c"]
    rest = placed["lut4"] - t_r * t_c * cell["resources"]["lut4"]
    return rest + array[0] * array[1] * cell["resources"]["lut4"], placed["utilisation"]["TRELLIS_COMB"][1]


def _no_clock(fit, array=None):
    """Why an array has no clock of its own: it does not fit (what overflowed), or it was not placed
    (with the estimate of its size when there is one)."""
    if fit is None:
        est = estimate(array) if array else None
        if est:
            verdict = "does not fit" if est[0] > est[1] else "may fit"
            return f"not placed; estimate {est[0]:,} LUT4 of {est[1]:,}: {verdict}"
        return "not placed"
    return f"does not fit ({fmax.shortfall(fit)})"


def section(maps=MAPS, arrays=ARRAYS):
    """The BENCHMARKS.md section: what ran and how to read it, then :func:`comparison`'s tables."""
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    spec = ",".join(f"{r}x{c}" for r, c in arrays)
    text, _ = comparison(maps, arrays)
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    text = (f"Measured by `python scripts/bench_edt_tiled.py --arrays {spec}` on {stamp}, load average "
            f"{load} on {os.cpu_count()} cores (the software's times vary with the load; module docstring: what "
            "runs, the clock's source). room-64-64-8x4 is room-64-64-8 with each cell drawn as 4 x 4 pixels. "
            "Cycles are the tiled model's, which the regression proves equal to the tile engine's RTL; the cost "
            "breakdown: tile visits, cycles per visit (EDT and BFS cycles over their visits), RAM words moved "
            "against the floor of reading and writing each visited tile once. The clock is the tile engine's "
            "own (make fit, median of the seeds in its JSON), the engine's RAM the smallest of "
            + ", ".join(f"{r[0]}x{r[1]}" for r in RAMS) + " that holds the map; an array that does not fit "
            f"the {PART} or was not placed has no job time; maze512-1-0's state does not fit the part's block "
            "RAM: it runs on the engine with an external store (store=external, RAM 512x512, its own clock); its "
            "time (marked ext.) assumes a store of StateRam's timing, with the floor of the same transfers (each visit "
            "reads its phase's fields of its window, models.edt_bfs_tiled.PHASE_READS, and writes its tile's) "
            "through a 16-bit SDRAM at its peak beside it (the engine through a DDR3 controller: the next "
            "section).\n\n" + text)
    return text


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "build" / "bench" / "edt_tiled.md"))
    ap.add_argument("--maps", default=",".join(MAPS))
    ap.add_argument("--arrays", default=",".join(f"{r}x{c}" for r, c in ARRAYS))
    ap.add_argument("--md", help=f"replace the section '{SECTION}' of this markdown file (added at its end if absent)")
    args = ap.parse_args(argv)
    arrays = [tuple(int(v) for v in a.split("x")) for a in args.arrays.split(",")]
    text = section(args.maps.split(","), arrays)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")
    print(text)
    if args.md:
        kept.replace_section(Path(args.md), SECTION, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
