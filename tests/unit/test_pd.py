"""Detection probability: closed forms against numerical integration, a textbook value, invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from uwb_env.sensing import detection_probability, pd_swerling0, pd_swerling1, pd_swerling3


@pytest.mark.parametrize("snr_db", [-5.0, 5.0, 13.0, 25.0])
@pytest.mark.parametrize("pfa", [1e-3, 1e-6])
def test_fluctuating_pd_equals_marcum_averaged_over_the_rcs(snr_db, pfa):
    s = 10 ** (snr_db / 10)
    sw1 = integrate.quad(lambda x: pd_swerling0(x, pfa) * math.exp(-x / s) / s, 0, 60 * s)[0]
    sw3 = integrate.quad(lambda x: pd_swerling0(x, pfa) * stats.gamma.pdf(x, 2, scale=s / 2), 0, 60 * s)[0]
    assert pd_swerling1(s, pfa) == pytest.approx(sw1, abs=1e-7)
    assert pd_swerling3(s, pfa) == pytest.approx(sw3, abs=1e-7)


def test_albersheim_reference_point():
    """Albersheim (n = 1): Pd = 0.9, Pfa = 1e-6 needs 13.1 dB for a steady target (accurate to ~0.2 dB)."""
    assert 0.87 < pd_swerling0(10**1.31, 1e-6) < 0.93


@pytest.mark.parametrize("case", [0, 1, 3])
def test_pd_at_zero_snr_is_pfa_and_unknown_case_raises(case):
    assert detection_probability(np.array([0.0]), 1e-4, case)[0] == pytest.approx(1e-4)
    with pytest.raises(ValueError, match="swerling = 2: must be one of"):
        detection_probability(np.array([1.0]), 1e-4, 2)


@settings(max_examples=100, deadline=None)
@given(
    s1=st.floats(0, 1e4),
    s2=st.floats(0, 1e4),
    p1=st.floats(1e-9, 0.1),
    p2=st.floats(1e-9, 0.1),
    case=st.sampled_from([0, 1, 3]),
)
def test_pd_is_monotone_in_snr_and_pfa(s1, s2, p1, p2, case):
    lo, hi = sorted((s1, s2))
    assert detection_probability(lo, p1, case) <= detection_probability(hi, p1, case) + 1e-12
    plo, phi = sorted((p1, p2))
    assert detection_probability(lo, plo, case) <= detection_probability(lo, phi, case) + 1e-12


@pytest.mark.parametrize("pfa", [7e-4, 1e-3, 1e-6])
@pytest.mark.parametrize("cells", [1.0, 61.92, 500.0])
def test_noise_window_term_closed_forms(pfa, cells):
    """P = 1 - (1 - Pd_echo) (1 - Pfa)^n: without an echo it is the n-cell noise term 1 - (1 - Pfa)^n; at SNR -> 0
    the echo's own cell is one more noise cell, 1 - (1 - Pfa)^(n + 1); n = 0 is the single-cell Pd, bit for bit."""
    from uwb_env.sensing.pd import noise_window_probability, windowed_detection_probability

    assert windowed_detection_probability(0.0, pfa, cells) == pytest.approx(1.0 - (1.0 - pfa) ** cells, rel=1e-12)
    assert noise_window_probability(pfa, cells) == pytest.approx(1.0 - (1.0 - pfa) ** cells, rel=1e-12)
    assert noise_window_probability(pfa, 1.0) == pytest.approx(pfa, rel=1e-12)
    for case in (0, 1, 3):
        p0 = windowed_detection_probability(detection_probability(1e-12, pfa, case), pfa, cells)
        assert p0 == pytest.approx(1.0 - (1.0 - pfa) ** (cells + 1.0), rel=1e-6)
    snr = np.geomspace(1e-3, 1e3, 40)
    pd = detection_probability(snr, pfa, 1)
    assert np.array_equal(windowed_detection_probability(pd, pfa, 0.0), pd)
    win = windowed_detection_probability(pd, pfa, cells)
    assert np.all(win >= pd) and np.all(np.diff(win) > 0) and win[-1] <= 1.0
    # independent events: the miss probability factorises
    np.testing.assert_allclose(1.0 - win, (1.0 - pd) * (1.0 - pfa) ** cells, rtol=1e-12)
    with pytest.raises(ValueError, match="cells"):
        noise_window_probability(pfa, -1.0)
