"""Plan on a map with the harmonic planner (model or RTL) and follow the gradient.

    python -m sim harmonic MAP (--goal R,C | --goal-xy X,Y) [...] [--start R,C | --start-xy X,Y ...]
        [--block NxM] [--iters I] [--schedule P1,P2,... | P1:STEP:PMAX] [--paper-schedule]
        [--engine model|icarus|verilator|serial:PORT[@BAUD]] [--block-exponents [--e-max N|map]]
        [--node-exponents [--p P] [--e-max N|map]]
        [--cell METRES] [--unknown obstacle|free] [--json OUT] [--csv OUT] [--plot OUT.png]

MAP is a Moving AI .map, an ASCII grid (.txt: '#'/'@' obstacle, '.' free),
an image (.pgm/.png: dark = obstacle) or a ROS map_server map (.yaml beside
its image, read with nav2's thresholds; unknown cells are obstacles unless
--unknown free).  Cells are ROW,COL from the top left as the map is drawn,
0-based; --goal-xy / --start-xy give points in metres in the map frame (a
ROS map's own; else x right, y down from the top-left corner, --cell metres
a cell).  Goals and starts are repeatable.  The map is cut into blocks of
NxM nodes (default 3x6, one cluster; the RTL engines need multiples of 3x6)
and I iterations per block visit at most (default 6; 1..255, the planner's
START command carries I in 8 bits); a size that is not a multiple of the
block is padded with obstacles on the bottom and right, which changes
nothing in the solution (outside the map already reads as an obstacle).

The planner runs the paper's block-synchronous algorithm (section 4
pseudo-code) with still blocks (issue 19, the RTL's default schedule): up to
I iterations per block while the block changes, sweeps over the blocks that
may still change (their own nodes or a facing border changed since their
last stable visit) until none is left, then the next precision of the
schedule while local maxima remain.  The field is the paper's schedule's
bit for bit; only the cycles are fewer.  --paper-schedule runs the paper's
schedule instead (model: plan(..., paper_schedule=True); RTL engines:
Planner(paper_schedule=True)): every block in every sweep, a confirmation
iteration after the first stable one, a check pass (one iteration per block)
before each precision rise; the same field, more cycles (the JSON's
"block_schedule" says which ran: "still blocks" or "paper"; the check
iterations are 0 with still blocks).  The board (--engine serial:...) runs
the default schedule only.  Schedule default 16:16:256 (p = 16, 32, ... 256);
the RTL engines run arithmetic schedules only (P1:STEP:PMAX), build one
design per map size and p_max, and simulate slowly (thousands of cycles per
second): use them on small maps.  Free cells no goal can reach cannot get a
gradient; they are reported ("unreachable") and left out of the convergence
criterion.  The work grows with the free cells times the square of the
longest distance to a goal: a run estimated at more than 10 minutes says so
before it starts, and on a terminal a progress line shows the precision and
the sweeps.

--engine serial:PORT[@BAUD] plans on a board with the planner bitstream
(make bitstream CORE=harmonic; docs/boards.md): --block must be the board
planner's (6x12 on the ULX3S-85F), the map at most its grid of blocks (it
is padded with obstacles to that grid, so the counters and cycles are the
whole grid's), the schedule arithmetic up to its p_max; the model plans
the same padded grid and every node, counter and cycle count is compared
(rtl_matches_model; a difference exits 1).

--block-exponents (beyond the paper, issue 10; every engine): every block
keeps an exponent e_b, a mantissa v of block b stands for v / 2**(p+e_b), so
far from the goal the p-bit word still holds p significant bits
(models.harmonic.plan_exponents states the exponent rule and why it
terminates).  Every engine runs the planner RTL's variant (plan(...,
block_exponents=True, rtl=True): the Maximum compares converted neighbour
values, the cycles include the clamp scans and shift visits); the RTL
engines build Planner(..., block_exponents=True).  "precision" is then the
word's p; the JSON gains "exponents" (the final e_b per block, BR x BC) and
"frac_bits" (p + max e_b: the potential's resolution); "maxima" counts the
exact local maxima of the final field.  --e-max: the largest exponent, the
Planner's exponent register 0..e_max (default "map": 2 x the longest BFS
distance to a goal, what the exact field can need, issue 22:
models.harmonic.exponent_bound, at least 255, the 8-bit default; the RTL
engines refuse a map that needs more than 65535); the summary names the
bound, its register width and the blocks that end at it.  The model runs
its fast visit (bit for bit the reference's, tested).

--node-exponents (issue 22): one exponent per node, block exponents with
blocks of one node (models.harmonic.plan_node_exponents: a (P+1)-bit
mantissa, default P = 16, its top 2 bits empty, and an exponent 0..e_max per
node, eq. 2 floored).  Where a maze puts corridors thousands of steps apart
into one block, no block exponent helps (its word needs about 2 bits a step
of that spread); a node's own exponent does.  The model updates every node
at once and stops when no local maximum is left and every reachable node
holds a value (about one iteration a step of the longest distance);
--engine icarus|verilator runs the node-exponent engine's RTL
(hdl/harmonic/node_exponent_engine.py, sized for the map: at most 1024 x
1024, e_max <= 65535) in that simulator, red-black in place to a fixed
point, and checks it against the model run the same way (field,
iterations, cycles: "rtl_matches_model"; a difference exits 1).  --block,
--iters and --schedule do not apply.  The JSON's "precision" is P,
"iterations" the iterations run, "order" (jacobi or red-black), "cycles"
(RTL engines), "exponents" the final e per cell (HxW, e_max where the field
is 0), "e_max"; "potential" holds float64 values, which are 0 below about
1e-308: use "log2_potential" (log2 of the value, null where it is 0).
Trajectories are the Decision module's (as with --block-exponents, on
blocks of one node).

Trajectories: steepest 4-neighbour ascent from each start (ties to the
first of N, E, W, S) until a goal, on the final field.  With
--block-exponents the trajectories are the Decision module's instead
(models.harmonic.decision_step: the RTL's steepest triangle's gradient,
the step closest to it among the higher neighbours), the path the
hardware gives; each
is compared with the exact ascent and the summary names where they part
("ascent" in the JSON holds the exact ascent's path, "differs_at" the
first step where they part, or null).

Output: a summary on stdout; --json writes height, width (of MAP, before
padding), engine, precision, converged, sweeps, block_iterations,
node_updates, cycles, potential (HxW floats, obstacles 0, goals 1),
unreachable ([r, c] list), trajectories ([{start, path, path_xy,
reached_goal, reachable}], path_xy in metres in the map frame), frame (its
resolution, origin, y_up); --csv writes every trajectory as rows
start,row,col,x,y; --plot the map, the log-scale potential (cells without a
value, potential 0, in their own colour) and the trajectories.

Exit status: 0 planned, converged, every start reached a goal; 1 planned but
not converged or a start did not reach a goal (e.g. no goal can reach it);
the board's plan differs from the model's; 2 bad input (one line on
stderr; for the serial engine also a port or a board that does not answer
or whose planner cannot take the map).
"""

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from . import serial_engine
from .cli import (CliError, add_block, add_engine, add_map, add_outputs, add_place, add_schedule, integer,
                  load_map_arg, parse_block, parse_schedule, path_csv, path_xy, places, save_figure,
                  write_text)
from .progress import Progress, Ticker, announce

DEFAULT_SCHEDULE = "16:16:256"
DEFAULT_BLOCK = (3, 6)  # one cluster (hdl/harmonic/cluster.py ROWS x COLS): the RTL builds in seconds
DEFAULT_ITERS = 6       # plan()'s I
MAX_ITERS = 255         # the Planner's START command carries I in 8 bits

# The run-time estimate (measured on the bundled maps with 3x6 blocks, I = 6,
# 16:16:256): node updates ~ K * free cells * L**2, L the longest
# Manhattan distance from a free cell to its nearest goal (K was 0.1 .. 0.45);
# the model updates about 400,000 nodes a second on this 2-core machine, an
# RTL planner takes about 5 cycles a node update and simulates about 4,000
# (Icarus) / 24,000 (Verilator) cycles a second (BENCHMARKS.md).
WORK_K = 0.25
MODEL_RATE = 4.0e5
RTL_CYCLES_PER_UPDATE = 5.0
RTL_RATE = {"icarus": 4.0e3, "verilator": 2.4e4}
# --node-exponents: about one iteration a step of the longest distance, every
# reachable node each (measured on maze512-1-0: 4e6 node updates a second).
NODE_RATE = 4.0e6
NODE_P_MIN, NODE_P_MAX = 4, 48      # models.harmonic.node_exponents: P_LIMIT
NODE_MAX_ITER = (1 << 16) - 1       # the node-exponent engine's command carries max_iter in 16 bits
NODE_RTL_RATE = {"icarus": 7.0e3, "verilator": 1.0e5}   # the engine's simulated cycles a second (measured)


def engine_cycles_estimate(shape, longest):
    """The engine's cycles on a map whose longest distance to a goal is ``longest`` (about 0.6 red-black
    iterations a step to the fixed point on the maze crops)."""
    from navcores.models.harmonic.node_exponents import engine_cycles
    return engine_cycles(shape[0], shape[1], max(1, int(0.6 * longest) + 16))


def add_arguments(parser):
    add_map(parser)
    add_place(parser, "goal", many=True, required=True, help="goal")
    add_place(parser, "start", many=True, help="start of a trajectory")
    add_block(parser, DEFAULT_BLOCK)
    parser.add_argument("--iters", type=integer(1, MAX_ITERS, "the planner's START command carries I in 8 bits"),
                        default=DEFAULT_ITERS, metavar="I",
                        help="iterations per block visit at most (default %(default)s)")
    add_schedule(parser, DEFAULT_SCHEDULE)
    parser.add_argument("--paper-schedule", action="store_true",
                        help="the paper's block schedule (every block every sweep, a confirmation iteration, "
                             "check passes) instead of the default still blocks: the same field, more cycles")
    add_engine(parser, "the planner RTL in that simulator (arithmetic schedules, blocks of whole 3x6 clusters)",
               serial=True)
    parser.add_argument("--block-exponents", action="store_true",
                        help="one exponent per block (issue 10, beyond the paper; every engine): "
                             "the word length follows the block, not the map")
    parser.add_argument("--node-exponents", action="store_true",
                        help="one exponent per node (issue 22; model, icarus or verilator): mazes whose "
                             "blocks hold corridors far apart")
    parser.add_argument("--p", type=integer(NODE_P_MIN, NODE_P_MAX, "the node-exponent model's int64 words"),
                        default=None, metavar="P",
                        help="with --node-exponents: the mantissa's precision (default 16)")
    parser.add_argument("--e-max", type=e_max_arg, default="map", metavar="N|map",
                        help="with --block-exponents or --node-exponents: the largest exponent (default map: "
                             "2 x the longest BFS distance to a goal; block exponents: at least 255)")
    add_outputs(parser, csv=True, plot_help="plot map, potential (log scale) and trajectories")


def e_max_arg(text):
    """--e-max: "map" or an integer >= 0."""
    return "map" if text == "map" else integer(0, None)(text)


def estimate(grid, goals, engine):
    """(seconds, basis) of a plan on ``grid``: see WORK_K."""
    rows, cols = np.nonzero(~grid)
    if not len(rows):
        return 0.0, "no free cell"
    # the longest Manhattan distance to the nearest goal, in chunks (bounded memory)
    far = 0
    g = np.array(goals)
    for k in range(0, len(rows), 1 << 20):
        r, c = rows[k:k + (1 << 20), None], cols[k:k + (1 << 20), None]
        far = max(far, int((np.abs(r - g[None, :, 0]) + np.abs(c - g[None, :, 1])).min(axis=1).max()))
    updates = WORK_K * len(rows) * float(far) ** 2
    if serial_engine.is_serial(engine):        # the board's clock runs it; its line reads it back
        return 0.0, "on a board"
    if engine == "model":
        return updates / MODEL_RATE, (f"about {updates:.2g} node updates: {len(rows)} free cells, "
                                      f"{far} cells to the farthest, at {MODEL_RATE:.0f} a second")
    cycles = updates * RTL_CYCLES_PER_UPDATE
    return cycles / RTL_RATE[engine], (f"about {cycles:.2g} clock cycles at {RTL_RATE[engine]:.0f} "
                                       f"simulated a second on {engine}")


def check_rtl(engine, shape, block, schedule, block_exponents, e_max=None, paper_schedule=False):
    """Refuse, before anything runs, what the planner RTL cannot run: a
    schedule that is not arithmetic, blocks that are not whole clusters, a
    map larger than a Planner's declared bounds (hdl/harmonic/planner.py)."""
    from navcores.hdl.harmonic.planner import Planner
    from navcores.hdl.params import check
    from .rtl.planner_driver import arithmetic, exponent_params, planner_params
    try:
        params = planner_params(shape, block, p_max=arithmetic(schedule)[2])
        if block_exponents:
            params = exponent_params(params, e_max)
        if paper_schedule:
            params["paper_schedule"] = True
        check(Planner.PARAMS, Planner.CONSTRAINTS, **{**{p.name: p.default for p in Planner.PARAMS}, **params})
    except ValueError as e:
        raise CliError(f"--engine {engine}: {e}") from None


def run_engine(engine, obstacle, goals, block, iters, schedule, block_exponents=False, progress=None, e_max=None,
               paper_schedule=False):
    """Plan with the model or the RTL; returns a dict with the PlanResult
    fields (h and unreachable on the unpadded map).  With block exponents
    also ``exponents`` (BR x BC) and ``frac_bits`` (h is then on
    the common scale 2**-frac_bits).  ``paper_schedule``: the paper's block
    schedule (model and RTL engines; the board runs the default only)."""
    keys = ("h", "p", "converged", "maxima", "unreachable", "sweeps", "block_iterations",
            "check_iterations", "node_updates", "cycles", "levels")
    if engine == "model":
        from navcores.models.harmonic import plan
        try:
            # With block exponents every engine runs the planner RTL's variant
            # (rtl=True: converted Maximum, scan and shift-visit cycles), so
            # the model and the RTL engines give the same JSON.
            opts = {"block_exponents": True, "rtl": True, "fast": True, "e_max": e_max} if block_exponents else {}
            r = plan(obstacle, goals, block=block, iters=iters, schedule=tuple(schedule), progress=progress,
                     paper_schedule=paper_schedule, **opts)
        except ValueError as e:
            raise CliError(str(e)) from None
        out = {k: getattr(r, k) for k in keys}
        if block_exponents:
            out["exponents"], out["frac_bits"], out["mantissa"] = r.exponents, r.frac_bits, r.mantissa
            # exact local maxima of the final field (the RTL engines count the same)
            out["maxima"] = _maxima(obstacle, goals, block, r.padded_h)
        return out
    if serial_engine.is_serial(engine):
        with Ticker(f"planner on the board ({engine})"):
            res = serial_engine.run_harmonic(engine, obstacle, goals, block, iters, schedule, block_exponents)
        res["maxima"] = _maxima(res["grid"], goals, block, res["padded_h"])
        return res
    from .rtl.planner_driver import run_planner_rtl
    with Ticker(f"planner RTL on {engine}") as ticker:
        try:
            out = run_planner_rtl(obstacle, goals, block, iters, tuple(schedule), engine, block_exponents=block_exponents,
                                  paper_schedule=paper_schedule,
                                  **({"e_max": e_max} if block_exponents else {}),
                                  progress=lambda st: ticker.status(f"p = {st.get('p')}, {st.get('sweeps')} sweeps, "
                                                                    f"{st.get('cycles')} cycles"))
        except ValueError as e:
            raise CliError(f"--engine {engine}: {e}") from None
    res = {k: out.get(k) for k in keys}
    # The RTL reports no per-level record and no maxima count (only
    # converged): the maxima are counted on the field it read back.
    res["levels"] = []
    if block_exponents:
        # Mantissas and e_b -> the common scale 2**-frac_bits, as the model's h.
        E = out["exponents"]
        frac = int(out["p"]) + int(E.max())
        full = np.array(out["padded_h"], dtype=object)
        n, m = block
        for br in range(E.shape[0]):
            for bc in range(E.shape[1]):
                full[br * n:br * n + n, bc * m:bc * m + m] <<= frac - int(out["p"]) - int(E[br, bc])
        res["h"] = full[:obstacle.shape[0], :obstacle.shape[1]].copy()
        res["exponents"], res["frac_bits"], res["mantissa"] = E, frac, out["padded_h"]
        res["maxima"] = _maxima(obstacle, goals, block, full)
        return res
    res["maxima"] = _maxima(obstacle, goals, block, out["padded_h"])
    return res


def _maxima(obstacle, goals, block, padded_h):
    from navcores.models.harmonic import local_max, neighbours, pad_to_blocks, reachable
    padded = pad_to_blocks(obstacle, block)
    const = padded | ~reachable(padded, goals)
    for g in goals:
        const[g] = True
    h = np.asarray(padded_h, dtype=object)
    return int(local_max(h, const, neighbours(h)).sum())


def plan_map(grid, goals, starts, block, iters, schedule, engine="model", block_exponents=False, frame=None,
             progress=None, e_max="map", paper_schedule=False):
    """The whole command without I/O: returns the JSON-ready dict and the
    field (h at precision p, unpadded map; with block exponents h is on the
    common scale 2**-frac_bits and p is that scale)."""
    from navcores.models.harmonic import ascent_next, decision_paths, e_max_for, pad_to_blocks, reachable, trajectory

    height, width = grid.shape
    padded = pad_to_blocks(grid, block)
    reach = reachable(grid, goals)
    if block_exponents and e_max == "map":
        e_max = e_max_for(grid, goals)
    res = run_engine(engine, grid, goals, block, iters, schedule, block_exponents, progress, e_max, paper_schedule)
    h, p = np.asarray(res["h"], dtype=object)[:height, :width], int(res["p"])
    scale = int(res["frac_bits"]) if block_exponents else p
    goal_mask = np.zeros(grid.shape, dtype=bool)
    for g in goals:
        goal_mask[g] = True
    nxt = ascent_next(h)
    if block_exponents:     # the Decision module's paths (the hardware's), on the padded mantissas
        pad_goal = np.zeros(padded.shape, dtype=bool)
        pad_goal[:height, :width] = goal_mask
        decided = decision_paths(res["mantissa"], res["exponents"], block, p, pad_goal, starts)
    trajectories = []
    for k, s in enumerate(starts):
        tr = trajectory(h, goal_mask, s, nxt=nxt).as_dict()
        if block_exponents:
            path, reached = decided[k]
            path, ascent = [list(c) for c in path], tr["path"]
            tr.update(path=path, reached_goal=reached, ascent=ascent, differs_at=_parted(path, ascent))
        tr["reachable"] = bool(reach[s])
        if frame is not None:
            tr["path_xy"] = path_xy(frame, tr["path"])
        trajectories.append(tr)
    unreachable = [[int(r), int(c)] for r, c in np.argwhere(~grid & ~reach)]
    unit = 1 << scale              # int / int is correctly rounded at any p
    potential = [[int(v) / unit for v in row] for row in h]
    out = {
        "height": height, "width": width, "engine": engine, "precision": p,
        "converged": bool(res["converged"]), "sweeps": int(res["sweeps"]),
        "block_iterations": int(res["block_iterations"]), "node_updates": int(res["node_updates"]),
        "cycles": int(res["cycles"]), "maxima": int(res["maxima"]),
        "check_iterations": int(res["check_iterations"]),
        "block": list(block), "iters": iters, "schedule": list(schedule),
        "block_schedule": "paper" if paper_schedule else "still blocks",
        "padded": list(padded.shape), "levels": _levels_json(res.get("levels") or []),
        "potential": potential, "unreachable": unreachable, "trajectories": trajectories,
    }
    if frame is not None:
        out["frame"] = frame.as_dict()
    if "rtl_matches_model" in res:           # the serial engine: the board against the model
        out["rtl_matches_model"], out["model_differences"] = res["rtl_matches_model"], res["differences"]
    if block_exponents:
        out["exponents"] = [[int(e) for e in row] for row in res["exponents"]]
        out["frac_bits"] = scale
        out["e_max"] = int(e_max)
    return out, (h, scale)


def _levels_json(levels):
    out = []
    for lv in levels:
        d = lv if isinstance(lv, dict) else getattr(lv, "__dict__", {})
        out.append({k: (int(v) if isinstance(v, (int, np.integer)) and not isinstance(v, bool) else v)
                    for k, v in d.items() if isinstance(v, (int, float, bool, str, np.integer))})
    return out


def plot(path, grid, result, title):
    """Map and log-scale potential; free cells without a value (potential 0:
    no goal reaches them, or below 2**-p) in their own colour, never the
    colour bar's minimum."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    if "log2_potential" in result:      # node exponents: values far below float64's range
        lg = np.array([[np.nan if x is None else x for x in row] for row in result["log2_potential"]], dtype=float)
        novalue = ~grid & np.isnan(lg)
        field = np.where(grid | novalue, np.nan, lg * np.log10(2.0))
    else:
        pot = np.array(result["potential"], dtype=float)
        novalue = ~grid & (pot <= 0)
        with np.errstate(divide="ignore"):
            field = np.where(grid | novalue, np.nan, np.log10(np.where(pot > 0, pot, 1.0)))
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6))
    axes[0].imshow(grid, cmap="gray_r", interpolation="nearest")
    axes[0].set_title("map (black: obstacle)")
    im = axes[1].imshow(field, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=axes[1], label="log10 potential (goal = 1)")
    # obstacles black, cells without a value light pink: both outside the colour map
    axes[1].imshow(np.where(grid, 1.0, np.nan), cmap=ListedColormap(["black"]), interpolation="nearest")
    axes[1].imshow(np.where(novalue, 1.0, np.nan), cmap=ListedColormap(["#f4c2d7"]), interpolation="nearest")
    axes[1].set_title(f"potential, p = {result['precision']}")
    axes[1].legend(handles=[Patch(color="black", label="obstacle"),
                            Patch(color="#f4c2d7", label=f"no value ({int(novalue.sum())} cells: potential 0)")],
                   loc="upper center", bbox_to_anchor=(0.5, -0.05), ncol=2, fontsize=8, frameon=False)
    for ax in axes:
        goals = result["_goals"]
        ax.plot([c for _, c in goals], [r for r, _ in goals], "*", color="red", ms=12)
        for tr in result["trajectories"]:
            pr, pc = np.array(tr["path"]).T
            ax.plot(pc, pr, color="white" if ax is axes[1] else "tab:blue", lw=1.5)
            ax.plot(pc[0], pr[0], "o", color="tab:orange" if tr["reached_goal"] else "tab:red")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def run(args):
    if args.node_exponents:
        return run_nodes(args)
    if args.p is not None:
        raise CliError("--p: only with --node-exponents (the block planner takes --schedule)")
    paper = bool(args.paper_schedule)
    if paper and serial_engine.is_serial(args.engine):
        raise CliError(f"--paper-schedule: the board's planner (--engine {args.engine}) runs the default "
                       "schedule (still blocks) only")
    if serial_engine.is_serial(args.engine):
        serial_engine.check(args.engine)        # the port exists, before any work
    grid, frame, goals, starts = _places(args)
    block = parse_block(args.block)
    schedule = parse_schedule(args.schedule)
    bexp = bool(args.block_exponents)
    e_max = args.e_max
    if bexp and e_max == "map":
        from navcores.models.harmonic import e_max_for
        e_max = e_max_for(grid, goals)
    if args.engine != "model" and not serial_engine.is_serial(args.engine):
        check_rtl(args.engine, grid.shape, block, schedule, bexp, e_max, paper)

    seconds, basis = estimate(grid, goals, args.engine)
    announce("sim harmonic", seconds, f"planning {grid.shape[0]}x{grid.shape[1]} on the {args.engine}", basis)
    t0 = time.time()
    with Progress(f"harmonic {args.engine}") as bar:
        result, _ = plan_map(grid, goals, starts, block, args.iters, schedule, args.engine, bexp, frame,
                             progress=lambda res, p, cycles: bar.update(
                                 note=f"p = {p}, {res.sweeps} sweeps, {res.block_iterations} block iterations"),
                             e_max=e_max, paper_schedule=paper)
    seconds = time.time() - t0

    name = Path(args.map).name
    lines = [
        f"{name}: {grid.shape[0]}x{grid.shape[1]}, {len(goals)} goal(s), block "
        f"{block[0]}x{block[1]} (padded to {result['padded'][0]}x{result['padded'][1]}), I = {args.iters}, "
        f"engine {args.engine}" + (", block exponents" if bexp else "")
        + (", the paper's schedule" if paper else ", still blocks"),
        f"precision {result['precision']} ("
        + ("converged: no local maximum" if result["converged"]
           else f"NOT converged: {result['maxima']} local maxima left at the schedule's end")
        + (f"; levels p = {','.join(str(lv['p']) for lv in result['levels'])}" if result["levels"] else "")
        + f"); {result['sweeps']} sweeps, "
        f"{result['block_iterations']} block iterations, {result['node_updates']} node updates, "
        f"{result['cycles']} cycles"
        + (f", {result['check_iterations']} check iterations" if paper else "") + f" ({seconds:.1f} s)",
    ]
    if bexp:
        ex = result["exponents"]
        top = max(map(max, ex))
        at = sum(e == result["e_max"] for row in ex for e in row)
        lines.append(f"block exponents e_b: {min(map(min, ex))}..{top} "
                     f"(fraction bits {result['precision']}..{result['frac_bits']}); e_max {result['e_max']} "
                     f"({int(result['e_max']).bit_length()}-bit exponent registers)"
                     + (f", {at} block(s) at e_max: a larger --e-max may converge" if at else ""))
    if "rtl_matches_model" in result:
        lines.append("board bit-exact against the model: " + ("yes" if result["rtl_matches_model"] else
                                                               "NO (" + "; ".join(result["model_differences"]) + ")"))
    if result["unreachable"]:
        lines.append(f"{len(result['unreachable'])} free cell(s) no goal can reach (no gradient there)")
    title = f"{name}: harmonic potential, p = {result['precision']}, engine {args.engine}"
    ok = _report(args, result, grid, goals, frame, lines, title)
    return 0 if ok and result.get("rtl_matches_model", True) else 1


def _places(args):
    """The map (obstacle grid), its frame, the goals (at least one) and the starts of the command line."""
    gm, frame = load_map_arg(args)
    grid = gm.obstacle
    goals = places(args, "goal", grid, frame)
    if not goals:
        raise CliError("no goal: give at least one --goal R,C or --goal-xy X,Y")
    return grid, frame, goals, places(args, "start", grid, frame)


def _report(args, result, grid, goals, frame, lines, title):
    """The trajectories' lines, the --json / --csv / --plot files, the summary
    printed; returns True when the plan converged and every start reached a goal."""
    for tr in result["trajectories"]:
        s = tuple(tr["start"])
        how = ""
        if "ascent" in tr:
            how = (" by the Decision module, the exact ascent's path" if tr["differs_at"] is None else
                   f" by the Decision module, parting from the exact ascent ({len(tr['ascent']) - 1} steps) "
                   f"at step {tr['differs_at']}, {tuple(tr['path'][min(tr['differs_at'], len(tr['path']) - 1)])}")
        if tr["reached_goal"]:
            lines.append(f"start {s}: reaches goal {tuple(tr['path'][-1])} in {len(tr['path']) - 1} steps{how}")
        elif not tr["reachable"]:
            lines.append(f"start {s}: no goal can reach this cell (walled off): no trajectory")
        else:
            lines.append(f"start {s}: STUCK at {tuple(tr['path'][-1])} after {len(tr['path']) - 1} steps "
                         f"(local maximum: more precision needed){how}")
    if args.json:
        write_text(args.json, json.dumps(result))
        lines.append(f"wrote {args.json}")
    if args.csv:
        rows = ["start,row,col,x,y"]
        for k, tr in enumerate(result["trajectories"]):
            rows += path_csv(frame, tr["path"], prefix=(k,))
        write_text(args.csv, "\n".join(rows) + "\n")
        lines.append(f"wrote {args.csv}")
    if args.plot:
        plot(args.plot, grid, dict(result, _goals=goals), title)
        lines.append(f"wrote {args.plot}")
    print("\n".join(lines))
    return result["converged"] and all(tr["reached_goal"] for tr in result["trajectories"])


def _parted(path, ascent):
    """The first step where the Decision's path and the exact ascent part, None if they are the same."""
    return next((i for i, (a, b) in enumerate(zip(path, ascent)) if a != b),
                None if len(path) == len(ascent) else min(len(path), len(ascent)))


def plan_nodes(grid, goals, starts, p, e_max, frame=None, progress=None, engine="model", work=None):
    """--node-exponents without I/O: the JSON-ready dict
    (models.harmonic.plan_node_exponents, Decision trajectories on blocks of one node).
    ``engine`` icarus / verilator: the node-exponent engine's RTL in that
    simulator (red-black, in place, to a fixed point; ``work``: its folder),
    checked against the model run the same way."""
    from navcores.models.harmonic import ascent_next, decision_paths, plan_node_exponents, reachable, trajectory
    from navcores.models.harmonic.node_exponents import engine_cycles
    rtl = engine != "model"
    try:
        if e_max == "map":
            from navcores.models.harmonic import exponent_bound
            e_max = exponent_bound(grid, goals)
        opts = {"order": "red-black", "until_fixed": True, "max_iter": NODE_MAX_ITER} if rtl else {}
        res = plan_node_exponents(grid, goals, p=p, e_max=e_max, progress=progress, **opts)
    except ValueError as e:
        raise CliError(str(e)) from None
    extra = {"order": "red-black" if rtl else "jacobi"}
    if rtl:
        got = run_node_engine(grid, goals, p, e_max, engine, work)
        diffs = [k for k, same in (
            ("field", np.array_equal(got["mantissa"], res.mantissa) and np.array_equal(got["exponents"], res.exponents)),
            ("iterations", got["iterations"] == res.iterations), ("fixed point", got["fixed"] == res.fixed_point),
            ("cycles", got["cycles"] == engine_cycles(*grid.shape, res.iterations))) if not same]
        extra.update(cycles=got["cycles"], fixed_point=got["fixed"], rtl_matches_model=not diffs,
                     model_differences=diffs)
    reach = reachable(grid, goals)
    value = res.mantissa > 0
    goal_mask = np.zeros(grid.shape, dtype=bool)
    for g in goals:
        goal_mask[g] = True
    nxt = ascent_next(res.key)
    decided = decision_paths(res.mantissa, res.exponents, (1, 1), res.p, goal_mask, starts)
    trajectories = []
    for s, (path, reached) in zip(starts, decided):
        ascent = trajectory(res.key, goal_mask, s, nxt=nxt).as_dict()["path"]
        path = [list(c) for c in path]
        tr = {"start": list(s), "path": path, "reached_goal": bool(reached), "ascent": ascent,
              "differs_at": _parted(path, ascent),
              "reachable": bool(reach[s])}
        if frame is not None:
            tr["path_xy"] = path_xy(frame, path)
        trajectories.append(tr)
    with np.errstate(divide="ignore"):
        log2 = np.log2(res.mantissa.astype(float)) - (res.p + res.exponents)
    out = {
        "height": grid.shape[0], "width": grid.shape[1], "engine": engine, "node_exponents": True,
        "precision": res.p, "headroom": res.headroom, "converged": bool(res.converged),
        "iterations": int(res.iterations), "maxima": int(max(res.maxima, 0)), "zeros": int(res.zeros),
        "e_max": res.e_max, "exponents": res.exponents.tolist(), **extra,
        "potential": np.where(value, np.exp2(log2), 0.0).tolist(),
        "log2_potential": [[float(x) if ok else None for x, ok in zip(row, vrow)] for row, vrow in zip(log2, value)],
        "unreachable": [[int(r), int(c)] for r, c in np.argwhere(~grid & ~reach)],
        "trajectories": trajectories,
    }
    if frame is not None:
        out["frame"] = frame.as_dict()
    return out


def node_engine_params(shape, p, e_max):
    """The node-exponent engine sized for a map (its checks: one line on a refusal)."""
    from navcores.hdl.harmonic.node_exponent_engine import NodeExponentEngine
    from navcores.hdl.params import check
    params = {"max_h": shape[0], "max_w": max(shape[1], 2), "p": p, "e_max": e_max, "headroom": 2}
    check(NodeExponentEngine.PARAMS, NodeExponentEngine.CONSTRAINTS, **params)
    if shape[1] < 2:
        raise ValueError("the engine takes maps 2 or more cells wide")
    return params


def run_node_engine(grid, goals, p, e_max, sim, work):
    """Run sim/rtl/node_engine_job.py on the engine sized for the map; returns its result."""
    from .rtl.runner import run
    job, result = work / "job.json", work / "result.json"
    params = node_engine_params(grid.shape, p, e_max)
    job.write_text(json.dumps({"obstacle": grid.tolist(), "goals": [list(g) for g in goals],
                               "max_iter": NODE_MAX_ITER, "params": params}))
    with Ticker(f"node-exponent engine RTL on {sim}"):
        run("harmonic_node_exponent_engine", params, sim, "navcores.sim.rtl.node_engine_job",
            env={"NODE_JOB": job, "NODE_RESULT": result}, log_file=work / "sim.log")
    return json.loads(result.read_text())


def run_nodes(args):
    """python -m sim harmonic --node-exponents."""
    if serial_engine.is_serial(args.engine):
        raise CliError(f"--node-exponents: the model, icarus or verilator (no board runs it), not --engine {args.engine}")
    if args.block_exponents:
        raise CliError("--node-exponents and --block-exponents: choose one")
    grid, frame, goals, starts = _places(args)
    from navcores.models.harmonic import distances
    from navcores.models.harmonic.node_exponents import NODE_P
    p = NODE_P if args.p is None else args.p
    dist = distances(grid, goals)
    e_max = max(1, 2 * int(dist.max())) if args.e_max == "map" else args.e_max
    rtl = args.engine != "model"
    if rtl:
        try:
            node_engine_params(grid.shape, p, e_max)
        except ValueError as e:
            raise CliError(f"--engine {args.engine}: {e}") from None
        # red-black to a fixed point: about 0.6 iterations a step of the longest distance
        cycles = engine_cycles_estimate(grid.shape, int(dist.max()))
        announce("sim harmonic", cycles / NODE_RTL_RATE[args.engine], f"the node-exponent engine on {args.engine}",
                 f"about {cycles:.2g} clock cycles at {NODE_RTL_RATE[args.engine]:.0f} simulated a second")
    else:
        work = float(max(int(dist.max()), 1)) * int((dist >= 0).sum())
        announce("sim harmonic", work / NODE_RATE, f"node exponents on {grid.shape[0]}x{grid.shape[1]}",
                 f"about {work:.2g} node updates at {NODE_RATE:.0g} a second")
    t0 = time.time()
    with Progress("harmonic node exponents", total=max(int(dist.max()), 1), unit=" iterations") as bar, \
            tempfile.TemporaryDirectory(prefix="sim_nodes_") as tmp:
        result = plan_nodes(grid, goals, starts, p, e_max, frame, engine=args.engine, work=Path(tmp),
                            progress=lambda i, zeros, maxima: bar.update(i, note=f"{zeros} nodes not reached"))
    seconds = time.time() - t0
    name = Path(args.map).name
    used = np.array(result["exponents"])[np.array([[x is not None for x in row] for row in result["log2_potential"]])]
    lines = [
        f"{name}: {grid.shape[0]}x{grid.shape[1]}, {len(goals)} goal(s), node exponents, p = {p}, "
        + (f"the engine's RTL on {args.engine} (red-black, in place, to a fixed point: {result['cycles']} cycles)"
           if rtl else "the model (every node at once)"),
        ("converged: no local maximum" if result["converged"] else
         f"NOT converged: {result['zeros']} reachable node(s) at 0, {result['maxima']} local maxima")
        + f"; {result['iterations']} iterations ({seconds:.1f} s); exponents "
        f"{int(used.min()) if used.size else 0}..{int(used.max()) if used.size else 0} of e_max {result['e_max']} "
        f"({int(result['e_max']).bit_length()}-bit exponent per node)",
    ]
    if rtl:
        lines.append("RTL bit-exact and cycle-exact against the model: " + (
            "yes" if result["rtl_matches_model"] else "NO (" + ", ".join(result["model_differences"]) + ")"))
    if result["unreachable"]:
        lines.append(f"{len(result['unreachable'])} free cell(s) no goal can reach (no gradient there)")
    title = f"{name}: harmonic potential, node exponents, p = {p}, engine {args.engine}"
    ok = _report(args, result, grid, goals, frame, lines, title)
    return 0 if ok and result.get("rtl_matches_model", True) else 1
