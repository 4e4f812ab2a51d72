"""Tiled EDT/NNT + BFS: paper 004's cells as a small array over a map in block RAM (issue 18).

The untiled engine (:mod:`models.edt_bfs`) has one cell per pixel.  Here a
physical array of ``T_r x T_c`` cells works over a map of any size ``H x W``
whose per-pixel state lives in RAM: a scheduler picks a *tile* (the map cut
into T_r x T_c pieces, the last row and column of tiles partial), the array
loads the tile's state plus a one-pixel *halo* ring from the neighbouring
tiles, iterates, and writes the tile back.  Halo cells are inputs only (the
paper's cell reads its eight neighbours; at the array's border they come from
the halo instead of being absent), plus the compare logic that decides which
neighbour tiles to mark.  The paper names this as its future work
(section V: "processing the images of portions of the environment in
sequence and integrating the partial results").

Everything is integer and exact.  The neighbourhood, eq. (1)-(4), the MAX
tree and its tie-break (smallest neighbour index) are the untiled model's:
the EDT iteration *is* :func:`models.edt_bfs.edt_step`.

State per pixel (one RAM entry; :func:`state_bits` sizes it)
-------------------------------------------------------------
* ``di``: the integer distance, the paper's iteration number k in which the
  pixel became done; NONE (all ones) while not done.  So ``done = di != NONE``
  and ``obstacle = di == 0`` (set by the map load) cost no bits.
* ``dx, dy``: the signed vector p - q to the nearest obstacle q (the NNT).
* ``hop``: the BFS hop count (steps to the nearest goal over 8-connected cfr
  pixels); NONE (all ones) while not visited: ``visited = hop != NONE``.
* ``parent``: 0..8, the BFS parent's neighbour index (0: a root, or none).
* Not stored: ``cfr = not done or di > d_far`` (from di and the job's d_far
  where a tile is loaded), and the paper's delta: a pixel done by the end of
  iteration k-1 enters iteration k with ``delta_{k-1} = k(k-1) - dx^2 - dy^2``
  (the untiled model's invariant ``delta_k = k^2 + k - d^2``), which the
  tile loader computes (two squarers per pixel lane).

EDT: level-synchronous tiles, exact
-----------------------------------
The paper's iteration number k is global, and the tiled EDT keeps it global
per *level*: for k = 1, 2, ... it visits the tiles of a worklist ``W_k``,
each visit running exactly one iteration k on the array, with every pixel
seen *as it was after iteration k-1*: a pixel counts as done iff
``di <= k-1`` (a halo pixel of a tile visited earlier in level k may already
hold di = k: it is masked).  The visit writes di = k and the vector of the
pixels it makes done.

**Invariant E.** After level k (every tile of W_k visited once, in any
order), every pixel's (di, dx, dy) equals the untiled model's after
iteration k.

*Proof* (induction on k; k = 0 is the load: obstacles di = 0, vector 0, the
rest NONE).  The untiled iteration k changes a pixel p only as a function of
the states of p and its 8 neighbours after iteration k-1.  (a) A visit in
level k gives each pixel of its tile exactly those inputs: the tile's own
pixels are as after k-1 (one visit per level, and a done pixel never
changes), the halo is masked to its after-(k-1) state, and delta is rebuilt
by the untiled invariant; the cell is the untiled cell, so the result is the
untiled result whatever the order of the tiles.  (b) A tile outside W_k does
not change in the untiled iteration k either, since W_k holds every tile
with a *frontier* pixel after k-1 (present, not done, an 8-neighbour done),
and only a frontier pixel can become done (the enable needs a done
neighbour).  W_{k+1} is built during level k by two marks, each computed by
the array from what it loaded and what it computed:

* ``self``: a pixel of the tile is not done after the visit and has a
  neighbour done in RAM at the end of the visit (di <= k in the halo: di = k
  there only if that tile was visited earlier in the level);
* ``border``: a pixel the visit made done is 8-adjacent to a present halo
  pixel that is NONE in RAM, and that pixel's tile is not still queued in
  W_k (a tile visited later in the level sees the new pixel itself).

Every frontier pixel p after level k is caught.  If its done neighbour q has
di(q) <= k-1, p was a frontier after k-1, its tile t was in W_k and marks
itself.  If di(q) = k and q is in t: the self mark.  If q is in another tile
t': when t comes after t' in level k, t's self mark sees q; when t came
before t' or is not in W_k, p is NONE in RAM at t''s visit and t is not
queued, so t' border-marks t.  Conversely every mark is a frontier tile
after level k (the self mark's pixel stays not done to the end of level k,
being visited once; the border mark's halo pixel is not done and its tile
is no longer visited in level k).  So W_{k+1} is *exactly* the set of tiles
with a frontier pixel after level k, whatever the order; only its FIFO order
depends on the order of level k.  W_1 is the same set after the load: the
tiles with a present free pixel 8-adjacent to an obstacle.

Hence the tiled di, dx, dy (so distance, vector, nearest, sqdist, done and
the cfr) equal the untiled ones on every pixel for every array size; with one
tile the schedule is the untiled one.  The last level is ``max di`` (the
untiled EDT has nothing left then and ends with one more, empty, iteration:
its ``iterations_edt`` is ``max di + 1``, or 1 without obstacles, and is
reported so).  A level visits the tiles its contour touches: the EDT's cost
follows the distance wave, each tile about (its range of di + 1) times, and
the maze's corridors (every free pixel at d_i = 1) cost one level.

BFS: per-pixel hop counts, tile relaxation, FIFO worklist
---------------------------------------------------------
The untiled BFS visits a pixel in the iteration equal to its hop count, with
parent the smallest index among the neighbours visited one iteration before.
Tiles cannot share that global iteration, so the hop count is stored per
pixel and a visit runs the cell's min relaxation (Bellman-Ford), one
iteration per clock, synchronously over the tile:

    for every cfr pixel p of the tile: m = the smallest hop of p's 8
    neighbours (halo included; NONE if none is visited), i = the smallest
    index attaining m;  if m + 1 <= hop(p): hop(p) = m + 1, parent(p) = i

until an iteration lowers no hop (that iteration counted; parents change
only when hop(p) = m + 1, and the last iteration sets every visited
non-root's parent from the final values).  Goals in the cfr start at hop 0
(roots: m + 1 <= 0 never holds, parent 0), everything else at NONE; a root
pushes its own tile only, and counts as fallen in every visit of that tile
(so the visit offers hop 1 to its neighbours in other tiles; the goal phase
reads one word per goal, never its neighbourhood).  After
a visit, a border pixel q whose hop fell (or a root) marks the tile of each 8-adjacent
halo pixel x with cfr(x) and either hop(q) + 1 < hop(x) (x will fall) or
hop(q) + 1 = hop(x) with q's index (seen from x) below parent(x) (x's
parent will change): the halo cells compare what the array loaded.

**Invariant B.** Every finite hop(p) is the length of a real path from a
goal in the cfr to p; and after tile t's visit, every pixel p of t satisfies
hop(p) = m(p) + 1 (non-roots) with parent(p) the smallest index attaining
m(p), against the values in RAM at the end of the visit.

*Proof sketch.*  Values only fall, each to a neighbour's value + 1, so they
stay lengths of real paths and, for non-roots, hop(p) >= m(p) + 1 at all
times; the visit's last iteration changes nothing, so hop(p) <= m(p) + 1, and
it set parent(p) from those values.  Every fall is strict and values are
bounded below, so the schedule ends.  When the worklist is empty, every pixel
still satisfies the invariant against the final values (a pixel of a tile
never visited is NONE with no visited neighbour): a neighbour q of p in
another tile that fell after p's tile's last visit (a root counts as fallen
in every visit of its tile, and its goal pushed that tile, so it is visited
at least once after the root was set) either offered
hop(q) + 1 < hop(p), or equal from a smaller index than parent(p), and then
marked p's tile (a contradiction), or left m(p) and the smallest minimising
index as they were.  So the final state is a fixpoint of
``hop(p) = 1 + min over neighbours`` on the cfr with the goals at 0, which is
the 8-connected BFS distance (at most it, by induction along a shortest
path; at least it, by the first point) and NONE exactly where no goal
reaches, and parent(p) is the smallest index with hop = hop(p) - 1: the
untiled parent (the neighbours visited one iteration before p are exactly
those).  So visited, parent and the path equal the untiled model's, and the
untiled ``iterations_bfs`` is ``max hop + 1`` (1 without a root).  The
fixpoint is unique, so the order of the worklist changes only the cost.

The worklist is a FIFO of tile indices with a queued bit per tile (a BRAM
FIFO and a bitmap).  A smallest-hop-first heap was measured against it and
gained nothing once the marks were exact (maze512-1-0 on 8x8: 14 164 BFS
visits against the FIFO's 14 051; every pixel's hop set exactly once by
both; with marks that also fired on equal offers the FIFO made 31 599).

Cycle model (the timing table the RTL will assert)
--------------------------------------------------
The RAM holds ``p = word_pixels`` pixels of a map row per word (p divides
T_c; columns [w p, (w+1) p) form word column w), in ``banks`` banks chosen by
word column modulo ``banks``: n consecutive words of a row take
ceil(n / banks) beats.  With p = T_c and 3 banks (the defaults) a window row
(the left neighbour's word, the tile's, the right neighbour's) is one beat.
One beat = one clock.  With the source always valid and the sink always
ready, counted from the command (exclusive) to the last beat:

    load       = H * ceil(W / p)        map rows in, one word per beat (the frontier
                                        flags of W_1 are computed on the fly)
    scan       = tiles                  W_1 from the per-tile frontier flags
    EDT        = sum over levels (level + sum over the level's visits: visit)
    goals      = goal * len(goals)      read the goal's word, write hop 0 and push its tile
                                        (when in the cfr and not queued) in the same beat
    BFS        = sum over visits: visit
    path       = 1 + latency * len(path)   (1 + latency without a path; 0 without a start):
                                        each pixel's read needs the previous one's parent
    readout    = latency + H * W        optional: every pixel, one per beat (reads run ahead)

    visit(t)   = sched + latency + read_beats(t) + iteration * iterations [+ stop, BFS]
                 + max(write_beats(t), marks)

``read_beats(t)``: the window's rows inside the map times the beats of the
words covering its columns inside the map; ``write_beats(t)``: the tile's
rows times the beats of its own words; ``iterations``: 1 per EDT visit, the
relaxation's count per BFS visit (the last one changes nothing), and in
a BFS visit ``stop`` cycles to see that (the engine registers the OR of
its cells' changes: that OR over the whole array is not on the clock's
path); ``iteration``: the cycles of one array iteration (1; 2 where the
cells register their MIN selection's winner between its comparators and
its multiplexers: the select cycle, then the step; in the BFS the cycle
that sees a change is the next iteration's select cycle, so ``stop``
stays one cycle); ``marks``: the tiles the visit enqueues
(self, then each marked direction in Fig. 1 order, when not already queued:
the engine reads the queued bits of the tile's 3 x 3 tile neighbourhood
while it schedules the visit), one per beat during the store.  The
constants are :class:`Timing`'s; the RTL's (``Timing()``): sched 2 (pop,
window set-up), latency 2 (the block RAM's read register and its output
register, which keeps the RAM's slow data output off the clock's paths),
level 1, goal 3 (= 1 + latency: issue the read, wait for the word), stop 1,
iteration 1 (2 with the engine's ``iter_cycles`` 2).
Words moved counts every word read or written; the floor is each visit
reading and writing each pixel of its tile once, ``2 ceil(T_r T_c / p)``
words per visit.
"""

from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .edt_bfs import OFFSETS, EdtBfsResult, _check_cell, edt_step, trace_path, widths

__all__ = ["Timing", "Geometry", "TileEngine", "EdtBfsTiledResult", "state_bits", "ram_blocks",
           "largest_map", "plan_path_tiled", "EBR_BITS", "LFE5U_85F_EBR"]

NONE = np.int64(1) << 40        # the model's "not done" / "not visited" (the RAM's all ones)
EBR_BITS = 18 * 1024            # one ECP5 EBR (DP16KD): 1024 x 18, or 512 x 36 as pseudo dual port
LFE5U_85F_EBR = 208


@dataclass(frozen=True)
class Timing:
    """Cycle constants of the tile engine (module docstring, cycle model)."""
    sched: int = 2        # pop the worklist, set up the window's addresses
    latency: int = 2      # RAM read latency before the first word of a burst (read + output register)
    level: int = 1        # EDT: swap the worklists of levels k and k+1
    goal: int = 3         # per goal: read its word (cfr?; 1 + latency), write hop 0 and push its tile
    stop: int = 1         # per BFS visit: the cycle that reads the registered "no cell changed" and leaves
    iteration: int = 1    # per array iteration (2: the cells' MIN selection registered between its halves)

    def __post_init__(self):
        for name in ("sched", "latency", "level", "goal", "stop", "iteration"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < (1 if name == "iteration" else 0):
                raise ValueError(f"Timing.{name} {v!r}: must be an integer >= {1 if name == 'iteration' else 0}")


def _bits(n):
    return max(1, int(n).bit_length())


def state_bits(height, width):
    """Bits of one pixel's RAM state for an ``height`` x ``width`` map.

    ``di`` holds 0..k_di and NONE = all ones (> k_di; k_di as in
    :func:`models.edt_bfs.widths`), ``dx`` / ``dy`` are signed
    (|dx| <= H - 1), ``hop`` holds 0..H*W - 1 and NONE = all ones (>= H*W),
    ``parent`` 0..8.  done, obstacle, visited, cfr and delta are derived
    (module docstring) and cost no bits.  Returns ``fields`` (name: bits)
    and ``total``.
    """
    w = widths(height, width)
    f = {"di": _bits(w["k_di"] + 1), "dx": w["dx"], "dy": w["dy"], "hop": _bits(height * width), "parent": 4}
    return {"fields": f, "total": sum(f.values())}


def ram_blocks(height, width, word_pixels, block_bits=EBR_BITS):
    """EBRs holding the state of an ``height`` x ``width`` map, ``word_pixels`` pixels per word.

    Each EBR is used as 512 x 36 or 1024 x 18, whichever needs fewer.
    Returns ``blocks``, ``words`` and ``word_bits``.
    """
    bits = state_bits(height, width)["total"] * word_pixels
    words = height * -(-width // word_pixels)
    blocks = min(-(-bits // lane) * -(-words // (block_bits // lane)) for lane in (36, 18))
    return {"blocks": blocks, "words": words, "word_bits": bits}


def largest_map(blocks=LFE5U_85F_EBR, word_pixels=8):
    """The side of the largest square map whose state fits in ``blocks`` EBRs."""
    n = 1
    while ram_blocks(n + 1, n + 1, word_pixels)["blocks"] <= blocks:
        n += 1
    return n


# The fields a visit of each phase reads and writes (pixel fields of state_bits).  An EDT visit
# needs its window's di (done, obstacle) and nearest-obstacle vectors (paper 004, eq. 1-3) and
# writes them; a BFS visit needs di (the cfr: di > d_far) and the hop counts, and writes hop and
# parent, so it reads the parents it writes back unchanged.  The tile engine's read commands name
# these groups (hdl/edt_bfs/state_ram.read_layout), so an external store moves only them.
PHASE_READS = {"edt": ("di", "dx", "dy"), "bfs": ("di", "hop", "parent")}
PHASE_WRITES = {"edt": ("di", "dx", "dy"), "bfs": ("hop", "parent")}


def _store_bits_min(counts, height, width):
    """The least a state store moves in a job: every visit reads its window's pixels (the tile and its
    halo inside the map, the phase's PHASE_READS) and writes its tile's pixels (its PHASE_WRITES)."""
    f = state_bits(height, width)["fields"]
    return sum(counts[f"pixels_read_{ph}"] * sum(f[k] for k in PHASE_READS[ph])
               + counts[f"pixels_written_{ph}"] * sum(f[k] for k in PHASE_WRITES[ph]) for ph in ("edt", "bfs"))


@dataclass
class EdtBfsTiledResult(EdtBfsResult):
    """:class:`models.edt_bfs.EdtBfsResult`'s fields (same values) plus the tile engine's figures.

    ``cycles`` is the tile engine's job (module docstring); ``stats`` holds
    the counts: levels, visits and array iterations per phase, words read
    and written, the floor, marks, the cycle breakdown (``cycles`` by phase;
    ``cycle_terms`` by the cycle model's terms: load, scan, level, a visit's
    sched, read, iterate and store, goals, path, readout); pixels read (the
    visits' windows inside the map) and written (their tiles, per phase)
    and ``store_bits_min``, the bits a state store moves at least (the
    phase's :data:`PHASE_READS` of a window pixel read, its
    :data:`PHASE_WRITES` of a tile pixel written): the bandwidth an
    external store needs.
    """
    hop: np.ndarray = None          # H x W int: BFS hop count, -1 not visited
    array: tuple = (0, 0)           # (T_r, T_c)
    tile_visits: int = 0
    stats: dict = field(default_factory=dict)
    trace: list = field(default_factory=list)   # every visit: (phase, level, tile, iterations, marks)


class Geometry:
    """Tiles, windows and RAM words of an ``H x W`` map on a ``T_r x T_c`` array.

    The model's arrays are padded to whole tiles plus a one-pixel ring
    (pixel (r, c) at (r + 1, c + 1)); ``present`` is False outside the map,
    which the array sees as absent neighbours (never done, never visited,
    never in the cfr).  Tile t = (t // nc, t % nc) in raster order.
    """

    def __init__(self, height, width, array, word_pixels=None, banks=3):
        try:
            tr, tc = array
        except (TypeError, ValueError):
            raise ValueError(f"array {array!r}: expected (rows, columns)") from None
        for name, v in (("height", height), ("width", width), ("array rows", tr), ("array columns", tc)):
            if not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} {v!r}: must be an integer >= 1")
        p = tc if word_pixels is None else word_pixels
        if not isinstance(p, (int, np.integer)) or p < 1 or tc % p:
            raise ValueError(f"word_pixels {p!r}: must be a divisor of the array's {tc} columns")
        if not isinstance(banks, (int, np.integer)) or banks < 1:
            raise ValueError(f"banks {banks!r}: must be an integer >= 1")
        self.h, self.w, self.tr, self.tc, self.p, self.banks = int(height), int(width), int(tr), int(tc), int(p), banks
        self.nr, self.nc = -(-self.h // tr), -(-self.w // tc)
        self.tiles = self.nr * self.nc
        self.shape = (self.nr * tr + 2, self.nc * tc + 2)
        self.present = np.zeros(self.shape, dtype=bool)
        self.present[1:self.h + 1, 1:self.w + 1] = True
        ti, tj = np.divmod(np.arange(self.tiles), self.nc)
        self.r0, self.c0 = ti * tr, tj * tc            # window top-left = tile top-left - 1, padded
        # RAM traffic of a visit (rows and word columns clipped to the map)
        win_rows = np.minimum(self.h, self.r0 + tr + 1) - np.maximum(0, self.r0 - 1)
        own_rows = np.minimum(self.h, self.r0 + tr) - self.r0
        win_words = np.minimum(self.w - 1, self.c0 + tc) // p - np.maximum(0, self.c0 - 1) // p + 1
        own_words = (np.minimum(self.w, self.c0 + tc) - 1) // p - self.c0 // p + 1
        self.read_words, self.write_words = win_rows * win_words, own_rows * own_words
        # pixels of the map a visit needs (its window) and changes (its tile): what a store moves at least
        win_cols = np.minimum(self.w, self.c0 + tc + 1) - np.maximum(0, self.c0 - 1)
        self.read_px, self.write_px = win_rows * win_cols, own_rows * (np.minimum(self.w, self.c0 + tc) - self.c0)
        self.read_beats = win_rows * -(-win_words // banks)
        self.write_beats = own_rows * -(-own_words // banks)
        # nbr[t, i]: the tile in direction i (Fig. 1) of tile t, -1 outside; nbr[t, 0] = t
        self.nbr = np.zeros((self.tiles, 9), dtype=np.int64)
        self.nbr[:, 0] = np.arange(self.tiles)
        for i, (dr, dc) in OFFSETS.items():
            r, c = ti + dr, tj + dc
            inside = (r >= 0) & (r < self.nr) & (c >= 0) & (c < self.nc)
            self.nbr[:, i] = np.where(inside, r * self.nc + c, -1)
        self.regions = _ring_regions(self.tr, self.tc)
        self.flat = _WindowIndex(self.tr, self.tc)

    def tile_of(self, r, c):
        """The tile holding map pixel (r, c)."""
        return (r // self.tr) * self.nc + c // self.tc

    def windows(self, a, tiles):
        """The windows (tile + halo) of the padded ``a`` at ``tiles``: (n, T_r + 2, T_c + 2), a copy."""
        return sliding_window_view(a, (self.tr + 2, self.tc + 2))[self.r0[tiles], self.c0[tiles]]

    def interior_index(self, tiles):
        """Padded (rows, cols) of the tiles' pixels: two (n, T_r, T_c) arrays."""
        rows = self.r0[tiles][:, None, None] + 1 + np.arange(self.tr)[None, :, None]
        cols = self.c0[tiles][:, None, None] + 1 + np.arange(self.tc)[None, None, :]
        return np.broadcast_arrays(rows, cols)


def _ring_regions(tr, tc):
    """Window slices (rows, cols) of the halo ring that belong to the neighbour tile in direction i."""
    rows = {-1: slice(0, 1), 0: slice(1, tr + 1), 1: slice(tr + 1, tr + 2)}
    cols = {-1: slice(0, 1), 0: slice(1, tc + 1), 1: slice(tc + 1, tc + 2)}
    return {i: (rows[dr], cols[dc]) for i, (dr, dc) in OFFSETS.items()}


class _WindowIndex:
    """Flat indices into a (T_r + 2) x (T_c + 2) window, row-major (the BFS visit's gathers).

    ``inner``: the tile's pixels; ``nb[i - 1]``: neighbour i of each of them;
    ``border``: the tile pixels on its edge (positions in ``inner``);
    ``ring``: the halo pixels, ``ring_dir`` the direction of the tile each
    belongs to, ``ring_nb`` its neighbours inside the tile (positions in
    ``inner``, in increasing neighbour index as seen from the halo pixel,
    padded with ``T_r * T_c``) and ``ring_nb_dir`` those indices (9: padding).
    """

    def __init__(self, tr, tc):
        wc = tc + 2
        r, c = (a.ravel() for a in np.meshgrid(np.arange(1, tr + 1), np.arange(1, tc + 1), indexing="ij"))
        self.inner = r * wc + c
        self.nb = np.stack([(r + dr) * wc + (c + dc) for dr, dc in OFFSETS.values()])
        self.border = np.flatnonzero((r == 1) | (r == tr) | (c == 1) | (c == tc))
        pos = {(int(a), int(b)): n for n, (a, b) in enumerate(zip(r, c))}
        ring, ring_dir, ring_nb = [], [], []
        for i, (rs, cs) in _ring_regions(tr, tc).items():
            for a in range(rs.start, rs.stop):
                for b in range(cs.start, cs.stop):
                    near = [(pos[(a + dr, b + dc)], j) for j, (dr, dc) in OFFSETS.items() if (a + dr, b + dc) in pos]
                    ring.append(a * wc + b)
                    ring_dir.append(i)
                    ring_nb.append(near + [(tr * tc, 9)] * (3 - len(near)))
        self.ring, self.ring_dir = np.array(ring), np.array(ring_dir)
        self.ring_nb = np.array([[n for n, _ in near] for near in ring_nb])
        self.ring_nb_dir = np.array([[j for _, j in near] for near in ring_nb])


def _nb(a, i, tr, tc):
    """Neighbour i of every tile pixel, from windows ``a`` (..., T_r + 2, T_c + 2)."""
    dr, dc = OFFSETS[i]
    return a[..., 1 + dr:1 + dr + tr, 1 + dc:1 + dc + tc]


def _dilate(a):
    """OR over the 3x3 neighbourhood of every pixel of ``a`` (..., h, w); outside is False."""
    p = np.pad(a, [(0, 0)] * (a.ndim - 2) + [(1, 1), (1, 1)])
    h, w = a.shape[-2:]
    out = np.zeros_like(a)
    for dr in (0, 1, 2):
        for dc in (0, 1, 2):
            out |= p[..., dr:dr + h, dc:dc + w]
    return out


class _Fifo:
    """The scheduler's worklist: a FIFO of tile indices with a queued bit per tile (no duplicates)."""

    def __init__(self, tiles):
        self.queued = np.zeros(tiles, dtype=bool)
        self.fifo = deque()

    def push(self, t):
        """Enqueue t unless it is queued; returns whether it was enqueued (a mark's beat)."""
        if self.queued[t]:
            return False
        self.queued[t] = True
        self.fifo.append(t)
        return True

    def pop(self):
        """The next tile, or None when empty."""
        if not self.fifo:
            return None
        t = self.fifo.popleft()
        self.queued[t] = False
        return t


PROGRESS_VISITS = 1024      # tile visits between two progress calls


class TileEngine:
    """One tiled job: the map's state (padded arrays standing for the RAM), the schedule, the counts.

    ``obstacle``: bool H x W; ``array``: (T_r, T_c); ``word_pixels``,
    ``banks``: the RAM layout (:class:`Geometry`); ``timing``: :class:`Timing`;
    ``progress``: called as ``progress(phase, visits)`` every
    :data:`PROGRESS_VISITS` tile visits (a command's progress line).
    """

    def __init__(self, obstacle, array, word_pixels=None, banks=3, timing=None, progress=None):
        obstacle = np.asarray(obstacle, dtype=bool)
        if obstacle.ndim != 2 or obstacle.size == 0:
            raise ValueError(f"obstacle must be a non-empty 2-D array, got shape {obstacle.shape}")
        self.timing = Timing() if timing is None else timing
        g = self.g = Geometry(*obstacle.shape, array, word_pixels, banks)
        self.inner = (slice(1, g.h + 1), slice(1, g.w + 1))
        self.di = np.full(g.shape, NONE, dtype=np.int64)
        self.di[self.inner][obstacle] = 0
        self.dx = np.zeros(g.shape, dtype=np.int64)
        self.dy = np.zeros(g.shape, dtype=np.int64)
        self.hop = np.full(g.shape, NONE, dtype=np.int64)
        self.parent = np.zeros(g.shape, dtype=np.int64)
        self.cfr = np.zeros(g.shape, dtype=bool)
        self.visits = np.zeros(g.tiles, dtype=np.int64)      # per tile, EDT + BFS
        self.counts = {"levels": 0, "visits_edt": 0, "visits_bfs": 0, "array_iterations_edt": 0,
                       "array_iterations_bfs": 0, "words_read": 0, "words_written": 0, "marks": 0,
                       "pixels_read_edt": 0, "pixels_read_bfs": 0, "pixels_written_edt": 0,
                       "pixels_written_bfs": 0}
        self.cycles = {"load": g.h * -(-g.w // g.p), "scan": g.tiles, "edt": 0, "goals": 0,
                       "bfs": 0, "path": 0, "readout": 0}
        # the visits' cycles by step (the cycle model's visit(t) term by term), and the levels': the job's
        # terms (result.stats["cycle_terms"]) against which a slower store's cost shows, state by state
        # (sim/rtl/engine_states.py; scripts/bench_dram.py --states)
        self.steps = {"level": 0, "sched": 0, "read": 0, "iterate": 0, "store": 0}
        self.trace = []          # every visit in order: (phase, level (0 in the BFS), tile, iterations, marks)
        self.progress = progress

    def _account(self, phase, k, t, iterations, marks):
        """One visit of tile t: trace, counts and cycles (module docstring, cycle model)."""
        g, tm = self.g, self.timing
        self.trace.append((phase, k, t, iterations, marks))
        if self.progress is not None and len(self.trace) % PROGRESS_VISITS == 0:
            self.progress(phase, len(self.trace))
        self.visits[t] += 1
        self.counts[f"visits_{phase}"] += 1
        self.counts[f"array_iterations_{phase}"] += iterations
        self.counts["words_read"] += int(g.read_words[t])
        self.counts["words_written"] += int(g.write_words[t])
        self.counts[f"pixels_read_{phase}"] += int(g.read_px[t])
        self.counts[f"pixels_written_{phase}"] += int(g.write_px[t])
        self.counts["marks"] += marks
        steps = {"sched": tm.sched, "read": tm.latency + int(g.read_beats[t]),
                 "iterate": tm.iteration * iterations + (tm.stop if phase == "bfs" else 0),
                 "store": max(int(g.write_beats[t]), marks)}
        for k, v in steps.items():
            self.steps[k] += v
        self.cycles[phase] += sum(steps.values())

    # -- EDT -----------------------------------------------------------------------------------
    def first_worklist(self):
        """W_1: the tiles with a present free pixel 8-adjacent to an obstacle, in raster order."""
        g = self.g
        obst = self.di == 0
        frontier = g.present & ~obst & _dilate(obst)
        per_tile = frontier[1:-1, 1:-1].reshape(g.nr, g.tr, g.nc, g.tc).any(axis=(1, 3))
        return [int(t) for t in np.flatnonzero(per_tile)]

    def edt_level(self, k, work, lo, hi):
        """Iteration k on the tiles ``work[lo:hi]`` of level k's worklist ``work``, as one batch.

        The results do not depend on the order within a level (invariant E),
        so any slice is one numpy batch.  The marks read what the level's
        earlier visits wrote, as the RTL's one-after-the-other visits do, and
        are computed as such a sequential run sees them (``self.level_pos``:
        each tile's place in ``work``, -1 if not in it).  Returns per tile
        (self mark, marked directions).
        """
        g, tr, tc = self.g, self.g.tr, self.g.tc
        tiles = np.asarray(work[lo:hi], dtype=np.int64)
        di_w, dx_w, dy_w = (g.windows(a, tiles) for a in (self.di, self.dx, self.dy))
        pr_w = g.windows(g.present, tiles)
        inner = (slice(None), slice(1, tr + 1), slice(1, tc + 1))
        if (di_w[inner] == k).any():
            raise AssertionError(f"a tile visited twice in level {k}")
        done_w = di_w <= k - 1                          # what iteration k reads: the state after k-1
        delta_w = np.where(done_w, k * (k - 1) - dx_w * dx_w - dy_w * dy_w, 0)
        nb = {i: tuple(_nb(a, i, tr, tc) for a in (done_w, delta_w, dx_w, dy_w)) for i in OFFSETS}
        done_c = done_w[inner] | ~pr_w[inner]           # absent cells never become done
        _, _, dx_n, dy_n, _, newly = edt_step(k, done_c, delta_w[inner], dx_w[inner], dy_w[inner],
                                              di_w[inner], nb)
        rows, cols = g.interior_index(tiles)
        rn, cn = rows[newly], cols[newly]
        self.di[rn, cn] = k
        self.dx[rn, cn] = dx_n[newly]
        self.dy[rn, cn] = dy_n[newly]
        # RAM as each visit ends: halo pixels of tiles visited earlier in the level
        # hold their di = k; tiles still queued in W_k are marked by themselves.
        mine = np.arange(lo, hi)
        npos = np.where(g.nbr[tiles] >= 0, self.level_pos[g.nbr[tiles]], -1)
        earlier_w = np.zeros_like(pr_w)
        later_w = np.zeros_like(pr_w)
        for i, (rs, cs) in g.regions.items():
            earlier_w[:, rs, cs] = ((npos[:, i] >= 0) & (npos[:, i] < mine))[:, None, None]
            later_w[:, rs, cs] = (npos[:, i] > mine)[:, None, None]
        earlier_w[inner] = True
        da_w = g.windows(self.di, tiles)
        done_ram = (da_w <= k - 1) | ((da_w == k) & earlier_w)
        near = np.zeros_like(newly)
        for i in OFFSETS:
            near |= _nb(done_ram, i, tr, tc)
        self_mark = (pr_w[inner] & ~done_ram[inner] & near).any(axis=(1, 2))
        newly_w = np.zeros_like(pr_w)
        newly_w[inner] = newly
        cand = pr_w & ~done_ram & ~later_w & _dilate(newly_w)
        dirs = {i: cand[:, rs, cs].any(axis=(1, 2)) for i, (rs, cs) in g.regions.items()}
        return [(bool(self_mark[n]), [i for i in OFFSETS if dirs[i][n]]) for n in range(len(tiles))]

    def edt(self, batch=None):
        """Level-synchronous EDT over W_1, W_2, ... (module docstring).

        ``batch``: tiles per numpy batch (None: a whole level; 1: the RTL's
        one-at-a-time order, which invariant E says gives the same state,
        marks and counts).
        """
        g = self.g
        work = self.first_worklist()
        k = 0
        while work:
            k += 1
            self.counts["levels"] += 1
            self.cycles["edt"] += self.timing.level
            self.steps["level"] += self.timing.level
            self.level_pos = np.full(g.tiles, -1, dtype=np.int64)
            self.level_pos[work] = np.arange(len(work))
            step = len(work) if batch is None else batch
            nxt = _Fifo(g.tiles)
            for lo in range(0, len(work), step):
                hi = min(len(work), lo + step)
                for t, (me, dirs) in zip(work[lo:hi], self.edt_level(k, work, lo, hi)):
                    # self first, then the directions in Fig. 1 order; a mark costs a
                    # beat when it enqueues (the self mark always does: t was just popped
                    # and no earlier visit of the level marks a tile still queued in W_k)
                    marks = nxt.push(t) if me else 0
                    marks += sum(nxt.push(int(g.nbr[t, i])) for i in dirs)
                    self._account("edt", k, t, 1, int(marks))
            work = list(nxt.fifo)

    # -- BFS -----------------------------------------------------------------------------------
    def bfs_visit(self, t):
        """Relax tile t to convergence; returns (iterations, marked directions)."""
        g, ix = self.g, self.g.flat
        r0, c0 = int(g.r0[t]), int(g.c0[t])
        win = (slice(r0, r0 + g.tr + 2), slice(c0, c0 + g.tc + 2))
        inner = (slice(r0 + 1, r0 + g.tr + 1), slice(c0 + 1, c0 + g.tc + 1))
        hw = self.hop[win].ravel()                      # a copy: the array's registers
        cw = self.cfr[win].ravel()
        ci = cw[ix.inner]
        hi = before = hw[ix.inner]
        iterations = 0
        while True:
            iterations += 1
            m = hw[ix.nb].min(axis=0) + 1
            upd = ci & (m < hi)
            if not upd.any():
                break
            hi = np.where(upd, m, hi)
            hw[ix.inner] = hi
        # The last iteration's parents: the smallest index attaining the minimum
        # (a root's hop - 1 = -1 and an unvisited pixel's NONE - 1 are no one's hop).
        eq = hw[ix.nb] == hi - 1
        self.parent[inner] = np.where(eq.any(axis=0), eq.argmax(axis=0) + 1, 0).reshape(g.tr, g.tc)
        self.hop[inner] = hi.reshape(g.tr, g.tc)
        # A root counts as fallen in every visit of its tile: its tile is the only one
        # its goal pushes, so this visit offers hop 1 to its neighbours in other tiles.
        changed = (hi < before) | (hi == 0)
        if not changed[ix.border].any():
            return iterations, []
        # Halo pixel x is marked when a fallen tile neighbour offers hop + 1 below hop(x),
        # or equal from a smaller index than parent(x); ring_nb runs in increasing index
        # (seen from x), so argmin finds the one x's MAX tree would take.
        offer = np.append(np.where(changed, hi + 1, NONE), NONE)[ix.ring_nb]
        best = offer.min(axis=1)
        j_best = ix.ring_nb_dir[np.arange(len(best)), offer.argmin(axis=1)]
        h_ring, p_ring = hw[ix.ring], self.parent[win].ravel()[ix.ring]
        cand = cw[ix.ring] & ((best < h_ring) | ((best == h_ring) & (j_best < p_ring)))
        return iterations, sorted(set(ix.ring_dir[cand].tolist()))

    def bfs(self, goals, dfar):
        """cfr, the roots at the goals inside it, then tile visits until the worklist is empty."""
        g = self.g
        self.cfr = g.present & ((self.di == NONE) | (self.di > dfar))
        work = _Fifo(g.tiles)
        for r, c in goals:
            # Read the goal's word (cfr?), write hop 0 and push its tile in the same beat.
            self.cycles["goals"] += self.timing.goal
            if self.cfr[r + 1, c + 1]:
                self.hop[r + 1, c + 1] = 0
                work.push(g.tile_of(r, c))
        while (t := work.pop()) is not None:
            iterations, dirs = self.bfs_visit(t)
            marks = sum(work.push(int(g.nbr[t, i])) for i in dirs)
            self._account("bfs", 0, t, iterations, int(marks))

    def plain(self, a):
        """A padded array cut to the map (a view)."""
        return a[self.inner]


def plan_path_tiled(obstacle, goals, start, dfar, array=(8, 8), word_pixels=None, banks=3,
                    timing=None, readout=False, progress=None):
    """Parallel_Path_Plan on a ``T_r x T_c`` tile array over the map (module docstring).

    Arguments as :func:`models.edt_bfs.plan_path`, plus ``array`` (T_r, T_c),
    ``word_pixels`` (pixels per RAM word, a divisor of T_c; default T_c),
    ``banks`` (RAM banks read in one beat), ``timing`` (:class:`Timing`) and
    ``readout`` (count the map read-out's cycles) and ``progress``
    (:class:`TileEngine`'s).  Returns an
    :class:`EdtBfsTiledResult`: its result fields equal ``plan_path``'s, its
    ``cycles`` are the tile engine's.
    """
    obstacle = np.asarray(obstacle, dtype=bool)
    if obstacle.ndim != 2 or obstacle.size == 0:
        raise ValueError(f"obstacle must be a non-empty 2-D array, got shape {obstacle.shape}")
    goals = [_check_cell(obstacle.shape, gl, "goal") for gl in goals]
    if start is not None:
        start = _check_cell(obstacle.shape, start, "start")
    if dfar < 0:
        raise ValueError(f"dfar {dfar} must be >= 0")
    eng = TileEngine(obstacle, array, word_pixels, banks, timing, progress)
    eng.edt()
    eng.bfs(goals, int(dfar))
    h, w = obstacle.shape
    g, tm, c = eng.g, eng.timing, eng.counts
    di, dx, dy, hop = (eng.plain(a) for a in (eng.di, eng.dx, eng.dy, eng.hop))
    done, visited = di != NONE, hop != NONE
    parent = eng.plain(eng.parent).copy()
    path = trace_path(visited, parent, start)
    if start is not None:
        eng.cycles["path"] = 1 + tm.latency * (len(path) if path else 1)
    if readout:
        eng.cycles["readout"] = tm.latency + h * w
    rows, cols = np.indices((h, w))
    nearest = np.stack([rows - dx, cols - dy], axis=-1)
    nearest[~done] = -1
    visits = c["visits_edt"] + c["visits_bfs"]
    stats = dict(c, tiles=g.tiles, word_pixels=g.p, banks=g.banks,
                 words_moved=c["words_read"] + c["words_written"],
                 store_bits_min=_store_bits_min(c, h, w),
                 words_floor=2 * visits * -(-g.tr * g.tc // g.p),
                 max_visits_per_tile=int(eng.visits.max()), cycles=dict(eng.cycles),
                 cycle_terms={"load": eng.cycles["load"], "scan": eng.cycles["scan"], **eng.steps,
                              **{k: eng.cycles[k] for k in ("goals", "path", "readout")}},
                 state_bits=state_bits(h, w)["total"])
    return EdtBfsTiledResult(
        distance=np.where(done, di, -1), nearest=nearest, vector=np.stack([dx, dy], axis=-1),
        sqdist=np.where(done, dx * dx + dy * dy, -1), done=done, cfr=eng.plain(eng.cfr).copy(),
        visited=visited, parent=parent, path=path, path_found=bool(path),
        iterations_edt=int(di[done].max()) + 1 if done.any() else 1,
        iterations_bfs=int(hop[visited].max()) + 1 if visited.any() else 1,
        cycles=sum(eng.cycles.values()), hop=np.where(visited, hop, -1), array=(g.tr, g.tc),
        tile_visits=visits, stats=stats, trace=eng.trace)
