r"""Measurement models of the tracker: bistatic range, bistatic range-rate, azimuth, 2-D position.

Every component maps states ``x (..., 6)`` = ``[x, vx, y, vy, ax, ay]`` to one scalar per state and has an
analytic Jacobian ``(..., 6)`` (tested against finite differences). A pair's measurement is the stack of the
components named in its ``Detections.measurement_names``.

    bistatic_range  h = |p - tx| + |p - rx|
    range_rate      h = v . (u_t + u_r),  u = (p - node) / |p - node|
                    dh/dp = (I - u_t u_t^T) v / |p - tx| + (I - u_r u_r^T) v / |p - rx|,  dh/dv = u_t + u_r
    azimuth         h = atan2(py - rx_y, px - rx_x), dh/dp = (-dy, dx) / |p - rx|^2 (angles: innovations wrap)
    x, y            position components (fused position measurements)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from uwb_env.typing import FloatArray


class _Legs:
    """Node-to-target vectors and distances of states ``x (..., 6)``, computed once per ``measure`` call."""

    __slots__ = ("dr", "dt", "lr", "lt", "x")

    def __init__(self, x: FloatArray, tx: FloatArray, rx: FloatArray) -> None:
        self.x = x
        px, py = x[..., 0], x[..., 2]
        self.dt = (px - tx[0], py - tx[1])
        self.dr = (px - rx[0], py - rx[1])
        self.lt = np.maximum(np.sqrt(self.dt[0] ** 2 + self.dt[1] ** 2), 1e-9)
        self.lr = np.maximum(np.sqrt(self.dr[0] ** 2 + self.dr[1] ** 2), 1e-9)


Component = Callable[[_Legs, FloatArray], FloatArray]


def _range(g: _Legs, jac: FloatArray) -> FloatArray:
    jac[..., 0] = g.dt[0] / g.lt + g.dr[0] / g.lr
    jac[..., 2] = g.dt[1] / g.lt + g.dr[1] / g.lr
    return g.lt + g.lr


def _range_rate(g: _Legs, jac: FloatArray) -> FloatArray:
    vx, vy = g.x[..., 1], g.x[..., 3]
    h = np.zeros(g.x.shape[:-1])
    for (dx, dy), n in ((g.dt, g.lt), (g.dr, g.lr)):  # the two legs
        ux, uy = dx / n, dy / n
        uv = ux * vx + uy * vy
        h = h + uv
        jac[..., 0] += (vx - ux * uv) / n  # (I - u u^T) v / |d|
        jac[..., 2] += (vy - uy * uv) / n
        jac[..., 1] += ux
        jac[..., 3] += uy
    return h


def _azimuth(g: _Legs, jac: FloatArray) -> FloatArray:
    dx, dy = g.dr
    n2 = g.lr**2
    jac[..., 0] = -dy / n2
    jac[..., 2] = dx / n2
    return np.arctan2(dy, dx)


def _position(axis: int) -> Component:
    def comp(g: _Legs, jac: FloatArray) -> FloatArray:
        jac[..., 2 * axis] = 1.0
        return g.x[..., 2 * axis].copy()

    return comp


COMPONENTS: dict[str, Component] = {
    "bistatic_range": _range,
    "range_rate": _range_rate,
    "azimuth": _azimuth,
    "x": _position(0),
    "y": _position(1),
}
ANGULAR = frozenset({"azimuth"})


def measure(names: tuple[str, ...], x: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Stacked measurement ``(..., m)`` and Jacobian ``(..., m, 6)`` of the named components at states ``x``.

    Args:
        names: component names (keys of :data:`COMPONENTS`); x: ``(..., 6)``; tx, rx: ``(2,)`` node positions [m].
    """
    unknown = [n for n in names if n not in COMPONENTS]
    if unknown:
        raise ValueError(f"measurement name {unknown[0]!r}: must be one of {sorted(COMPONENTS)}")
    legs = _Legs(x, tx, rx)
    z = np.empty((*x.shape[:-1], len(names)))
    jac = np.zeros((*x.shape[:-1], len(names), 6))
    for i, n in enumerate(names):  # m <= 3 components
        z[..., i] = COMPONENTS[n](legs, jac[..., i, :])
    return z, jac


def angular_mask(names: tuple[str, ...]) -> np.ndarray:
    """``(m,)`` True for components whose differences wrap to (-pi, pi]."""
    return np.array([n in ANGULAR for n in names])


def wrap_residual(nu: FloatArray, angular: np.ndarray) -> FloatArray:
    """Wrap the angular components of residuals ``(..., m)`` to [-pi, pi)."""
    if not angular.any():
        return nu
    out = nu.copy()
    out[..., angular] = (out[..., angular] + np.pi) % (2.0 * np.pi) - np.pi
    return out
