r"""One-step lookahead: the expected cost of every scan plan after the next scan (seed 003 eq. 7), pure.

For the confirmed tracks, from the tracker's predicted state (IMM mixing + prediction to the next scan time,
combined), and for every candidate plan a:

    P_a <- P_pred
    for each formed pair (tx, rx) the plan uses, in the tracker's order:
        H       = C^T P_pred^-1                         statistical linearisation of the unscented transform
                                                         at the predicted state (action-independent, once per pair)
        R_a     = the waveform's covariance at the mean SNR of the predicted position (sensor model), DOA appended
        P_D,a   = the sensor model's detection probability there (capped like the tracker's)
        S       = H P_a H^T + R_a,   K = P_a H^T S^-1
        P_a    <- P_a - P_D,a q_2 K S K^T                  expected PDA posterior covariance
    cost_a = (1 / T) sum_t trace(P_a^(t) [position block])

Seed 003 evaluates (7) with the UKF covariance update (q_2 = 1, P_D = 1). We keep the detection probability
(the expected Riccati update of a filter that is updated with probability P_D) and write the information-reduction
factor q_2 of PDA in clutter (Kershaw and Evans) as an argument: ``q2 = 1`` (the default) is the seed's
clutter-free value. A calibrated q_2(P_D, clutter per gate) is not implemented yet.

The whole computation is batched over plans x tracks (numpy), draws nothing and changes no state.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking.kernels import linearised_h, symmetrise, ukf_moments
from uwb_env.tracking.measurement import angular_mask
from uwb_env.tracking.tracker import Tracker
from uwb_env.typing import FloatArray

POSITION = np.array([0, 2])


def expected_posterior(
    x: FloatArray,
    P: FloatArray,
    sensor: ParametricSensor,
    tracker: Tracker,
    plans: Sequence[ScanPlan],
    q2: float = 1.0,
) -> FloatArray:
    """Expected posterior covariances ``(A, N, 6, 6)`` of N predicted tracks ``x (N, 6)``, ``P (N, 6, 6)``."""
    A, N = len(plans), x.shape[0]
    Pa = np.broadcast_to(P, (A, N, 6, 6)).copy()
    if N == 0:
        return Pa
    cfg = tracker.cfg
    waveforms = np.array([p.waveform for p in plans])  # (A, T)
    listening = np.array([p.active_rx for p in plans])  # (A, R)
    pos = x[:, POSITION]
    for tx, rx in sensor.pairs.tolist():
        used = listening[:, rx]
        if not used.any():
            continue
        names = sensor.measurement_names(rx)
        _, _, C = ukf_moments(names, x, P, tracker.tx_pos[tx], tracker.rx_pos[rx], tracker.weights, angular_mask(names))
        H = linearised_h(P, C)  # (N, m, 6)
        wf = waveforms[:, tx]
        pd = np.zeros((A, N))
        R = np.zeros((A, N, len(names), len(names)))
        for w in np.unique(wf[used]).tolist():  # the waveforms the plans send: a small set
            pd_w, R_w = sensor.expected_measurement(tx, rx, pos, w, cfg.assumed_rcs_m2, cfg.assumed_swerling)
            sel = (wf == w) & used
            pd[sel] = np.minimum(pd_w, cfg.max_detection_probability)
            R[sel] = R_w
        PHt = Pa @ np.swapaxes(H, -1, -2)[None]  # (A, N, 6, m)
        S = H[None] @ PHt + R
        K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
        gain = (q2 * pd)[..., None, None]
        Pa = symmetrise(Pa - gain * (K @ np.swapaxes(PHt, -1, -2)))
    return Pa


def lookahead_costs(
    sensor: ParametricSensor,
    tracker: Tracker,
    plans: Sequence[ScanPlan],
    time_s: float,
    scan_index: int,
    q2: float = 1.0,
) -> FloatArray:
    """Expected mean position-covariance trace ``(A,)`` [m^2] over the confirmed tracks after the next scan.

    Zero for every plan when there is no confirmed track. Pure: no tracker state changes, no random draw.
    """
    pred = tracker.predicted(time_s, scan_index)
    keep = pred.confirmed
    if not keep.any():
        return np.zeros(len(plans))
    x, P = pred.select(keep).combined()
    Pa = expected_posterior(x, P, sensor, tracker, plans, q2)
    trace = Pa[..., 0, 0] + Pa[..., 2, 2]  # (A, N)
    return trace.mean(axis=1)
