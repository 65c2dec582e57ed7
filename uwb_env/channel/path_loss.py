r"""Frequency-dependent path loss in the IEEE 802.15.4a form (seed 000 eq. 9, seed 002 eq. 4).

One-way path loss PL(f, d) = PL0 (f / fc)^{2 (kappa + 1)} (d / d0)^rho, with PL0 = (4 pi fc d0 / c)^2 x excess.
For rho = 2, kappa = 0 and no excess this is exactly free space, (4 pi f d / c)^2.
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.config import ChannelConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray
from uwb_env.units import db_to_linear


def path_gain(freq_hz: FloatArray, distance_m: FloatArray, center_freq_hz: float, channel: ChannelConfig) -> FloatArray:
    """One-way power gain 1 / PL(f, d) (broadcasts ``freq_hz`` against ``distance_m``)."""
    pl0 = (4.0 * math.pi * center_freq_hz * channel.reference_distance_m / SPEED_OF_LIGHT_MPS) ** 2
    pl0 *= db_to_linear(channel.excess_loss_db)
    f = np.asarray(freq_hz, dtype=float)
    d = np.asarray(distance_m, dtype=float)
    return 1.0 / (
        pl0
        * (f / center_freq_hz) ** (2.0 * (channel.frequency_exponent + 1.0))
        * (d / channel.reference_distance_m) ** channel.path_loss_exponent
    )
