"""Calls per second of the relative track slots (``envs.relative.relative_track_features``) against the absolute ones
(``envs.features.track_features``), both compiled, called from Python as ``UWBSchedulingEnv._observation`` does.

Run: python benchmarks/relative_features.py [--tracks 12] [--calls 20000] [--repeats 5]

The scene: 8 slots, 2 transmitters, 3 receivers (two with an array), all 6 (tx, rx) pairs formed, seed 003's four
models (ncv, nca, ct_left, ct_right); ``--tracks`` tracks with random states and positive definite covariances (seed
0). Medians (min, max) over ``--repeats`` after a warm-up call (numba compilation or cache load); the ratio is
relative / absolute calls per second.
"""

from __future__ import annotations

import argparse

import numpy as np
from timing import call_rate

from uwb_env.envs.features import track_features
from uwb_env.envs.relative import check_geometry, model_groups, relative_track_features

MODELS = ("ncv", "nca", "ct_left", "ct_right")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tracks", type=int, default=12)
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    n = args.tracks
    tx = np.array([[0.0, 0.0], [60.0, 10.0]])
    rx = np.array([[20.0, -15.0], [40.0, 30.0], [-10.0, 25.0]])
    boresight = np.array([1.2, -2.0, np.nan])
    pairs = np.array([(t, j) for t in range(2) for j in range(3)], np.int64)
    A = rng.normal(size=(n, 6, 6))
    P = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(6)
    x = rng.normal(scale=[20.0, 5.0, 20.0, 5.0, 1.0, 1.0], size=(n, 6))
    existence, confirmed = rng.uniform(size=n), rng.uniform(size=n) < 0.5
    mu = rng.dirichlet(np.ones(4), size=n)
    single_models, turn_pairs = model_groups(MODELS)
    check_geometry(tx, rx, boresight, pairs, 80.0, 15.0, 8)
    centre, half = np.array([25.0, 10.0]), np.array([50.0, 40.0])

    def relative():
        relative_track_features(
            existence, confirmed, mu, x, P, tx, rx, boresight, pairs, single_models, turn_pairs, 80.0, 15.0, 8
        )

    def absolute():
        track_features(existence, confirmed, mu, x, P, centre, half, 15.0, 8)

    rel = call_rate(relative, args.calls, args.repeats)
    ab = call_rate(absolute, args.calls, args.repeats)
    print(f"{n} tracks, 8 slots, 2 tx, 3 rx, 6 pairs, 4 models; calls/s median (min, max) over {args.repeats}")
    print(f"relative_track_features  {rel[0]:12,.0f}  ({rel[1]:,.0f}, {rel[2]:,.0f})")
    print(f"track_features           {ab[0]:12,.0f}  ({ab[1]:,.0f}, {ab[2]:,.0f})")
    print(f"ratio relative / absolute  {rel[0] / ab[0]:.2f}")


if __name__ == "__main__":
    main()
