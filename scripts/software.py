"""The software a user would pick instead of each core, timed on this machine.

Every figure is the median of ``REPEATS`` runs (the first run of each is a
warm-up and not counted).  Used by the performance report (scripts/bench.py);
each function returns a dict with ``software`` (what ran, in words),
``sw_seconds`` (median seconds per job) and the job's own figures.

* Harmonic: numpy float64 Jacobi on a block (time per iteration: 4 shifted
  adds and a multiply over the grid, the obstacles and goals held), and
  scipy.sparse.linalg.spsolve of the whole Dirichlet problem of a map (time
  to the converged field).
* EDT/BFS: scipy.ndimage.distance_transform_edt with return_indices, then a
  BFS over the 8-connected collision-free cells (scipy.sparse.csgraph's
  breadth_first_order on a prebuilt graph, or a plain deque: the faster of
  the two, both timed).
* DFLC: pyfuzzylite's own engine on the same .fll, one call per sample and
  vectorized (numpy arrays on the input variables) over many samples.
"""

import statistics
import time
from collections import deque

import numpy as np

REPEATS = 7


def median_time(fn, repeats=REPEATS):
    """Median wall seconds of ``fn()`` over ``repeats`` runs after one warm-up."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def jacobi_iteration(obstacle, goals, iterations=200):
    """numpy float64 Jacobi: seconds per iteration on ``obstacle`` (bool grid)."""
    free = ~obstacle
    for r, c in goals:
        free[r, c] = False
    h = np.zeros((obstacle.shape[0] + 2, obstacle.shape[1] + 2))
    inner = h[1:-1, 1:-1]
    for r, c in goals:
        inner[r, c] = 1.0

    def run():
        for _ in range(iterations):
            s = 0.25 * (h[:-2, 1:-1] + h[2:, 1:-1] + h[1:-1, :-2] + h[1:-1, 2:])
            np.copyto(inner, s, where=free)

    seconds = median_time(run) / iterations
    return {"software": f"numpy float64 Jacobi, {obstacle.shape[0]}x{obstacle.shape[1]} grid",
            "sw_seconds": seconds}


def dirichlet_solve(obstacle, goals):
    """scipy sparse direct solve of the harmonic Dirichlet problem (goals 1, walls 0)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    rows, cols = obstacle.shape
    goal = np.zeros_like(obstacle)
    for r, c in goals:
        goal[r, c] = True
    free = ~obstacle & ~goal
    index = -np.ones(obstacle.shape, dtype=int)
    index[free] = np.arange(free.sum())

    def run():
        i, j, v = [], [], []
        b = np.zeros(free.sum())
        for (r, c), k in zip(np.argwhere(free), index[free]):
            i.append(k), j.append(k), v.append(1.0)
            for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                if 0 <= rr < rows and 0 <= cc < cols:
                    if free[rr, cc]:
                        i.append(k), j.append(index[rr, cc]), v.append(-0.25)
                    elif goal[rr, cc]:
                        b[k] += 0.25
        a = sp.csr_matrix((v, (i, j)), shape=(len(b), len(b)))
        return spla.spsolve(a.tocsc(), b)

    return {"software": "scipy.sparse.linalg.spsolve of the Dirichlet problem (matrix assembly included)",
            "sw_seconds": median_time(run)}


_MOVES8 = ((0, 1), (-1, 0), (0, -1), (1, 0), (-1, 1), (-1, -1), (1, -1), (1, 1))


def edt_bfs(obstacle, goals, dfar, bfs=("deque", "csgraph"), repeats=REPEATS):
    """scipy EDT with indices + the faster of the BFS over the cfr cells named in ``bfs``
    (a plain deque, scipy.sparse.csgraph), each the median of ``repeats`` runs."""
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order

    rows, cols = obstacle.shape

    def edt():
        return ndimage.distance_transform_edt(~obstacle, return_indices=True)

    def bfs_deque(cfr):
        seen = np.zeros(obstacle.shape, dtype=bool)
        queue = deque()
        for g in goals:
            if cfr[g]:
                seen[g] = True
                queue.append(g)
        while queue:
            r, c = queue.popleft()
            for dr, dc in _MOVES8:
                rr, cc = r + dr, c + dc
                if 0 <= rr < rows and 0 <= cc < cols and cfr[rr, cc] and not seen[rr, cc]:
                    seen[rr, cc] = True
                    queue.append((rr, cc))
        return seen

    def bfs_csgraph(cfr):
        idx = np.arange(rows * cols).reshape(rows, cols)
        src, dst = [], []
        for dr, dc in _MOVES8:
            a = cfr[max(0, -dr):rows - max(0, dr), max(0, -dc):cols - max(0, dc)]
            b = cfr[max(0, dr):rows - max(0, -dr), max(0, dc):cols - max(0, -dc)]
            ia = idx[max(0, -dr):rows - max(0, dr), max(0, -dc):cols - max(0, dc)]
            ib = idx[max(0, dr):rows - max(0, -dr), max(0, dc):cols - max(0, -dc)]
            both = a & b
            src.append(ia[both]), dst.append(ib[both])
        src, dst = np.concatenate(src), np.concatenate(dst)
        graph = coo_matrix((np.ones(len(src)), (src, dst)), shape=(rows * cols,) * 2).tocsr()
        return breadth_first_order(graph, idx[goals[0]], directed=True, return_predecessors=True)

    d, _ = edt()
    cfr = d > dfar
    t_edt = median_time(edt, repeats)
    times = {}
    if "deque" in bfs:
        times["plain deque BFS"] = median_time(lambda: bfs_deque(cfr), repeats)
    if "csgraph" in bfs:
        times["scipy.sparse.csgraph BFS"] = median_time(lambda: bfs_csgraph(cfr), repeats)
    bfs_name = min(times, key=times.get)
    return {"software": f"scipy.ndimage.distance_transform_edt(return_indices) + {bfs_name}",
            "sw_seconds": t_edt + times[bfs_name], "edt_seconds": t_edt,
            "bfs_deque_seconds": times.get("plain deque BFS"),
            "bfs_csgraph_seconds": times.get("scipy.sparse.csgraph BFS")}


def fuzzylite_engine(fll_path, samples):
    """pyfuzzylite on ``fll_path``: seconds per sample, single calls and vectorized."""
    import fuzzylite as fl

    engine = fl.FllImporter().from_file(str(fll_path))
    samples = np.asarray(samples, dtype=float)
    ins, out = engine.input_variables, engine.output_variables[0]

    def single():
        for row in samples[:50]:
            for var, x in zip(ins, row):
                var.value = float(x)
            engine.process()
            _ = out.value

    def vector():
        for k, var in enumerate(ins):
            var.value = samples[:, k]
        engine.process()
        return out.value

    return {"software": f"pyfuzzylite {fl.__version__} Engine.process on {fll_path.name}",
            "sw_seconds": median_time(single, repeats=3) / 50,
            "vectorized_seconds_per_sample": median_time(vector, repeats=3) / len(samples),
            "vectorized_samples": len(samples)}
