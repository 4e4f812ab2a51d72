"""Fields for the host-side tests, from the block-synchronous model (one place)."""

from navcores.models.harmonic import plan, reachable


def reachable_mask(obstacle, goals):
    """Free cells 4-connected to a goal (goals included)."""
    return reachable(obstacle, goals)


def fixed(obstacle, goals, p, block=(8, 8), iters=4):
    """The planner's fixed point at the single precision ``p``."""
    return plan(obstacle, goals, block=block, iters=iters, schedule=(p,))


def converged(obstacle, goals, schedule=range(16, 513, 16), block=(8, 8), iters=4):
    """The planner run with increasing precision until no local maximum."""
    return plan(obstacle, goals, block=block, iters=iters, schedule=tuple(schedule))


def tie_kinds(v):
    """Which of the Decision's ties a neighbourhood ``v`` = {"c", "N", "E",
    "S", "W": value} holds: equal row terms (h - h_N)^2 = (h - h_S)^2 only,
    equal column terms only, both, or a flat neighbourhood."""
    c = v["c"]
    rows = (c - v["N"]) ** 2 == (c - v["S"]) ** 2
    cols = (c - v["E"]) ** 2 == (c - v["W"]) ** 2
    return {"row_tie": rows and not cols, "col_tie": cols and not rows, "both_ties": rows and cols,
            "flat": len(set(v.values())) == 1}
