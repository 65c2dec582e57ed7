"""The detector registry (``uwb_env.detection.registry``): lookup errors, duplicates, and identity with the kernels."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env.config import SignalConfig
from uwb_env.detection import (
    ca_cfar,
    ca_threshold_factor,
    cluster_detections,
    dtb_cfar,
    g_cfar,
    os_cfar,
    os_threshold_factor,
)
from uwb_env.detection.registry import (
    CFAR_DETECTORS,
    TOA_ESTIMATORS,
    Registry,
    cfar_detector,
    toa_estimator,
)


def test_unknown_cfar_names_the_field_the_value_and_the_allowed_names():
    with pytest.raises(ValueError, match=r"sensing\.signal\.cfar = 'cax': must be one of \('dtb', 'ca', 'g', 'os'\)"):
        cfar_detector("cax")
    with pytest.raises(ValueError, match=r"did you mean 'ca'\?"):
        cfar_detector("cax")


def test_unknown_toa_estimator_names_the_field_and_the_allowed_names():
    with pytest.raises(ValueError, match=r"sensing\.signal\.toa_estimator = 'mean': must be one of \(.*'median'"):
        toa_estimator("mean")


def test_duplicate_registration_raises():
    reg: Registry[int] = Registry("sensing.signal.x")
    reg.register("a", 1)
    with pytest.raises(KeyError, match="'a' already registered"):
        reg.register("a", 2)
    assert reg.get("a") == 1
    assert reg.names() == ("a",)


def test_registered_names():
    assert CFAR_DETECTORS.names() == ("dtb", "ca", "g", "os")
    assert {"median", "peak", "energy-detector"} <= set(TOA_ESTIMATORS.names())
    assert toa_estimator("energy-detector").replaces_cfar
    assert toa_estimator("energy-detector").estimate is None


def test_threshold_factor_designs_match_the_closed_forms():
    """CA: alpha = N (Pfa^(-1/N) - 1), N = 2 n_ref = 64, Pfa = 1e-4 -> 9.906047; G: N = n - 2 guard - 1; OS: Rohling."""
    sig = SignalConfig(cfar_pfa=1e-4, cfar_reference=32, cfar_guard=16, os_rank=48)
    n = 1920
    assert cfar_detector("dtb").design(sig, n) == 0.0
    np.testing.assert_allclose(cfar_detector("ca").design(sig, n), 64 * (1e-4 ** (-1 / 64) - 1), rtol=1e-15)
    np.testing.assert_allclose(cfar_detector("ca").design(sig, n), 9.906047020125328, rtol=1e-12)
    np.testing.assert_allclose(cfar_detector("g").design(sig, n), ca_threshold_factor(1e-4, n - 33), rtol=0)
    assert cfar_detector("os").design(sig, n) == os_threshold_factor(1e-4, 64, 48)


def test_registry_detectors_give_the_kernels_decisions_bit_for_bit():
    rng = np.random.default_rng(12345)
    d = np.abs(rng.standard_normal((3, 512)))
    d[:, 200:205] += 8.0
    sig = SignalConfig(n_samples=512)
    a_ca = ca_threshold_factor(sig.cfar_pfa, 2 * sig.cfar_reference)
    a_g = ca_threshold_factor(sig.cfar_pfa, 512 - 2 * sig.cfar_guard - 1)
    a_os = os_threshold_factor(sig.cfar_pfa, 2 * sig.cfar_reference, sig.os_rank)
    expected = {
        "dtb": dtb_cfar(d, sig.dtb_alpha_local, sig.dtb_alpha_global, sig.dtb_buffer, sig.dtb_qmax, sig.dtb_delta),
        "ca": ca_cfar(d, a_ca, sig.cfar_reference, sig.cfar_guard),
        "g": g_cfar(d, a_g, sig.cfar_guard),
        "os": os_cfar(d, a_os, sig.cfar_reference, sig.cfar_guard, sig.os_rank),
    }
    for name, dec in expected.items():
        det = cfar_detector(name)
        np.testing.assert_array_equal(det.detect(d, det.design(sig, 512), sig), dec)
        assert dec[:, 200:205].any()
    fs = sig.sample_rate_hz
    for name in ("median", "peak"):
        got = toa_estimator(name).estimate(expected["ca"], d, sig, fs)
        ref = cluster_detections(expected["ca"], d, sig.cluster_distance_s * fs, sig.cluster_min_weight, name)
        for g, r in zip(got, ref, strict=True):
            np.testing.assert_array_equal(g, r)
