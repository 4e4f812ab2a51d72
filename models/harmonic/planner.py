"""The harmonic planner as the RTL runs it (paper 000, section 4 pseudo-code,
3.3, 4.5, 5.1): :func:`plan`, the model of hdl/harmonic/planner.py.

Number format and rounding: fixed point v / 2**p, eq. 2 floored
(:mod:`models.harmonic.node`, :mod:`models.harmonic.grid`); with
``block_exponents=True`` the block-exponent field
(:mod:`models.harmonic.exponents`).  Cycle counts: the Control module's
timing table (:mod:`models.harmonic.schedule`), exactly the RTL's: the default
schedule (still blocks) or the paper's (``paper_schedule=True``).
"""

from .exponents import plan_exponents
from .grid import BlockGrid
from .schedule import control, run

__all__ = ["plan"]


def plan(obstacle, goals, block=(6, 12), iters=6, schedule=(16, 32), events=(),
         block_exponents=False, progress=None, paper_schedule=False, **exponent_options):
    """Block-synchronous relaxation with increasing precision (section 4).

    The map (``obstacle``: bool H x W, True = obstacle; ``goals``: mask or
    (row, col) list) is padded with obstacles to whole blocks of ``block =
    (n, m)`` nodes (:func:`pad_to_blocks`).  Free cells no goal reaches are
    walled off (constant 0) before the run.  Block b = br*BC + bc (row-major)
    covers rows br*n .. br*n+n-1 and columns bc*m .. bc*m+m-1; blocks are
    visited in order b = 0 .. B-1.

    A *pass* (sweep) goes over the blocks in order.  Each block it visits
    runs up to ``iters`` (I) Jacobi iterations, stopping early after the
    first iteration in which no node of the block changed (it counts);
    neighbours in other blocks read their latest stored values (the border
    storage), outside the map reads 0.

    The default schedule (still blocks, :mod:`models.harmonic.schedule`):
    a sweep visits only the *dirty* blocks (all at a level's start; a visit
    makes dirty the neighbours whose facing edge it changed, and its own
    block if it used up I iterations), an early stop costs no confirmation
    iteration, and the level's check is the Maximum flags of each block's
    last stable iteration (no check pass).  Sweeps repeat while a block is
    dirty.  ``paper_schedule=True``: the paper's, every block in every
    sweep, sweeps repeat until one changes nothing (every block stable in
    its first iteration: the pseudo-code's ``block_cvg`` alone would also
    accept a block that changed in its first iterations and then was
    stable, whose neighbours' borders changed), then a check pass, one
    check iteration per block.  Both end every level in the same field (the
    least fixed point at that p, bit for bit), so they reach the same
    precision and the same result; only the cycles differ.  No local
    maximum: converged.  Otherwise the next precision of ``schedule`` (the
    new low bits start at 0, i.e. values shift left); after the last one:
    not converged, ``maxima`` left.

    ``events``: dynamic orders ``(s, (r, c), kind)``, kind ``"obstacle"`` or
    ``"goal"``.  Passes are numbered 0, 1, ... from the start of the run
    (update and check passes alike).  An event with s >= 1 is applied at the
    end of pass s-1 (the Control module takes a host order at the next pass
    boundary); s = 0: before the run, as a SET command sent while idle (its
    cycles are not part of the run).  Applying an order is a clear pass: node
    (r, c) becomes constant (goal 2**p or obstacle 0) and every free node
    restarts from 0 at the current precision.  From 0 the floored iteration
    rises monotonically to its fixed point, whereas started above it (a new
    obstacle lowers values) it may oscillate with period 2 (see
    :mod:`models.harmonic.node`), so every run terminates.  The next pass is
    an update sweep at the same precision.  Free cells a new obstacle cuts
    off from every goal are not walled off by the planner: they stay a zero
    plateau and count as maxima; the host walls them off with more obstacle
    orders.

    ``block_exponents=True``: the block-exponent variant, see
    :func:`plan_exponents` (``exponent_options`` go there).  ``progress``:
    called after every sweep (:func:`models.harmonic.schedule.run`).
    """
    if block_exponents:
        return plan_exponents(obstacle, goals, block=block, iters=iters, schedule=schedule, events=events,
                              progress=progress, paper_schedule=paper_schedule, **exponent_options)
    if exponent_options:
        raise ValueError(f"{sorted(exponent_options)}: options of block_exponents=True only")
    grid = BlockGrid(obstacle, goals, block, iters, schedule)
    grid.res.paper_schedule = bool(paper_schedule)
    visits, timing = control(grid, paper_schedule)
    return run(grid, events=events, visits=visits, timing=timing, progress=progress)
