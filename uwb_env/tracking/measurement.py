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

Component = Callable[[FloatArray, FloatArray, FloatArray], tuple[FloatArray, FloatArray]]


def _legs(x: FloatArray, node: FloatArray) -> tuple[FloatArray, FloatArray]:
    d = np.stack([x[..., 0] - node[0], x[..., 2] - node[1]], axis=-1)
    return d, np.maximum(np.linalg.norm(d, axis=-1), 1e-9)


def _range(x: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
    dt, lt = _legs(x, tx)
    dr, lr = _legs(x, rx)
    g = dt / lt[..., None] + dr / lr[..., None]
    jac = np.zeros((*x.shape[:-1], 6))
    jac[..., 0], jac[..., 2] = g[..., 0], g[..., 1]
    return lt + lr, jac


def _range_rate(x: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
    v = np.stack([x[..., 1], x[..., 3]], axis=-1)
    jac = np.zeros((*x.shape[:-1], 6))
    h = np.zeros(x.shape[:-1])
    for node in (tx, rx):  # the two legs
        d, n = _legs(x, node)
        u = d / n[..., None]
        uv = np.sum(u * v, axis=-1)
        h = h + uv
        dp = (v - u * uv[..., None]) / n[..., None]  # (I - u u^T) v / |d|
        jac[..., 0] += dp[..., 0]
        jac[..., 2] += dp[..., 1]
        jac[..., 1] += u[..., 0]
        jac[..., 3] += u[..., 1]
    return h, jac


def _azimuth(x: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
    d, n = _legs(x, rx)
    jac = np.zeros((*x.shape[:-1], 6))
    jac[..., 0] = -d[..., 1] / n**2
    jac[..., 2] = d[..., 0] / n**2
    return np.arctan2(d[..., 1], d[..., 0]), jac


def _position(axis: int) -> Component:
    def comp(x: FloatArray, tx: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
        jac = np.zeros((*x.shape[:-1], 6))
        jac[..., 2 * axis] = 1.0
        return x[..., 2 * axis].copy(), jac

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
    try:
        parts = [COMPONENTS[n](x, tx, rx) for n in names]  # m <= 3 components
    except KeyError as err:
        raise ValueError(f"measurement name {err.args[0]!r}: must be one of {sorted(COMPONENTS)}") from None
    return np.stack([p[0] for p in parts], axis=-1), np.stack([p[1] for p in parts], axis=-2)


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
