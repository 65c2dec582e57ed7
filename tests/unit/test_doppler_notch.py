"""The zero-Doppler clutter notch: kernels against their definitions, and the sensor's blind speeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env import scenarios
from uwb_env.channel.doppler_notch import (
    clutter_cnr_profile,
    doppler_notch_gain,
    fold_doppler_hz,
    train_doppler_spread_hz,
)
from uwb_env.constants import SPEED_OF_LIGHT_MPS as C
from uwb_env.sensing import ParametricSensor
from uwb_env.waveforms import chirp_rate
from uwb_env.waveforms.chirp import compressed_range_spread_m as chirp_range_spread_m


def test_range_spread_is_the_std_of_the_compressed_chirp_power():
    kappa = 1.375e-6
    gamma = chirp_rate(kappa, 40e6, "up")
    t = np.linspace(-8 * kappa, 8 * kappa, 200001)
    dt = t[1] - t[0]
    s = np.exp((1j * gamma - 0.5 / kappa**2) * t**2)
    taus = np.linspace(-60e-9, 60e-9, 601)
    power = np.array(
        [abs(np.sum(s * np.conj(np.exp((1j * gamma - 0.5 / kappa**2) * (t - u) ** 2))) * dt) ** 2 for u in taus]
    )
    std_tau = math.sqrt(np.sum(power * taus**2) / np.sum(power))
    assert chirp_range_spread_m(kappa, gamma) == pytest.approx(C * std_tau, rel=1e-3)
    assert chirp_range_spread_m(kappa, gamma) == pytest.approx(C / (math.pi * 40e6), rel=1e-3)  # ~ c / (pi B)


def test_doppler_main_lobe_fit_matches_the_dirichlet_kernel_near_zero():
    B, T1 = 25, 0.01
    sigma = train_doppler_spread_hz(B, T1)
    f = np.array([0.05, 0.1, 0.2]) / (B * T1)
    dirichlet = (np.sin(math.pi * B * T1 * f) / (B * np.sin(math.pi * T1 * f))) ** 2
    np.testing.assert_allclose(np.exp(-0.5 * (f / sigma) ** 2), dirichlet, rtol=2e-3)
    assert train_doppler_spread_hz(B, T1, 4.0) == pytest.approx(math.hypot(sigma, 4.0))


@settings(max_examples=200, deadline=None)
@given(f=st.floats(-1e4, 1e4), prf=st.floats(1.0, 1e3))
def test_fold_lands_in_one_interval_a_whole_number_of_prfs_away(f, prf):
    g = float(fold_doppler_hz(np.array(f), prf))
    assert -prf / 2 - 1e-9 <= g < prf / 2 + 1e-9
    k = (f - g) / prf
    assert abs(k - round(k)) < 1e-6


def test_notch_gain_hand_values_and_blind_speeds():
    lam, pri, sigma, eta = C / 4e9, 0.01, 2.0, 0.5
    blind = lam / pri  # 7.49 m/s
    g = doppler_notch_gain(np.array([100.0] * 4), np.array([0.0, blind, 2 * blind, 0.5 * blind]), lam, pri, sigma, eta)
    np.testing.assert_allclose(g[:3], 1.0 / (1.0 + 50.0), rtol=1e-9)
    assert g[3] == pytest.approx(1.0, abs=1e-12)  # 50 Hz away: far outside a 2 Hz notch
    f = 3.0  # Hz from the clutter line
    rdot = -f * lam
    assert float(doppler_notch_gain(100.0, rdot, lam, pri, sigma, eta)) == pytest.approx(
        1.0 / (1.0 + 50.0 * math.exp(-0.5 * (f / sigma) ** 2)), rel=1e-12
    )


def test_cnr_profile_sums_gaussians():
    grid = np.array([10.0, 12.0, 30.0])
    out = clutter_cnr_profile(np.array([10.0, 30.0]), np.array([4.0, 2.0]), grid, 2.0)
    np.testing.assert_allclose(
        out, [4.0 + 2.0 * math.exp(-50), 4.0 * math.exp(-0.5) + 2.0 * math.exp(-40.5), 2.0 + 4.0 * math.exp(-50)]
    )


def test_urban_sensor_blind_speeds_differ_by_pri_and_the_lookahead_sees_them():
    cfg = scenarios.get("urban-intersection")
    s = ParametricSensor(cfg)
    names = s.library.names
    w10, w7 = names.index("k1.375us-up"), names.index("k1.375us-up-pri7ms")
    lam = s.library[w10].wavelength_m
    # a scatterer's own bistatic range, where the CNR is largest for rx 0
    cnr = s._notch[0][w10, 0, 0]
    r = float(np.argmax(cnr) * s._notch[1])
    g = s.notch_gain(np.array([w10, w7]), 0, 0, np.array([r, r]), np.array([lam / 0.01, lam / 0.01]))
    eta = cfg.sensing.clutter.residue_fraction
    assert g[0] == pytest.approx(1.0 / (1.0 + eta * cnr.max()), rel=1e-6)  # blind at 10 ms
    assert g[1] > 0.9  # not at 7 ms: 7.49 m/s folds to 3.2 m/s there, 43 Hz from the clutter line
    # expected_measurements with velocities sees the loss; without them it does not
    lay = s.layout
    pos = np.array([[2060.0, 1500.0]])
    d_t, d_r = pos[0] - lay.tx_pos[0], pos[0] - lay.rx_pos[0]
    u = d_t / np.linalg.norm(d_t) + d_r / np.linalg.norm(d_r)
    vel = (lam / 0.01) * u / (u @ u)  # range-rate exactly one blind speed of the 10 ms PRI
    pd_plain, R_plain = s.expected_measurements(0, 0, pos, np.array([w10, w7]), 10.0, 1)
    pd_notch, R_notch = s.expected_measurements(0, 0, pos, np.array([w10, w7]), 10.0, 1, velocities=vel[None])
    notch = s.notch_gain(
        np.array([w10, w7]), 0, 0, np.full(2, np.linalg.norm(d_t) + np.linalg.norm(d_r)), np.full(2, lam / 0.01)
    )
    walk = s.migration_gain(np.array([w10, w7]), np.full(2, lam / 0.01))  # 7.5 m/s walks +-0.9 m: 2.5 % at 40 MHz
    assert 0.97 < walk[0] < walk[1] < 1.0
    gain = notch * walk
    # 7 ms: out of the notch (gain ~ 1); the walk's 1.2 % SNR loss at Pd 0.99 moves Pd by ~1e-4
    assert pd_plain[1, 0] - 1e-3 < pd_notch[1, 0] < pd_plain[1, 0]
    assert pd_notch[0, 0] <= pd_plain[0, 0]
    assert pd_notch[0, 0] <= pd_plain[0, 0] + 1e-12
    assert np.isclose(pd_notch[0, 0], pd_plain[0, 0], rtol=1e-9, atol=0) == (gain[0] > 1 - 1e-9)
    # R at the SCNR (notch and walk's peak loss), times the walk's accuracy factors (ParametricSensor.walk_factors)
    R_scnr = R_plain[0, 0] / gain[0]
    f = s.walk_factors(np.array([w10]), np.array([lam / 0.01]), np.diag(R_scnr)[None])[0]
    assert 1.0 < f[0] < 1.1 and 1.0 <= f[1] < 1.1  # 2.4 % in range std at 7.5 m/s
    np.testing.assert_allclose(R_notch[0, 0], R_scnr * np.sqrt(np.outer(f, f)), rtol=1e-9)


@pytest.mark.parametrize("residue", [0.0, 3e-7])
def test_pd_with_velocities_equals_the_link_pd_where_the_notch_gain_is_one(residue):
    """Far from every blind speed (folded Doppler PRF / 2) the notch gain is 1: Pd with and without the velocities
    agree, whatever detector gain and clutter-residue quadrature the link uses (review finding: the residue was
    dropped)."""
    cfg = scenarios.get("urban-intersection", **{"sensing.clutter_residue_ratio": residue})
    s = ParametricSensor(cfg)
    s._migration = None  # the notch's plumbing alone (the range walk's own loss: test_doppler_notch's test above)
    lay = s.layout
    pos = np.array([[2060.0, 1500.0], [2000.0, 1505.0], [2090.0, 1560.0]])
    w = np.array([2, 5])
    lam = s.library[2].wavelength_m
    for rx in range(2):
        d_t, d_r = pos - lay.tx_pos[0], pos - lay.rx_pos[rx]
        u = d_t / np.linalg.norm(d_t, axis=1)[:, None] + d_r / np.linalg.norm(d_r, axis=1)[:, None]
        for i, wi in enumerate(w):
            pri = s.library[int(wi)].config.pri_s
            vel = (0.5 * lam / pri) * u / np.einsum("nd,nd->n", u, u)[:, None]  # range-rate P / 2: far from the notch
            plain, _ = s.expected_measurements(0, rx, pos, w[i : i + 1], 10.0, 1)
            with_v, _ = s.expected_measurements(0, rx, pos, w[i : i + 1], 10.0, 1, velocities=vel)
            np.testing.assert_allclose(with_v, plain, rtol=1e-6, atol=1e-12)
