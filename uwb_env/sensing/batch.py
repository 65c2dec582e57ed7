"""One scan of several episodes of one parametric sensor at once (the batched vector env, ``uwb_env.envs.vector``).

``sense_many`` gives, episode by episode, what ``ParametricSensor.sense`` gives: each episode's rows of the scan are
selected as ``sense`` selects them, then every episode's rows are sorted (by episode, pair, range), given their
covariances and split per pair in one pass. Plans whose transmitters send different waveforms (or a waveform
without a 1/SNR covariance) go through ``sense`` itself.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from uwb_env.sensing.parametric import _KEY_SPAN, EpisodeSensing, ParametricSensor, _columns
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.typing import FloatArray, IntArray


def sense_many(
    sensor: ParametricSensor,
    episodes: Sequence[EpisodeSensing],
    scans: IntArray,
    plans: Sequence[ScanPlan],
    times_s: FloatArray,
) -> list[tuple[Detections, ...]]:
    """``[sensor.sense(episodes[j], scans[j], plans[j], times_s[j]) for j]``, batched (module docstring)."""
    m = sensor.library.measurement_dim
    col = _columns(m)
    out: list[tuple[Detections, ...] | None] = [None] * len(episodes)
    parts, sizes, batch, waveform = [], [], [], []
    for j, (ep, k, plan) in enumerate(zip(episodes, scans.tolist(), plans, strict=True)):
        all_active, w0, single, _ = sensor._validate(plan)
        if not single:
            out[j] = sensor.sense(ep, k, plan, float(times_s[j]))
            continue
        target_rows, clutter_rows = sensor.single_waveform_rows(ep, k, w0, plan.active_rx, all_active)
        parts += [target_rows, clutter_rows]
        sizes.append(target_rows.shape[0] + clutter_rows.shape[0])
        batch.append(j)
        waveform.append(w0)
    if not batch:
        return out  # type: ignore[return-value]
    rows = np.concatenate(parts)
    env = np.repeat(np.arange(len(batch)), sizes)
    order = np.lexsort((rows[:, 0] * _KEY_SPAN + rows[:, 1], env))  # episode, then pair and range as sense sorts
    rows, env = rows.take(order, axis=0), env[order]
    w = np.asarray(waveform, np.int64)[env]
    snr = rows[:, col["snr"]]
    unit = np.stack([sensor._unit_cov[v] if sensor._unit_cov[v] is not None else np.zeros((m, m))
                     for v in range(len(sensor.library))])  # fmt: skip
    cov = unit[w] / np.minimum(snr, sensor._snr_cap[w])[:, None, None]
    if m == 2 and sensor._migration is not None:  # the range walk's accuracy loss (target rows; 0 means 1)
        d = np.sqrt(np.maximum(rows[:, [col["walk_r"], col["walk_d"]]], 1.0))
        cov = cov * d[:, :, None] * d[:, None, :]
    n_pairs = len(sensor._pair_list)
    keys = env * float(n_pairs) + rows[:, 0]  # small integers: exact
    bounds = np.searchsorted(keys, (np.arange(len(batch))[:, None] * n_pairs + sensor._pair_index[None]).ravel())
    bounds = np.append(bounds, rows.shape[0]).tolist()
    origin = rows[:, col["origin"]].astype(np.int64)
    n_tx = sensor.n_tx
    for i, (j, w0) in enumerate(zip(batch, waveform, strict=True)):
        pair_bounds = bounds[i * n_pairs : (i + 1) * n_pairs + 1]
        out[j] = sensor.pair_records(rows, cov, snr, origin, pair_bounds, plans[j].active_rx, [w0] * n_tx,
                                     float(times_s[j]))  # fmt: skip
    return out  # type: ignore[return-value]
