"""Gradient ascent (models.harmonic.trajectory) on fields the model computes.

Claim tested: on a converged field (no free local maximum, section 4.1), the
steepest 4-neighbour ascent reaches a goal from EVERY free cell a goal can
reach, on the bundled maps, the paper's corridor and a spiral (3.2.2), and a
multi-goal map (den312d is left out: 14 s in the model).  The fields come
from the block-synchronous planner (models.harmonic.plan, 8x8 blocks, I = 4,
p = 16, 32, ... until no local maximum).  Every path is also checked cell by cell: 4-connected, free
or goal cells only, values strictly increasing, ending on a goal.  And the
converse, so the test can fail: with too little precision the same ascent
gets stuck on plateaus.
"""

from pathlib import Path

import numpy as np
import pytest

from harmonic_small_maps import corridor, pocket, spiral
from navcores.models.harmonic import ASCENT_MOVES, ascent_next, ascent_reaches, one, trajectory
from navcores.models.maps import load_map, load_scenarios

import harmonic_fields as hf

ROOT = Path(__file__).resolve().parents[2]


def _bundled(name):
    grid = load_map(ROOT / "maps" / name)
    scen = ROOT / "maps" / (Path(name).stem + "-even-10.scen")
    if scen.exists():
        goal = max(load_scenarios(scen, grid), key=lambda s: s.optimal_length).goal
    else:
        goal = tuple(int(x) for x in np.argwhere(~grid)[-1])
    return grid, [goal]


def _two_goals():
    grid = load_map(ROOT / "maps" / "room-32-32-4.map")
    free = np.argwhere(~grid)
    return grid, [tuple(int(x) for x in free[0]), tuple(int(x) for x in free[-1])]


MAPS = {
    "empty-16-16": lambda: _bundled("empty-16-16.map"),
    "room-32-32-4": lambda: _bundled("room-32-32-4.map"),
    "random-32-32-10": lambda: _bundled("random-32-32-10.map"),
    "maze-32-32-2": lambda: _bundled("maze-32-32-2.map"),
    "room-two-goals": _two_goals,
    "corridor-30": lambda: corridor(30),
    "spiral-13": lambda: spiral(13),
    "pocket": pocket,
}


def _check_path(tr, h, obstacle, goal_mask):
    path = tr.path
    assert path[0] == tr.start
    for (r0, c0), (r1, c1) in zip(path, path[1:]):
        assert (r1 - r0, c1 - c0) in ASCENT_MOVES, "4-connected steps only"
        assert not obstacle[r1, c1] or goal_mask[r1, c1], "path enters an obstacle"
        assert h[r1, c1] > h[r0, c0], "values must strictly increase"
    assert tr.reached_goal == bool(goal_mask[path[-1]])


@pytest.mark.parametrize("name", list(MAPS))
def test_reaches_a_goal_from_every_reachable_cell(name):
    obstacle, goals = MAPS[name]()
    field = hf.converged(obstacle, goals)
    assert field.converged, f"{name}: no converged field up to p={field.p}"
    goal_mask = np.zeros(obstacle.shape, dtype=bool)
    goal_mask[tuple(np.array(goals).T)] = True
    free = ~obstacle & ~goal_mask
    reach = hf.reachable_mask(obstacle, goals) & free
    ok = ascent_reaches(field.h, goal_mask, reach)
    bad = [tuple(int(x) for x in rc) for rc in np.argwhere(reach & ~ok)]
    assert not bad, f"{name} at p={field.p}: ascent stuck from {len(bad)} cells, e.g. {bad[:5]}"
    assert reach.sum() > 0 and ok.sum() == reach.sum()
    # Cells no goal reaches stay a zero plateau: the ascent reports them stuck.
    cut = free & ~reach
    assert not ascent_reaches(field.h, goal_mask, cut).any()
    assert (name != "pocket") or cut.sum() == 9
    # Every path, walked one by one with trajectory(): a sample of starts.
    nxt = ascent_next(field.h)
    starts = np.argwhere(reach)[:: max(1, int(reach.sum()) // 40)]
    for s in starts:
        tr = trajectory(field.h, goals, tuple(s), nxt=nxt)
        assert tr.reached_goal, tr
        _check_path(tr, field.h, obstacle, goal_mask)
    assert len(starts) >= min(10, int(reach.sum()))


def test_low_precision_gets_stuck():
    """The same ascent fails on a field computed with too few bits: the
    corridor needs O(L) bits (3.2.2), at p = 16 most of it is a zero plateau."""
    obstacle, goals = corridor(30)
    field = hf.fixed(obstacle, goals, 16)
    goal_mask = np.zeros(obstacle.shape, dtype=bool)
    goal_mask[goals[0]] = True
    ok = ascent_reaches(field.h, goal_mask, ~obstacle)
    assert 0 < ok.sum() < (~obstacle).sum() - 5
    tr = trajectory(field.h, goals, (1, 1))
    assert not tr.reached_goal and tr.path == [(1, 1)]


def test_tie_break_order_and_stops():
    p = 8
    h = np.array([[0, 5, 0],
                  [5, 3, 5],
                  [0, 5, 0]], dtype=object)
    nr, nc = ascent_next(h)
    assert (int(nr[1, 1]), int(nc[1, 1])) == (0, 1), "N wins a four-way tie"
    h[0, 1] = 4
    nr, nc = ascent_next(h)
    assert (int(nr[1, 1]), int(nc[1, 1])) == (1, 2), "then E"
    h[1, 2] = 4
    nr, nc = ascent_next(h)
    assert (int(nr[1, 1]), int(nc[1, 1])) == (1, 0), "then W"
    h[1, 0] = 4
    nr, nc = ascent_next(h)
    assert (int(nr[1, 1]), int(nc[1, 1])) == (2, 1), "then S"
    h[1, 1] = 4
    h[2, 1] = 4
    nr, nc = ascent_next(h)
    assert (int(nr[1, 1]), int(nc[1, 1])) == (1, 1), "an equal neighbour is not a step"
    tr = trajectory(h, [(0, 0)], (1, 1))
    assert tr.path == [(1, 1)] and not tr.reached_goal
    tr = trajectory(h, [(0, 0)], (2, 0))
    assert tr.path == [(2, 0), (1, 0)] and not tr.reached_goal, "N before E"
    # A goal stops the ascent even with a higher neighbour beside it.
    h = np.array([[one(p), one(p) - 1, 7]], dtype=object)
    assert trajectory(h, [(0, 1)], (0, 2)).path == [(0, 2), (0, 1)]
    assert trajectory(h, [(0, 2)], (0, 2)).path == [(0, 2)]
    with pytest.raises(ValueError, match="outside"):
        trajectory(h, [(0, 0)], (1, 0))


def test_as_dict():
    h = np.array([[1, 2, 3]], dtype=object)
    d = trajectory(h, [(0, 2)], (0, 0)).as_dict()
    assert d == {"start": [0, 0], "path": [[0, 0], [0, 1], [0, 2]], "reached_goal": True}
