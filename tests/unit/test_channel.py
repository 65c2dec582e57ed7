"""Channel: radar equation and constant, 802.15.4a path loss, seed 000 eq. 7, Cassini ovals, walls, RCS, geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from uwb_env.channel import (
    bistatic_radar_constant,
    bistatic_range,
    bistatic_range_rate,
    bistatic_snr,
    blind_zone,
    cassini_shape_ratio,
    in_field_of_view,
    leg_lengths,
    line_of_sight,
    max_range_product,
    noise_psd,
    pair_obstruction,
    path_gain,
    rcs_fluctuation,
    snr_on_iso_range,
)
from uwb_env.config import ChannelConfig
from uwb_env.constants import BOLTZMANN_J_PER_K
from uwb_env.constants import SPEED_OF_LIGHT_MPS as C

FREE = ChannelConfig()


def test_free_space_path_gain_and_frequency_exponent():
    f, d = np.array([2e9, 4e9, 8e9]), 7.0
    np.testing.assert_allclose(path_gain(f, d, 4e9, FREE), (C / (4 * math.pi * f * d)) ** 2, rtol=1e-12)
    ch = ChannelConfig(path_loss_exponent=3.0, frequency_exponent=0.5, excess_loss_db=10.0)
    g = path_gain(np.array([4e9, 8e9]), np.array([1.0, 1.0]), 4e9, ch)
    assert g[1] / g[0] == pytest.approx(2.0 ** (-2 * 1.5))  # (f/fc)^(-2 (kappa + 1))
    assert path_gain(4e9, 2.0, 4e9, ch) / path_gain(4e9, 1.0, 4e9, ch) == pytest.approx(2.0**-3)
    assert path_gain(4e9, 1.0, 4e9, ch) == pytest.approx(0.1 * path_gain(4e9, 1.0, 4e9, FREE))


def test_noise_psd_is_k_t0_f():
    assert noise_psd(0.0) == pytest.approx(BOLTZMANN_J_PER_K * 290.0)
    assert 10 * math.log10(noise_psd(3.98)) == pytest.approx(-200.0, abs=0.01)  # seed 002: N0 = -200 dBW/Hz


def test_radar_constant_reduces_to_seed000_eq1_in_free_space():
    """SNR = E Gt Gr sigma int p(f) (c/f)^2 df / ((4 pi)^3 N0 (lt lr)^2), integrated independently with quad."""
    fc, beta, E, nf = 4.3e9, 0.5e9, 2e-9, 4.8
    gamma = bistatic_radar_constant(E, fc, beta, 3.0, 2.0, nf, 3, FREE)
    norm = integrate.quad(lambda f: math.exp(-0.5 * ((f - fc) / beta) ** 2), fc - 5 * beta, fc + 5 * beta)[0]
    avg = (
        integrate.quad(lambda f: math.exp(-0.5 * ((f - fc) / beta) ** 2) * (C / f) ** 2, fc - 5 * beta, fc + 5 * beta)[
            0
        ]
        / norm
    )
    expected = E * 10**0.5 * 3 * avg / ((4 * math.pi) ** 3 * noise_psd(nf))
    assert gamma == pytest.approx(expected, rel=1e-6)


def test_narrowband_radar_constant_matches_single_frequency_radar_equation():
    gamma = bistatic_radar_constant(1e-5, 4e9, 5e6, 0.0, 0.0, 5.0, 1, FREE)
    lam = C / 4e9
    assert gamma == pytest.approx(1e-5 * lam**2 / ((4 * math.pi) ** 3 * noise_psd(5.0)), rel=1e-5)


def test_snr_decays_as_range_product_to_the_minus_rho():
    gamma = np.array([[1e9]])
    lt, lr = np.array([[10.0, 20.0]]), np.array([[10.0, 5.0]])
    s = bistatic_snr(gamma, np.array([1.0, 1.0]), lt, lr, 2.0, 1.0)
    assert s[0, 0, 0] == pytest.approx(1e9 / 1e4) and s[0, 0, 1] == pytest.approx(1e9 / 1e4)  # same product
    s3 = bistatic_snr(gamma, np.array([2.0]), np.array([[4.0]]), np.array([[2.0]]), 3.0, 1.0, np.array([[[10.0]]]))
    assert s3[0, 0, 0] == pytest.approx(1e9 * 2.0 / 8.0**3 / 10.0)
    blocked = bistatic_snr(gamma, np.array([1.0]), lt[:, :1], lr[:, :1], 2.0, 1.0, np.array([[[np.inf]]]))
    assert blocked[0, 0, 0] == 0.0


def test_seed000_eq7_snr_along_an_iso_range_ellipse():
    """Points on the ellipse l_t + l_r = 2 A with foci at +-l/2: SNR from the radar equation equals eq. 7."""
    l, A, gamma = 4.0, 5.0, 1e6
    tx, rx = np.array([[-l / 2, 0.0]]), np.array([[l / 2, 0.0]])
    b = math.sqrt(A**2 - (l / 2) ** 2)
    th = np.linspace(0, 2 * math.pi, 37)
    p = np.column_stack([A * np.cos(th), b * np.sin(th)])
    lt, lr = leg_lengths(tx, rx, p)
    np.testing.assert_allclose(lt + lr, 2 * A)
    beta = np.arccos(np.clip((lt**2 + lr**2 - l**2) / (2 * lt * lr), -1, 1))[0]
    snr = bistatic_snr(np.array([[gamma]]), np.ones(p.shape[0]), lt, lr, 2.0, 1.0)[0, 0]
    np.testing.assert_allclose(snr, snr_on_iso_range(gamma, beta, 2 * A, l), rtol=1e-9)
    # extremes stated in the seed: 16 G / ((2A)^2 - l^2)^2 on the baseline, 16 G / (2A)^4 equidistant
    assert snr.max() == pytest.approx(16 * gamma / ((2 * A) ** 2 - l**2) ** 2)
    assert snr.min() == pytest.approx(16 * gamma / (2 * A) ** 4)


def test_cassini_max_oval_is_the_snr_min_contour():
    gamma, snr_min, rho = 5e7, 20.0, 2.0
    prod = max_range_product(np.array(gamma), 1.0, snr_min, rho, 1.0)
    tx, rx = np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])
    # points on the Cassini oval l_t l_r = prod: scan along a ray and pick the root
    for ang in np.linspace(0.1, 3.0, 7):
        r = np.linspace(0.01, 100, 200001)
        p = np.column_stack([r * math.cos(ang), r * math.sin(ang)])
        lt, lr = leg_lengths(tx, rx, p)
        i = np.argmin(np.abs(lt[0] * lr[0] - prod))
        snr = bistatic_snr(np.array([[gamma]]), np.ones(1), lt[:, i : i + 1], lr[:, i : i + 1], rho, 1.0)
        assert snr[0, 0, 0] == pytest.approx(snr_min, rel=1e-3)
    assert cassini_shape_ratio(np.array(1.0), np.array(2.0)) == pytest.approx(1.0)  # lemniscate


@settings(max_examples=100, deadline=None)
@given(
    pts=st.lists(st.floats(-1e3, 1e3), min_size=6, max_size=6),
    shift=st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)),
)
def test_bistatic_range_triangle_inequality_and_translation_invariance(pts, shift):
    tx, rx, p = (np.array([pts[i : i + 2]]) for i in (0, 2, 4))
    r = bistatic_range(tx, rx, p)[0, 0, 0]
    assert r >= np.linalg.norm(tx - rx) - 1e-9
    s = np.array([shift])
    assert bistatic_range(tx + s, rx + s, p + s)[0, 0, 0] == pytest.approx(r, abs=1e-6)


def test_bistatic_range_rate_is_the_time_derivative():
    tx, rx = np.array([[0.0, 0.0], [5.0, -3.0]]), np.array([[10.0, 0.0]])
    p, v = np.array([[4.0, 7.0], [-3.0, 2.0]]), np.array([[1.5, -2.0], [0.3, 0.9]])
    h = 1e-6
    fd = (bistatic_range(tx, rx, p + h * v) - bistatic_range(tx, rx, p - h * v)) / (2 * h)
    np.testing.assert_allclose(bistatic_range_rate(tx, rx, p, v), fd, rtol=1e-7)


def test_walls_loss_and_delay_counted_per_leg_and_opaque_blocks():
    a = np.array([[5.0, -10.0], [8.0, -10.0], [0.0, 20.0]])
    b = np.array([[5.0, 10.0], [8.0, 10.0], [1.0, 20.0]])
    loss, delay = np.array([3.0, 7.0, np.inf]), np.array([1e-9, 2e-9, 0.0])
    tx, rx = np.array([[0.0, 0.0]]), np.array([[0.0, 1.0], [10.0, 0.0]])
    tgt = np.array([[6.0, 0.0], [9.0, 1.0], [0.5, 25.0]])
    L, D = pair_obstruction(tx, rx, tgt, a, b, loss, delay)
    np.testing.assert_allclose(L[0, :, 0], [3.0 + 3.0, 3.0 + 7.0])  # through wall 1 both legs / one each
    np.testing.assert_allclose(L[0, :, 1], [10.0 + 10.0, 10.0 + 0.0])
    np.testing.assert_allclose(D[0, :, 1], [6e-9, 3e-9])
    assert np.isinf(L[0, :, 2]).all()  # behind the opaque wall
    # a monostatic radar counts each wall twice (seed 002's factor 2)
    Lm, _ = pair_obstruction(tx, tx, tgt[:1], a, b, loss, delay)
    assert Lm[0, 0, 0] == pytest.approx(6.0)
    np.testing.assert_array_equal(line_of_sight(np.zeros((3, 2)), tgt, a, b), [False, False, False])
    np.testing.assert_array_equal(line_of_sight(np.zeros((1, 2)), np.array([[4.0, 3.0]]), a, b), [True])


def test_blind_zone_and_field_of_view():
    r = np.array([[[10.2, 10.6, 30.0]]])
    np.testing.assert_array_equal(blind_zone(r, np.array([[10.0]]), 0.5), [[[True, False, False]]])
    in_view, az, off = in_field_of_view(
        np.array([[0.0, 0.0], [0.0, 0.0]]),
        np.array([math.pi / 2, np.nan]),
        np.array([math.radians(45), np.nan]),
        np.array([[0.0, 5.0], [5.0, 4.0], [0.0, -5.0]]),
    )
    np.testing.assert_array_equal(in_view, [[True, False, False], [True, True, True]])
    assert off[0, 0] == pytest.approx(0.0) and az[0, 1] == pytest.approx(math.atan2(4, 5))


def test_swerling_factor_moments():
    """Unit mean; variance 1 (Swerling I, exponential) and 1/2 (Swerling III, chi-square 4 dof / 4); 4-sigma."""
    n = 200_000
    f = rcs_fluctuation(np.array([0, 1, 3]), (n,), np.random.default_rng(1))
    np.testing.assert_array_equal(f[:, 0], 1.0)
    for col, var in ((1, 1.0), (3 - 1, 0.5)):
        x = f[:, col]
        assert abs(x.mean() - 1.0) < 4 * math.sqrt(var / n)
        # var of the sample variance ~ (mu4 - var^2) / n; mu4 = 9 (exp) and 3 * 2 * (2+1)... use a loose 4 x bound
        assert abs(x.var() - var) < 4 * math.sqrt((9.0 if var == 1.0 else 1.5) / n)
