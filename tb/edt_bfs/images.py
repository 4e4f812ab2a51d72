"""Test images for the EDT/BFS core (the model tests and the cocotb tests share them).

Every generator returns a bool array (True = obstacle) from a numpy Generator.
"""

import numpy as np

__all__ = ["random_image", "rooms", "corridors", "sparse_points", "empty", "FAMILIES", "free_cells"]


def random_image(rng, h, w, density=None):
    """Independent pixels, obstacle probability ``density`` (random if None)."""
    if density is None:
        density = rng.choice([0.02, 0.08, 0.2, 0.35])
    return rng.random((h, w)) < density


def rooms(rng, h, w):
    """Walls on a coarse lattice with random doors, plus a few boxes."""
    img = np.zeros((h, w), dtype=bool)
    step = max(4, min(h, w) // 3)
    for r in range(step, h, step):
        img[r, :] = True
        for _ in range(2):
            c = rng.integers(w)
            img[r, c:c + 2] = False
    for c in range(step, w, step):
        img[:, c] = True
        for _ in range(2):
            r = rng.integers(h)
            img[r:r + 2, c] = False
    for _ in range(rng.integers(0, 4)):
        r, c = rng.integers(h), rng.integers(w)
        img[r:r + rng.integers(1, 4), c:c + rng.integers(1, 4)] = True
    return img


def corridors(rng, h, w):
    """Solid blocks with carved horizontal and vertical corridors of width 1..3."""
    img = np.ones((h, w), dtype=bool)
    for _ in range(rng.integers(2, 5)):
        r, t = rng.integers(h), rng.integers(1, 4)
        img[r:r + t, :] = False
        c, t = rng.integers(w), rng.integers(1, 4)
        img[:, c:c + t] = False
    return img


def sparse_points(rng, h, w):
    """A large empty area with 1..6 isolated obstacle pixels."""
    img = np.zeros((h, w), dtype=bool)
    for _ in range(rng.integers(1, 7)):
        img[rng.integers(h), rng.integers(w)] = True
    return img


def empty(rng, h, w):
    """No obstacle at all."""
    return np.zeros((h, w), dtype=bool)


FAMILIES = {"random": random_image, "rooms": rooms, "corridors": corridors,
            "sparse": sparse_points, "empty": empty}


def free_cells(img, rng, n):
    """``n`` distinct free cells (fewer if the image has fewer)."""
    free = np.argwhere(~img)
    if len(free) == 0:
        return []
    idx = rng.choice(len(free), size=min(n, len(free)), replace=False)
    return [tuple(int(v) for v in free[i]) for i in idx]
