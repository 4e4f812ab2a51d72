"""Small synthetic maps shared by the harmonic host-side tests and benchmarks.

Each returns a bool grid, True = obstacle, and the goal cells.
"""

import numpy as np


def corridor(length):
    """Paper 3.2.2: a 1-wide corridor of ``length`` cells, closed on the left,
    the goal at the right end (a 3-row grid: walls above and below)."""
    grid = np.ones((3, length + 2), dtype=bool)
    grid[1, 1:length + 1] = False
    return grid, [(1, length)]


def spiral(size):
    """A 1-wide square spiral corridor in a ``size`` x ``size`` grid (paper
    3.2.2: a path of length ~L in ~2L cells), goal at the spiral's inner end.
    Returns (grid, [goal])."""
    grid = np.ones((size, size), dtype=bool)
    r, c = 1, 1
    top, left, bottom, right = 1, 1, size - 2, size - 2
    cells = []
    while top <= bottom and left <= right:
        for c in range(left, right + 1):
            cells.append((top, c))
        for r in range(top + 1, bottom + 1):
            cells.append((r, right))
        if top < bottom:
            for c in range(right - 1, left - 1, -1):
                cells.append((bottom, c))
        if left < right:
            for r in range(bottom - 1, top + 1, -1):
                cells.append((r, left))
        top, left, bottom, right = top + 2, left + 2, bottom - 2, right - 2
        # step into the next ring: one cell right of the last turn
        if top <= bottom and left <= right:
            cells.append((top, left - 1))
    for cell in cells:
        grid[cell] = False
    return grid, [cells[-1]]


def pocket(rows=6, cols=9):
    """An open room with a walled-off pocket no goal reaches: goal (1, 1),
    pocket cells rows 3..5, columns 6..8, behind walls
    and the map edge."""
    grid = np.zeros((rows, cols), dtype=bool)
    grid[2:6, 5] = True
    grid[2, 5:9] = True
    return grid, [(1, 1)]
