"""Differential-drive robot and its odometry (paper 003, section 2, eq. 4-20).

Units: metres, seconds, radians; a pose is ``(x, y, θ)`` of the middle point
K of the wheel axle, θ from the x axis, counter-clockwise positive.

Khepera II parameters (:class:`Khepera`)
-----------------------------------------
* ``axle`` L = 0.053 m: distance between the wheels (K-Team Khepera II user
  manual: 53 mm wheel spacing; also Webots' Khepera model).
* ``wheel_radius`` r = 0.008 m (the same sources; it only converts linear wheel
  speeds to angular ones, eq. 5: the kinematics below use linear speeds).
* ``tick`` = 0.08 mm of wheel travel per encoder pulse (paper section 2).
* ``period`` Δt = 12.5 ms: one encoder query and one curvature command per
  control period (paper section 2).
* ``max_wheel_speed`` = 1.0 m/s (Khepera II top speed); commands beyond it
  saturate, both wheels scaled by the same factor so the curvature is kept.

Kinematics
----------
Eq. 14 gives the linear wheel speeds from the speed v and the curvature κ:
``v_r = v (1 + κ L/2)``, ``v_l = v (1 - κ L/2)``.  Eq. 11 gives the turn rate
``ω = (v_r - v_l) / L`` (the paper's eq. 6 swaps v_l and v_r in its third row:
we follow eq. 4 and 11, right wheel forward turns left).  Over one control
period the wheel speeds are constant, so K moves on an arc, and eq. 15-19
(with ΔS_R, ΔS_L the wheel travels) are the exact solution: :func:`arc_step`.

Simulated robot (:class:`Robot`)
--------------------------------
It keeps a *true* pose and an *odometric* estimate:

* The encoders count whole ticks of each wheel's cumulative travel (floor of
  travel / tick): quantization is always on, and it never accumulates beyond
  one tick per wheel because the counts are of the total travel.
* Odometry is eq. 15-20 applied to the tick differences of each period, as
  the paper's MATLAB host did (time is absent from it).
* Wheel slip (``slip`` = s, 0 by default) makes the ground travel differ from
  the wheel rotation the encoders see: ground travel = wheel travel times
  ``(1 + b + e)``, with ``e`` ~ N(0, s) drawn per wheel and period (random
  slip) and ``b`` ~ N(0, s/5) drawn once per wheel and run (systematic:
  unequal effective wheel radii, the error that makes odometry drift most on
  small robots; a wheel difference δ bends the true path by about
  δ d² / (2L) over a distance d), from a seeded generator.  s = 0.02 gives a
  few centimetres over a metre, the paper's order of magnitude.  The true pose moves by the ground travel,
  the odometry by the ticks, so they drift apart as in the paper's section 8.
"""

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Khepera", "KHEPERA_II", "wheel_speeds", "speed_curvature", "arc_step", "Odometry", "Robot"]


@dataclass(frozen=True)
class Khepera:
    """Robot parameters (defaults: the Khepera II of the paper, see the module docstring)."""
    axle: float = 0.053
    wheel_radius: float = 0.008
    tick: float = 0.08e-3
    period: float = 0.0125
    max_wheel_speed: float = 1.0

    def __post_init__(self):
        for name in ("axle", "wheel_radius", "tick", "period", "max_wheel_speed"):
            if not getattr(self, name) > 0:
                raise ValueError(f"robot parameter {name} must be > 0, got {getattr(self, name)}")


KHEPERA_II = Khepera()


def wheel_speeds(v, kappa, axle=KHEPERA_II.axle):
    """Eq. 14: linear wheel speeds ``(v_r, v_l)`` for speed ``v`` and curvature ``kappa``."""
    return v * (1 + kappa * axle / 2), v * (1 - kappa * axle / 2)


def speed_curvature(v_r, v_l, axle=KHEPERA_II.axle):
    """Eq. 10-12 inverted: ``(v, κ)`` from the wheel speeds (κ = ω / v, v != 0)."""
    v = (v_r + v_l) / 2
    return v, (v_r - v_l) / (axle * v)


def arc_step(pose, ds_r, ds_l, axle=KHEPERA_II.axle):
    """Eq. 15-19: the pose after the wheels travelled ``ds_r``, ``ds_l`` on one arc."""
    x, y, th = pose
    dth = (ds_r - ds_l) / axle                 # eq. 15
    ds = (ds_r + ds_l) / 2                     # eq. 17
    # eq. 18, and its eq. 19 limit where dθ is too small for the quotient
    half = dth / 2
    chord = ds * (math.sin(half) / half if abs(half) > 1e-9 else 1 - half * half / 6)
    mid = th + half
    return (x + chord * math.cos(mid), y + chord * math.sin(mid), th + dth)


class Odometry:
    """Eq. 15-20 from encoder tick counts; ``pose`` is the running estimate."""

    def __init__(self, pose, robot=KHEPERA_II):
        self.robot = robot
        self.pose = tuple(float(v) for v in pose)
        self.ticks = (0, 0)

    def update(self, ticks_r, ticks_l):
        """New cumulative counts ``(right, left)``; returns the new pose."""
        d_r = (ticks_r - self.ticks[0]) * self.robot.tick
        d_l = (ticks_l - self.ticks[1]) * self.robot.tick
        self.ticks = (ticks_r, ticks_l)
        self.pose = arc_step(self.pose, d_r, d_l, self.robot.axle)
        return self.pose


class Robot:
    """A simulated differential-drive robot: true pose, encoders, odometry.

    ``slip`` is the standard deviation s of the relative wheel-travel error
    (module docstring); ``seed`` seeds it.  :meth:`command` runs one control
    period at constant wheel speeds.
    """

    def __init__(self, pose, params=KHEPERA_II, slip=0.0, seed=0):
        if not slip >= 0:
            raise ValueError(f"slip must be >= 0, got {slip}")
        self.params = params
        self.slip = float(slip)
        self.rng = np.random.default_rng(seed)
        self.bias = self.rng.normal(0.0, self.slip / 5, 2) if self.slip > 0 else np.zeros(2)
        self.true_pose = tuple(float(v) for v in pose)
        self.travel = np.zeros(2)              # cumulative wheel rotation as travel (right, left), m
        self.odometry = Odometry(pose, params)

    @property
    def pose(self):
        """The odometric estimate (what a controller sees)."""
        return self.odometry.pose

    def saturate(self, v_r, v_l):
        """Scale both wheel speeds by one factor so neither exceeds max_wheel_speed."""
        m = max(abs(v_r), abs(v_l))
        if m > self.params.max_wheel_speed:
            k = self.params.max_wheel_speed / m
            return v_r * k, v_l * k
        return v_r, v_l

    def command(self, v_r, v_l):
        """One control period at wheel speeds ``(v_r, v_l)`` (m/s); returns the odometric pose."""
        v_r, v_l = self.saturate(v_r, v_l)
        wheel = np.array([v_r, v_l]) * self.params.period
        ground = wheel.copy()
        if self.slip > 0:
            ground = wheel * (1 + self.bias + self.rng.normal(0.0, self.slip, 2))
        self.true_pose = arc_step(self.true_pose, ground[0], ground[1], self.params.axle)
        self.travel += wheel
        ticks = np.floor(self.travel / self.params.tick).astype(int)
        return self.odometry.update(int(ticks[0]), int(ticks[1]))
