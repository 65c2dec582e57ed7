r"""IMM and variable-structure IMM kernels (batched over tracks).

Conventions (written once, tested): the full model set is fixed per tracker (``models`` order); each track has an
``active`` mask over it. ``Pi[i, j] = P(model_k = j | model_{k-1} = i)``: rows are "from", rows sum to 1.

Seed 003 section V prints its 4 x 4 matrix over (NCV, NCA, CT-left, CT-right) as
    [0.99 0.01 0 0; 0.1 0.7 0.1 0.1; 0 0.1 0.99 0; 0 0.1 0 0.99],
whose last two rows sum to 1.09. We read their 0.1 as 0.01 -- the same small exit as NCV's row, leaving a 0.99
self-transition -- which makes every row sum to 1 (:data:`SEED003_TRANSITION`).

VS-IMM set changes (our rule, seed 003 gives none): when a track's active set changes, models that stay keep
their estimate and probability; the probability mass of removed models is shared equally among the added models
(or, if none is added, given to the kept models in proportion to their probabilities); added models start from
the combined (moment-matched) estimate of the old set. Mass is conserved and the combined estimate is unchanged
at the switch when models are only added.
"""

from __future__ import annotations

import numpy as np

from uwb_env.config import SEED003_TRANSITION_ROWS
from uwb_env.tracking.kernels import mixture_reduce
from uwb_env.typing import BoolArray, FloatArray

SEED003_MODELS = ("ncv", "nca", "ct_left", "ct_right")
SEED003_TRANSITION = np.array(SEED003_TRANSITION_ROWS)


def restrict_transition(Pi: FloatArray, active: BoolArray) -> FloatArray:
    """``(N, r, r)`` transition matrices restricted to each track's active set (N, r), rows renormalised.

    A row with no mass left on the active set becomes uniform over it.
    """
    A = Pi[None] * active[:, None, :]
    s = A.sum(axis=-1, keepdims=True)
    uniform = active[:, None, :] / np.maximum(active.sum(axis=-1), 1)[:, None, None]
    return np.where(s > 0, A / np.where(s > 0, s, 1.0), uniform)


def imm_mix(mu: FloatArray, Pi: FloatArray, x: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """IMM interaction (mixing).

    Args:
        mu: ``(N, r)`` model probabilities; Pi: ``(N, r, r)`` transitions; x: ``(N, r, n)``; P: ``(N, r, n, n)``.

    Returns:
        cbar ``(N, r)`` predicted model probabilities sum_i Pi[i, j] mu_i, and the mixed initial conditions
        x0 ``(N, r, n)``, P0 ``(N, r, n, n)``; w[i | j] = Pi[i, j] mu_i / cbar_j. Models with cbar_j = 0 keep
        their own estimate.
    """
    joint = Pi * mu[:, :, None]  # (N, i, j)
    cbar = joint.sum(axis=1)
    w = np.swapaxes(joint / np.where(cbar > 0, cbar, 1.0)[:, None, :], 1, 2)  # (N, j, i)
    x0, P0 = mixture_reduce(w, x[:, None], P[:, None])
    dead = cbar <= 0
    if dead.any():
        x0 = np.where(dead[..., None], x, x0)
        P0 = np.where(dead[..., None, None], P, P0)
    return cbar, x0, P0


def imm_combine(mu: FloatArray, x: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Combined estimate ``(N, n)``, ``(N, n, n)`` of the model-conditioned ones."""
    return mixture_reduce(mu, x, P)


def switch_probabilities(active_old: BoolArray, active_new: BoolArray, mu: FloatArray) -> FloatArray:
    """The model probabilities ``(N, r)`` on the new sets under the set-change rule of the module docstring."""
    added = active_new & ~active_old
    removed = active_old & ~active_new
    lost = np.where(removed, mu, 0.0).sum(axis=-1)
    n_added = added.sum(axis=-1)
    kept = active_new & active_old
    mu = np.where(active_new, mu, 0.0) * kept
    share_added = np.where(n_added > 0, lost / np.maximum(n_added, 1), 0.0)
    mu = mu + added * share_added[:, None]
    kept_mass = mu.sum(axis=-1)
    fix = (n_added == 0) & (kept_mass > 0)
    mu = np.where(fix[:, None], mu / np.where(kept_mass > 0, kept_mass, 1.0)[:, None], mu)
    empty = mu.sum(axis=-1) <= 0
    return np.where(empty[:, None], active_new / np.maximum(active_new.sum(-1), 1)[:, None], mu)


def switch_model_sets(
    active_old: BoolArray, active_new: BoolArray, mu: FloatArray, x: FloatArray, P: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Apply the VS-IMM set-change rule of the module docstring; returns (mu, x, P) on the new sets."""
    changed = (active_old != active_new).any(axis=-1)
    if not changed.any():
        return mu, x, P
    xc, Pc = imm_combine(mu, x, P)
    added = active_new & ~active_old
    x = np.where(added[..., None], xc[:, None], x)
    P = np.where(added[..., None, None], Pc[:, None], P)
    return switch_probabilities(active_old, active_new, mu), x, P
