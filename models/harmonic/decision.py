"""The Decision module (paper 000, section 5.3): the navigation direction at a
node from the steepest of its four triangles, on a fixed-point field and on a
block-exponent field (issue 10, beyond the paper).

Number format: the field's integers as stored (fixed point: v / 2**p; block
exponents: mantissas, each neighbour first converted into the centre block's
units, :func:`~models.harmonic.ram.convert_mantissa`).  Outside the map reads
0.  Arithmetic is exact (Python integers): the scores are sums of squared
differences, no rounding; ties go to the first triangle in :data:`TRIANGLES`
order.  hdl/harmonic/decision.py is bit-exact with :func:`decision` and
:func:`decision_exponents`.
"""

import numpy as np

from .ram import convert_mantissa

__all__ = ["TRIANGLES", "decision", "steepest_triangle", "decision_exponents", "decision_step", "decision_paths"]

# The four triangles of a node and two consecutive neighbours, in this order
# (the tie-break: the first of equal slopes wins).
TRIANGLES = (("N", "E"), ("E", "S"), ("S", "W"), ("W", "N"))
_OFFSET = {"N": (-1, 0), "E": (0, 1), "S": (1, 0), "W": (0, -1)}


def decision(h, r, c):
    """The steepest of the four triangles at node (r, c) of ``h`` (section 5.3).

    The triangle of two consecutive neighbours (X', Y'), (X'', Y'') that
    maximizes (h - h')**2 + (h - h'')**2 (outside the map reads 0); ties go to
    the first in :data:`TRIANGLES` order (NE, ES, SW, WN).  Returns
    ``(t, (g_row, g_col))``: the triangle's index and the gradient of its
    plane in grid axes (row down, column right): g_col = h_E - h or h - h_W,
    g_row = h_S - h or h - h_N: the direction of steepest ascent.
    """
    h = np.asarray(h, dtype=object)
    _check_node(h.shape, r, c)
    cells = _neighbour_cells(h.shape, r, c)
    return steepest_triangle(int(h[r, c]), {d: int(h[x]) if x else 0 for d, x in cells.items()})


def _check_node(shape, r, c):
    rows, cols = shape
    if not (0 <= r < rows and 0 <= c < cols):
        raise ValueError(f"node ({r}, {c}) is outside the {rows}x{cols} map")


def _neighbour_cells(shape, r, c):
    """{d: the N, E, S, W neighbour (rr, cc) of (r, c), None outside the map}."""
    out = {}
    for d in "NESW":
        rr, cc = r + _OFFSET[d][0], c + _OFFSET[d][1]
        out[d] = (rr, cc) if 0 <= rr < shape[0] and 0 <= cc < shape[1] else None
    return out


def steepest_triangle(centre, v):
    """The Decision module's rule (5.3) on one node: ``centre`` and its
    neighbours ``v`` = {"N", "E", "S", "W": value}; returns
    ``(t, (g_row, g_col))`` as :func:`decision`."""
    best, best_t = -1, 0
    for t, (a, b) in enumerate(TRIANGLES):
        score = (centre - v[a]) ** 2 + (centre - v[b]) ** 2
        if score > best:
            best, best_t = score, t
    pair = TRIANGLES[best_t]
    g_row = v["S"] - centre if "S" in pair else centre - v["N"]
    g_col = v["E"] - centre if "E" in pair else centre - v["W"]
    return best_t, (g_row, g_col)


def decision_exponents(mantissa, exponents, block, p, r, c):
    """The Decision module (5.3) on a block-exponent field, as the planner
    RTL's exponent option computes it: node (r, c) of the padded
    ``mantissa`` field (BR*n x BC*m), ``exponents`` (BR x BC), ``block`` =
    (n, m), word precision ``p``.

    Each neighbour in another block is first seen in the centre's units,
    2**-(p + e_c), through the border conversion the node's update uses
    (:func:`convert_mantissa`, s = e_c - e_neighbour); then the rule of
    :func:`steepest_triangle`.  Returns ``(t, (g_row, g_col), e_c)``: the
    gradient is in the centre's units, so its direction needs no exponent.

    Error bound (what the conversion loses): a neighbour's converted value
    v' and its exact value x (in the centre's units) satisfy
    v' <= x < v' + 1 unless it was clamped (then v' = 2**(p+1)-1 <= x): a
    finer neighbour (s < 0) loses its bits below the centre's LSB (floor),
    a coarser one (s > 0) is exact below the clamp.  So each gradient
    component is within one unit of the exact plane's, and the triangle can
    differ from the exact one's only where scores are that close or a
    neighbour clamps (tested against exact fractions on converged fields).
    """
    mantissa = np.asarray(mantissa, dtype=object)
    n, m = block
    _check_node(mantissa.shape, r, c)
    e = int(exponents[r // n][c // m])
    v = {d: convert_mantissa(int(mantissa[x]), e - int(exponents[x[0] // n][x[1] // m]), p)[0] if x else 0
         for d, x in _neighbour_cells(mantissa.shape, r, c).items()}
    t, g = steepest_triangle(int(mantissa[r, c]), v)
    return t, g, e


# The Decision's candidate moves, in tie-break order (N, E, W, S, as the ascent's).
_STEPS = ((-1, 0), (0, 1), (0, -1), (1, 0))


def decision_step(mantissa, exponents, block, p, r, c):
    """The cell the Decision module sends a robot at node (r, c) to (issue
    22): the steepest triangle's gradient (g_row, g_col)
    (:func:`decision_exponents`, the RTL's), then the 4-neighbour step
    closest to it, the one with the largest projection (-g_row N, g_row
    S, -g_col W, g_col E; ties in N, E, W, S order), among the neighbours
    whose exact value (v / 2**(p + e_b)) is strictly above the node's:
    the direction is the hardware's, the cell grid and the rising values
    a robot's (so a path never repeats a cell, and on a converged field,
    where every free node has a higher neighbour, it ends on a goal).
    ``None`` where no neighbour is higher.  Where the Decision's direction
    is closest to a higher neighbour that is not the highest, the path
    parts from the exact ascent (:func:`~models.harmonic.trajectory`)."""
    n, m = block
    _, (g_row, g_col), _ = decision_exponents(mantissa, exponents, block, p, r, c)
    here, e_here = int(mantissa[r, c]), int(exponents[r // n][c // m])
    best, best_proj = None, None
    for dr, dc in _STEPS:
        rr, cc = r + dr, c + dc
        if not (0 <= rr < mantissa.shape[0] and 0 <= cc < mantissa.shape[1]):
            continue
        there, e_there = int(mantissa[rr, cc]), int(exponents[rr // n][cc // m])
        top = max(e_here, e_there)            # exact comparison on the finer of the two scales
        if (there << (top - e_there)) <= (here << (top - e_here)):
            continue
        proj = dr * g_row + dc * g_col
        if best is None or proj > best_proj:
            best, best_proj = (rr, cc), proj
    return best


def decision_paths(mantissa, exponents, block, p, goals, starts):
    """Paths by :func:`decision_step` from each of ``starts`` until a goal
    (``goals``: bool mask of the mantissa's shape) or a stop: a list of
    (path, reached_goal).  Steps are memoized, so many starts on one
    field cost one Decision per cell visited."""
    mantissa = np.asarray(mantissa, dtype=object)
    memo = {}
    out = []
    for start in starts:
        r, c = (int(x) for x in start)
        path = [(r, c)]
        while not goals[r, c]:
            if (r, c) not in memo:
                memo[r, c] = decision_step(mantissa, exponents, block, p, r, c)
            nxt = memo[r, c]
            if nxt is None:
                break
            r, c = nxt
            path.append(nxt)
        out.append((path, bool(goals[r, c])))
    return out
