"""Command lines: ``uwb-env-evaluate`` (:func:`evaluate_main`) and ``uwb-env-train`` (:func:`train_main`).

``scripts/evaluate.py`` and ``scripts/train.py`` call the same functions. The training command imports
stable-baselines3 and torch only when it runs, so the campaign command works without the ``rl`` extra.

Conventions shared by both commands:

* ``KEY=VALUE`` options (``--set``, ``--env-kwarg``, ``--hyper``) accumulate: ``--set a=1 --set b=2`` and
  ``--set a=1 b=2`` mean the same; a key given twice is refused (which one was meant is not clear).
* Counts are checked by their argparse type (``--runs``, ``--workers``, ``--timesteps`` >= 1, seeds >= 0), and
  every error (a bad argument, a damaged file, a folder in use) exits with status 2 and one line naming the
  field or file, the value and what is allowed. Nothing is written before every argument has been checked.
* Ctrl-C (or SIGTERM) during a campaign stops its workers at once and writes the summary of the finished paired
  runs; the exit status is 130 and running the same command again resumes.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import signal
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

import yaml

from uwb_env.agents.campaign import BACKENDS, Campaign
from uwb_env.agents.multiseed import expand_seed_schemes
from uwb_env.agents.presets import PRESETS
from uwb_env.agents.schedulers import scheduler_names
from uwb_env.agents.storage import FolderLocked
from uwb_env.agents.summary import CampaignInterrupted, evaluate
from uwb_env.envs import ENV_IDS

EVALUATE_DOC = """Monte Carlo campaign: one environment x schemes x N seeded runs, paired by common random numbers.

    uwb-env-evaluate --preset seed003 --runs 100 --out results/seed003
    uwb-env-evaluate --env uwb_env/UrbanWaveform-v3 --schemes myopic round-robin random fixed-0 --baseline myopic

See ``uwb_env.agents.campaign`` for the output folder and the per-run metrics.
"""

TRAIN_DOC = """Train an RL scheduler (stable-baselines3 / sb3-contrib) on a registered uwb_env environment.

    uwb-env-train --env uwb_env/UrbanWaveform-v3 --algo maskable-ppo --timesteps 200000 --out runs/urban-mppo
    uwb-env-train --env uwb_env/UrbanWaveform-v3 --algo maskable-ppo --timesteps 400000 --out runs/urban-mppo --resume
    uwb-env-train --env uwb_env/IndoorJoint-v1 --algo dqn --timesteps 50000 --hyper learning_rate=3e-4 \\
        --env-kwarg fidelity=parametric --out runs/joint-dqn

Several training seeds (what rliable-style reporting needs; each seed's run is exactly a single run's):

    uwb-env-train --env uwb_env/UrbanWaveform-v3 --timesteps 200000 --seeds 5 --out runs/urban-mppo-5
    uwb-env-evaluate --schemes myopic rl:runs/urban-mppo-5 --baseline myopic --env-kwarg include_lookahead=true

``--seeds N`` trains seeds ``--seed`` .. ``--seed + N - 1`` (default 0 .. N - 1) one after another into
``OUT/seed-<s>/``, skips seeds whose run finished (run it again to continue a stopped job; add ``--resume`` to
continue a seed interrupted mid-run, or to extend every seed to a larger ``--timesteps``), then plots
``OUT/learning_curves.png`` (IQM across seeds, 95 % stratified-bootstrap band, myopic and round-robin; also
``python scripts/learning_curves.py OUT``). In a campaign ``rl:OUT`` stands for every seed's run; the summary
reports each seed, the IQM across seeds with its bootstrap interval and the probability of improvement over the
baseline.

Algorithms: ppo, a2c, dqn, maskable-ppo. Hyper-parameters come from the versioned preset
``agents/rl/presets/<Id>.yaml`` (``--hyper KEY=VALUE`` replaces an entry of the algorithm's block or of ``common``);
``--env-kwarg KEY=VALUE`` goes to ``gymnasium.make`` (dotted scenario overrides included). ``--resume`` continues
from the newest checkpoint up to ``--timesteps`` in total. Evaluate a trained run in a paired campaign with
``uwb-env-evaluate --schemes myopic rl:RUN_DIR ...``.

Behaviour-cloning warm start (actor-critic algorithms): ``--hyper bc_steps=20000`` fits the policy and its critic to
that many steps of a scheduler's episodes before PPO (``bc_scheduler=myopic`` by default, ``bc_epochs=20``;
``agents/rl/imitation.py``; ``bc.yaml`` in the run folder records the agreement). With the lookahead costs observed
(``--env-kwarg include_lookahead=true``) and ``learning_rate=1e-4 ent_coef=0.0`` it is the README's urban recipe.

With ``--engine rllib`` (the ``ray`` extra; RLlib's new API stack, ``agents/rl/rllib_engine.py``):

    uwb-env-train --engine rllib --env uwb_env/IndoorSensorSubset-v1 --algo ppo --timesteps 20000 \
        --env-runners 2 --envs-per-runner 2 --out runs/subset-rllib
    uwb-env-train --engine rllib --address auto ...     # on a cluster started with ray start --head

Algorithms: ppo and dqn, both masking the env's invalid actions. ``--hyper`` takes RLlib's names (lr, gamma, lambda_,
train_batch_size_per_learner, fcnet_hiddens, eval_episodes, ...); the defaults translate the SB3 preset.
Checkpoints every ``--checkpoint-every`` iterations and at the end; evaluate with ``--schemes rllib:RUN_DIR``.
"""


RL_INSTALL = 'pip install torch==2.13.0 (a CPU build is on disk on these machines), then pip install -e ".[rl]"'
ALGORITHM_NAMES = ("a2c", "dqn", "maskable-ppo", "ppo")  # agents.rl.ALGORITHMS, named here to parse without torch
ENGINES = ("sb3", "rllib")  # --engine: stable-baselines3 (agents.rl.training) or RLlib (agents.rl.rllib_engine)


def parse_overrides(items: Sequence[str], flag: str = "--set") -> dict[str, Any]:
    """``["a.b=1", ...]`` -> ``{"a.b": 1}``: values parsed as YAML, and ``1e-5`` (a string to YAML 1.1) as a float.

    Raises ``ValueError`` naming the flag and the item for a missing ``=`` or key, a key given twice, or a value
    that is not YAML.
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"{flag} {item!r}: must be KEY=VALUE, e.g. sensing.clutter.density_per_m2=0")
        key = key.strip()
        if key in out:
            raise ValueError(f"{flag} {item!r}: key {key!r} is given twice (give each key once)")
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError as e:
            why = getattr(e, "problem", None) or type(e).__name__
            raise ValueError(f"{flag} {item!r}: the value {value!r} is not valid YAML ({why})") from None
        if isinstance(parsed, str):
            try:
                parsed = float(parsed)
            except ValueError:
                pass
        out[key] = parsed
    return out


def count(minimum: int):
    """An argparse type: an integer >= ``minimum``, with a message naming the value and the range."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer (must be >= {minimum})") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} must be >= {minimum}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


def folder(text: str) -> pathlib.Path:
    """An argparse type: a folder path (existing or not), not an existing file."""
    path = pathlib.Path(text)
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path (must be a folder)")
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a file (must be a folder, existing or new)")
    return path


def add_pairs(ap: argparse.ArgumentParser, flag: str, dest: str, help: str) -> None:
    """A ``KEY=VALUE`` option that takes one or more pairs and may be repeated (the pairs accumulate)."""
    ap.add_argument(flag, dest=dest, action="extend", nargs="+", default=[], metavar="KEY=VALUE", help=help)


def _interrupt(signum: int, frame: object) -> NoReturn:
    raise KeyboardInterrupt


def evaluate_parser() -> argparse.ArgumentParser:
    """The arguments of ``uwb-env-evaluate``."""
    ap = argparse.ArgumentParser(
        prog="uwb-env-evaluate", description=EVALUATE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--preset", choices=sorted(PRESETS), help="a named campaign (env, schemes, baseline)")
    ap.add_argument("--env", choices=sorted(ENV_IDS), help="the registered env id")
    ap.add_argument("--schemes", nargs="+", help=f"SCHEDULER[@TRACKER]; schedulers {scheduler_names()}")
    ap.add_argument("--baseline", help="the scheme the others are compared with (default: the last scheme)")
    ap.add_argument("--runs", type=count(2), default=20, help="paired runs (seeds) per scheme, >= 2")
    ap.add_argument("--seed0", type=count(0), default=0, help="the first episode seed, >= 0")
    add_pairs(ap, "--set", "overrides", "scenario override (dotted path); repeatable, several per flag")
    add_pairs(ap, "--env-kwarg", "env_kwargs", "env argument, e.g. include_lookahead=true; repeatable")
    ap.add_argument("--workers", type=count(1), default=os.cpu_count() or 1, help="worker processes, >= 1")
    ap.add_argument(
        "--backend", choices=BACKENDS, default="local", help="local process pool, or one Ray task per run (.[ray])"
    )
    ap.add_argument("--address", help="with --backend ray: a Ray cluster to join (auto, ray://host:10001); none: local")
    ap.add_argument("--out", type=folder, default=pathlib.Path("results/campaign"), help="the campaign's folder")
    ap.add_argument("--no-progress", action="store_true")
    return ap


def campaign_from_args(args: argparse.Namespace) -> Campaign:
    """The campaign the parsed arguments describe (``ValueError`` naming the field when it is not valid).

    A scheme ``rl:DIR`` (or ``rllib:DIR``) naming a multi-seed run becomes one scheme per seed
    (``uwb_env.agents.multiseed.expand_seed_schemes``); the summary groups them back.
    """
    preset = PRESETS[args.preset] if args.preset else {}
    listed = args.schemes or preset.get("schemes") or ["myopic", "round-robin"]
    baseline = args.baseline or (preset.get("baseline") if not args.schemes else None) or listed[-1]
    if expand_seed_schemes([baseline]) != [baseline]:
        raise ValueError(
            f"baseline={baseline!r}: a multi-seed run (seed-<s>/ folders) cannot be the baseline; "
            "name one seed's run (rl:DIR/seed-0) or another scheme, e.g. --baseline myopic"
        )
    schemes = expand_seed_schemes(listed)  # rl:DIR of a multi-seed run -> rl:DIR/seed-<s>, one per seed
    return Campaign(
        env=args.env or preset.get("env") or "uwb_env/UrbanWaveform-v3",
        schemes=tuple(schemes),
        baseline=baseline,
        runs=args.runs,
        seed0=args.seed0,
        overrides=parse_overrides(args.overrides, "--set"),
        env_kwargs=parse_overrides(args.env_kwargs, "--env-kwarg"),
        title=preset.get("title", ""),
        reference=preset.get("reference", {}) if not args.schemes else {},
    )


def evaluate_main(argv: Sequence[str] | None = None) -> None:
    """``uwb-env-evaluate``: run (or resume) a campaign and print its summary."""
    ap = evaluate_parser()
    args = ap.parse_args(argv)
    previous = signal.signal(signal.SIGTERM, _interrupt)  # SIGTERM stops a campaign as Ctrl-C does
    try:
        text = evaluate(
            campaign_from_args(args),
            args.out,
            args.workers,
            progress=not args.no_progress,
            backend=args.backend,
            address=args.address,
        )
    except CampaignInterrupted as e:
        if e.summary:
            print(e.summary)
        print(str(e), file=sys.stderr)
        raise SystemExit(130) from None
    except (ValueError, FolderLocked) as e:
        ap.error(str(e))
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(text)
    print(f"wrote {args.out}/summary.md, runs.csv and confirmed_tracks.png, position_rmse.png, model_probabilities.png")


def train_parser() -> argparse.ArgumentParser:
    """The arguments of ``uwb-env-train``."""
    ap = argparse.ArgumentParser(
        prog="uwb-env-train", description=TRAIN_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--engine", choices=ENGINES, default="sb3", help="stable-baselines3 (default) or RLlib (.[ray])")
    ap.add_argument("--env", default="uwb_env/UrbanWaveform-v3", choices=sorted(ENV_IDS))
    ap.add_argument("--algo", choices=ALGORITHM_NAMES, help="sb3: default maskable-ppo; rllib: ppo (default) or dqn")
    ap.add_argument("--timesteps", type=count(1), default=100_000, help="environment steps in total, >= 1")
    ap.add_argument("--out", type=folder, required=True, help="the run's folder")
    ap.add_argument("--seed", type=count(0), default=0, help="the training seed, >= 0 (with --seeds: the first)")
    ap.add_argument(
        "--seeds", type=count(1), help="train N seeds (--seed .. --seed + N - 1) into OUT/seed-<s>/, >= 1 (sb3)"
    )
    ap.add_argument("--resume", action="store_true", help="continue from the newest readable checkpoint in --out")
    add_pairs(ap, "--hyper", "hyper", "preset entry (algorithm block or common); repeatable, several per flag")
    add_pairs(ap, "--env-kwarg", "env_kwargs", "argument of gymnasium.make; repeatable, several per flag")
    ap.add_argument("--tensorboard", action="store_true", help="also log to TensorBoard (needs tensorboard)")
    ap.add_argument(
        "--vectorize",
        help="the training envs: sb3 dummy, subproc (default: the preset's vec_env) or batched (one batched vector "
        "env, parametric fidelity + imm-lmipda only); rllib sync (default) or batched",
    )
    ap.add_argument("--no-progress", action="store_true")
    rllib = ap.add_argument_group("--engine rllib")
    rllib.add_argument("--env-runners", type=count(1), help="Ray actors sampling the env, >= 1 (default 2)")
    rllib.add_argument("--envs-per-runner", type=count(1), help="envs per runner, >= 1 (default 1)")
    rllib.add_argument("--checkpoint-every", type=count(1), help="training iterations between checkpoints (default 5)")
    rllib.add_argument("--address", help="a Ray cluster to join (auto, ray://host:10001); none: a local Ray")
    return ap


def import_rl():
    """``uwb_env.agents.rl``, or ``SystemExit`` naming the extra to install when torch or SB3 is missing."""
    try:
        import uwb_env.agents.rl as rl
    except ImportError as e:
        missing = getattr(e, "name", None) or str(e)
        raise SystemExit(
            f"uwb-env-train: error: training needs the rl extra ({missing} is missing): {RL_INSTALL}"
        ) from None
    return rl


RLLIB_ONLY = ("env_runners", "envs_per_runner", "checkpoint_every", "address")


def import_rllib():
    """``uwb_env.agents.rl.rllib_engine`` with RLlib, or ``SystemExit`` naming the extra to install."""
    try:
        import uwb_env.agents.rl.rllib_engine as engine

        engine._import_rllib()
    except ImportError as e:
        missing = getattr(e, "name", None) or str(e)
        raise SystemExit(
            f"uwb-env-train: error: --engine rllib needs the ray extra ({missing} is missing): pip install -e '.[ray]'"
        ) from None
    return engine


def train_rllib_main(ap: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``uwb-env-train --engine rllib``."""
    if args.tensorboard:
        ap.error("--tensorboard: only with --engine sb3 (RLlib's metrics are in progress.csv)")
    engine = import_rllib()
    try:
        cfg = engine.RLlibTrainConfig(
            env_id=args.env,
            algo=args.algo or "ppo",
            timesteps=args.timesteps,
            out=args.out,
            seed=args.seed,
            env_kwargs=parse_overrides(args.env_kwargs, "--env-kwarg"),
            overrides=parse_overrides(args.hyper, "--hyper"),
            env_runners=2 if args.env_runners is None else args.env_runners,
            envs_per_runner=1 if args.envs_per_runner is None else args.envs_per_runner,
            checkpoint_every=5 if args.checkpoint_every is None else args.checkpoint_every,
            address=args.address,
            vectorize=args.vectorize or "sync",
        )
    except ValueError as e:
        ap.error(str(e))
    try:
        algo = engine.train_rllib(cfg, resume=args.resume, progress=not args.no_progress)
    except (ValueError, FolderLocked) as e:
        ap.error(str(e))
    steps = engine.sampled_steps(algo)
    print(f"trained rllib {cfg.algo} on {args.env}: {algo.iteration} iterations, {steps} steps; run in {args.out}/")


def train_main(argv: Sequence[str] | None = None) -> None:
    """``uwb-env-train``: train (or resume) an RL scheduler."""
    ap = train_parser()
    args = ap.parse_args(argv)
    if args.engine == "rllib":
        if args.seeds is not None:
            ap.error("--seeds: only with --engine sb3 (train RLlib seeds one --seed at a time)")
        return train_rllib_main(ap, args)
    given = [name for name in RLLIB_ONLY if getattr(args, name) is not None]
    if given:
        ap.error(f"--{given[0].replace('_', '-')}: only with --engine rllib")
    rl = import_rl()
    try:
        cfg = rl.TrainConfig(
            env_id=args.env,
            algo=args.algo or "maskable-ppo",
            timesteps=args.timesteps,
            out=args.out,
            seed=args.seed,
            env_kwargs=parse_overrides(args.env_kwargs, "--env-kwarg"),
            overrides=parse_overrides(args.hyper, "--hyper"),
            tensorboard=args.tensorboard,
            vectorize=args.vectorize,
        )
        if args.seeds is not None:
            seeds = list(range(args.seed, args.seed + args.seeds))
            plan = rl.train_seeds(cfg, seeds, resume=args.resume, progress=not args.no_progress)
        else:
            model = rl.train(cfg, resume=args.resume, progress=not args.no_progress)
    except (ValueError, FolderLocked) as e:
        ap.error(str(e))
    if args.seeds is not None:
        said = {"train": "trained", "resume": "resumed", "finished": "skipped: finished"}
        done = ", ".join(f"{s} ({said[p]})" for s, p in plan.items())
        print(f"trained {args.algo or 'maskable-ppo'} on {args.env}, seeds {done}; runs in {args.out}/seed-<s>/")
        return
    print(f"trained {args.algo or 'maskable-ppo'} on {args.env}: {model.num_timesteps} steps; run in {args.out}/")


if __name__ == "__main__":
    sys.exit(evaluate_main())
