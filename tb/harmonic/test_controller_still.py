"""The Control module's still-block schedule (hdl/harmonic/controller.py) on
its own, in Amaranth's simulator: its next-block choice against a reference
of the rule, over random visit outcomes on many block grids.

The planner tests (test_planner.py, cocotb on both simulators) check the
whole planner against models.harmonic on real maps, but a map reaches only
some of the choices the Control module makes at the end of a visit: with
the choice prepared during the visit (issue 17: ``Controller._still_prep``),
each of its priority cases is a path of its own.  Here a mock Block answers
every visit with random flags (stable or not, edges changed, Maximum), and
the reference below, the rule of models.harmonic.schedule.StillBlocks
written out per visit, predicts every visit's block, the sweeps and the end
of the run (converged, a precision rise, or not converged).  The test counts
the cases it reached and asserts each one.  Randomized: SEED= replays (the
seed is printed).
"""

import random

from amaranth.sim import Simulator

from navcores.hdl.harmonic.controller import Controller
from navcores.sim.rtl.runner import seed_from_env

L = 3           # the mock's cycles per iteration (take ... done)
LEAD_IN = 3     # cycles from the run request to the first take (the clusters' two-cycle lead-in)
ITERS = 3       # I
P1, STEP, P_LAST = 4, 2, 8      # two precision rises, then not converged


def _rng(salt):
    seed = int(seed_from_env())
    print(f"SEED={seed}")
    return random.Random(seed * 1000 + salt)


class Reference:
    """Still blocks, visit by visit (models.harmonic.schedule.StillBlocks
    and Timing's folded check): dirty and Maximum bits per block, the next
    dirty block after this one in raster order, else the next sweep from the
    first dirty block, else the end of the level."""

    def __init__(self, BR, BC):
        self.BR, self.BC, self.B = BR, BC, BR * BC
        self.dirty, self.mx, self.b, self.p = set(range(self.B)), set(), 0, P1
        self.cases = {}

    def _case(self, name):
        self.cases[name] = self.cases.get(name, 0) + 1

    def visit(self, stable, edges, mx):
        """The visit of block self.b ended: returns None (the run goes on
        at self.b), 'converged' or 'stopped'."""
        b, BC = self.b, self.BC
        br, bc = divmod(b, BC)
        self.last = (b, stable, sorted(edges), sorted(self.dirty))
        self.dirty.discard(b)
        before = {x for x in self.dirty if x > b}      # dirty after b before this visit's marks
        if not stable:
            self.dirty.add(b)
        else:
            (self.mx.add if mx else self.mx.discard)(b)
        nbrs = {"N": (br > 0, b - BC), "S": (br < self.BR - 1, b + BC),
                "W": (bc > 0, b - 1), "E": (bc < BC - 1, b + 1)}
        for side, (ok, nb) in nbrs.items():
            if ok and side in edges:
                self.dirty.add(nb)
        after = sorted(x for x in self.dirty if x > b)
        if after:
            nxt = after[0]
            if nxt == b + 1 and "E" in edges and bc < BC - 1:
                self._case("next: E neighbour")
            elif nxt == b + BC and nxt not in before:
                self._case("next: S neighbour" + (" before a dirty block" if before else ""))
            else:
                self._case("next: a dirty block" + (", S marked after it" if b + BC in after and b + BC > nxt
                                                     and b + BC not in before else ""))
            self.b = nxt
            return None
        if self.dirty:
            first = min(self.dirty)
            if first == b:
                self._case("sweep from: the block itself")
            elif "N" in edges and first == b - BC and br > 0:
                self._case("sweep from: N neighbour" + (" before a dirty block" if len(self.dirty) > 1 else ""))
            elif "W" in edges and first == b - 1 and bc > 0:
                self._case("sweep from: W neighbour")
            elif first == b - 1:
                self._case("sweep from: the block before, dirty")
            elif "W" in edges and bc > 0:
                self._case("sweep from: a dirty block before the W neighbour")
            else:
                self._case("sweep from: a dirty block")
            self.b = first
            return None
        if not self.mx:
            self._case("converged")
            return "converged"
        if self.p + STEP <= P_LAST:
            self._case("precision rise")
            self.p += STEP
            self.dirty, self.b = set(range(self.B)), 0
            return None
        self._case("not converged")
        return "stopped"


async def _take(ctx, blk):
    """One take: the Control module's run command for the next iteration."""
    ctx.set(blk.take, 1)
    go = ctx.get(blk.run)
    await ctx.tick()
    ctx.set(blk.take, 0)
    return go


def _scripts(BR, BC):
    """The first visits of the first runs, each a list of iterations
    (stable, edges changed, Maximum): the rarest choices on purpose.

    Run 1, sweep 1: the first and the last block use up their I iterations,
    the others are stable at once.  Sweep 2 (blocks 0 and B-1 dirty): block
    0 changes its S edge, then is stable, so the S neighbour comes before
    the dirty block B-1; B-1 stays unstable, the only dirty block: the next
    sweep starts at itself.  Then the W and N neighbours as the next sweep's
    first block, and the block before the last one visited.
    Run 2 (BC >= 3): sweep 1 leaves B-3 dirty and B-1 changes its W edge,
    so the next sweep starts at B-3, before the W neighbour B-2.
    Run 3 (BC >= 3, BR >= 2): B-1 changes its N edge instead, so the next
    sweep starts at the N neighbour B-1-BC, before B-3 in the last row."""
    B = BR * BC
    unstable, still = [(False, set(), False)] * ITERS, [(True, set(), False)]

    def changed(side):      # one iteration that changes the edge, then a stable one
        return [(False, {side}, False), (True, set(), False)]

    if B == 1:
        return [[unstable]]
    script = [unstable] + [still] * (B - 2) + [unstable]
    if BR >= 2 and B - 1 > BC:
        script += [changed("S"), still, unstable]
    else:
        script += [still, unstable]
    # sweep 3 from B-1: its W edge changes (the next sweep from the W
    # neighbour B-2), then B-2's N edge (from B-2-BC); one column: B-1's N edge
    if BC >= 2:
        script += [changed("W")]
        if BR >= 2:
            # ... then from c = B-2-BC: c unstable and its E edge changed, c+1 stable: the
            # next sweep from the block before c+1 (in a row >= 1 when BR >= 3)
            script += [changed("N"), [(False, {"E"}, False)] + unstable[1:], still]
    else:   # ... then B-2's W edge, at the map's edge: no block to mark, the level ends
        script += [changed("N"), changed("W")]
    if BC < 3:
        return [script]
    scripts = [script, [still] * (B - 3) + [unstable, still, changed("W")]]
    if BR >= 2:
        scripts.append([still] * (B - 3) + [unstable, still, changed("N")])
    return scripts


def _run(BR, BC, rng, runs):
    """``runs`` runs of the Controller against the reference, the first
    ones starting with :func:`_scripts`; returns the cases reached."""
    scripts = _scripts(BR, BC)
    ctl = Controller((BR, BC), 3, 6, 16)
    blk = ctl.block
    cases = {}

    async def bench(ctx):
        for run in range(runs):
            ref = Reference(BR, BC)
            p_stable, p_edge, p_max = rng.choice([(0.5, 0.25, 0.5), (0.8, 0.15, 0.3), (0.3, 0.4, 0.7)])
            # each side its own rate (a run without E changes reaches the S cases more often)
            p_side = {s: min(1.0, p_edge * rng.choice([0, 0.5, 1, 2])) for s in "NSWE"}
            ctx.set(ctl.p1, P1)
            ctx.set(ctl.step, STEP)
            ctx.set(ctl.p_last, P_LAST)
            ctx.set(ctl.iters, ITERS)
            ctx.set(ctl.start, 1)
            await ctx.tick()
            ctx.set(ctl.start, 0)
            visits, outcome = 0, None
            while outcome is None:
                # idle Block: wait for the run request of the next visit
                for _ in range(20):
                    if ctx.get(blk.run):
                        break
                    await ctx.tick()
                else:
                    raise AssertionError(f"{BR}x{BC}: no visit started after visit {visits} (reference: dirty {sorted(ref.dirty)}, Maximum {sorted(ref.mx)}, p {ref.p}, cases {ref.cases}; RTL busy {ctx.get(ctl.busy)} converged {ctx.get(ctl.converged)} p {ctx.get(ctl.p)})")
                got = (ctx.get(blk.br), ctx.get(blk.bc))
                assert got == divmod(ref.b, BC), (f"{BR}x{BC} visit {visits}: block {got}, "
                                                  f"reference {divmod(ref.b, BC)} (dirty {sorted(ref.dirty)}; the last visit: block, stable, "
                                                  f"edges, dirty before: {getattr(ref, 'last', None)})")
                assert ctx.get(blk.base) == ref.b * 18, "base is not b * (p_max + 2)"
                ctx.set(blk.busy, 1)
                for _ in range(LEAD_IN):
                    await ctx.tick()
                assert await _take(ctx, blk), "the first take does not run"
                stable, edges, mx = False, set(), False
                script = scripts[run] if run < len(scripts) else []
                plan = list(script[visits]) if visits < len(script) else []
                while True:         # one iteration: its cycles, the next take, then its flags
                    for _ in range(L - 1):
                        await ctx.tick()
                    go = await _take(ctx, blk)
                    if plan:            # the scripted start of the run
                        st, ch, flag = plan.pop(0)
                    else:               # the field settles: fewer unstable iterations and changed edges
                        fade = 0.99 ** visits
                        st = rng.random() > (1 - p_stable) * fade
                        ch = set() if st else {s for s in "NSWE" if rng.random() < p_side[s] * fade}
                        flag = rng.random() < p_max
                    if not go:      # the stop iteration: the last flags come with the clusters idle
                        ctx.set(blk.busy, 0)
                    ctx.set(blk.done, 1)
                    ctx.set(blk.all_stable, st)
                    ctx.set(blk.any_max, flag)
                    ctx.set(blk.edge_changed, {s: int(s in ch) for s in "NSWE"})
                    assert ctx.get(blk.abort) == st, "the early stop follows the first stable iteration"
                    edges |= ch
                    await ctx.tick()
                    ctx.set(blk.done, 0)
                    if st:
                        stable, mx = True, flag
                    if st or not go:
                        break
                ctx.set(blk.busy, 0)
                visits += 1
                outcome = ref.visit(stable, edges, mx)
                assert visits < 5000, "the run does not end"
            for _ in range(6):
                await ctx.tick()
            assert not ctx.get(ctl.busy), f"{BR}x{BC}: the reference ended the run ({outcome}), the RTL did not"
            assert ctx.get(ctl.converged) == (outcome == "converged")
            assert ctx.get(ctl.p) == ref.p
            for k, n in ref.cases.items():
                cases[k] = cases.get(k, 0) + n

    sim = Simulator(ctl)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return cases


# grids: one block, a row, a column, square, wide, tall (BR != BC catches a swapped shift)
GRIDS = [(1, 1), (1, 4), (4, 1), (3, 3), (2, 5), (5, 2), (4, 6)]
CASES = ["next: E neighbour", "next: S neighbour", "next: S neighbour before a dirty block",
         "next: a dirty block", "next: a dirty block, S marked after it", "sweep from: the block itself",
         "sweep from: N neighbour", "sweep from: N neighbour before a dirty block", "sweep from: W neighbour", "sweep from: the block before, dirty",
         "sweep from: a dirty block before the W neighbour", "sweep from: a dirty block",
         "converged", "precision rise", "not converged"]


def test_still_block_choice():
    cases = {}
    for i, (BR, BC) in enumerate(GRIDS):
        for k, n in _run(BR, BC, _rng(i), runs=6 if BR * BC > 1 else 3).items():
            cases[k] = cases.get(k, 0) + n
    print(cases)
    missing = [c for c in CASES if not cases.get(c)]
    assert not missing, f"not reached: {missing} (reached {cases})"

