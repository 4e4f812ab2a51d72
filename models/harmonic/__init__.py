"""Golden model of the harmonic planner (paper 000): the node grid, the
block-synchronous schedule with increasing precision, the Decision module,
the storage format, trajectories, the schedule study and block exponents.

One module per concern; every name callers used from the former single
module ``models/harmonic.py`` is re-exported here, so ``from models.harmonic
import plan`` keeps working:

================  ==============================================================
module            what lives there
================  ==============================================================
node.py           the number format (:func:`one`: v / 2**p) and the Node
                  module's rule on a whole grid: :func:`neighbours`,
                  :func:`update` (eq. 2, floored), :func:`local_max`,
                  :func:`step`, :func:`relax` (plain Jacobi, the reference)
grid.py           the map on blocks: :func:`pad_to_blocks`, :func:`reachable`,
                  and ``BlockGrid``, the fixed-point field the schedule runs
                  on (block visit, check, precision rise, dynamic orders)
schedule.py       the section 4 schedule: the one loop (``run``) and its
                  hooks, the Control module's two schedules (``control``:
                  still blocks, the default, or the paper's) and timing
                  (:data:`VISIT_OVERHEAD`, :func:`visit_cycles`, ``Timing``,
                  ``StillTiming``), :class:`PlanResult`
planner.py        :func:`plan`: the schedule on the fixed-point field (or
                  block exponents), as the RTL runs it
decision.py       the Decision module (5.3): :func:`decision`,
                  :func:`steepest_triangle`, :data:`TRIANGLES`,
                  :func:`decision_exponents`
ram.py            storage: :func:`word_bits`, :func:`ram_image`,
                  :func:`from_ram_image`, the cluster's pipeline (:func:`iteration_cycles`,
                  :func:`pads`, :func:`counters`, :func:`strobes`), and the border
                  conversion between block exponents :func:`convert_mantissa`
ascent.py         gradient ascent on a field: :func:`trajectory`,
                  :func:`ascent_next`, :func:`ascent_reaches`, ``Trajectory``
explore.py        the schedule study (4.5): :func:`plan_explore` with block
                  orders, still blocks or the paper's visits
exponents.py      block exponents (issue 10): ``ExponentGrid``,
                  :func:`plan_exponents`, :func:`shift_iterations`,
                  the exponent width a map needs (:func:`exponent_bound`,
                  :func:`e_max_for`) and the word (:func:`precision_estimate`),
                  :data:`E_MAX`, :data:`REPICK_HEADROOM`, :data:`SHIFT_STEP`
node_exponents.py one exponent per node (issue 22: block exponents with
                  blocks of one node, where a block's spread defeats one
                  exponent a block): :func:`plan_node_exponents`,
                  :func:`node_update`, :func:`order_key`
================  ==============================================================

``decision.py`` shares its name with hdl/harmonic/decision.py (the house rule:
a model and its RTL share a name) and with its function: the package's
attribute ``decision`` is the function, as callers expect; the module's names
are all re-exported here.  Each module states its number format and rounding.  The package imports
nothing of the project outside ``models.harmonic``.
"""

from .decision import TRIANGLES, decision, decision_exponents, decision_paths, decision_step, steepest_triangle
from .explore import plan_explore
from .exponents import (E_MAX, REPICK_HEADROOM, SHIFT_STEP, e_max_for, exponent_bound, plan_exponents,
                        precision_estimate, shift_iterations)
from .grid import distances, pad_to_blocks, reachable
from .node_exponents import NodeExponentResult, node_update, order_key, plan_node_exponents
from .node import local_max, neighbours, one, relax, step, update
from .planner import plan
from .ram import (P_MIN, convert_mantissa, counters, from_ram_image, iteration_cycles, pads, ram_image, read_offset,
                  strobes, word_bits)
from .schedule import RUN_OVERHEAD, SET_OVERHEAD, VISIT_OVERHEAD, PlanResult, visit_cycles
from .ascent import ASCENT_MOVES, Trajectory, ascent_next, ascent_reaches, trajectory

__all__ = [
    "one", "neighbours", "update", "local_max", "step", "relax",
    "pad_to_blocks", "reachable", "PlanResult", "plan", "decision", "steepest_triangle", "visit_cycles",
    "VISIT_OVERHEAD", "RUN_OVERHEAD", "SET_OVERHEAD", "TRIANGLES",
    "word_bits", "ram_image", "from_ram_image", "counters", "strobes", "read_offset", "pads", "iteration_cycles",
    "P_MIN",
    "ASCENT_MOVES", "ascent_next", "Trajectory", "trajectory", "ascent_reaches",
    "plan_explore",
    "E_MAX", "REPICK_HEADROOM", "SHIFT_STEP", "convert_mantissa", "decision_exponents", "plan_exponents",
    "shift_iterations", "exponent_bound", "e_max_for", "precision_estimate", "distances", "decision_step", "decision_paths",
    "NodeExponentResult", "node_update", "order_key", "plan_node_exponents",
]
