"""Train an RL scheduler (stable-baselines3 / sb3-contrib) on a registered uwb_env environment.

Usage:
    uwb-env-train --env uwb_env/UrbanWaveform-v1 --algo maskable-ppo --timesteps 200000 --out runs/urban-mppo
    uwb-env-train --env uwb_env/UrbanWaveform-v1 --algo maskable-ppo --timesteps 400000 --out runs/urban-mppo --resume
    uwb-env-train --env uwb_env/IndoorJoint-v0 --algo dqn --timesteps 50000 --hyper learning_rate=3e-4 \\
        --env-kwarg fidelity=parametric --out runs/joint-dqn

Algorithms: ppo, a2c, dqn, maskable-ppo. Hyper-parameters come from the versioned preset
``agents/rl/presets/<Id>.yaml`` (``--hyper KEY=VALUE`` replaces an entry of the algorithm's block or of ``common``);
``--env-kwarg KEY=VALUE`` goes to ``gymnasium.make`` (dotted scenario overrides included). The run directory gets
checkpoints (model, normaliser, replay buffer), ``progress.csv`` (SB3's logger), ``eval.csv`` (the policy against
the myopic and round-robin schedulers on fixed evaluation seeds), the final ``model.zip`` and ``vecnormalize.pkl``.
``--resume`` continues from the newest checkpoint up to ``--timesteps`` in total. Evaluate a trained run in a paired
campaign with ``uwb-env-evaluate --schemes myopic rl:RUN_DIR ...``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from agents.rl import ALGORITHMS, TrainConfig, train
from scripts.evaluate import parse_overrides


def _pairs(items: list[str], flag: str) -> dict:
    try:
        return parse_overrides(items, flag)
    except ValueError as e:
        raise SystemExit(str(e)) from None


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="uwb_env/UrbanWaveform-v1")
    ap.add_argument("--algo", default="maskable-ppo", choices=sorted(ALGORITHMS))
    ap.add_argument("--timesteps", type=int, default=100_000)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--resume", action="store_true", help="continue from the newest checkpoint in --out")
    ap.add_argument("--hyper", nargs="*", default=[], metavar="KEY=VALUE")
    ap.add_argument("--env-kwarg", nargs="*", default=[], metavar="KEY=VALUE")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    cfg = TrainConfig(
        env_id=args.env,
        algo=args.algo,
        timesteps=args.timesteps,
        out=args.out,
        seed=args.seed,
        env_kwargs=_pairs(args.env_kwarg, "--env-kwarg"),
        overrides=_pairs(args.hyper, "--hyper"),
    )
    model = train(cfg, resume=args.resume, progress=not args.no_progress)
    print(f"trained {args.algo} on {args.env}: {model.num_timesteps} steps; run in {args.out}/")


if __name__ == "__main__":
    main()
