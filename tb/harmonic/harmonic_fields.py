"""Converged fields for the host-side tests (one place to get them)."""

from collections import deque
from dataclasses import dataclass

import numpy as np

from models.harmonic import local_max, neighbours, one, relax


@dataclass
class Field:
    h: np.ndarray
    p: int
    converged: bool


def reachable_mask(obstacle, goals):
    """Free cells 4-connected to a goal (goals included)."""
    seen = np.zeros(obstacle.shape, dtype=bool)
    queue = deque()
    for g in goals:
        seen[g] = True
        queue.append(tuple(g))
    while queue:
        r, c = queue.popleft()
        for dr, dc in ((-1, 0), (0, 1), (0, -1), (1, 0)):
            rr, cc = r + dr, c + dc
            if 0 <= rr < obstacle.shape[0] and 0 <= cc < obstacle.shape[1] \
                    and not obstacle[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                queue.append((rr, cc))
    return seen


def _initial(obstacle, goals, p):
    const = obstacle.copy()
    h = np.zeros(obstacle.shape, dtype=object)
    for g in goals:
        const[g] = True
        h[g] = one(p)
    return h, const


def fixed(obstacle, goals, p):
    h, const = _initial(obstacle, goals, p)
    h, _ = relax(h, const, p)
    cut = ~obstacle & ~reachable_mask(obstacle, goals)
    return Field(h, p, not (local_max(h, const, neighbours(h)) & ~cut).any())


def converged(obstacle, goals, schedule=range(16, 513, 16)):
    schedule = list(schedule)
    h, const = _initial(obstacle, goals, schedule[0])
    cut = ~obstacle & ~reachable_mask(obstacle, goals)
    p = schedule[0]
    for i, p in enumerate(schedule):
        if i:
            h = h * (1 << (p - schedule[i - 1]))
        h, _ = relax(h, const, p)
        if not (local_max(h, const, neighbours(h)) & ~cut).any():
            return Field(h, p, True)
    return Field(h, p, False)
