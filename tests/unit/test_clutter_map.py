"""Spatial clutter map (Musicki & Evans 2004, ``uwb_env.detection.clutter_map``): known answers, the sensor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.config import SignalConfig
from uwb_env.detection.clutter_map import (
    ClutterMap,
    ClutterMapGrid,
    cell_index,
    map_density,
    map_update,
    passing_density_bound,
    steady_density,
)
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import SignalSensor

AREA = (-2.35, 2.35, 0.48, 6.1)  # through-wall's surveillance area
CELL, N, FLOOR = 0.25, 50.0, 0.05


def _map() -> ClutterMap:
    return ClutterMap.over(AREA, CELL, N, FLOOR)


def test_grid_covers_the_area_and_indexes_cells():
    g = ClutterMapGrid.over(AREA, CELL)
    assert (g.nx, g.ny) == (math.ceil(4.7 / 0.25), math.ceil(5.62 / 0.25)) == (19, 23)
    assert g.cell_area_m2 == pytest.approx(0.0625)
    z = np.array([[-2.35, 0.48], [-2.35 + 0.26, 0.48 + 0.01], [0.0, 1.25], [9.0, 1.0], [np.nan, 1.0]])
    idx = cell_index(g, z)
    assert idx[:2].tolist() == [0, 1]
    assert idx[2] == math.floor((1.25 - 0.48) / 0.25) * g.nx + math.floor(2.35 / 0.25)
    assert idx[3:].tolist() == [-1, -1]  # outside, not finite


def test_density_after_k_scans_is_the_geometric_sum_over_the_cell_area():
    m, z = _map(), np.array([[0.01, 1.26]])
    a = 1.0 / N
    for k in range(1, 121):
        m.update(z)
        closed = (1.0 - (1.0 - a) ** k) / CELL**2  # a sum_{j<k} (1 - a)^j / A
        assert float(m.density(z)[0]) == pytest.approx(max(closed, FLOOR), rel=1e-12)
        assert steady_density(k, N, CELL**2) == pytest.approx(closed, rel=1e-12)
    assert float(m.density(z)[0]) == pytest.approx((1.0 - 0.98**120) / 0.0625)  # 14.5 per m^2, -> 16
    assert m.scans == 120


def test_floor_the_map_never_says_less_clutter_than_the_prior():
    m = _map()
    z = np.array([[0.0, 1.3], [1.0, 3.0], [50.0, 50.0]])
    assert np.all(m.density(z) == FLOOR)  # empty map, and a position outside the grid
    m.update(z[:1])  # one detection: a / A = 0.32 per m^2 in its cell, none elsewhere
    assert m.density(z).tolist() == pytest.approx([1.0 / N / CELL**2, FLOOR, FLOOR])
    for _ in range(400):  # forgotten: (1 - a)^400 / (N A) = 1e-5 per m^2 < the floor
        m.update(np.zeros((0, 2)))
    assert np.all(m.density(z) == FLOOR)
    counts = np.array([0.0, 1e-4, 1.0])
    assert map_density(counts, np.array([0, 1, 2, -1]), 0.0625, FLOOR).tolist() == pytest.approx(
        [FLOOR, FLOOR, 16.0, FLOOR]
    )


def test_forgetting_decays_by_one_minus_a_per_scan():
    m, z = _map(), np.array([[-1.0, 2.0]])
    for _ in range(30):
        m.update(z)
    d0 = float(m.density(z)[0])
    for j in range(1, 40):
        m.update(np.array([[1.5, 5.0]]))  # detections elsewhere do not touch this cell
        assert float(m.density(z)[0]) == pytest.approx(d0 * (1.0 - 1.0 / N) ** j, rel=1e-12)
    # after N ln 2 scans half of it is left
    assert (1.0 - 1.0 / N) ** (N * math.log(2.0)) == pytest.approx(0.5, rel=0.02)


def test_update_counts_detections_per_cell_with_weights_and_does_not_modify_its_input():
    counts = np.zeros(4)
    new = map_update(counts, np.array([1, 1, 3, -1]), 10.0)
    assert counts.tolist() == [0.0] * 4
    assert new.tolist() == pytest.approx([0.0, 0.2, 0.0, 0.1])
    w = map_update(counts, np.array([1, 1, 3, -1]), 10.0, np.array([1.0, 0.5, 0.0, 1.0]))
    assert w.tolist() == pytest.approx([0.0, 0.15, 0.0, 0.0])


def test_a_person_walking_across_cells_adds_at_most_the_passing_bound():
    """A walker at 0.8 m/s, scans of 0.074 s, one detection per scan at its position, straight lines at any angle:
    no cell's density exceeds ``passing_density_bound`` (7 scans in a cell at most: 2.24 per m^2), and after the
    walker has left, a cell is far below a static detection's steady 16 per m^2."""
    v, T = 0.8, 0.074
    bound = passing_density_bound(1.0, v, T, CELL, N)
    assert bound == pytest.approx((math.ceil(CELL * math.sqrt(2.0) / (v * T)) + 1) / N / CELL**2)
    assert bound == pytest.approx(7 / 50 / 0.0625)
    rng = np.random.default_rng(1)
    for heading in np.linspace(0.0, math.pi, 13):
        m = _map()
        p = (
            np.array([0.1, 3.0])
            + rng.uniform(-0.125, 0.125, 2)
            - 1.5 * np.array([math.cos(heading), math.sin(heading)])
        )
        step = v * T * np.array([math.cos(heading), math.sin(heading)])
        worst = 0.0
        for _ in range(round(3.0 / (v * T))):
            m.update(p[None])
            worst = max(worst, float(m.density_map().max()))
            p = p + step
        assert worst <= bound + 1e-12
        assert worst < 0.15 * steady_density(10**6, N, CELL**2)


def test_configuration_is_validated():
    with pytest.raises(ValueError, match="clutter_map_cell_m"):
        SignalConfig(clutter_map_cell_m=0.0)
    with pytest.raises(ValueError, match="clutter_map_memory_scans"):
        SignalConfig(clutter_map_memory_scans=0.5)
    with pytest.raises(ValueError, match="clutter_map_count"):
        SignalConfig(clutter_map_count="still")  # nu-tuples: no couples to test for stillness
    with pytest.raises(ValueError, match="clutter_map"):
        SignalConfig(clutter_map=True, output="ranges")
    with pytest.raises(ValueError, match="memory_scans"):
        ClutterMap.over(AREA, CELL, 0.0, FLOOR)
    assert SignalConfig().clutter_map is False  # off by default: every scenario's chain unchanged


# ------------------------------------------------------------------------------------------ the signal sensor
def _through_wall(**over) -> SignalSensor:
    return SignalSensor(scenarios.get("through-wall", **{"sensing.fidelity": "signal", **over}))


def _episode(sensor: SignalSensor, seed: int):
    rngs = RngStreams.from_seed(seed)
    return sensor.new_episode(sample_truth(sensor.cfg, rngs.truth, sensor.layout), rngs)


def test_through_wall_signal_path_is_the_seeds_chain_without_a_map():
    """ThroughWall-v4: the seed's chain, no clutter map (``through_wall.THROUGH_WALL_SIGNAL``; v3 counted the still
    couples, which at the fast background's alpha 0.4 costs the persons their tracks); the map is an option."""
    sig = scenarios.get("through-wall").sensing.signal
    assert sig.clutter_map is False and sig.background_alpha == 0.4
    still = {"sensing.signal.clutter_map": True, "sensing.signal.clutter_map_count": "still"}
    assert scenarios.get("through-wall", **still).sensing.signal.clutter_map_count == "still"


ALL = {"sensing.signal.clutter_map": True, "sensing.signal.clutter_map_count": "all"}
"""Every couple counted (the tests of the map's update, which counts 1 per detection)."""


def test_sensor_reads_the_map_before_the_scan_updates_it_and_resets_it_per_episode():
    s = _through_wall(**ALL)
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    floor = s.sig.false_position_density_per_m2
    ep = _episode(s, 43)
    assert ep.clutter_map is not None and ep.clutter_map.scans == 0
    for k in range(1, 41):
        before = ep.clutter_map.counts.copy()
        (det,) = s.sense(ep, k, plan, 0.0)
        expected = map_density(before, cell_index(ep.clutter_map.grid, det.z), CELL**2, floor)
        np.testing.assert_array_equal(det.clutter_intensity, expected)
        np.testing.assert_array_equal(
            ep.clutter_map.counts, map_update(before, cell_index(ep.clutter_map.grid, det.z), N)
        )
    assert ep.clutter_map.scans == 40 and ep.clutter_map.counts.sum() > 0.0
    fresh = _episode(s, 43)  # a new episode starts an empty map: the first scan sees the prior everywhere
    assert fresh.clutter_map is not ep.clutter_map and fresh.clutter_map.scans == 0
    (det,) = s.sense(fresh, 1, plan, 0.0)
    assert np.all(det.clutter_intensity == floor)


def test_sensor_with_the_map_off_gives_the_constant_prior_and_the_same_positions():
    off, on = _through_wall(**{"sensing.signal.clutter_map": False}), _through_wall(**ALL)
    plan = ScanPlan.all_listening(0, off.n_tx, off.n_rx)
    a, b = _episode(off, 7), _episode(on, 7)
    assert a.clutter_map is None
    for k in range(1, 25):
        (da,) = off.sense(a, k, plan, 0.0)
        (db,) = on.sense(b, k, plan, 0.0)
        np.testing.assert_array_equal(da.z, db.z)
        np.testing.assert_array_equal(da.R, db.R)
        assert np.all(da.clutter_intensity == off.sig.false_position_density_per_m2)
        assert np.all(db.clutter_intensity >= da.clutter_intensity)
        assert da.expected_false_alarms == db.expected_false_alarms


def test_still_count_weighs_only_couples_that_have_not_moved():
    s = _through_wall(**{"sensing.signal.clutter_map": True, "sensing.signal.clutter_map_count": "still"})
    ep = _episode(s, 0)
    bound = s.still_s * 299_792_458.0
    r0 = np.array([[2.57, 2.57], [5.0, 5.3]])
    tx = np.zeros(2, np.int64)
    assert s._still_couples(ep, r0, tx, True).tolist() == [0.0, 0.0]  # nothing before the first scan
    r1 = np.array([[2.57 + 0.9 * bound, 2.57 - 0.9 * bound], [5.0 + 1.5 * bound, 5.3]])
    assert s._still_couples(ep, r1, tx, True).tolist() == [1.0, 0.0]  # the static one, not the moved one
    assert s._still_couples(ep, np.zeros((0, 2)), np.zeros(0, np.int64), False).size == 0
    assert s._still_couples(ep, r1, tx, True).tolist() == [1.0, 1.0]  # an unobserved scan keeps the last couples
