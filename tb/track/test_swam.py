"""The strip-wise affine map (paper 003, section 3) against its own definitions.

* Φ(Φ⁻¹(w)) = w and Φ⁻¹(Φ(z)) = z to 1e-9 (relative to the chain's size) on
  random points of random strictly monotone chains, default and random valid
  shifting angles, points in every strip including the two end half-lines.
* Ψ⁻¹(Ψ(q)) = q for the heading too.
* The canonical segment y = 0, x in [0, 1] maps onto the chain: vertex i at
  a_i (eq. 21), points in between on their edge.
* The transformed dynamics (eq. 31) and the feedback-equivalent Dubins car
  (eq. 32, through Ω) agree with the physical ones: canonical states of a
  physical Dubins-car trajectory (exact circular arcs) are differentiated by
  central differences and compared with the right-hand sides.
* Refusals: a chain that is not strictly monotone, a shifting angle along an
  edge, zero-length edges, too few vertices.
"""

import math

import numpy as np
import pytest

from navcores.models.swam import Swam, SwamError
from navcores.sim.rtl.runner import seed_from_env


def random_chain(rng, n=None, spread=None):
    """A random strictly monotone chain: edge angles in an arc narrower than 180 degrees."""
    n = n or int(rng.integers(2, 12))
    spread = rng.uniform(0, math.radians(170)) if spread is None else spread
    mean = rng.uniform(-math.pi, math.pi)
    angles = mean + rng.uniform(-spread / 2, spread / 2, n - 1)
    lengths = rng.uniform(0.05, 1.0, n - 1)
    steps = np.stack([lengths * np.cos(angles), lengths * np.sin(angles)], axis=1)
    start = rng.uniform(-2, 2, 2)
    return np.vstack([start, start + np.cumsum(steps, axis=0)])


def random_swam(rng):
    w = random_chain(rng)
    m = Swam(w)
    if rng.random() < 0.5:
        # any other valid shifting angle: a random one kept only if invertible
        for _ in range(50):
            ts = rng.uniform(-math.pi, math.pi)
            try:
                return Swam(w, theta_s=ts)
            except SwamError:
                continue
    return m


def test_round_trip():
    seed = seed_from_env()
    print(f"seed {seed}")
    rng = np.random.default_rng(seed)
    checked = strips_seen = 0
    for _ in range(200):
        m = random_swam(rng)
        span = np.ptp(m.vertices, axis=0).max() + 1
        # physical points around the chain (also beyond both ends)
        lo, hi = m.vertices.min(axis=0) - span, m.vertices.max(axis=0) + span
        u, v = rng.uniform(lo[0], hi[0], 50), rng.uniform(lo[1], hi[1], 50)
        x, y = m.phi_inv(u, v)
        uu, vv = m.phi(x, y)
        scale = max(1.0, np.abs(m.vertices).max(), span)
        assert np.abs(uu - u).max() < 1e-9 * scale and np.abs(vv - v).max() < 1e-9 * scale
        # canonical points, every strip
        x = rng.uniform(-0.5, 1.5, 50)
        y = rng.uniform(-1, 1, 50)
        xx, yy = m.phi_inv(*m.phi(x, y))
        assert np.abs(xx - x).max() < 1e-9 and np.abs(yy - y).max() < 1e-9
        strips_seen |= sum(1 << int(k) for k in set(m.strip_of_x(x)) if k in (0, m.n))
        # heading too
        tc = rng.uniform(-math.pi, math.pi, 50)
        _, _, tc2, _ = m.psi_inv(m.psi((x, y, tc)))
        assert np.abs(np.angle(np.exp(1j * (tc2 - tc)))).max() < 1e-9
        checked += 150
    assert checked == 200 * 150
    assert strips_seen & 1, "no point fell in the strip before the first vertex"


def test_canonical_path_is_the_chain():
    rng = np.random.default_rng(seed_from_env() + 1)
    edges = 0
    for _ in range(50):
        m = random_swam(rng)
        u, v = m.phi(m.a, np.zeros(m.n))
        assert np.allclose(np.stack([u, v], axis=1), m.vertices, atol=1e-12)
        x, y = m.phi_inv(m.vertices[:, 0], m.vertices[:, 1])
        assert np.allclose(x, m.a, atol=1e-9) and np.allclose(y, 0, atol=1e-9)
        for i in range(m.n - 1):
            t = rng.uniform(0, 1, 5)
            u, v = m.phi(m.a[i] + t * (m.a[i + 1] - m.a[i]), np.zeros(5))
            expect = m.vertices[i] + t[:, None] * (m.vertices[i + 1] - m.vertices[i])
            assert np.allclose(np.stack([u, v], axis=1), expect, atol=1e-12)
            edges += 1
    assert edges > 100


def test_dynamics_by_finite_differences():
    """Eq. 31 and 32 against central differences of Ψ⁻¹ along physical arcs."""
    rng = np.random.default_rng(seed_from_env() + 2)
    h = 1e-6
    compared = 0
    for _ in range(100):
        m = random_swam(rng)
        for _ in range(10):
            # a physical Dubins-car arc: speed v, curvature kappa, through a random point
            v = rng.uniform(0.01, 0.5)
            kappa = rng.uniform(-5, 5)
            x0 = rng.uniform(-0.2, 1.2)
            p0 = m.psi((x0, rng.uniform(-0.3, 0.3), rng.uniform(-math.pi, math.pi)))
            x_p, y_p, th = (float(c) for c in p0)

            def pose(t):
                if abs(kappa) < 1e-12:
                    return x_p + v * t * math.cos(th), y_p + v * t * math.sin(th), th
                a = th + kappa * v * t
                return (x_p + (math.sin(a) - math.sin(th)) / kappa,
                        y_p - (math.cos(a) - math.cos(th)) / kappa, a)

            q = [m.psi_inv(pose(t)) for t in (-h, 0.0, h)]
            if len({int(k) for *_, k in q}) != 1:
                continue            # the arc crosses a strip boundary: θ_c jumps there
            xc, yc, tc, k = (float(c) for c in q[1])
            dx = (q[2][0] - q[0][0]) / (2 * h)
            dy = (q[2][1] - q[0][1]) / (2 * h)
            dth = np.angle(np.exp(1j * (q[2][2] - q[0][2]))) / (2 * h)
            vc = float(m.speed_c(v, (xc, yc, tc)))
            g = float(m.gamma(tc, int(k)))
            J = m.jacobian[int(k)]
            scale = max(1.0, abs(vc))
            assert abs(dx - vc * math.cos(tc)) < 1e-5 * scale                        # eq. 31, row 1
            assert abs(dy - vc * math.sin(tc)) < 1e-5 * scale                        # row 2
            rhs = m.length ** 3 * g ** 3 / J * vc * kappa                            # row 3
            assert abs(dth - rhs) < 1e-5 * max(1.0, abs(rhs))
            kc = float(m.omega_inv(kappa, (xc, yc, tc)))                             # eq. 32
            assert abs(dth - vc * kc) < 1e-5 * max(1.0, abs(rhs))
            assert abs(float(m.omega(kc, (xc, yc, tc))) - kappa) < 1e-9 * max(1.0, abs(kappa))
            compared += 1
    assert compared > 500


def test_refusals():
    with pytest.raises(SwamError, match="not strictly monotone: its edge directions span 180.0"):
        Swam([(0, 0), (1, 0), (1, 1), (0, 1)])           # a U turn
    with pytest.raises(SwamError, match="not strictly monotone: its edge directions span"):
        Swam([(0, 0), (1, 0), (1, 1), (0, 0.8)])      # 0, 90, 191 degrees
    with pytest.raises(SwamError, match="shifting angle 0.000 deg lies along edge 0"):
        Swam([(0, 0), (1, 0), (2, 1)], theta_s=0.0)
    with pytest.raises(SwamError, match="shifting angle 180.000 deg lies along edge 0|shifting angle -180.000 deg"):
        Swam([(0, 0), (1, 0), (2, 1)], theta_s=math.pi)
    with pytest.raises(SwamError, match="not strictly monotone along the axis normal"):
        Swam([(0, 0), (1, 0), (2, 1)], theta_s=math.radians(20))
    with pytest.raises(SwamError, match="edge 1 of the chain has zero length"):
        Swam([(0, 0), (1, 0), (1, 0), (2, 0)])
    with pytest.raises(SwamError, match="at least 2 vertices"):
        Swam([(0, 0)])
    # valid: a straight line and a 170-degree fan are accepted; J > 0 by default
    assert (Swam([(0, 0), (1, 0)]).jacobian > 0).all()
    fan = Swam([(0, 0), (1, 0), (1 + math.cos(math.radians(170)), math.sin(math.radians(170)))])
    assert (fan.jacobian > 0).all()
