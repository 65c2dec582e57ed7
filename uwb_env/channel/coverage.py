"""Coverage of a bistatic pair: Cassini ovals, blind zone, range limits, array field of view (seed 000 III, IV-G)."""

from __future__ import annotations

import numpy as np

from uwb_env.typing import BoolArray, FloatArray


def max_range_product(gamma: FloatArray, rcs_m2: float, snr_min: float, rho: float, d0: float) -> FloatArray:
    """(l_t l_r)_max [m^2]: the maximum Cassini oval, seed 000 eq. 4 generalised to path-loss exponent rho.

    From SNR = Gamma sigma / (l_t l_r / d0^2)^rho >= SNR_min: (l_t l_r)_max = d0^2 (Gamma sigma / SNR_min)^(1/rho).
    """
    return d0**2 * (np.asarray(gamma) * rcs_m2 / snr_min) ** (1.0 / rho)


def cassini_shape_ratio(range_product_m2: FloatArray, baseline_m: FloatArray) -> FloatArray:
    """B / a = sqrt(l_t l_r) / (l / 2) (seed 000 eq. 5): < 1 two loops, = 1 lemniscate, > 1 one oval."""
    return np.sqrt(range_product_m2) / (np.asarray(baseline_m) / 2.0)


def blind_zone(bistatic_range_m: FloatArray, baseline_m: FloatArray, blind_excess_m: float) -> BoolArray:
    """True where the echo arrives within ``blind_excess_m`` of the direct path (seed 000 section IV-G).

    Args: bistatic_range_m (T, R, K), baseline_m (T, R) [m].
    """
    return bistatic_range_m - baseline_m[..., None] < blind_excess_m


def in_field_of_view(
    rx_pos: FloatArray, boresight_rad: FloatArray, fov_rad: FloatArray, tgt_pos: FloatArray
) -> tuple[BoolArray, FloatArray, FloatArray]:
    """Array field of view and angles.

    Args: rx_pos (R, 2), boresight_rad (R,) (nan = no array: always in view), fov_rad (R,), tgt_pos (K, 2).

    Returns:
        in_view (R, K), azimuth (R, K) [rad] global angle of the target seen from the receiver, off-boresight
        angle (R, K) [rad] in (-pi, pi] (nan without array).
    """
    d = tgt_pos[None] - rx_pos[:, None]
    az = np.arctan2(d[..., 1], d[..., 0])
    off = np.angle(np.exp(1j * (az - boresight_rad[:, None])))
    in_view = np.where(np.isnan(boresight_rad)[:, None], True, np.abs(off) <= fov_rad[:, None])
    return in_view, az, off
