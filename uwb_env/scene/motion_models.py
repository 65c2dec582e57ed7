"""Target motion models on the 6-D state ``[x, vx, y, vy, ax, ay]`` (seed 003 section 3.3).

Each model returns the transition ``F`` (6, 6) and the process-noise gain ``G`` (6, 2) so that
``x_{k+1} = F x_k + G w_k``, ``w_k ~ N(0, sigma_w^2 I_2)``, hence ``Q = sigma_w^2 G G^T`` (seed 003: Q = diag(
sigma_wx^2 Q', sigma_wy^2 Q'), Q' = G G^T). These are the seed's discrete white-noise-acceleration forms, exact for
a piecewise-constant acceleration over each period T:

* NCV: velocity integrates, acceleration rows are zero (the seed zeroes them).
* CT (known turn rate omega, positive = left / counter-clockwise): the seed's F, velocity rotates by omega T.
* NCA (Wiener-sequence acceleration): acceleration is a random walk; G has the identity on the acceleration rows.

The tracker uses the same matrices (``uwb_env.tracking`` re-exports them), so truth and filter agree by
construction when the model matches.
"""

from __future__ import annotations

import numpy as np

from uwb_env.typing import FloatArray

STATE_DIM = 6
POSITION_INDEX = (0, 2)
VELOCITY_INDEX = (1, 3)
ACCELERATION_INDEX = (4, 5)


def _g_velocity(T: float) -> FloatArray:
    G = np.zeros((6, 2))
    G[0, 0] = G[2, 1] = 0.5 * T * T
    G[1, 0] = G[3, 1] = T
    return G


def ncv_transition(T: float) -> tuple[FloatArray, FloatArray]:
    """Nearly-constant-velocity ``(F, G)`` for period ``T`` [s] (seed 003 eq. 4)."""
    F = np.zeros((6, 6))
    F[0, 0] = F[1, 1] = F[2, 2] = F[3, 3] = 1.0
    F[0, 1] = F[2, 3] = T
    return F, _g_velocity(T)


def ct_transition(T: float, omega: float) -> tuple[FloatArray, FloatArray]:
    """Coordinated turn with known rate ``omega`` [rad/s] (positive = left), period ``T`` [s] (seed 003)."""
    if omega == 0.0:
        return ncv_transition(T)
    s, c = np.sin(omega * T), np.cos(omega * T)
    F = np.zeros((6, 6))
    F[0, 0] = F[2, 2] = 1.0
    F[0, 1], F[0, 3] = s / omega, -(1.0 - c) / omega
    F[1, 1], F[1, 3] = c, -s
    F[2, 1], F[2, 3] = (1.0 - c) / omega, s / omega
    F[3, 1], F[3, 3] = s, c
    return F, _g_velocity(T)


def nca_transition(T: float) -> tuple[FloatArray, FloatArray]:
    """Wiener-sequence acceleration (nearly constant acceleration) ``(F, G)`` for period ``T`` [s] (seed 003)."""
    F = np.eye(6)
    F[0, 1] = F[2, 3] = T
    F[0, 4] = F[2, 5] = 0.5 * T * T
    F[1, 4] = F[3, 5] = T
    G = _g_velocity(T)
    G[4, 0] = G[5, 1] = 1.0
    return F, G


def process_noise(G: FloatArray, sigma_w: float) -> FloatArray:
    """``Q = sigma_w^2 G G^T`` (6, 6)."""
    return sigma_w**2 * (G @ G.T)


def model_transition(model: str, T: float, turn_rate_rps: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """``(F, G)`` of a named model: ``ncv``, ``ct`` (with ``turn_rate_rps``) or ``nca``."""
    factories = {
        "ncv": lambda: ncv_transition(T),
        "ct": lambda: ct_transition(T, turn_rate_rps),
        "nca": lambda: nca_transition(T),
    }
    if model not in factories:
        raise ValueError(f"model = {model!r}: must be one of {sorted(factories)}")
    return factories[model]()
