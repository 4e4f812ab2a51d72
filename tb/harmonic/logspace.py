"""A log-space harmonic solver, the software peer of block exponents (issue 22).

In the style of Wray, Ruiken, Grupen and Zilberstein, "Log-space harmonic
function path planning" (IROS 2016): the potential h (goals 1, obstacles 0,
each free cell the mean of its four neighbours, eq. 1 of paper 000) is
stored as u = log h, so the values a maze drives far below float64's
smallest number (about 1e-308, or 1e-45 in float32) keep their relative
precision.  A free cell's update is

    u = log((e^uN + e^uS + e^uW + e^uE) / 4) = logaddexp(uN, uS, uW, uE) - log 4

(numpy's ``logaddexp``: exact for -inf, an obstacle's or an unreached
cell's log 0, no overflow).  Red-black Gauss-Seidel: the cells with even
row + column, then the odd ones, each half from the other's newest values;
stop when a sweep changes no finite u by ``tol`` or more (and no cell
became finite), or after ``max_sweeps``.

Number format and rounding: ``dtype`` (float64 by default; float32 as
Wray et al.) logarithms, numpy's rounding; the reference is the exact
harmonic field (tb/harmonic/dirichlet.py where float64 holds it).  Not part
of the installed package: the bench's baseline (scripts/bench_float.py).
"""

import numpy as np

__all__ = ["log_harmonic", "order_field"]


def log_harmonic(obstacle, goals, tol=1e-9, max_sweeps=1_000_000, dtype=np.float64):
    """``(u, sweeps, converged)``: u = log of the harmonic potential on the
    map (H x W; -inf on obstacles and cells no goal reaches), the red-black
    sweeps run and whether the tolerance was met."""
    obstacle = np.asarray(obstacle, dtype=bool)
    rows, cols = obstacle.shape
    S = cols + 2
    u = np.full((rows + 2) * S, -np.inf, dtype=dtype)       # flat, with an outside ring at -inf
    goal = np.zeros(obstacle.shape, dtype=bool)
    for r, c in goals:
        goal[r, c] = True
    u.reshape(rows + 2, S)[1:-1, 1:-1][goal] = 0.0
    free = ~obstacle & ~goal
    rr, cc = np.nonzero(free)
    colour = (rr + cc) % 2
    halves = []
    for k in (0, 1):
        idx = (rr[colour == k] + 1) * S + cc[colour == k] + 1
        halves.append((idx, idx - S, idx + S, idx - 1, idx + 1))
    log4 = dtype(np.log(4.0))
    sweeps = 0
    while sweeps < max_sweeps:
        sweeps += 1
        change = 0.0
        for idx, n, s, w, e in halves:
            new = np.logaddexp(np.logaddexp(u[n], u[s]), np.logaddexp(u[w], u[e])) - log4
            old = u[idx]
            fin = np.isfinite(new)
            if (fin & ~np.isfinite(old)).any():
                change = np.inf
            elif fin.any():
                change = max(change, float(np.abs(new[fin] - old[fin]).max()))
            u[idx] = new
        if change < tol:
            return u.reshape(rows + 2, S)[1:-1, 1:-1].copy(), sweeps, True
    return u.reshape(rows + 2, S)[1:-1, 1:-1].copy(), sweeps, False


def order_field(u):
    """Non-negative integers in the order of ``u`` (ties kept, -inf -> 0),
    for :func:`models.harmonic.ascent_reaches`, which compares integer
    fields (its outside reads -1)."""
    u = np.asarray(u)
    fin = np.isfinite(u)
    out = np.zeros(u.shape, dtype=np.int64)
    _, inverse = np.unique(u[fin], return_inverse=True)
    out[fin] = inverse + 1
    return out
