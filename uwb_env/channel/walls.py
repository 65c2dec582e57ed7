"""Wall obstruction: loss and excess delay counted per wall crossed on each leg (seed 002 section II-D).

Seed 002 eq. 6 counts the walls on the radar-to-target-to-radar path (the factor 2 there is the double pass of a
monostatic radar); for a bistatic pair we count the crossings of the transmitter-target leg and of the
target-receiver leg separately and add them, which reduces to the seed's factor 2 when Tx = Rx.
"""

from __future__ import annotations

import numpy as np

from uwb_env.scene.geometry import segments_cross
from uwb_env.typing import BoolArray, FloatArray


def leg_crossings(nodes: FloatArray, targets: FloatArray, wall_a: FloatArray, wall_b: FloatArray) -> BoolArray:
    """Which walls each node-target leg crosses, ``(N, K, W)`` for nodes (N, 2), targets (K, 2), walls (W, 2)."""
    n, k = nodes.shape[0], targets.shape[0]
    p0 = np.broadcast_to(nodes[:, None], (n, k, 2)).reshape(-1, 2)
    p1 = np.broadcast_to(targets[None], (n, k, 2)).reshape(-1, 2)
    return segments_cross(p0, p1, wall_a, wall_b).reshape(n, k, -1)


def leg_obstruction(crossings: BoolArray, loss_db: FloatArray, delay_s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Sum loss [dB] (inf if an opaque wall is crossed) and excess delay [s] over the crossed walls.

    Args: crossings (..., W) bool; loss_db (W,) (inf = opaque); delay_s (W,).
    Returns: loss (...,) [dB], delay (...,) [s].
    """
    opaque = np.isinf(loss_db)
    finite_loss = np.where(opaque, 0.0, loss_db)
    c = crossings.astype(float)
    loss = c @ finite_loss
    if opaque.any():
        loss = np.where((crossings & opaque).any(axis=-1), np.inf, loss)
    return loss, c @ delay_s


def pair_obstruction(
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    tgt_pos: FloatArray,
    wall_a: FloatArray,
    wall_b: FloatArray,
    loss_db: FloatArray,
    delay_s: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Two-leg obstruction of every (tx, rx, target): loss ``(T, R, K)`` [dB] and excess delay ``(T, R, K)`` [s]."""
    if wall_a.shape[0] == 0:
        shape = (tx_pos.shape[0], rx_pos.shape[0], tgt_pos.shape[0])
        return np.zeros(shape), np.zeros(shape)
    lt_loss, lt_delay = leg_obstruction(leg_crossings(tx_pos, tgt_pos, wall_a, wall_b), loss_db, delay_s)
    lr_loss, lr_delay = leg_obstruction(leg_crossings(rx_pos, tgt_pos, wall_a, wall_b), loss_db, delay_s)
    return lt_loss[:, None, :] + lr_loss[None, :, :], lt_delay[:, None, :] + lr_delay[None, :, :]


def line_of_sight(p0: FloatArray, p1: FloatArray, wall_a: FloatArray, wall_b: FloatArray) -> BoolArray:
    """Whether each segment ``p0[i] -> p1[i]`` (N, 2) crosses no wall, ``(N,)``."""
    if wall_a.shape[0] == 0:
        return np.ones(p0.shape[0], dtype=bool)
    return ~segments_cross(p0, p1, wall_a, wall_b).any(axis=1)
