"""The tiled EDT/BFS model (models/edt_bfs_tiled.py) against the untiled model, scipy and a plain BFS.

* Invariant E: d_i, the vector, nearest, sqdist, done and the cfr equal the
  untiled model's on every pixel, for many array shapes (square, 1 x n,
  non-square, larger than the map) and maps whose last row and column of
  tiles are partial; so scipy's bounds hold as for the untiled model
  (checked here again: never below the exact d^2, d_i at most 1 above the
  rounded exact distance, mismatch rates below 1e-4, the vector points at an
  obstacle at exactly that distance).
* Invariant B: hop counts equal a plain queue BFS from the goals (several at
  once), the parent is the smallest neighbour index with one hop less, the
  path is a shortest path; visited, parent and path equal the untiled model's.
* The worklists: W_{k+1} is exactly the set of tiles with a frontier pixel
  after level k; a level run tile by tile (the RTL's order) gives the same
  state, marks and trace as one batch.
* One tile covering the map runs the untiled schedule.
* Cost follows the wave: on concentric rings and on maze512-1-0 the BFS
  visits stay a few per tile, far below sweeps x tiles; walled-off tiles are
  never visited.
* The cycle model, recomputed from the visit trace by brute force (words per
  window row counted from the pixels), and one job counted by hand.
* State bits per pixel and the block RAM they need.
"""

from pathlib import Path

import numpy as np
import pytest

from images import FAMILIES, free_cells
from navcores.models.edt_bfs import plan_path
from navcores.models.edt_bfs_tiled import (EBR_BITS, LFE5U_85F_EBR, TileEngine, Timing, largest_map,
                                  plan_path_tiled, ram_blocks, state_bits)
from references import MOVES, bfs_hops, exact_di, lowest_parent, scipy_edt
from navcores.models.maps import load_grid
from navcores.sim.rtl.runner import seed_from_env

MAPS = Path(__file__).resolve().parents[2] / "maps"
FIELDS = ("distance", "nearest", "vector", "sqdist", "done", "cfr", "visited", "parent")


def _same_as_untiled(res, img, goals, start, dfar):
    ref = plan_path(img, goals, start, dfar)
    for f in FIELDS:
        assert np.array_equal(getattr(res, f), getattr(ref, f)), f
    assert res.path == ref.path and res.path_found == ref.path_found
    assert (res.iterations_edt, res.iterations_bfs) == (ref.iterations_edt, ref.iterations_bfs)
    return ref


def _references(res, img, goals, start, dfar):
    """Check ``res`` against scipy and a plain BFS; returns (pixels, d_i mismatches, d^2 mismatches)."""
    if img.any():
        d2, _ = scipy_edt(img)
        assert res.done.all()
        assert (res.sqdist >= d2).all(), "never below the exact distance"
        diff = res.distance - exact_di(d2)
        assert diff.min() >= 0 and diff.max() <= 1
        assert (res.distance * res.distance + res.distance >= res.sqdist).all()
        nr, nc = res.nearest[..., 0], res.nearest[..., 1]
        assert img[nr, nc].all(), "the vector points at an obstacle"
        rows, cols = np.indices(img.shape)
        assert ((rows - nr) ** 2 + (cols - nc) ** 2 == res.sqdist).all()
        bad = (int((diff != 0).sum()), int((res.sqdist != d2).sum()))
    else:
        assert (res.distance == -1).all() and (res.nearest == -1).all() and res.cfr.all()
        bad = (0, 0)
    assert np.array_equal(res.cfr, ~res.done | (res.distance > dfar))
    hop = bfs_hops(res.cfr, goals)
    assert np.array_equal(res.hop, hop), "hop counts = a plain BFS from all goals at once"
    assert np.array_equal(res.visited, hop >= 0)
    assert np.array_equal(res.parent, lowest_parent(hop))
    if start is not None and hop[start] >= 0:
        path = res.path
        assert len(path) == hop[start] + 1 and path[0] == start and hop[path[-1]] == 0
        assert path[-1] in goals
        for a, b in zip(path, path[1:]):
            assert max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1 and res.cfr[b]
    else:
        assert res.path == [] and not res.path_found
    return img.size, bad[0], bad[1]


def _frontier_tiles(res, k):
    """Tiles holding a pixel not done after level k with a neighbour done by then (from the final d_i)."""
    h, w = res.distance.shape
    tr, tc = res.array
    di = np.where(res.done, res.distance, 1 << 30)
    done = np.pad(di <= k, 1)
    near = np.zeros((h, w), dtype=bool)
    for dr, dc in MOVES.values():
        near |= done[1 + dr:1 + dr + h, 1 + dc:1 + dc + w]
    rr, cc = np.nonzero((di > k) & near)
    return set((rr // tr * -(-w // tc) + cc // tc).tolist())


def _check_worklists(res):
    """Each level visits each tile once, and exactly the tiles with a frontier after the level before."""
    levels = {}
    for phase, k, t, _, _ in res.trace:
        if phase == "edt":
            levels.setdefault(k, []).append(t)
    assert sorted(levels) == list(range(1, len(levels) + 1))
    assert len(levels) == max(0, res.iterations_edt - 1) == res.stats["levels"]
    for k, tiles in levels.items():
        assert len(set(tiles)) == len(tiles), f"a tile twice in level {k}"
        assert set(tiles) == _frontier_tiles(res, k - 1), f"W_{k} is not the frontier after level {k - 1}"
    return len(levels)


def _random_case(rng, n):
    name = list(FAMILIES)[n % len(FAMILIES)]
    h, w = (int(v) for v in rng.integers(4, 41, 2))
    img = FAMILIES[name](rng, h, w)
    tr, tc = (int(v) for v in rng.integers(1, 12, 2))
    divisors = [p for p in range(1, tc + 1) if tc % p == 0]
    cells = free_cells(img, rng, 5)
    return name, img, (tr, tc), int(rng.choice(divisors)), int(rng.integers(1, 4)), cells


def test_random_maps_match_untiled_and_references():
    seed = seed_from_env()
    print(f"seed {seed} (replay with SEED={seed})")
    rng = np.random.default_rng(seed + 10)
    pixels = bad_di = bad_d2 = partial = multi = found = unreached = 0
    for n in range(120):
        name, img, array, p, banks, cells = _random_case(rng, n)
        if len(cells) < 2:
            continue
        start, goals = cells[0], cells[1:1 + int(rng.integers(1, 4))]
        dfar = int(rng.integers(0, 3))
        res = plan_path_tiled(img, goals, start, dfar, array=array, word_pixels=p, banks=banks)
        _same_as_untiled(res, img, goals, start, dfar)
        px, bd, b2 = _references(res, img, goals, start, dfar)
        _check_worklists(res)
        pixels, bad_di, bad_d2 = pixels + px, bad_di + bd, bad_d2 + b2
        partial += img.shape[0] % array[0] != 0 and img.shape[1] % array[1] != 0
        multi += len(goals) > 1
        found += res.path_found
        unreached += bool((res.cfr & ~res.visited).any())
    print(f"{pixels} pixels, d_i differs at {bad_di}, d^2 at {bad_d2}; {partial} maps with partial last "
          f"tiles both ways, {multi} with several goals, {found} paths, {unreached} with unreached cfr pixels")
    assert bad_di <= 1e-4 * pixels and bad_d2 <= 1e-4 * pixels
    assert pixels > 40_000 and partial > 30 and multi > 30 and 20 < found < 100 and unreached > 10


@pytest.mark.parametrize("name", ["den312d", "room-64-64-8", "random-64-64-10", "maze-32-32-2", "room-32-32-4"])
@pytest.mark.parametrize("array", [(8, 8), (16, 16)])
def test_bundled_maps(name, array):
    img = load_grid(MAPS / f"{name}.map")
    rng = np.random.default_rng(seed_from_env() + 20)
    cells = free_cells(img, rng, 4)
    start, goals = cells[0], cells[1:]
    res = plan_path_tiled(img, goals, start, 1, array=array)
    _same_as_untiled(res, img, goals, start, 1)
    _references(res, img, goals, start, 1)
    _check_worklists(res)
    assert res.tile_visits == len(res.trace) == res.stats["visits_edt"] + res.stats["visits_bfs"]


def test_maze512():
    """The 512x512 maze: references, the worklists, and visits that follow the wave."""
    img = load_grid(MAPS / "maze512-1-0.map")
    free = np.argwhere(~img)
    goals = [tuple(int(v) for v in free[i]) for i in (-1, len(free) // 2)]
    start = tuple(int(v) for v in free[0])
    res = plan_path_tiled(img, goals, start, 0, array=(8, 8))
    _references(res, img, goals, start, 0)
    assert _check_worklists(res) == 1 and res.distance.max() == 1      # corridors 1 wide: one level
    tiles, st = res.stats["tiles"], res.stats
    assert st["visits_edt"] == tiles == 4096
    print(f"maze512 on 8x8: {st['visits_edt']} EDT + {st['visits_bfs']} BFS visits over {tiles} tiles; "
          f"BFS depth {res.iterations_bfs - 1}; {res.cycles} cycles")
    # The untiled schedule pays every tile each BFS iteration; the tiled one a few visits a tile.
    assert st["visits_bfs"] < 4 * tiles and st["visits_bfs"] < tiles * res.iterations_bfs / 500
    sb = state_bits(*img.shape)
    assert res.hop.max() < (1 << sb["fields"]["hop"]) - 1 and res.distance.max() < (1 << sb["fields"]["di"]) - 1


def _rings(n, box):
    """Concentric square walls, each with one door, doors alternating sides (the BFS winds round
    each ring); plus a walled-off ``box`` x ``box`` room in the top-left corner."""
    img = np.zeros((n, n), dtype=bool)
    for j, d in enumerate(range(box + 2, n // 2 - 1, 2)):
        img[d, d:n - d] = img[n - 1 - d, d:n - d] = True
        img[d:n - d, d] = img[d:n - d, n - 1 - d] = True
        mid = n // 2
        img[d if j % 2 else n - 1 - d, mid] = False
    img[:box + 1, :box + 1] = False
    img[box, :box + 1] = img[:box + 1, box] = True
    return img


def test_visits_follow_the_wave():
    img = _rings(96, 12)
    goal, start = (48, 48), (0, 95)
    res = plan_path_tiled(img, [goal], start, 0, array=(8, 8))
    _same_as_untiled(res, img, [goal], start, 0)
    _references(res, img, [goal], start, 0)
    st, tiles = res.stats, res.stats["tiles"]
    bfs_tiles = {t for phase, _, t, _, _ in res.trace if phase == "bfs"}
    print(f"rings 96x96 on 8x8: BFS depth {res.iterations_bfs - 1}, {st['visits_bfs']} BFS visits "
          f"over {tiles} tiles (sweeps x tiles = {res.iterations_bfs * tiles})")
    assert res.path_found and res.iterations_bfs > 500
    assert st["visits_bfs"] < 3 * tiles and st["visits_bfs"] < tiles * res.iterations_bfs / 300
    assert not bfs_tiles & {0}, "the walled-off room's tile is never visited by the BFS"


@pytest.mark.parametrize("shape, array", [((37, 53), (8, 8)), ((37, 53), (5, 7)), ((9, 30), (1, 6))])
def test_edge_cases(shape, array):
    h, w = shape
    # no obstacles: nothing reached, everything in the cfr, no EDT visit
    img = np.zeros(shape, dtype=bool)
    res = plan_path_tiled(img, [(h - 1, w - 1)], (0, 0), 3, array=array)
    _same_as_untiled(res, img, [(h - 1, w - 1)], (0, 0), 3)
    _references(res, img, [(h - 1, w - 1)], (0, 0), 3)
    assert res.stats["visits_edt"] == 0 and res.iterations_edt == 1 and len(res.path) == max(h, w)
    # a wall: an unreachable goal alone (no path), then with a reachable one too
    img[:, w // 2] = True
    for goals, found in (([(h - 1, w - 1)], False), ([(h - 1, w - 1), (h // 2, 1)], True)):
        res = plan_path_tiled(img, goals, (0, 0), 0, array=array)
        _same_as_untiled(res, img, goals, (0, 0), 0)
        _references(res, img, goals, (0, 0), 0)
        assert res.path_found == found and res.visited[h - 1, w - 1]
        assert not res.visited[:, :w // 2].any() if not found else res.visited[:, :w // 2].all()
    # a goal on an obstacle is dropped; start = goal; start outside the cfr
    for goals, start, dfar in (([(0, w // 2)], (0, 0), 0), ([(1, 1)], (1, 1), 0), ([(1, 1)], (0, w // 2 - 1), 1)):
        res = plan_path_tiled(img, goals, start, dfar, array=array)
        _same_as_untiled(res, img, goals, start, dfar)
        _references(res, img, goals, start, dfar)
    assert res.cfr[1, 1] and not res.cfr[0, w // 2 - 1] and not res.path_found


def test_one_tile_is_the_untiled_schedule():
    rng = np.random.default_rng(seed_from_env() + 30)
    for n in range(20):
        name = list(FAMILIES)[n % len(FAMILIES)]
        h, w = (int(v) for v in rng.integers(3, 30, 2))
        img = FAMILIES[name](rng, h, w)
        cells = free_cells(img, rng, 3)
        if len(cells) < 2:
            continue
        for array in ((h, w), (h + 3, w + 5)):
            res = plan_path_tiled(img, cells[1:], cells[0], 0, array=array)
            ref = _same_as_untiled(res, img, cells[1:], cells[0], 0)
            st = res.stats
            assert st["tiles"] == 1 and st["visits_edt"] == st["levels"] == st["array_iterations_edt"]
            assert st["array_iterations_edt"] + 1 == ref.iterations_edt
            if res.visited.any():
                assert st["visits_bfs"] == 1 and st["array_iterations_bfs"] == ref.iterations_bfs
            else:
                assert st["visits_bfs"] == 0


def test_level_order_one_tile_at_a_time():
    """A level run tile by tile (as the RTL runs it) equals the one-batch level: state, marks, trace."""
    rng = np.random.default_rng(seed_from_env() + 40)
    levels = 0
    for n in range(8):
        img = FAMILIES[["random", "rooms", "sparse", "corridors"][n % 4]](rng, 33, 29)
        runs = []
        for batch in (None, 1, 7):
            eng = TileEngine(img, (6, 5))
            eng.edt(batch=batch)
            runs.append(eng)
        for other in runs[1:]:
            for a in ("di", "dx", "dy"):
                assert np.array_equal(getattr(runs[0], a), getattr(other, a)), a
            assert runs[0].trace == other.trace and runs[0].cycles == other.cycles
        levels += runs[0].counts["levels"]
    assert levels > 20


def _brute_inside(rows, cols, h, w):
    """Pixels of rows x cols inside the h x w map, by enumeration."""
    return sum(0 <= r < h and 0 <= c < w for r in rows for c in cols)


def _brute_beats(rows, cols, h, w, p, banks):
    """Words and beats of the pixels rows x cols clipped to the map, by enumeration."""
    words = beats = 0
    for r in rows:
        if 0 <= r < h:
            ws = sorted({c // p for c in cols if 0 <= c < w})
            words += len(ws)
            beats += -(-len(ws) // banks)
    return words, beats


def test_cycle_model_brute_force():
    rng = np.random.default_rng(seed_from_env() + 50)
    for n in range(25):
        name, img, (tr, tc), p, banks, cells = _random_case(rng, n)
        tm = Timing(*(int(v) for v in rng.integers(0, 4, 5)), iteration=int(rng.integers(1, 4)))
        start = cells[0] if cells else None
        res = plan_path_tiled(img, cells[1:3], start, 0, array=(tr, tc), word_pixels=p, banks=banks,
                              timing=tm, readout=bool(n % 2))
        h, w = img.shape
        nc = -(-w // tc)
        cyc = {"edt": 0, "bfs": 0}
        steps = {"level": tm.level * res.stats["levels"], "sched": 0, "read": 0, "iterate": 0, "store": 0}
        read = written = 0
        px = {"read_edt": 0, "read_bfs": 0, "edt": 0, "bfs": 0}    # map pixels of the windows read, the tiles written
        for phase, _, t, iterations, marks in res.trace:
            r0, c0 = t // nc * tr, t % nc * tc
            px[f"read_{phase}"] += _brute_inside(range(r0 - 1, r0 + tr + 1), range(c0 - 1, c0 + tc + 1), h, w)
            px[phase] += _brute_inside(range(r0, r0 + tr), range(c0, c0 + tc), h, w)
            rw, rb = _brute_beats(range(r0 - 1, r0 + tr + 1), range(c0 - 1, c0 + tc + 1), h, w, p, banks)
            ww, wb = _brute_beats(range(r0, r0 + tr), range(c0, c0 + tc), h, w, p, banks)
            read, written = read + rw, written + ww
            visit = {"sched": tm.sched, "read": tm.latency + rb,
                     "iterate": tm.iteration * iterations + (tm.stop if phase == "bfs" else 0), "store": max(wb, marks)}
            cyc[phase] += sum(visit.values())
            steps.update({k: steps[k] + v for k, v in visit.items()})
        cyc["edt"] += tm.level * res.stats["levels"]
        goals = tm.goal * len(cells[1:3])
        total = (h * -(-w // p) + res.stats["tiles"] + cyc["edt"] + goals + cyc["bfs"]
                 + (1 + tm.latency * max(1, len(res.path)) if start else 0) + (tm.latency + h * w if n % 2 else 0))
        assert (res.stats["words_read"], res.stats["words_written"]) == (read, written)
        assert res.stats["cycles"]["edt"] == cyc["edt"] and res.stats["cycles"]["bfs"] == cyc["bfs"]
        assert res.cycles == total == sum(res.stats["cycle_terms"].values())
        assert res.stats["cycle_terms"] == {"load": h * -(-w // p), "scan": res.stats["tiles"], **steps,
                                            "goals": goals, "path": res.stats["cycles"]["path"],
                                            "readout": res.stats["cycles"]["readout"]}
        assert res.stats["words_floor"] == 2 * len(res.trace) * -(-tr * tc // p)
        assert (res.stats["pixels_read_edt"], res.stats["pixels_read_bfs"], res.stats["pixels_written_edt"],
                res.stats["pixels_written_bfs"]) == (px["read_edt"], px["read_bfs"], px["edt"], px["bfs"])
        f = state_bits(h, w)["fields"]
        # EDT reads and writes di, dx, dy; BFS reads di, hop, parent and writes hop, parent
        assert res.stats["store_bits_min"] == ((px["read_edt"] + px["edt"]) * (f["di"] + f["dx"] + f["dy"])
                                               + px["read_bfs"] * (f["di"] + f["hop"] + f["parent"])
                                               + px["bfs"] * (f["hop"] + f["parent"]))


def test_cycles_by_hand():
    """A 2x3 map, obstacle at (0, 0), on one 8x8 tile (the arithmetic in the comments)."""
    img = np.zeros((2, 3), dtype=bool)
    img[0, 0] = True
    res = plan_path_tiled(img, [(1, 2)], (0, 1), 0, array=(8, 8), readout=True)
    # EDT: level 1 makes (0,1), (1,0), (1,1) done and keeps a frontier (self mark);
    # level 2 the rest.  A visit: sched 2 + latency 2 + 2 rows x 1 word + 1 iteration
    # + max(2 stores, marks) = 9; plus 1 per level.
    assert [e[:2] + e[3:] for e in res.trace] == [("edt", 1, 1, 1), ("edt", 2, 1, 0), ("bfs", 0, 3, 0)]
    assert res.stats["cycles"] == {"load": 2, "scan": 1, "edt": 2 * 9 + 2, "goals": 3,
                                   # BFS: hop 1 at iteration 1, (1, 0) hop 2 at 2, nothing at 3,
                                   # then the stop cycle that sees it
                                   "bfs": 2 + 2 + 2 + 3 + 1 + 2,
                                   # path: the issue, then latency 2 per pixel (each needs its parent)
                                   "path": 1 + 2 * 2, "readout": 2 + 6}
    assert res.cycles == 2 + 1 + 20 + 3 + 12 + 5 + 8
    # the three visits' steps: sched 2 each, read 2 + 2 each, iterate 1 + 1 + 3 + stop 1, store 2 each
    assert res.stats["cycle_terms"] == {"load": 2, "scan": 1, "level": 2, "sched": 6, "read": 12, "iterate": 6,
                                        "store": 6, "goals": 3, "path": 5, "readout": 8}
    assert res.path == [(0, 1), (1, 2)] and res.parent[0, 1] == 8 and res.parent[1, 0] == 1


def test_state_bits_and_block_ram():
    # 512 x 512: k_di = 723 (722^2 + 722 = 522006 < 2 * 511^2 = 522242 <= 723^2 + 723),
    # d_i 0..723 + NONE in 10 bits, dx/dy 9 + sign, hop 0..262143 + NONE in 19, parent 4
    sb = state_bits(512, 512)
    assert sb["fields"] == {"di": 10, "dx": 10, "dy": 10, "hop": 19, "parent": 4} and sb["total"] == 53
    # 8 pixels a word = 424 bits = 12 lanes of 36 (512 deep) x 32768 words / 512 = 768 EBRs
    assert ram_blocks(512, 512, 8) == {"blocks": 768, "words": 32768, "word_bits": 424}
    assert 512 * 512 * 53 > LFE5U_85F_EBR * EBR_BITS
    n = largest_map(LFE5U_85F_EBR, 8)
    assert ram_blocks(n, n, 8)["blocks"] <= LFE5U_85F_EBR < ram_blocks(n + 1, n + 1, 8)["blocks"]
    assert n * n * state_bits(n, n)["total"] <= LFE5U_85F_EBR * EBR_BITS
    print(f"LFE5U-85F ({LFE5U_85F_EBR} EBR): largest square map {n}x{n} at {state_bits(n, n)['total']} bits a pixel")


def test_bad_parameters():
    img = np.zeros((5, 5), dtype=bool)
    for kw, msg in (({"array": (0, 4)}, "array rows"), ({"array": (4, 6), "word_pixels": 4}, "word_pixels"),
                    ({"banks": 0}, "banks"), ({"array": 8}, "array")):
        with pytest.raises(ValueError, match=msg):
            plan_path_tiled(img, [(0, 0)], None, 0, **kw)
    with pytest.raises(ValueError, match="Timing.sched"):
        Timing(sched=-1)
    with pytest.raises(ValueError, match="Timing.iteration 0"):
        Timing(iteration=0)
    with pytest.raises(ValueError, match="outside"):
        plan_path_tiled(img, [(5, 0)], None, 0)
    with pytest.raises(ValueError, match="dfar"):
        plan_path_tiled(img, [(0, 0)], None, -1)
