"""``urban-distributed``: seed 003's intersection watched by two radar nodes whose transmitters pick their own chirps.

Seed 003's conclusion names the open problem: coordinated scheduling of distributed transmitters that need not send
the same waveform. The scene is ``urban-intersection``'s (buildings, vegetation, clutter, the two vehicles' left
turn, 140 scans of 0.25 s) with the eight-chirp library of ``urban-intersection-wideband`` (the seed's four at a
10 ms PRI, the up-sweeps at 7 ms, and the long up-chirp at 160 MHz at both PRIs; false alarms per waveform,
``ClutterConfig.reference_bandwidth_hz`` = 40 MHz) and the seed's regime (range + range-rate per receiver, the
vegetation's residue and the multipath ghosts calibrated on the chirp chain).

Nodes (our choice; the seed has one transmitter). Each node is a transmitter with two 3-element receive arrays
beside it, as the seed's:
    * south-east (the seed's node): tx-se at (2085, 1470.5), rx-se1 (2088, 1475), rx-se2 (2078, 1467), boresight
      130 deg. It sees the whole path (the west arm along the street, the turn, the north arm), but the north arm
      at 60-200 m, nearly along its line of sight: there its two receivers, 12 m apart, resolve range and not
      cross-range.
    * north-west: tx-nw at (2040, 1715) on the west sidewalk of the north arm, north-west of the intersection,
      rx-nw1 (2037, 1710.5), rx-nw2 (2047, 1718.5) (the seed node's offsets turned by 180 deg), boresight 280 deg
      (looking back down the north arm towards the intersection). The north-west block hides the west arm from it;
      it sees the turn and the north arm, from the other end, so its ellipses cross the south-east node's at large
      angles there, and the receding-from-one-node vehicle approaches the other (range-rates of opposite sign:
      the best PRI and bandwidth differ per node). While vehicle 1 drives the north arm (t = 20-35 s) vehicle 2 is
      on the west arm or in the turn: each transmitter has its own vehicle to serve.
    * Formed pairs: each transmitter with its own node's two receivers (4 pairs, ``ScenarioConfig.pairs``). A
      cross-node pair (tx-se to rx-nw, 250 m apart) would need the two nodes' clocks synchronised to a fraction of
      the 25 ns range cell and their carriers coherent across the 0.25 s dwell (the range-rate), which separate
      nodes do not share without a common reference; and on this path it would see the north arm near its
      baseline, in the direct path's blind zone (bistatic range within 7.5 m of the baseline): with every
      combination formed, the cross pairs covered 16-25 of the 140 scans (the turn's entry), while adding their
      false alarms and 3-tuples to the range-only initiation.
    * Power: each transmitter's peak power puts its short chirp's one-pulse, one-element E/N0 at the seed's 0.2
      (-7.0 dB) on the median of its covered links with its own node's receivers along the path
      (``SEED_REGIME_POWER_DBM`` = 4.5 dBm for the seed's node, as in ``urban-intersection``: -6.97 dB;
      :data:`NW_POWER_DBM` = 21.1 dBm for the north-west node: -7.01 dB; ``median_pulse_snr_db``, checked by
      tests/test_distributed.py). The north-west node needs 16.6 dB more: most of its covered links are the vehicles
      in the turn and the south of the north arm, 150-215 m away, against ~100 m for the seed's node; as the vehicles
      drive towards it its scan SNR climbs by ~23 dB (the radar equation's R^-4), as the seed node's spans ~30 dB.

Multiple access: the transmitters' pulse trains are interleaved in time within the scan. A pulse lasts at most
1.4 us and its echoes arrive within 2 us (600 m of bistatic range), against PRIs of whole milliseconds (7 and 10 ms),
so with the north-west train offset by 0.5 ms every pulse of one train lies an odd multiple of 0.5 ms from every
pulse of the other (0.5 + 10 i - 7 j is never within 2 us of 0) and each receiver gates every
transmitter's echoes by that transmitter's pulse times. Every (tx, rx) pair therefore forms its own delay-Doppler
image from its own transmitter's train: its Pd, accuracy R, range-rate period and false alarms are those of the
waveform its transmitter sends (``ParametricSensor.sense``: each transmitter's target rows from its waveform's draws,
each false alarm measured through, and thinned by, the waveform of its pair's transmitter; all pre-drawn per pair,
so plans stay paired under common random numbers). The signal fidelity does the same (``ChirpSignalSensor.scan``
forms each pair's image with its transmitter's waveform, pairs grouped by waveform); nothing of one transmitter's
train leaks into another's image (the offset is larger than any echo delay).

The action is the waveform of every transmitter (``UWBSchedulingEnv(action_kind="per-tx")``, W^T = 64 plans,
``uwb_env/UrbanDistributed-v0``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from uwb_env.config import ReceiverConfig, ScenarioConfig, TransmitterConfig
from uwb_env.scenarios import register
from uwb_env.scenarios.urban_intersection import SEED_REGIME_POWER_DBM, urban_intersection_wideband

NW_POWER_DBM = 21.1
"""Peak power of the north-west transmitter [dBm]: its short chirp's one-pulse, one-element E/N0 is the seed's 0.2
on the median of its covered links (``median_pulse_snr_db``, seeds 0-2: module docstring)."""

SE_NODE = {"tx": (2085.0, 1470.5), "rx": ((2088.0, 1475.0), (2078.0, 1467.0)), "boresight_deg": 130.0}
NODE_RECEIVERS = ((0, 1), (2, 3))
"""The receivers of each transmitter's own node (the co-located arrays; the other pairs are cross-node)."""
NW_NODE = {"tx": (2040.0, 1715.0), "rx": ((2037.0, 1710.5), (2047.0, 1718.5)), "boresight_deg": 280.0}


@register("urban-distributed")
def urban_distributed() -> ScenarioConfig:
    """Seed 003's intersection with two transmitters (south-east, north-west), four receivers and eight chirps."""
    base = urban_intersection_wideband()
    array = base.receivers[0].array
    assert array is not None
    nodes = (("se", SE_NODE, SEED_REGIME_POWER_DBM), ("nw", NW_NODE, NW_POWER_DBM))
    transmitters = tuple(TransmitterConfig(f"tx-{n}", node["tx"], power_dbm=p) for n, node, p in nodes)
    receivers = tuple(
        ReceiverConfig(
            f"rx-{n}{i + 1}",
            pos,
            noise_figure_db=base.receivers[0].noise_figure_db,
            array=dataclasses.replace(array, boresight_deg=node["boresight_deg"]),
        )
        for n, node, _ in nodes
        for i, pos in enumerate(node["rx"])
    )
    return dataclasses.replace(
        base,
        name="urban-distributed",
        description=(
            "Seed 003's intersection watched by two radar nodes (south-east, north-west), each transmitter choosing "
            "its own chirp of eight every scan."
        ),
        seed_reference="003 (closed-loop active sensing in urban terrain), section V, Fig. 3; its conclusion's "
        "distributed transmitters",
        transmitters=transmitters,
        receivers=receivers,
        pairs=tuple((t, r) for t, own in enumerate(NODE_RECEIVERS) for r in own),
    )


def median_pulse_snr_db(
    cfg: ScenarioConfig,
    node_receivers: tuple[tuple[int, ...], ...] = NODE_RECEIVERS,
    seeds: tuple[int, ...] = (0, 1, 2),
) -> np.ndarray:
    """``(T,)`` each transmitter's median one-pulse, one-element E/N0 [dB] of waveform 0 over its node's links.

    The seed's "SNR experienced is 0.2" (``uwb_env.scenarios.urban_intersection``): the scan SNR of the steered
    array (its full coherent gain L divided out) over the pulses per scan, at the targets' mean RCS, over every
    covered (scan, receiver, target) link of transmitter t with its own node's receivers ``node_receivers[t]`` in
    the seeded episodes (the truth's draws; the path is the same in every episode).
    """
    from uwb_env.rng import RngStreams
    from uwb_env.scene import sample_truth
    from uwb_env.sensing import ParametricSensor

    steered = ParametricSensor(
        dataclasses.replace(cfg, sensing=dataclasses.replace(cfg.sensing, array_beams="steered"))
    )
    n_el = np.array([r.array.n_elements if r.array else 1 for r in cfg.receivers], dtype=float)
    n_pulses = cfg.waveforms[0].n_pulses  # type: ignore[union-attr]
    per_tx: list[list[np.ndarray]] = [[] for _ in cfg.transmitters]
    for seed in seeds:
        truth = sample_truth(cfg, RngStreams.from_seed(seed).truth, steered.layout)
        geom = steered.episode_geometry(truth)  # unit_snr, covered (S, T, R, K)
        snr = steered.radar_constant[0][None, :, :, None] * geom.unit_snr / (n_pulses * n_el[None, None, :, None])
        for t in range(len(cfg.transmitters)):
            own = list(node_receivers[t])
            per_tx[t].append(snr[:, t][:, own][geom.covered[:, t][:, own]])
    return np.array([10.0 * np.log10(np.median(np.concatenate(v))) for v in per_tx])
