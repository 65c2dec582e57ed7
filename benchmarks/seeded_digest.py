"""Digest of seeded myopic episodes (observations, rewards, infos, tracker state, lookahead costs), for before/after.

Run: python benchmarks/seeded_digest.py [--episodes N] [--envs ID ...] [--out FILE]

Prints one SHA-256 per env over every step's observation, reward, info, the lookahead costs the myopic scheduler
saw and the tracker's whole state (tracks, candidates, next id), byte for byte; ``--out`` also pickles the raw
records so two trees' runs can be diffed step by step. Run it on two trees (``PYTHONPATH=<tree>``) and compare:
a speed-up must leave every digest unchanged.
"""

from __future__ import annotations

import argparse
import hashlib
import pickle

import gymnasium as gym
import numpy as np

import uwb_env  # noqa: F401
from uwb_env.agents import make_scheduler


def _bytes(v: object) -> bytes:
    if isinstance(v, np.ndarray):
        return str(v.dtype).encode() + str(v.shape).encode() + np.ascontiguousarray(v).tobytes()
    if isinstance(v, dict):
        return b"{" + b"".join(k.encode() + b":" + _bytes(v[k]) for k in sorted(v)) + b"}"
    if isinstance(v, (list, tuple)):
        return b"[" + b"".join(_bytes(x) for x in v) + b"]"
    if isinstance(v, (float, np.floating)):
        return np.float64(v).tobytes()
    return repr(v).encode()


def _tracker_state(tr: object) -> dict:
    out = {}
    t = tr.tracks
    for f in ("ids", "confirmed", "age", "born", "existence", "mu", "active", "x", "P"):
        if hasattr(t, f):
            out[f] = np.asarray(getattr(t, f))
    prev = getattr(tr, "_previous", None)
    if prev is not None and hasattr(prev, "p"):
        out["prev_p"], out["prev_cov"], out["prev_t"] = prev.p, prev.cov, prev.time_s
    out["next_id"] = getattr(tr, "_next_id", None)
    return out


def run(env_id: str, episodes: int) -> tuple[str, list]:
    env = gym.make(env_id)
    agent = make_scheduler("myopic")
    h = hashlib.sha256()
    records = []
    for seed in range(episodes):
        obs, info = env.reset(seed=seed)
        agent.reset(seed)
        h.update(_bytes(obs) + _bytes(info))
        done = False
        while not done:
            costs = env.unwrapped.lookahead_costs()
            a = agent.act(obs, env)
            obs, r, term, trunc, info = env.step(a)
            done = term or trunc
            rec = {
                "a": int(a), "obs": obs, "r": r, "info": info, "costs": costs,
                "tracker": _tracker_state(env.unwrapped.sim.tracker),
            }  # fmt: skip
            h.update(_bytes(rec))
            records.append(rec)
    return h.hexdigest(), records


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--envs", nargs="+", default=["uwb_env/UrbanWaveform-v3", "uwb_env/UrbanWideband-v2"])
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    allrec = {}
    for env_id in args.envs:
        digest, records = run(env_id, args.episodes)
        allrec[env_id] = records
        print(f"{env_id} {args.episodes} episodes {len(records)} steps sha256 {digest}")
    if args.out:
        with open(args.out, "wb") as f:
            pickle.dump(allrec, f)


if __name__ == "__main__":
    main()
