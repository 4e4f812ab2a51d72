"""Independent references for the EDT/BFS models: scipy's exact EDT and a plain queue BFS."""

from collections import deque

import numpy as np
import scipy.ndimage as ndi

__all__ = ["exact_di", "scipy_edt", "bfs_hops", "lowest_parent", "MOVES"]

# Fig. 1's neighbour index -> (row, column) offset, written out again (not taken
# from the model) so that the reference stands alone.
MOVES = {1: (0, 1), 2: (-1, 0), 3: (0, -1), 4: (1, 0), 5: (-1, 1), 6: (-1, -1), 7: (1, -1), 8: (1, 1)}


def exact_di(d2):
    """Smallest k with d2 <= k^2 + k (d rounded to the nearest integer), elementwise."""
    k = np.ceil(np.sqrt(d2 + 0.25) - 0.5).astype(np.int64)
    k = np.where(k * k + k < d2, k + 1, k)          # guard float rounding
    return np.where((k > 0) & ((k - 1) * (k - 1) + (k - 1) >= d2), k - 1, k)


def scipy_edt(img):
    """Exact squared distance to the nearest obstacle (True) and scipy's nearest-pixel indices."""
    dist, idx = ndi.distance_transform_edt(~img, return_indices=True)
    return np.rint(dist ** 2).astype(np.int64), idx


def bfs_hops(cfr, goals):
    """Hop counts of a plain 8-connected queue BFS over ``cfr`` from the goals inside it; -1 unreached."""
    h, w = cfr.shape
    wp = w + 2
    free = np.pad(np.asarray(cfr, dtype=bool), 1).ravel().tolist()      # padded: no bounds checks
    hop = [-1] * len(free)
    steps = [dr * wp + dc for dr, dc in MOVES.values()]
    queue = deque()
    for r, c in goals:
        p = (r + 1) * wp + c + 1
        if free[p] and hop[p] < 0:
            hop[p] = 0
            queue.append(p)
    while queue:
        p = queue.popleft()
        nxt = hop[p] + 1
        for s in steps:
            q = p + s
            if free[q] and hop[q] < 0:
                hop[q] = nxt
                queue.append(q)
    return np.array(hop, dtype=np.int64).reshape(h + 2, wp)[1:-1, 1:-1]


def lowest_parent(hop):
    """Per pixel: the smallest neighbour index whose hop is one less (0 for roots and unreached)."""
    h, w = hop.shape
    padded = np.pad(hop, 1, constant_values=-1)
    parent = np.zeros((h, w), dtype=np.int64)
    for i in sorted(MOVES, reverse=True):
        dr, dc = MOVES[i]
        nb = padded[1 + dr:1 + dr + h, 1 + dc:1 + dc + w]
        parent = np.where((hop > 0) & (nb == hop - 1), i, parent)
    return parent
