"""Strip-wise affine map (SWAM) of a strictly monotone polygonal chain (paper 003, section 3).

Conventions (0-based where the paper is 1-based)
-----------------------------------------------
* The chain: vertices ``w[0..n-1]`` (n >= 2) in the physical plane (metres),
  edges ``w[i] -> w[i+1]``, total length S (eq. 21).  Vertex i maps to
  ``a[i]`` on the canonical real axis: ``a[0] = 0``, ``a[n-1] = 1`` (eq. 21).
* Strips j = 0..n: strip 0 is the half-line before ``w[0]`` (the paper's
  θ_-∞ edge), strip j = 1..n-1 is edge j-1, strip n the half-line after
  ``w[n-1]`` (θ_+∞).  Strip j has an anchor vertex ``anchor[j]``, its canonical
  start ``a_strip[j]`` and edge angle ``theta[j]``.  The end edges continue
  the first and the last edge (θ_-∞ = θ_0, θ_+∞ = θ_{n-2}) unless given.
  In x, strip j covers ``[a_strip[j], a_strip[j+1])`` (eq. 23: closed on the
  left).
* Φ (eq. 26-27): ``w = y S e^{jθ_s} + anchor + S (x - a_strip) e^{jθ_strip}``.
  As a map R² -> R² in one strip it is affine with matrix
  ``M = S [[cos θ_k, cos θ_s], [sin θ_k, sin θ_s]]``, determinant
  ``J = S² sin(θ_s - θ_k)`` (the paper's Jacobian).
* Φ⁻¹ (eq. 28-29): the strip is found by a binary search (``np.searchsorted``)
  of the point's projection ``b_c`` on the axis normal to θ_s among the
  vertices' projections ``b[i]`` (the paper's point-in-strip test), then eq. 28
  with that strip's C, D, J and A⁻¹.
* Ψ (eq. 30): the heading maps as the direction of ``M (cos θ_c, sin θ_c)``,
  i.e. ``θ_p = atan2(sin θ_k cos θ_c + sin θ_s sin θ_c, cos θ_k cos θ_c +
  cos θ_s sin θ_c)``: eq. 30's tan⁻¹ with the quadrant kept.  Speeds scale by
  ``S γ``, ``γ = sqrt(1 + sin 2θ_c cos(θ_s - θ_k))`` (eq. 31).
* Ω (section 3): ``κ_p = S⁻³ J γ⁻³ κ_c``, the curvature of a curve under the
  linear map M (sign included: a negative J reverses orientation).

Invertibility (section 3, Moustris & Tzafestas 2008): the chain must be
strictly monotone along the axis normal to θ_s, i.e. every edge (and the two
end half-lines) must cross the θ_s direction on the same side:
``sin(θ_s - θ_k)`` non-zero with one sign for all k.  A chain whose edge
directions do not fit in an open half-turn admits no such θ_s and is refused;
so is a θ_s along (or opposite to) an edge.  Without a given θ_s the map takes
the normal of the bisector of the edges' angular range, the choice farthest
from every edge, with ``J > 0`` (canonical +y is the left of the path).
"""

import math

import numpy as np

__all__ = ["SwamError", "Swam", "monotone_direction"]

ANGLE_TOL = 1e-9          # |sin(θ_s - θ_k)| below this counts as "along an edge"


class SwamError(ValueError):
    """A chain or shifting angle for which the SWAM would not be invertible."""


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def monotone_direction(angles):
    """Bisector and width (radians) of the smallest arc holding every angle.

    The chain is strictly monotone in some direction iff the width is < π.
    """
    t = np.sort(np.mod(np.asarray(angles, dtype=float), 2 * np.pi))
    gaps = np.diff(np.concatenate([t, [t[0] + 2 * np.pi]]))
    i = int(np.argmax(gaps))
    width = 2 * np.pi - gaps[i]
    start = t[(i + 1) % len(t)]             # the arc starts after the largest gap
    return float(_wrap(start + width / 2)), float(width)


class Swam:
    """The SWAM of ``vertices`` (n x 2, metres) with shifting angle ``theta_s`` (radians)."""

    def __init__(self, vertices, theta_s=None, theta_start=None, theta_end=None):
        w = np.asarray(vertices, dtype=float)
        if w.ndim != 2 or w.shape[1] != 2 or len(w) < 2:
            raise SwamError(f"a chain needs at least 2 vertices as (x, y) rows, got shape {w.shape}")
        if not np.isfinite(w).all():
            raise SwamError("chain vertices must be finite numbers")
        d = np.diff(w, axis=0)
        seg = np.hypot(d[:, 0], d[:, 1])
        if (seg <= 1e-12 * max(1.0, np.abs(w).max())).any():
            k = int(np.argmax(seg <= 1e-12 * max(1.0, np.abs(w).max())))
            raise SwamError(f"edge {k} of the chain has zero length (vertices {k} and {k + 1} coincide)")
        edge = np.arctan2(d[:, 1], d[:, 0])
        self.vertices = w
        self.n = len(w)
        self.length = float(seg.sum())                              # S
        self.a = np.concatenate([[0.0], np.cumsum(seg) / self.length])   # eq. 21
        self.a[-1] = 1.0
        t0 = edge[0] if theta_start is None else float(theta_start)
        t1 = edge[-1] if theta_end is None else float(theta_end)
        self.theta = np.concatenate([[t0], edge, [t1]])            # strip angles, n + 1
        self.anchor = np.vstack([w[:1], w[:-1], w[-1:]])            # strip anchors
        self.a_strip = np.concatenate([[0.0], self.a[:-1], [1.0]])
        mid, width = monotone_direction(self.theta)
        if theta_s is None:
            if width >= np.pi - ANGLE_TOL:
                raise SwamError(
                    f"the chain is not strictly monotone: its edge directions span "
                    f"{math.degrees(width):.1f} degrees (they must fit in less than 180)")
            theta_s = mid + np.pi / 2
        self.theta_s = float(_wrap(theta_s))
        s = np.sin(self.theta_s - self.theta)
        k = 1 + int(np.argmin(np.abs(s[1:-1])))          # name a real edge when one is at fault
        if abs(s[k]) >= ANGLE_TOL:
            k = int(np.argmin(np.abs(s)))
        if abs(s[k]) < ANGLE_TOL:
            raise SwamError(
                f"shifting angle {math.degrees(self.theta_s):.3f} deg lies along "
                f"{self._strip_name(k)} ({math.degrees(self.theta[k]):.3f} deg): the map would not be invertible")
        if not ((s > 0).all() or (s < 0).all()):
            bad = int(np.argmax(np.sign(s) != np.sign(s[0])))
            raise SwamError(
                f"the chain is not strictly monotone along the axis normal to the shifting angle "
                f"{math.degrees(self.theta_s):.3f} deg ({self._strip_name(bad)} crosses it the other "
                f"way from {self._strip_name(0)}): the map would not be invertible")
        self.orientation = 1 if s[0] > 0 else -1
        self.normal = np.array([math.sin(self.theta_s), -math.cos(self.theta_s)])
        self.b = (w - w[0]) @ self.normal * self.orientation          # strictly increasing
        self.jacobian = self.length ** 2 * s                         # J per strip

    def _strip_name(self, j):
        if j == 0:
            return "the half-line before the first vertex"
        if j == self.n:
            return "the half-line after the last vertex"
        return f"edge {j - 1}"

    # -- strips --------------------------------------------------------------------
    def strip_of_x(self, x):
        """Strip index (0..n) of canonical abscissae ``x`` (eq. 23)."""
        return np.searchsorted(self.a, x, side="right")

    def strip_of_w(self, u, v):
        """Strip index (0..n) of physical points: binary search of their normal projection."""
        bc = ((np.asarray(u) - self.vertices[0, 0]) * self.normal[0]
              + (np.asarray(v) - self.vertices[0, 1]) * self.normal[1]) * self.orientation
        return np.searchsorted(self.b, bc, side="right")

    # -- Φ, Φ⁻¹ ---------------------------------------------------------------------
    def phi(self, x, y):
        """Eq. 27: physical ``(u, v)`` of canonical ``(x, y)`` (arrays or scalars)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        k = self.strip_of_x(x)
        S, th = self.length, self.theta[k]
        dx = S * (x - self.a_strip[k])
        u = self.anchor[k, 0] + dx * np.cos(th) + y * S * math.cos(self.theta_s)
        v = self.anchor[k, 1] + dx * np.sin(th) + y * S * math.sin(self.theta_s)
        return u, v

    def phi_inv(self, u, v):
        """Eq. 28-29: canonical ``(x, y)`` of physical ``(u, v)``."""
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        k = self.strip_of_w(u, v)
        S, th, ts = self.length, self.theta[k], self.theta_s
        wr, wi = self.anchor[k, 0], self.anchor[k, 1]
        J = self.jacobian[k]
        C = S * (wr * math.sin(ts) - wi * math.cos(ts))
        D = S * (wr * np.sin(th) - wi * np.cos(th))
        den = S * np.sin(ts - th)                                    # eq. 29's divisor
        ax = (math.sin(ts) * u - math.cos(ts) * v) / den             # A⁻¹ [u v]ᵀ
        ay = (-np.sin(th) * u + np.cos(th) * v) / den
        return ax - (C / J - self.a_strip[k]), ay + D / J            # eq. 28

    # -- Ψ, Ω ---------------------------------------------------------------------
    def gamma(self, theta_c, k):
        """γ of eq. 31 in strip ``k``."""
        return np.sqrt(1 + np.sin(2 * theta_c) * np.cos(self.theta_s - self.theta[k]))

    def psi(self, qc):
        """Eq. 30: physical state ``(x_p, y_p, θ_p)`` of canonical ``(x_c, y_c, θ_c)``."""
        x, y, tc = (np.asarray(q, dtype=float) for q in qc)
        k = self.strip_of_x(x)
        u, v = self.phi(x, y)
        th, ts = self.theta[k], self.theta_s
        tp = np.arctan2(np.sin(th) * np.cos(tc) + math.sin(ts) * np.sin(tc),
                        np.cos(th) * np.cos(tc) + math.cos(ts) * np.sin(tc))
        return u, v, tp

    def psi_inv(self, qp):
        """Ψ⁻¹: canonical state of physical ``(x_p, y_p, θ_p)``; also returns the strip."""
        u, v, tp = (np.asarray(q, dtype=float) for q in qp)
        x, y = self.phi_inv(u, v)
        k = self.strip_of_x(x)
        th, ts = self.theta[k], self.theta_s
        # direction M⁻¹ (cos θ_p, sin θ_p); the sign of J keeps the orientation
        cx = (math.sin(ts) * np.cos(tp) - math.cos(ts) * np.sin(tp)) / np.sin(ts - th)
        cy = (-np.sin(th) * np.cos(tp) + np.cos(th) * np.sin(tp)) / np.sin(ts - th)
        return x, y, np.arctan2(cy, cx), k

    def omega(self, kappa_c, qc):
        """Ω: physical curvature ``κ_p = S⁻³ J γ⁻³ κ_c`` at canonical state ``qc``."""
        x, _, tc = qc
        k = self.strip_of_x(np.asarray(x, dtype=float))
        return kappa_c * self.jacobian[k] / (self.length ** 3 * self.gamma(tc, k) ** 3)

    def omega_inv(self, kappa_p, qc):
        """Ω⁻¹: canonical curvature of physical ``κ_p`` at canonical state ``qc``."""
        x, _, tc = qc
        k = self.strip_of_x(np.asarray(x, dtype=float))
        return kappa_p * self.length ** 3 * self.gamma(tc, k) ** 3 / self.jacobian[k]

    def speed_c(self, v_p, qc):
        """Canonical speed of physical speed ``v_p``: ``v_c = v_p / (S γ)``."""
        x, _, tc = qc
        k = self.strip_of_x(np.asarray(x, dtype=float))
        return v_p / (self.length * self.gamma(tc, k))
