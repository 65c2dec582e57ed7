"""Decibel <-> linear conversions. dB appears only at the configuration boundary (fields ending in ``_db``).

Examples:
    >>> db_to_linear(10.0)
    10.0
    >>> round(linear_to_db(2.0), 4)
    3.0103
    >>> dbm_to_watts(30.0)
    1.0
    >>> round(watts_to_dbm(1e-3), 6)
    0.0
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np

T = TypeVar("T", float, np.ndarray)


def db_to_linear(x_db: T) -> T:
    """Power ratio from decibels: 10^(x/10)."""
    return 10.0 ** (np.asarray(x_db) / 10.0) if isinstance(x_db, np.ndarray) else float(10.0 ** (x_db / 10.0))


def linear_to_db(x: T) -> T:
    """Decibels from a power ratio: 10 log10(x)."""
    return 10.0 * np.log10(x) if isinstance(x, np.ndarray) else float(10.0 * np.log10(x))


def dbm_to_watts(p_dbm: float) -> float:
    """Power in watts from dBm."""
    return float(10.0 ** ((p_dbm - 30.0) / 10.0))


def watts_to_dbm(p_w: float) -> float:
    """Power in dBm from watts."""
    return float(10.0 * np.log10(p_w) + 30.0)
