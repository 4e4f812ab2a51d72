"""Plan on a map with the harmonic planner (model or RTL) and follow the gradient.

    python -m sim harmonic MAP --goal R,C [--goal R,C ...] [--start R,C ...]
        [--block NxM] [--iters I] [--schedule P1,P2,... | P1:STEP:PMAX]
        [--engine model|icarus|verilator] [--block-exponents]
        [--json OUT] [--plot OUT.png]

MAP is a Moving AI .map, an ASCII grid (.txt: '#'/'@' obstacle, '.' free) or
an image (.pgm/.png: dark = obstacle).  Cells are ROW,COL from the top left,
0-based.  The map is cut into blocks of NxM nodes (default 3x6, one cluster,
and I = 6, plan()'s default; the RTL engines need multiples of 3x6); a size
that is not a multiple of the block is padded with obstacles on the bottom
and right, which changes nothing in the solution (outside the map already
reads as an obstacle).

The planner runs the paper's block-synchronous algorithm (section 4
pseudo-code): up to I iterations per block while the block changes, sweeps
over all blocks until none changes, then the next precision of the schedule
while local maxima remain.  Schedule default 16:16:256 (p = 16, 32, ... 256);
the RTL engines run arithmetic schedules only (P1:STEP:PMAX), build one
design per map size and p_max, and simulate slowly (hundreds to thousands of
cycles per second): use them on small maps.  Free cells no goal can reach
cannot get a gradient; they are reported ("unreachable") and left out of
the convergence criterion.

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
exact local maxima of the final field.

Trajectories: steepest 4-neighbour ascent from each --start (ties to the
first of N, E, W, S) until a goal, on the final field.

Output: a summary on stdout; --json writes height, width (of MAP, before
padding), engine, precision, converged, sweeps, block_iterations,
node_updates, cycles, potential (HxW floats, obstacles 0, goals 1),
unreachable ([r, c] list), trajectories ([{start, path, reached_goal}]);
--plot writes the map, the log-scale potential and the trajectories.

Exit status: 0 planned, converged, every start reached a goal; 1 planned but
not converged or a start did not reach a goal (e.g. no goal can reach it);
2 bad input (one line on stderr).
"""

import json
import sys
import time
from pathlib import Path

import numpy as np

from .cli import CliError, check_cell, parse_cell

ENGINES = ("model", "icarus", "verilator")
DEFAULT_SCHEDULE = "16:16:256"
DEFAULT_BLOCK = (3, 6)  # one cluster (hdl/harmonic/cluster.py ROWS x COLS)
MAX_BLOCK_SIDE = 4096   # the map is padded to whole blocks: keep that bounded
P_LIMIT = 1022          # the deepest word (p+2 bits) a 1024-deep node RAM holds


def add_arguments(parser):
    parser.add_argument("map", metavar="MAP", help="map file: .map, .txt, .pgm or .png")
    parser.add_argument("--goal", action="append", default=[], metavar="R,C",
                        help="goal cell (repeat for several goals; at least one)")
    parser.add_argument("--start", action="append", default=[], metavar="R,C",
                        help="start cell of a trajectory (repeatable)")
    parser.add_argument("--block", metavar="NxM",
                        help="block size in nodes (default 3x6: one cluster; the RTL needs multiples of 3x6)")
    parser.add_argument("--iters", default=None, metavar="I",
                        help="iterations per block visit at most (default: plan's default)")
    parser.add_argument("--schedule", default=None, metavar="P1,P2,...|P1:STEP:PMAX",
                        help=f"precisions, increasing (default {DEFAULT_SCHEDULE})")
    parser.add_argument("--engine", choices=ENGINES, default="model",
                        help="model (default), or the planner RTL on icarus / verilator")
    parser.add_argument("--block-exponents", action="store_true",
                        help="one exponent per block (issue 10, beyond the paper; every engine): "
                             "the word length follows the block, not the map")
    parser.add_argument("--json", metavar="OUT", help="write the result as JSON")
    parser.add_argument("--plot", metavar="OUT.png", help="plot map, potential (log scale) and trajectories")


# --- argument parsing -------------------------------------------------------

def parse_schedule(text, limit=P_LIMIT):
    """``"P1,P2,..."`` or ``"P1:STEP:PMAX"`` -> strictly increasing list of precisions."""
    text = text.strip()
    try:
        if ":" in text:
            parts = [int(x) for x in text.split(":")]
            if len(parts) != 3:
                raise ValueError
            first, step, last = parts
            if step < 1:
                raise CliError(f"--schedule {text!r}: STEP must be >= 1")
            if last < first:
                raise CliError(f"--schedule {text!r}: PMAX {last} is below P1 {first}")
            if first < 2 or last > limit:
                raise CliError(f"--schedule {text!r}: precisions must lie in 2..{limit}")
            ps = list(range(first, last + 1, step))
        else:
            ps = [int(x) for x in text.split(",")]
    except ValueError:
        raise CliError(f"--schedule {text!r}: expected P1,P2,... or P1:STEP:PMAX (integers)") from None
    if not ps:
        raise CliError(f"--schedule {text!r}: no precision")
    if any(b <= a for a, b in zip(ps, ps[1:])):
        raise CliError(f"--schedule {text!r}: precisions must increase")
    if ps[0] < 2 or ps[-1] > limit:
        raise CliError(f"--schedule {text!r}: precisions must lie in 2..{limit}")
    return ps


def parse_block(text, default):
    if text is None:
        return tuple(default)
    parts = text.lower().split("x")
    try:
        if len(parts) != 2:
            raise ValueError
        n, m = int(parts[0]), int(parts[1])
    except ValueError:
        raise CliError(f"--block {text!r}: expected NxM (two positive integers, e.g. 16x16)") from None
    if n < 1 or m < 1:
        raise CliError(f"--block {text!r}: both sides must be >= 1")
    if n > MAX_BLOCK_SIDE or m > MAX_BLOCK_SIDE:
        raise CliError(f"--block {text!r}: sides above {MAX_BLOCK_SIDE} are not supported")
    return n, m


def parse_iters(text):
    try:
        iters = int(text)
    except ValueError:
        raise CliError(f"--iters {text!r}: expected a positive integer") from None
    if iters < 1:
        raise CliError(f"--iters {iters}: must be >= 1")
    return iters


# --- running ----------------------------------------------------------------

def _progress(message):
    print(f"\r{message}", end="", file=sys.stderr, flush=True)


def _plan_defaults():
    """The block and I used when the command line gives none: one 3x6 cluster
    (the block the planner RTL regression runs, so that --engine icarus /
    verilator builds in seconds; the same default for the model, so every
    engine gives the same JSON), and plan()'s own I."""
    import inspect
    from navcores.models.harmonic import plan
    return DEFAULT_BLOCK, int(inspect.signature(plan).parameters["iters"].default)


def run_engine(engine, obstacle, goals, block, iters, schedule, block_exponents=False):
    """Plan with the model or the RTL; returns a dict with the PlanResult
    fields (h and unreachable on the unpadded map).  With block exponents
    also ``exponents`` (BR x BC) and ``frac_bits`` (h is then on
    the common scale 2**-frac_bits)."""
    keys = ("h", "p", "converged", "maxima", "unreachable", "sweeps", "block_iterations",
            "check_iterations", "node_updates", "cycles", "levels")
    if engine == "model":
        from navcores.models.harmonic import plan
        try:
            # With block exponents every engine runs the planner RTL's variant
            # (rtl=True: converted Maximum, scan and shift-visit cycles), so
            # the model and the RTL engines give the same JSON.
            opts = {"block_exponents": True, "rtl": True} if block_exponents else {}
            r = plan(obstacle, goals, block=block, iters=iters, schedule=tuple(schedule), **opts)
        except ValueError as e:
            raise CliError(str(e)) from None
        out = {k: getattr(r, k) for k in keys}
        if block_exponents:
            out["exponents"], out["frac_bits"] = r.exponents, r.frac_bits
            # exact local maxima of the final field (the RTL engines count the same)
            out["maxima"] = _maxima(obstacle, goals, block, r.padded_h)
        return out
    from .rtl.planner_driver import run_planner_rtl
    ticker = _Ticker(f"planner RTL on {engine}")
    try:
        out = run_planner_rtl(obstacle, goals, block, iters, tuple(schedule), engine,
                              progress=ticker.status, block_exponents=block_exponents)
    except ValueError as e:
        raise CliError(f"--engine {engine}: {e}") from None
    finally:
        ticker.stop()
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
        res["exponents"], res["frac_bits"] = E, frac
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


class _Ticker:
    """A progress line on stderr while the simulator runs (it runs in a
    subprocess: the line shows the elapsed time, then the final status)."""

    def __init__(self, what):
        import threading
        self.what, self.t0, self.done = what, time.time(), threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.done.wait(1.0):
            _progress(f"{self.what}: building / simulating, {time.time() - self.t0:.0f} s")

    def status(self, st):
        _progress(f"{self.what}: p = {st.get('p')}, {st.get('sweeps')} sweeps, "
                  f"{st.get('cycles')} cycles, {time.time() - self.t0:.0f} s")

    def stop(self):
        self.done.set()
        self.thread.join()
        print(file=sys.stderr, flush=True)


def plan_map(grid, goals, starts, block, iters, schedule, engine="model", block_exponents=False):
    """The whole command without I/O: returns the JSON-ready dict and the
    field (h at precision p, unpadded map; with block exponents h is on the
    common scale 2**-frac_bits and p is that scale)."""
    from navcores.models.harmonic import ascent_next, pad_to_blocks, reachable, trajectory

    height, width = grid.shape
    padded = pad_to_blocks(grid, block)
    reach = reachable(grid, goals)
    res = run_engine(engine, grid, goals, block, iters, schedule, block_exponents)
    h, p = np.asarray(res["h"], dtype=object)[:height, :width], int(res["p"])
    scale = int(res["frac_bits"]) if block_exponents else p
    goal_mask = np.zeros(grid.shape, dtype=bool)
    for g in goals:
        goal_mask[g] = True
    nxt = ascent_next(h)
    trajectories = []
    for s in starts:
        tr = trajectory(h, goal_mask, s, nxt=nxt).as_dict()
        tr["reachable"] = bool(reach[s])
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
        "padded": list(padded.shape), "levels": _levels_json(res.get("levels") or []),
        "potential": potential, "unreachable": unreachable, "trajectories": trajectories,
    }
    if block_exponents:
        out["exponents"] = [[int(e) for e in row] for row in res["exponents"]]
        out["frac_bits"] = scale
    return out, (h, scale)


def _levels_json(levels):
    out = []
    for lv in levels:
        d = lv if isinstance(lv, dict) else getattr(lv, "__dict__", {})
        out.append({k: (int(v) if isinstance(v, (int, np.integer)) and not isinstance(v, bool) else v)
                    for k, v in d.items() if isinstance(v, (int, float, bool, str, np.integer))})
    return out


def plot(path, grid, result, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pot = np.array(result["potential"], dtype=float)
    floor = 2.0 ** -result.get("frac_bits", result["precision"])
    field = np.where(grid, np.nan, np.log10(np.maximum(pot, max(floor, 1e-300))))
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6))
    axes[0].imshow(grid, cmap="gray_r", interpolation="nearest")
    axes[0].set_title("map (black: obstacle)")
    axes[1].set_facecolor("black")
    im = axes[1].imshow(field, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=axes[1], label="log10 potential (goal = 1)")
    axes[1].set_title(f"potential, p = {result['precision']}")
    for ax in axes:
        goals = result["_goals"]
        ax.plot([c for _, c in goals], [r for r, _ in goals], "*", color="red", ms=12)
        for tr in result["trajectories"]:
            pr, pc = np.array(tr["path"]).T
            ax.plot(pc, pr, color="white" if ax is axes[1] else "tab:blue", lw=1.5)
            ax.plot(pc[0], pr[0], "o", color="tab:orange" if tr["reached_goal"] else "tab:red")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args):
    from navcores.models.maps import load_grid

    path = Path(args.map)
    if not path.is_file():
        raise CliError(f"{path}: no such map file")
    grid = load_grid(path)
    if not args.goal:
        raise CliError("no goal: give at least one --goal R,C")
    goals = [check_cell(grid, parse_cell(g, "--goal"), "goal") for g in args.goal]
    starts = [check_cell(grid, parse_cell(s, "--start"), "start") for s in args.start]
    default_block, default_iters = _plan_defaults()
    block = parse_block(args.block, default_block)
    iters = parse_iters(args.iters) if args.iters is not None else default_iters
    schedule = parse_schedule(args.schedule or DEFAULT_SCHEDULE)

    t0 = time.time()
    bexp = bool(getattr(args, "block_exponents", False))
    result, _ = plan_map(grid, goals, starts, block, iters, schedule, args.engine, bexp)
    seconds = time.time() - t0

    lines = [
        f"{path.name}: {grid.shape[0]}x{grid.shape[1]}, {len(goals)} goal(s), block "
        f"{block[0]}x{block[1]} (padded to {result['padded'][0]}x{result['padded'][1]}), I = {iters}, "
        f"engine {args.engine}" + (", block exponents" if bexp else ""),
        f"precision {result['precision']} ("
        + ("converged: no local maximum" if result["converged"]
           else f"NOT converged: {result['maxima']} local maxima left at the schedule's end")
        + (f"; levels p = {','.join(str(lv['p']) for lv in result['levels'])}" if result["levels"] else "")
        + f"); {result['sweeps']} sweeps, "
        f"{result['block_iterations']} block iterations, {result['node_updates']} node updates, "
        f"{result['cycles']} cycles ({seconds:.1f} s)",
    ]
    if bexp:
        ex = result["exponents"]
        lines.append(f"block exponents e_b: {min(map(min, ex))}..{max(map(max, ex))} "
                     f"(fraction bits {result['precision']}..{result['frac_bits']})")
    if result["unreachable"]:
        lines.append(f"{len(result['unreachable'])} free cell(s) no goal can reach (no gradient there)")
    for tr in result["trajectories"]:
        s = tuple(tr["start"])
        if tr["reached_goal"]:
            lines.append(f"start {s}: reaches goal {tuple(tr['path'][-1])} in {len(tr['path']) - 1} steps")
        elif not tr["reachable"]:
            lines.append(f"start {s}: no goal can reach this cell (walled off): no trajectory")
        else:
            lines.append(f"start {s}: STUCK at {tuple(tr['path'][-1])} after {len(tr['path']) - 1} steps "
                         "(local maximum: more precision needed)")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result))
        lines.append(f"wrote {args.json}")
    if args.plot:
        Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
        title = f"{path.name}: harmonic potential, p = {result['precision']}, engine {args.engine}"
        plot(args.plot, grid, dict(result, _goals=goals), title)
        lines.append(f"wrote {args.plot}")
    print("\n".join(lines))
    ok = result["converged"] and all(tr["reached_goal"] for tr in result["trajectories"])
    return 0 if ok else 1
