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
