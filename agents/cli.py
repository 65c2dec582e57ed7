"""Command lines: ``uwb-env-evaluate`` (:func:`evaluate_main`) and ``uwb-env-train`` (:func:`train_main`).

``scripts/evaluate.py`` and ``scripts/train.py`` call the same functions. The training command imports
stable-baselines3 and torch only when it runs, so the campaign command works without the ``rl`` extra.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
from collections.abc import Sequence
from typing import Any

import yaml

from uwb_env.agents.campaign import Campaign, run_campaign
from uwb_env.agents.presets import PRESETS
from uwb_env.agents.schedulers import scheduler_names
from uwb_env.agents.summary import summarise
from uwb_env.envs import ENV_IDS

EVALUATE_DOC = """Monte Carlo campaign: one environment x schemes x N seeded runs, paired by common random numbers.

    uwb-env-evaluate --preset seed003 --runs 100 --out results/seed003
    uwb-env-evaluate --env uwb_env/UrbanWaveform-v1 --schemes myopic round-robin random fixed-0 --baseline myopic

See ``uwb_env.agents.campaign`` for the output folder and the per-run metrics.
"""

TRAIN_DOC = """Train an RL scheduler (stable-baselines3 / sb3-contrib) on a registered uwb_env environment.

    uwb-env-train --env uwb_env/UrbanWaveform-v1 --algo maskable-ppo --timesteps 200000 --out runs/urban-mppo
    uwb-env-train --env uwb_env/UrbanWaveform-v1 --algo maskable-ppo --timesteps 400000 --out runs/urban-mppo --resume
    uwb-env-train --env uwb_env/IndoorJoint-v0 --algo dqn --timesteps 50000 --hyper learning_rate=3e-4 \\
        --env-kwarg fidelity=parametric --out runs/joint-dqn

Algorithms: ppo, a2c, dqn, maskable-ppo. Hyper-parameters come from the versioned preset
``agents/rl/presets/<Id>.yaml`` (``--hyper KEY=VALUE`` replaces an entry of the algorithm's block or of ``common``);
``--env-kwarg KEY=VALUE`` goes to ``gymnasium.make`` (dotted scenario overrides included). ``--resume`` continues
from the newest checkpoint up to ``--timesteps`` in total. Evaluate a trained run in a paired campaign with
``uwb-env-evaluate --schemes myopic rl:RUN_DIR ...``.
"""


def parse_overrides(items: Sequence[str], flag: str = "--set") -> dict[str, Any]:
    """``["a.b=1", ...]`` -> ``{"a.b": 1}``: values parsed as YAML, and ``1e-5`` (a string to YAML 1.1) as a float."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{flag} {item!r}: must be KEY=VALUE, e.g. sensing.clutter.density_per_m2=0")
        parsed = yaml.safe_load(value)
        if isinstance(parsed, str):
            try:
                parsed = float(parsed)
            except ValueError:
                pass
        out[key] = parsed
    return out


def evaluate_main(argv: Sequence[str] | None = None) -> None:
    """``uwb-env-evaluate``: run (or resume) a campaign and print its summary."""
    ap = argparse.ArgumentParser(description=EVALUATE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), help="a named campaign (env, schemes, baseline)")
    ap.add_argument("--env", help=f"one of {sorted(ENV_IDS)}")
    ap.add_argument("--schemes", nargs="+", help=f"SCHEDULER[@TRACKER]; schedulers {scheduler_names()}")
    ap.add_argument("--baseline", help="the scheme the others are compared with (default: the last scheme)")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="scenario override (dotted path), repeatable")  # fmt: skip
    ap.add_argument("--env-kwarg", dest="env_kwargs", action="append", default=[], metavar="KEY=VALUE",
                    help="env argument, e.g. include_lookahead=true (what an rl: agent was trained on)")  # fmt: skip
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("results/campaign"))
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    preset = PRESETS[args.preset] if args.preset else {}
    env = args.env or preset.get("env") or "uwb_env/UrbanWaveform-v1"
    schemes = args.schemes or preset.get("schemes") or ["myopic", "round-robin"]
    campaign = Campaign(
        env=env,
        schemes=tuple(schemes),
        baseline=args.baseline or (preset.get("baseline") if not args.schemes else None) or schemes[-1],
        runs=args.runs,
        seed0=args.seed0,
        overrides=parse_overrides(args.overrides),
        env_kwargs=parse_overrides(args.env_kwargs, "--env-kwarg"),
        title=preset.get("title", ""),
        reference=preset.get("reference", {}) if not args.schemes else {},
    )
    run_campaign(campaign, args.out, args.workers, progress=not args.no_progress)
    print(summarise(campaign, args.out))
    print(f"wrote {args.out}/summary.md, runs.csv and confirmed_tracks.png, position_rmse.png, model_probabilities.png")


def _pairs(items: list[str], flag: str) -> dict:
    try:
        return parse_overrides(items, flag)
    except ValueError as e:
        raise SystemExit(str(e)) from None


def train_main(argv: Sequence[str] | None = None) -> None:
    """``uwb-env-train``: train (or resume) an RL scheduler."""
    from uwb_env.agents.rl import ALGORITHMS, TrainConfig, train

    ap = argparse.ArgumentParser(description=TRAIN_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="uwb_env/UrbanWaveform-v1")
    ap.add_argument("--algo", default="maskable-ppo", choices=sorted(ALGORITHMS))
    ap.add_argument("--timesteps", type=int, default=100_000)
    ap.add_argument("--out", type=pathlib.Path, required=True)
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
    sys.exit(evaluate_main())
