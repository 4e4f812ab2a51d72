"""hdl/catalog.py: every parameter set is a valid set of an emitted top, and
hdl.emit, make synth and make bench read their sets from it."""

import pytest

from navcores.hdl import catalog, emit


def test_every_set_is_a_valid_top_set():
    names = [s.name for s in catalog.SETS]
    assert len(names) == len(set(names)), "a set name used twice"
    for s in catalog.SETS:
        assert s.top in emit.TOPS, s
        assert s.emit or s.family, f"{s.name}: neither emitted nor synthesized"
        assert s.family in (None, "xc2v", "xc3s"), s
        assert not (s.paper and s.beyond), s
        man = emit.manifest(s.top, s.params)        # builds the component: its own checks pass
        assert man["module"] == emit.top_name(s.top, s.params)


def test_emit_reads_the_catalog():
    assert emit.DEFAULT_SETS is catalog.DEFAULT_SETS
    assert emit.DEFAULT_SETS == [(s.top, s.params) for s in catalog.SETS if s.emit]
    # one module per set: two sets never emit the same file
    modules = [emit.top_name(s.top, s.params) for s in catalog.SETS]
    assert len(modules) == len(set(modules))


def test_paper_column():
    node = catalog.get("node")
    assert node.paper_text() == "11 FF, 22 LUT4, 361 MHz (XC2V6000-5, Table 1)"
    assert catalog.get("planner_exp").paper_text().startswith("(beyond the paper: ")
    assert catalog.get("edt_8x8").paper_text() == "-"
    # every paper figure that a script reports is one of PAPER's (one definition each)
    assert {s.paper for s in catalog.SYNTHESIZED if s.paper} <= set(catalog.PAPER.values())
    with pytest.raises(KeyError, match="no parameter set 'nope'"):
        catalog.get("nope")


def test_timing_goals_are_valid_tops():
    """Issue 17's timing-closure rows (make bench places them): each a buildable top, named once."""
    modules = [emit.top_name(g.top, g.params) for g in catalog.TIMING_GOALS]
    assert len(modules) == len(set(modules)), "a timing goal listed twice"
    for g in catalog.TIMING_GOALS:
        assert g.top in emit.TOPS and g.goal_mhz > 0 and g.seeds >= 1 and g.router in ("router1", "router2"), g
        emit.manifest(g.top, g.params)          # builds the component: its own checks pass
