"""The harmonic models' independent reference: scipy's sparse Dirichlet solve.

On the free nodes (``~const``) of a 4-connected grid, with the constants
(goals at their value, obstacles at 0) as the boundary, the exact solution
``x* = Hx* + C`` (H: each free node the mean of its four neighbours, a
neighbour outside the grid counting as 0) and ``(I - H)^-1 1``, the factor
of the floored relaxation's error bound (tb/harmonic/test_model.py), in
float64.
"""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["dirichlet"]


def dirichlet(goal, const):
    """``(free, a, exact, resolvent)``: the free nodes (row, column) in
    order, the sparse matrix ``a = I - H`` on them (CSC), ``x*`` and
    ``(I - H)^-1 1`` there.  ``goal``: the constants' values (a bool mask or
    floats), ``const``: the mask of constant nodes."""
    goal = np.asarray(goal, dtype=float)
    rows, cols = const.shape
    free = np.argwhere(~const)
    index = -np.ones(const.shape, dtype=int)
    index[tuple(free.T)] = np.arange(len(free))
    a = sp.lil_matrix((len(free), len(free)))
    b = np.zeros(len(free))
    for k, (r, c) in enumerate(free):
        a[k, k] = 1.0
        for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if 0 <= rr < rows and 0 <= cc < cols:
                if const[rr, cc]:
                    b[k] += 0.25 * goal[rr, cc]
                else:
                    a[k, index[rr, cc]] = -0.25
    a = a.tocsc()
    return free, a, spla.spsolve(a, b), spla.spsolve(a, np.ones(len(free)))
