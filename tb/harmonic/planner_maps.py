"""Small maps for the planner regression: a corridor, a spiral, a random map."""

import numpy as np


def corridor(rows, cols):
    """A serpentine corridor of width 1: walls every other row, open at
    alternating ends; the goal at the far end."""
    ob = np.zeros((rows, cols), dtype=bool)
    for r in range(1, rows, 2):
        ob[r, :] = True
        ob[r, cols - 1 if (r // 2) % 2 == 0 else 0] = False
    end = (rows - 1, cols - 1 if ((rows - 1) // 2) % 2 == 0 else 0)
    return ob, [end]


def spiral(rows, cols):
    """A rectangular spiral wall, the goal in its centre."""
    ob = np.zeros((rows, cols), dtype=bool)
    top, left, bottom, right = 1, 1, rows - 2, cols - 2
    k = 0
    while top <= bottom and left <= right:
        ob[top, left:right + 1] = True
        ob[top:bottom + 1, right] = True
        ob[bottom, left:right + 1] = True
        ob[top + 2:bottom + 1, left] = True
        ob[top + 1, left] = False           # the opening into the next ring
        top, left, bottom, right = top + 2, left + 2, bottom - 2, right - 2
        k += 1
    free = np.argwhere(~ob)
    centre = np.array([rows // 2, cols // 2])
    goal = tuple(int(x) for x in free[np.abs(free - centre).sum(axis=1).argmin()])
    return ob, [goal]


def random_map(rows, cols, seed, density=0.25):
    rng = np.random.default_rng(seed)
    ob = rng.random((rows, cols)) < density
    free = np.argwhere(~ob)
    goal = tuple(int(x) for x in free[rng.integers(len(free))])
    return ob, [goal]


MAPS = {
    "corridor": lambda rows, cols, seed: corridor(rows, cols),
    "spiral": lambda rows, cols, seed: spiral(rows, cols),
    "random": lambda rows, cols, seed: random_map(rows, cols, seed),
}
