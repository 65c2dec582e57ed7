"""Gymnasium environments of uwb_env (registered on ``import uwb_env``)."""

from uwb_env.envs.scheduling import ACTION_KINDS, UWBSchedulingEnv, enumerate_plans

ENV_IDS = {
    "uwb_env/UrbanWaveform-v3": {"scenario": "urban-intersection", "action_kind": "waveform"},
    "uwb_env/UrbanWideband-v2": {"scenario": "urban-intersection-wideband", "action_kind": "waveform"},
    "uwb_env/IndoorSensorSubset-v1": {"scenario": "indoor-rsn", "action_kind": "subset", "subset_size": 3},
    "uwb_env/IndoorJoint-v1": {"scenario": "indoor-rsn", "action_kind": "joint", "subset_size": 3},
    "uwb_env/IndoorSubsetWarmup-v1": {
        "scenario": "indoor-rsn",
        "action_kind": "subset",
        "subset_size": 3,
        "receiver_warmup": True,
    },
    "uwb_env/ThroughWall-v5": {"scenario": "through-wall", "action_kind": "waveform"},
    "uwb_env/UrbanDistributed-v0": {
        "scenario": "urban-distributed",
        "action_kind": "per-tx",
        "action_encoding": "flat",
        "track_frame": "relative",
    },
}
"""Registered ids and their default keyword arguments (``gymnasium.make(id, **kwargs)`` overrides them).

``UrbanWideband-v2`` adds two 160 MHz chirps to seed 003's library (``Discrete(8)``): range accuracy against the
range migration of fast vehicles, a trade-off that depends on each track's range-rate
(``uwb_env.scenarios.urban_intersection``).

``UrbanDistributed-v0`` is seed 003's intersection watched by two radar nodes whose transmitters each pick their own
chirp of eight every scan: ``Discrete(64)`` joint plans with ``action_masks()`` (the id's default, the space every
agent and test of the package takes), ``action_encoding="multi"`` gives ``MultiDiscrete([8, 8])`` (per-transmitter
masks, sb3-contrib's convention), decoding to the same plans (``uwb_env.scenarios.urban_distributed``). Its track
slots are relative to the nodes (``track_frame="relative"``, ``uwb_env.envs.relative``).

``IndoorSubsetWarmup-v1`` is the scenario where one-step lookahead is short-sighted (receiver warm-up,
``uwb_env.envs.scheduling``).

``ThroughWall-v5`` is seed 001's handheld radar (one transmitter between two receivers, 0.24 m before a 24 cm brick
wall, two persons behind it; ``uwb_env.scenarios.through_wall``): the action is the number of M-sequence periods
averaged per impulse response (``Discrete(3)``); its signal path is the seed's chain (exponential-averaging
background, advance normalization, CFAR, ToA association, wall compensation, two-ellipse intersection).

Version history:
    * ``ThroughWall-v5`` (issue 18): the tracker confirms a person within 10 scans (``TrackerConfig.
      tentative_max_age``, was seed 003's 5, set for vehicles detected in ~90 % of scans: a person's couples come in
      ~60 %, and about half of the persons' tentative tracks were deleted one or two scans short of confirmation;
      ``through_wall.PERSON_CONFIRMATION_SCANS``), and the signal path's running background starts on the room as it
      is at the episode's start (``SignalSensor.new_episode``: the static paths' scan-0 fluctuation, not their nominal
      gains, which left a burst of static couples in the first scans). Dynamics and rewards changed (both fidelities:
      the time-out is the tracker's), spaces unchanged, hence the bump.
    * ``ThroughWall-v4`` (issue 18): seed 001's exponential background averages with alpha 0.4 (was 0.9): a person
      shadowing a static path leaves a residue that now falls 8 dB a scan instead of 0.9, so it no longer masks the
      persons in the CFAR's window in rooms other than the scenario's (``through_wall`` module docstring,
      results/seed001/alphas.md); with it the signal path is the seed's chain again (no clutter map: the still
      couples' map now cost the persons their tracks), the ToA offset is re-measured (1.58 ns) and the couples'
      range errors take their white-equivalent stds (0.141 / 0.074 m: the errors' scan-to-scan correlation); the
      parametric path, whose MTI loss follows alpha, is recalibrated on the chain (Swerling III persons, gains
      -5.0 to -5.1 dB, false alarms per waveform, ``ImpulseWaveformConfig.false_alarm_factor``:
      results/calibration-through-wall). Dynamics and rewards changed (both fidelities), spaces unchanged, hence the
      bump.
    * ``ThroughWall-v3`` (issue 18): the tracker's NCV acceleration std is a walking person's, 2 m/s^2 (was seed
      003's 0.5 m/s^2: tracks fell behind a person turning back and were held > 1 m off,
      ``through_wall.PERSON_ACCEL_STD_MPS2``), and the signal path's clutter intensity is a clutter map of the couples
      that have not moved (``SignalConfig.clutter_map_count = "still"``: the static paths' residue no longer confirms
      ghost tracks). Dynamics and rewards changed (both fidelities), spaces unchanged, hence the bump.
    * ``ThroughWall-v2``: the parametric detector is the chain's interval ToA test's: Pfa the binomial tail
      P(Bin(15, 1e-2) >= 4) = 1.25e-5 per window (``through_wall.interval_test_pfa``; was the CFAR's per-sample
      1e-2) and Swerling I persons in the parametric detection test only (``SensingConfig.detection_swerling``; the
      signal path's scattering centres stay Swerling III), gain and residue refitted by binomial likelihood
      (results/calibration-through-wall). Dynamics and rewards changed (parametric path), spaces unchanged, hence the
      bump.
    * ``ThroughWall-v1``: the signal path's echoes keep their carrier phase (``SignalConfig.coherent_echoes``), so seed
      001's exponential background cancels a still target (``uwb_env.channel.background_mti``); the parametric model
      takes that loss on the echo's SNR and is recalibrated on the chain (results/calibration-through-wall: max |dPd|
      0.040 / 0.048 / 0.038); tracks above 2 m position std are deleted. Dynamics and rewards changed, spaces
      unchanged, hence the bump.
    * ``UrbanWideband-v2``: false alarms per waveform (``ClutterConfig.reference_bandwidth_hz`` = 40 MHz: the 160 MHz
      chirps draw 4x the seed's density, and their clutter map, which the tracker and the lookahead read, is 4x), and
      the signal chain caps its peaks per image cell (``ChirpSignalConfig.scale_max_peaks``), and the parametric Pd
      sees a walked echo's ridge (``ParametricSensor.detection_migration_gain``: the 160 MHz chirps' range walk
      costs detection about half the peak's loss in dB), with which the parametric Pd of the 160 MHz chirps matches
      the chain (``results/calibration-urban-wideband/report.md``).
      Dynamics and rewards changed, spaces unchanged, hence the bump; ``UrbanWaveform-v3`` is unchanged (its 40 MHz
      library keeps every draw).
    * ``UrbanWaveform-v3``, ``UrbanWideband-v1`` (issue 15): the parametric Pd of the chirp scenarios is what the
      signal detector does: the echo's own test OR a noise peak in the truth-matching window,
      1 - (1 - Pd_echo) (1 - Pfa)^n with n = 61.9 cells derived from the window (2 x 2 resolution cells, 4 x 4 image
      cells each, 3 beams) and the chain's noise-peak density (``SensingConfig.noise_window_cells``,
      ``uwb_env.scenarios.urban_intersection.noise_window_cells``), and the detector gain refitted with it, 1.30 ->
      0.80 dB (``results/calibration-urban/report.md``: max |dPd| 0.014-0.023 per waveform, was 0.041-0.067). Pd
      (so the dynamics, the lookahead and the rewards) changed, spaces unchanged, hence the bump; results made on
      ``-v2`` / ``-v0`` keep their names.
    * ``IndoorSensorSubset-v1``, ``IndoorJoint-v1``, ``IndoorSubsetWarmup-v1`` (issue 18): indoor-rsn's person is the
      extended body of scattering centres (``signal.target_model = "extended"``) and the parametric detector, the
      ids' default fidelity, is recalibrated on it (Swerling III body against the signal path's fluctuating centres,
      ``uwb_env.scenarios.indoor_rsn``): Pd and so the dynamics and rewards changed, spaces unchanged, hence the bump.
      Results made on the ``-v0`` ids (results/warmup-*) keep their names.
    * ``UrbanWaveform-v2`` and the new ``UrbanWideband-v0``: the pulse train's range walk across the dwell, which
      seed 003's filter does not follow, in the parametric model (``uwb_env.waveforms.chirp``: the peak's power loss
      in Pd, its accuracy loss in R; at most 0.8 dB for the seed's 40 MHz chirps at 20 m/s), and the urban
      calibration refitted with it (detector gain 1.30 dB, vegetation residue 4.2 %). Spaces unchanged; dynamics and
      rewards changed, hence the bump.
    * Issue 16, in place on every id (the observation ``Box``, the action spaces, the dynamics and the rewards are
      unchanged, so the ids are not bumped and trained policies still load and act the same): the scenario's horizon
      ends an episode by truncation (``truncated=True``, ``terminated=False``; it was ``terminated=True``, with no
      time in the observation); ``info`` has the same keys and shapes at every step and at ``reset``
      (``position_errors_m`` padded with 0 to the scenario's target count, plus ``position_errors_count``), so vector
      envs can stack it; the ``Dict`` observation keeps the ``Box``'s part order (it was sorted by key);
      ``out_of_service_rx`` / ``unavailable_waveforms`` make ``action_masks()`` mask plans; ``render()`` returns None
      in ``human`` mode and titles the frame with the plan; every keyword is type-checked. The scenarios' new
      measurement-variance floor (``sensing.min_range_std_m``, 50 um) changes a reward only where an echo's range
      CRLB falls below it: none at the registered ids' configured powers outdoors, rare scans of a person next to a
      receiver indoors.
    * ``UrbanWaveform-v1``: seed 003's regime (range + range-rate per receiver, SNR 0.2 per pulse and element), the
      pulse train's measurement model (precise, folded range-rate), six chirps (``Discrete(6)``: the seed's four and
      two at a 7 ms PRI), DFT receive beams, the vegetation's zero-Doppler residue and multipath ghosts calibrated on
      the chirp signal path, and a signal fidelity (``fidelity="signal"``).
    * ``UrbanWaveform-v0``: ``Discrete(4)``, azimuth measured, single-pulse chirp bound, 22-50 dB SNR."""


# ------------------------------------------------------------------ scene families (issue 20, item 3)
FAMILY_ENV_IDS = {
    "uwb_env/UrbanFamily-v0": {
        "family": "urban-intersection",
        "split": "train",
        "action_kind": "waveform",
        "track_frame": "relative",
    },
    "uwb_env/UrbanWidebandFamily-v0": {
        "family": "urban-intersection-wideband",
        "split": "train",
        "action_kind": "waveform",
        "track_frame": "relative",
    },
}
"""Scene-family ids (``uwb_env.envs.family.SceneFamilyEnv``): every episode a variant of seed 003's intersection
(D4 orientation, left / straight / right path, 1-3 vehicles, jittered births; ``uwb_env.scenarios.families``) drawn by
the reset seed from ``split`` (``train`` by default; ``gymnasium.make(id, split="heldout")`` for the held-out cells,
``"all"`` for every cell). They are in :data:`ENV_IDS` (so training and campaigns take them) with their own entry
point and no batched ``vector_entry_point`` (Gymnasium's sync / async vector envs and SB3's work). Their track slots
are relative to the nodes (``track_frame="relative"``, ``uwb_env.envs.relative``: the same numbers for a scene and its
rotated or mirrored copy), so a policy trained on some variants reads the others in the same terms; to play a
family-trained policy on a plain id, give that id ``track_frame="relative"`` too."""
ENV_IDS.update(FAMILY_ENV_IDS)
# ------------------------------------------------------------------ end of scene families


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS` with gymnasium (idempotent).

    Each id has a ``vector_entry_point``: ``gymnasium.make_vec(id, num_envs=N, vectorization_mode=
    "vector_entry_point")`` gives the batched ``uwb_env.envs.vector.UWBVectorEnv``.
    The scene-family ids (:data:`FAMILY_ENV_IDS`) are ``SceneFamilyEnv``'s, without a ``vector_entry_point``.
    """
    import gymnasium as gym

    for env_id, kwargs in FAMILY_ENV_IDS.items():  # scene families: their own entry point
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="uwb_env.envs.family:SceneFamilyEnv", kwargs=dict(kwargs))
    for env_id, kwargs in ENV_IDS.items():
        if env_id in FAMILY_ENV_IDS:  # registered above
            continue
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point="uwb_env.envs.scheduling:UWBSchedulingEnv",
                vector_entry_point="uwb_env.envs.vector:UWBVectorEnv",
                kwargs=dict(kwargs),
            )


__all__ = ["ACTION_KINDS", "ENV_IDS", "UWBSchedulingEnv", "enumerate_plans", "register_envs"]
