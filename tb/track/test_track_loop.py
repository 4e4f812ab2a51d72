"""The fuzzy tracker in closed loop with the DFLC golden model (paper 003, sections 3, 4, 8).

* The tracker's inputs: φ1, φ2 of section 4 on hand-made canonical states,
  and eq. 34 (φ1 - φ2 = -φ, or 2π - φ after the wrap) on random ones.
* Closed loop, no slip: on a straight line and on a curved monotone chain
  (a sine arc, 30 vertices, smallest radius about 0.11 m), from on the path
  and from off it (offset and turned away), the robot reaches the end and,
  after the approach phase (models/tracker.py), stays within
  - 2 mm of the line, 10 mm of the curve (the paper's "below 10 mm" on
    odometry, section 8), both on odometry and on the true pose;
* With slip (s = 0.02): the controller sees only odometry, so the odometric
  figure is the same as without slip while the true pose drifts away from
  it (asserted: the drift is real), as the paper reports.
"""

import math

import numpy as np
import pytest

from navcores.models.swam import Swam
from navcores.models.tracker import ClosedLoop, TrackerParams, canonical_inputs, distance_to_chain, run_model
from navcores.sim.rtl.runner import seed_from_env
from navcores.sim.tracking import load_dflc

LINE = Swam([(0.0, 0.0), (1.0, 0.5)])
_t = np.linspace(0, 1, 30)
CURVE = Swam(np.stack([_t * 0.8, 0.15 * np.sin(2 * math.pi * _t)], 1))


@pytest.fixture(scope="module")
def dflc():
    return load_dflc()


def test_inputs_by_hand():
    d = 0.1
    assert canonical_inputs((0.3, 0.0, 0.0), d) == (0.0, 0.0)                  # on the line, aligned
    p1, p2 = canonical_inputs((0.3, d, 0.0), d)                               # left of it, aligned
    assert p1 == pytest.approx(-45.0) and p2 == pytest.approx(0.0)
    p1, p2 = canonical_inputs((0.3, 0.0, math.radians(30)), d)                # on it, turned left 30
    assert p1 == pytest.approx(-30.0) and p2 == pytest.approx(-30.0)
    p1, p2 = canonical_inputs((0.3, -d, math.pi), d)                          # right of it, reversed
    assert p1 == pytest.approx(-135.0) and p2 == pytest.approx(-180.0)


def test_eq34():
    rng = np.random.default_rng(seed_from_env())
    n = 0
    for _ in range(2000):
        y, th, d = rng.uniform(-1, 1), rng.uniform(-math.pi, math.pi), rng.uniform(0.01, 1)
        p1, p2 = canonical_inputs((0.0, y, th), d)
        phi = math.degrees(math.atan(y / d))
        diff = p1 - p2
        assert min(abs(diff + phi), abs(diff - (360 - phi)), abs(diff + 360 + phi)) < 1e-9
        assert -180 <= p1 < 180 and -180 <= p2 < 180
        n += 1
    assert n == 2000


CASES = [
    ("line", LINE, None, 0.002),
    ("line", LINE, (0.0, 0.06, math.radians(-40)), 0.002),
    ("curve", CURVE, None, 0.010),
    ("curve", CURVE, (0.02, -0.04, math.radians(60)), 0.010),
]


@pytest.mark.parametrize("name,chain,start,bound", CASES, ids=[f"{c[0]}-{'on' if c[2] is None else 'off'}" for c in CASES])
def test_tracks(dflc, name, chain, start, bound):
    loop = ClosedLoop(chain, dflc, start=start)
    r = run_model(loop)
    print(f"{name} start {start}: {r['steps']} periods, approach {r['approach_m']:.3f} m, "
          f"true max {r['max_cross_track'] * 1e3:.2f} mm rms {r['rms_cross_track'] * 1e3:.2f} mm, "
          f"odometry max {r['odometry_max_cross_track'] * 1e3:.2f} mm")
    assert r["reached_end"]
    assert r["samples_after_approach"] > 0.5 * r["steps"]
    assert r["odometry_max_cross_track"] <= bound
    assert r["max_cross_track"] <= bound + 0.001          # no slip: true = odometry up to quantization
    end = np.array(r["pose"][-1][:2])
    assert np.hypot(*(end - chain.vertices[-1])) < 0.02    # it stops at the end vertex
    if start is not None:
        assert r["approach_m"] > 0
        d0 = distance_to_chain([start[:2]], chain.vertices)[0]
        assert d0 > 2 * bound                              # the approach was real


def test_slip_drift(dflc):
    clean = run_model(ClosedLoop(CURVE, dflc))
    slip = run_model(ClosedLoop(CURVE, dflc, slip=0.02, seed=1))
    print(f"slip 0.02: true max {slip['max_cross_track'] * 1e3:.1f} mm, "
          f"odometry max {slip['odometry_max_cross_track'] * 1e3:.1f} mm")
    assert slip["reached_end"]
    assert slip["odometry_max_cross_track"] <= 0.010
    # the encoders see wheel rotation, not ground travel: the controls and the
    # odometry are the same as without slip, the true pose is not
    assert slip["curvature_codes"] == clean["curvature_codes"]
    assert slip["max_cross_track"] > 2 * slip["odometry_max_cross_track"]


def test_params_checked(dflc):
    """The run's ranges live in models/tracker.py (check_run), with reasons;
    a start past the end of a single chain is refused (nothing to track)."""
    from navcores.models.tracker import MAX_PERIODS, RangeError
    for kw, match in ((dict(lookahead=0), r"lookahead 0: must be in \(0, 1\]"),
                      (dict(speed=0.001), r"speed 0.001: must be in \[0.008, 1\] \(m/s: the Khepera II"),
                      (dict(speed=float("nan")), "speed nan: must be a finite number"),
                      (dict(kappa_fs=-1), "kappa_fs -1")):
        with pytest.raises(RangeError, match=match):
            TrackerParams(**kw)
    with pytest.raises(ValueError, match="past the end of the path"):
        ClosedLoop(CURVE, dflc, start=(5.0, 0.0, 0.0))
    long = Swam([[0, 0], [3e4, 1]])
    with pytest.raises(ValueError, match=f"may need 144002800 control periods of 12.5 ms .a 3e.04 m path.* at most {MAX_PERIODS}"):
        ClosedLoop(long, dflc)


def test_fired_rules(dflc):
    """The rule count of the demo's summary: exact at MF peaks, and a strict subset of Table 1 in a run."""
    from navcores.models.tracker import fired_rules
    assert len(fired_rules(dflc, dflc.encode([[0.0, 0.0]]))) == 1            # both inputs on a peak
    assert len(fired_rules(dflc, dflc.encode([[22.5, 0.0]]))) == 2           # one between two MFs
    assert len(fired_rules(dflc, dflc.encode([[22.5, -22.5]]))) == 4
    r = run_model(ClosedLoop(CURVE, dflc, start=(0.02, -0.04, math.radians(60))))
    assert len(r["input_codes"]) == r["steps"]
    fired = fired_rules(dflc, r["input_codes"])
    print(f"{len(fired)} of 81 rules fired")
    assert 4 <= len(fired) < 40          # section 4: the fixed look-ahead keeps (φ1, φ2) in a strip
