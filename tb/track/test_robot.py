"""Differential-drive model and odometry (paper 003, section 2, eq. 4-20).

* Eq. 14 and its inverse (eq. 10-12) agree; saturation keeps the curvature.
* A run at constant wheel speeds drives the true pose exactly on the circle
  of radius 1/κ (closed form, 1e-12), and the odometry from the quantized
  encoders reproduces it within the quantization bound: the counts of the
  cumulative travel are within one tick of it, so the heading error stays
  below 2 ticks / L and the position error below 2 ticks + (2 ticks / L) x
  distance travelled.
* A straight run: no heading change at all.
* Slip: with s > 0 the true pose and the odometry drift apart (more than the
  quantization bound), reproducibly for a seed and differently for another.
"""

import math

import numpy as np
import pytest

from navcores.models.robot import KHEPERA_II, Khepera, Robot, arc_step, speed_curvature, wheel_speeds


def test_wheel_speeds_round_trip():
    for v, k in [(0.05, 0.0), (0.1, 10.0), (0.02, -37.7), (0.3, 2 / KHEPERA_II.axle)]:
        vr, vl = wheel_speeds(v, k)
        v2, k2 = speed_curvature(vr, vl)
        assert math.isclose(v2, v) and math.isclose(k2, k, abs_tol=1e-12)
    r = Robot((0, 0, 0))
    vr, vl = r.saturate(*wheel_speeds(2.0, 20.0))
    assert max(abs(vr), abs(vl)) == pytest.approx(KHEPERA_II.max_wheel_speed)
    assert speed_curvature(vr, vl)[1] == pytest.approx(20.0)


@pytest.mark.parametrize("kappa", [8.0, -25.0, 0.5])
def test_odometry_reproduces_an_arc(kappa):
    v, steps = 0.08, 1200                        # 15 s, 1.2 m of travel
    p = KHEPERA_II
    x0, y0, t0 = 0.1, -0.2, 0.7
    robot = Robot((x0, y0, t0))
    vr, vl = wheel_speeds(v, kappa)
    worst_pos = worst_th = 0.0
    for n in range(1, steps + 1):
        odo = robot.command(vr, vl)
        s = v * p.period * n
        th = t0 + kappa * s
        expect = (x0 + (math.sin(th) - math.sin(t0)) / kappa, y0 - (math.cos(th) - math.cos(t0)) / kappa)
        tx, ty, tt = robot.true_pose
        assert abs(tx - expect[0]) < 1e-12 + 1e-12 * n and abs(ty - expect[1]) < 1e-12 + 1e-12 * n
        assert abs(tt - th) < 1e-12 * n
        worst_pos = max(worst_pos, math.hypot(odo[0] - expect[0], odo[1] - expect[1]))
        worst_th = max(worst_th, abs(odo[2] - th))
        assert worst_th < 2 * p.tick / p.axle
        assert worst_pos < 2 * p.tick + 2 * p.tick / p.axle * s
    assert worst_pos > 0                         # quantization did act


def test_straight_line():
    robot = Robot((0, 0, math.radians(30)))
    for _ in range(400):
        robot.command(0.1, 0.1)
    x, y, th = robot.true_pose
    assert th == pytest.approx(math.radians(30), abs=1e-15)
    assert math.hypot(x, y) == pytest.approx(0.1 * 400 * KHEPERA_II.period, rel=1e-12)
    ox, oy, oth = robot.pose
    assert oth == pytest.approx(th, abs=2 * KHEPERA_II.tick / KHEPERA_II.axle)
    assert math.hypot(ox - x, oy - y) < 2 * KHEPERA_II.tick


def test_arc_step_limit():
    # eq. 18 tends to eq. 19 as dθ -> 0
    a = arc_step((0, 0, 0.3), 0.01, 0.01 - 1e-12, 0.05)
    b = arc_step((0, 0, 0.3), 0.01, 0.01, 0.05)
    assert np.allclose(a, b, atol=1e-12)


def _drift(slip, seed, steps=1600):
    robot = Robot((0, 0, 0), slip=slip, seed=seed)
    vr, vl = wheel_speeds(0.08, 3.0)
    worst = 0.0
    for _ in range(steps):
        o = robot.command(vr, vl)
        t = robot.true_pose
        worst = max(worst, math.hypot(o[0] - t[0], o[1] - t[1]))
    return worst, robot.true_pose


def test_slip_drift():
    quant = 2 * KHEPERA_II.tick + 2 * KHEPERA_II.tick / KHEPERA_II.axle * 1600 * 0.08 * KHEPERA_II.period
    clean, _ = _drift(0.0, 1)
    assert clean < quant
    d1, end1 = _drift(0.02, 1)
    _, end1b = _drift(0.02, 1)
    d2, end2 = _drift(0.02, 2)
    assert d1 > 2 * quant and d2 > 2 * quant       # slip makes them drift apart
    assert end1 == end1b and end1 != end2          # seeded


def test_parameters_checked():
    with pytest.raises(ValueError, match="axle must be > 0"):
        Khepera(axle=0)
    with pytest.raises(ValueError, match="slip must be >= 0"):
        Robot((0, 0, 0), slip=-1)
