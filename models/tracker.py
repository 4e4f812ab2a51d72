"""Fuzzy path tracker in the canonical domain, closed loop with the robot (paper 003, sections 3-4).

One control period (12.5 ms, section 2) of :class:`ClosedLoop`:

1. the odometric pose ``q_p`` (the controller never sees the true pose) is
   mapped to the canonical state ``q_c = Ψ⁻¹(q_p)`` (eq. 30) of the chain's
   SWAM, where the path is the segment ``y = 0, x in [0, 1]``;
2. the two DFLC inputs of section 4 (Fig. 6b) are computed with a fixed
   look-ahead: the tracked point is ``T = (x_c + Δ, 0)``, Δ the look-ahead
   distance ``lookahead`` (metres along the path, Δ = lookahead / S in
   canonical units, S the chain length):

   * ``φ1`` = angle of the sight line to T relative to the heading:
     ``wrap(atan2(-y_c, Δ) - θ_c)``;
   * ``φ2`` = direction of the path tangent relative to the heading:
     ``wrap(0 - θ_c)``;

   in degrees, wrapped to [-180, 180).  Then ``φ1 - φ2 = -φ`` with
   ``φ = atan(y_c / Δ)`` the sight-line angle, or ``2π - φ`` after the wrap:
   eq. 34.  With a fixed look-ahead φ stays in (-90°, 90°), the strip of
   section 4;
3. the DFLC (golden model or RTL, one sample per period) maps the input
   codes to an output code ``y`` (full scale ±1): the canonical curvature is
   ``κ_c = y · κ_fs · S`` with ``κ_fs`` (``kappa_fs``, 1/m) the *physical*
   curvature a full-scale output means on a straight chain (the canonical
   domain has length 1, so canonical curvatures are S times physical ones).
   A sample in which no rule fires (``zero``) commands κ_c = 0;
4. Ω (section 3) gives ``κ_p = S⁻³ J γ⁻³ κ_c``, limited to ±``kappa_limit``
   (near-degenerate strips can blow Ω up); eq. 14 gives the wheel speeds at
   the constant speed ``speed``; the robot moves one period (true pose with
   slip, encoders, odometry: models.robot).

Several chains (sim navigate) are tracked one after another: the tracker
moves on to the next chain when the look-ahead point passes the end of the
current one (x_c + Δ >= 1), so it turns into the joint as it turns into a
corner inside a chain; the run ends when the odometric canonical abscissa of
the last chain reaches x_c >= 1 (the end vertex's strip boundary).

Defaults (:class:`TrackerParams`): speed 0.05 m/s, look-ahead 0.03 m,
κ_fs = 80 1/m (a 12.5 mm turn radius at full scale), |κ_p| <= 120 1/m.  With
the Table 1 rule base near the path the output is about y = φ1 / 90°, so the
loop behaves like pure pursuit with κ ≈ (2/π) κ_fs φ1; κ_fs ≈ 2.4 / lookahead
keeps it well damped from 0.05 to 0.5 m/s.  On a curve the output needs a
standing φ1 to hold the curvature, so the error there falls as κ_fs rises
(measured on paths/sine.csv: 7.2 mm at 40 mm / 60 1/m, 4.5 mm at the defaults,
3.2 mm at 25 mm / 100 1/m with twice the curvature activity).

Cross-track error: the distance from a pose to the chain (its segments, not
the end half-lines).  The *approach phase* is the part of a run before the
odometric progress along the path, ``x_c · S``, has advanced ``approach``
metres past its starting value; ``approach`` = 0 when the start is on the path
(within 5 mm and 5 degrees of it), else ``4 d0 + 4 · lookahead`` with d0 the
starting distance (override with ``approach=``).  Max and RMS cross-track
figures are over the samples after the approach phase.
"""

import math
from dataclasses import dataclass

import numpy as np

from .robot import KHEPERA_II, Robot, wheel_speeds
from .swam import Swam

__all__ = ["TrackerParams", "RangeError", "check_range", "check_run", "MAX_PERIODS", "canonical_inputs",
           "wrap_degrees", "ClosedLoop", "distance_to_chain", "fired_rules", "run_model",
           "track_chains", "loop_job", "loop_from_job"]


class RangeError(ValueError):
    """A run parameter out of its range: ``name``, ``value`` and the reason."""

    def __init__(self, name, value, why):
        super().__init__(f"{name} {value:g}: {why}" if isinstance(value, (int, float)) else f"{name} {value}: {why}")
        self.name, self.value, self.why = name, value, why


# The ranges of a run, and why (one place: TrackerParams, ClosedLoop and the commands check with these).
MIN_SPEED = 0.008        # m/s: the Khepera II's speed unit, one 0.08 mm encoder pulse per 10 ms
MAX_SPEED = 1.0          # m/s: the Khepera II's top speed (KHEPERA_II.max_wheel_speed)
MAX_LOOKAHEAD = 1.0      # m: ten times the robot's size; the strip map needs Δ well below the chain length
MAX_SLIP = 0.5           # relative: at s = 0.5 a wheel's ground travel is off by half its own
MAX_SEED = 2 ** 63 - 1   # numpy's generator seeds
# A run logs every period (poses, codes, curvatures: about 1 KB a period in
# Python objects): 2,000,000 periods (7 h of driving at 12.5 ms, 25 km at
# 1 m/s) is about 2 GB, what this class of machine can spend.
MAX_PERIODS = 2_000_000


def check_range(name, value, lo, hi, why, lo_open=False):
    """``value`` if ``lo <= value <= hi`` (``lo_open``: ``lo < value``) and finite, else RangeError."""
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise RangeError(name, value, "must be a finite number")
    if (value <= lo if lo_open else value < lo) or value > hi:
        raise RangeError(name, value, f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}] ({why})")
    return value


def check_run(speed, lookahead, slip=0.0, seed=0):
    """The ranges of a closed-loop run (speed, look-ahead, slip, seed), with reasons."""
    check_range("speed", speed, MIN_SPEED, MAX_SPEED, "m/s: the Khepera II moves in steps of 8 mm/s "
                "(one encoder pulse per 10 ms) up to 1 m/s")
    check_range("lookahead", lookahead, 0.0, MAX_LOOKAHEAD, "m: a look-ahead beyond 1 m is no tracking "
                "of a path", lo_open=True)
    check_range("slip", slip, 0.0, MAX_SLIP, "relative wheel slip: 0.5 is half of every wheel turn lost")
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed <= MAX_SEED:
        raise RangeError("seed", seed, f"must be an integer in 0..{MAX_SEED} (the slip noise generator's seeds)")


@dataclass(frozen=True)
class TrackerParams:
    speed: float = 0.05          # m/s, the constant linear speed v of eq. 13-14
    lookahead: float = 0.03      # m, look-ahead distance along the path (section 4, Fig. 6b)
    kappa_fs: float = 80.0       # 1/m, physical curvature of a full-scale DFLC output
    kappa_limit: float = 120.0   # 1/m, limit on the commanded physical curvature

    def __post_init__(self):
        check_run(self.speed, self.lookahead)
        for name in ("kappa_fs", "kappa_limit"):
            check_range(name, getattr(self, name), 0.0, 1e6, "1/m", lo_open=True)


def wrap_degrees(a):
    """An angle (degrees; scalar or array) wrapped by whole turns into [-180, 180)."""
    return (a + 180.0) % 360.0 - 180.0


def canonical_inputs(qc, delta):
    """φ1, φ2 (degrees, [-180, 180)) of canonical state ``qc`` with canonical look-ahead ``delta``."""
    _, y, th = qc
    phi1 = wrap_degrees(math.degrees(math.atan2(-y, delta) - th))
    phi2 = wrap_degrees(math.degrees(-th))
    return phi1, phi2


def distance_to_chain(points, vertices):
    """Distance of each (x, y) of ``points`` to the polyline ``vertices`` (its segments)."""
    p = np.asarray(points, dtype=float)[:, None, :2]
    a = np.asarray(vertices, dtype=float)[None, :-1, :]
    b = np.asarray(vertices, dtype=float)[None, 1:, :]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / (ab * ab).sum(-1), 0, 1)
    d = p - (a + t[..., None] * ab)
    return np.sqrt((d * d).sum(-1)).min(axis=1)


class ClosedLoop:
    """The tracker of one chain (or a list of chains, tracked one after another) around a robot.

    ``dflc`` is the golden model object of models.dflc (its ``encode`` and
    ``decode`` are used here; the inference itself is the caller's, so the
    same loop runs with the model or the RTL): per period call
    :meth:`inputs` for the input codes, run the DFLC on them, and give its
    output code to :meth:`advance`.
    """

    def __init__(self, chains, dflc, params=TrackerParams(), robot=None, start=None,
                 slip=0.0, seed=0, max_steps=None, approach=None, robot_params=KHEPERA_II):
        if isinstance(chains, Swam):
            chains = [chains]
        self.chains = list(chains)
        self.dflc = dflc
        self.params = params
        first = self.chains[0]
        if start is None:
            start = (*first.vertices[0], first.theta[1])
        self.robot = robot or Robot(start, robot_params, slip=slip, seed=seed)
        self.order = self._input_order(dflc)
        self.index = 0                       # chain being tracked
        self.done = False
        total = sum(c.length for c in self.chains)
        d0 = float(distance_to_chain([start[:2]], first.vertices)[0])
        x0, y0, tc0, _ = first.psi_inv(start)
        heading_err = abs(math.degrees(float(tc0)))
        if approach is None:
            approach = 0.0 if (d0 < 0.005 and heading_err < 5) else 4 * d0 + 4 * params.lookahead
        self.approach = float(approach)
        self.progress0 = float(x0) * first.length
        if len(self.chains) == 1 and float(x0) >= 1.0:
            raise ValueError(f"the start ({start[0]:g}, {start[1]:g}) lies past the end of the path "
                             f"(its projection is {float(x0) * first.length:.3f} m along a {first.length:.3f} m "
                             "chain): nothing to track")
        self.max_steps = max_steps or int(3 * (total + 4 * d0 + 0.5)
                                          / (params.speed * self.robot.params.period)) + 400
        if self.max_steps > MAX_PERIODS:
            raise ValueError(f"the run may need {self.max_steps} control periods of 12.5 ms (a {total:.4g} m "
                             f"path, the start {d0:.3g} m off it, at {params.speed:g} m/s); at most {MAX_PERIODS} "
                             "are run (7 h of driving, about 2 GB of log)")
        self.steps = 0
        self.log = {k: [] for k in ("true", "odometry", "codes", "y_code", "zero", "kappa_p", "phi", "chain",
                                        "approach")}
        self._approaching = self.approach > 0
        self._qc = None

    @staticmethod
    def _input_order(dflc):
        """Positions of (φ1, φ2) in the DFLC's inputs (by name, default: as listed)."""
        names = [n.lower() for n in getattr(dflc, "input_names", ["phi1", "phi2"])]
        if len(names) != 2:
            raise ValueError(f"the tracker needs a 2-input DFLC, this one has inputs {names}")
        for a, b in (("phi1", "phi2"), ("input1", "input2"), ("in1", "in2")):
            if a in names and b in names:
                return names.index(a), names.index(b)
        return 0, 1

    @property
    def chain(self):
        return self.chains[self.index]

    def _canonical(self):
        """Canonical state of the odometric pose; moves on to the next chain when the
        look-ahead point passes the end of this one (x_c + Δ >= 1), ends at x_c >= 1 on the last."""
        while True:
            x, y, th, _ = self.chain.psi_inv(self.robot.pose)
            last = self.index + 1 == len(self.chains)
            end = 1.0 if last else 1.0 - self.params.lookahead / self.chain.length
            if float(x) < end:
                return float(x), float(y), float(th)
            if last:
                self.done = True
                return None
            self.index += 1

    def inputs(self):
        """The DFLC input codes of this period (a row in the DFLC's input order), or None when done."""
        if self.done or self.steps >= self.max_steps:
            return None
        qc = self._canonical()
        if qc is None:
            return None
        self._qc = qc
        delta = self.params.lookahead / self.chain.length
        phi = canonical_inputs(qc, delta)
        self._phi = phi
        row = [0.0, 0.0]
        row[self.order[0]], row[self.order[1]] = phi
        codes = np.asarray(self.dflc.encode(np.array([row])))[0]
        self.log["codes"].append([int(c) for c in codes])
        return codes

    def advance(self, y_code, zero=False):
        """Apply the DFLC's output code: Ω, eq. 14, one robot period."""
        p = self.params
        chain = self.chain
        y = 0.0 if zero else float(np.asarray(self.dflc.decode(np.array([y_code]))).ravel()[0])
        kc = y * p.kappa_fs * chain.length
        kp = float(chain.omega(kc, self._qc))
        kp = max(-p.kappa_limit, min(p.kappa_limit, kp))
        vr, vl = wheel_speeds(p.speed, kp, self.robot.params.axle)
        self.log["odometry"].append(self.robot.pose)
        self.log["true"].append(self.robot.true_pose)
        self.robot.command(vr, vl)
        self.steps += 1
        if self._approaching and (self.index > 0 or self._qc[0] * chain.length - self.progress0 >= self.approach):
            self._approaching = False
        self.log["approach"].append(self._approaching)
        self.log["y_code"].append(int(np.asarray(y_code).ravel()[0]))
        self.log["zero"].append(bool(zero))
        self.log["kappa_p"].append(kp)
        self.log["phi"].append(self._phi)
        self.log["chain"].append(self.index)

    def result(self):
        """Figures of the run (module docstring defines them), metres."""
        true = np.array(self.log["true"] + [self.robot.true_pose])
        odo = np.array(self.log["odometry"] + [self.robot.pose])
        verts = np.vstack([self.chains[0].vertices] + [c.vertices[1:] for c in self.chains[1:]])
        after = ~np.array(self.log["approach"] + [False])
        d_true = distance_to_chain(true, verts)
        d_odo = distance_to_chain(odo, verts)
        sel_t, sel_o = d_true[after], d_odo[after]
        return {
            "reached_end": bool(self.done),
            "steps": self.steps,
            "approach_m": self.approach,
            "approach_steps": int(sum(self.log["approach"])),
            "samples_after_approach": int(after.sum()),
            "max_cross_track": float(sel_t.max()) if len(sel_t) else None,
            "rms_cross_track": float(np.sqrt((sel_t ** 2).mean())) if len(sel_t) else None,
            "odometry_max_cross_track": float(sel_o.max()) if len(sel_o) else None,
            "odometry_rms_cross_track": float(np.sqrt((sel_o ** 2).mean())) if len(sel_o) else None,
            "final_true_pose": [float(v) for v in self.robot.true_pose],
            "final_odometry": [float(v) for v in self.robot.pose],
            "curvature_codes": list(self.log["y_code"]),
            "input_codes": list(self.log["codes"][:self.steps]),
            "curvature": [float(k) for k in self.log["kappa_p"]],
            "pose": true.tolist(),
            "odometry": odo.tolist(),
        }


def fired_rules(dflc, input_codes):
    """Indices of the rules that fired (weight > 0) on any of ``input_codes`` (section 4's rule reduction)."""
    if not len(input_codes):
        return set()
    rule, w, _, _ = dflc.combos(np.asarray(input_codes, dtype=np.int64))
    return {int(r) for r in np.unique(rule[w > 0])}


def run_model(loop, memo=None, progress=None):
    """Run ``loop`` to its end with the DFLC golden model (``dflc.infer``); returns ``loop.result()``.

    ``memo`` (a dict, shared between runs with the same DFLC if given) caches
    the model's answer per input-code pair: the DFLC is a pure function of its
    input codes, so this only saves time.  ``progress(steps, max_steps)``:
    called every 1000 periods.
    """
    memo = {} if memo is None else memo
    while True:
        codes = loop.inputs()
        if codes is None:
            return loop.result()
        if progress is not None and loop.steps % 1000 == 0:
            progress(loop.steps, loop.max_steps)
        key = tuple(int(c) for c in codes)
        if key not in memo:
            y, zero = loop.dflc.infer(np.array([key]))
            memo[key] = (int(np.asarray(y).ravel()[0]), bool(np.asarray(zero).ravel()[0]))
        loop.advance(*memo[key])


def track_chains(chains, dflc, **kw):
    """Build a :class:`ClosedLoop` over ``chains`` and run it with the golden model."""
    return run_model(ClosedLoop(chains, dflc, **kw))


def loop_job(chains, params, start, slip, seed, approach=None):
    """Everything that defines a closed-loop run, as JSON-able data (the job an
    RTL run of the loop reads inside the simulator: sim/rtl/track_job.py)."""
    return {
        "chains": [{"vertices": c.vertices.tolist(), "theta_s": c.theta_s} for c in chains],
        "params": {"speed": params.speed, "lookahead": params.lookahead,
                   "kappa_fs": params.kappa_fs, "kappa_limit": params.kappa_limit},
        "start": list(start) if start is not None else None,
        "slip": slip, "seed": seed, "approach": approach,
    }


def loop_from_job(job, dflc):
    """The :class:`ClosedLoop` a :func:`loop_job` describes (used on both sides of the RTL run)."""
    chains = [Swam(c["vertices"], theta_s=c["theta_s"]) for c in job["chains"]]
    return ClosedLoop(chains, dflc, params=TrackerParams(**job["params"]),
                      start=tuple(job["start"]) if job["start"] is not None else None,
                      slip=job["slip"], seed=job["seed"], approach=job["approach"])
