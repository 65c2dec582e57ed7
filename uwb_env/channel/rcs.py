"""Swerling radar-cross-section fluctuation (scan-to-scan).

The RCS of a scan is sigma_mean x factor, with a factor of unit mean:
    Swerling 0: 1;  Swerling I: exponential (chi-square, 2 dof);  Swerling III: chi-square with 4 dof / 4,
    i.e. Gamma(2, 1/2) -- seed 002's model of a person.
Each call consumes exactly two standard exponentials per entry whatever the Swerling case, so the stream stays
aligned across configurations (common random numbers): factor_I = e1, factor_III = (e1 + e2) / 2.
"""

from __future__ import annotations

import numpy as np

from uwb_env.typing import FloatArray, IntArray

_WEIGHTS = {0: (1.0, 0.0, 0.0), 1: (0.0, 1.0, 0.0), 3: (0.0, 0.5, 0.5)}


def swerling_weights(swerling: IntArray) -> FloatArray:
    """``(3, K)`` weights (c, w1, w2) with factor = c + w1 e1 + w2 e2 for Swerling cases 0, 1, 3."""
    return np.array([_WEIGHTS[int(s)] for s in swerling], dtype=float).T.reshape(3, -1)


def rcs_fluctuation(
    swerling: IntArray, shape: tuple[int, ...], rng: np.random.Generator, weights: FloatArray | None = None
) -> FloatArray:
    """Unit-mean RCS factors of shape ``shape + (K,)`` for targets with Swerling cases ``swerling`` (K,).

    ``weights`` (from :func:`swerling_weights`) may be passed precomputed.
    """
    w = swerling_weights(swerling) if weights is None else weights
    e = rng.standard_exponential((2, *shape, swerling.shape[0]))
    return w[0] + w[1] * e[0] + w[2] * e[1]
