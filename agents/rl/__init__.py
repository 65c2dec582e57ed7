"""Reinforcement-learning schedulers: training, presets, trained-model agents.

stable-baselines3 / sb3-contrib (:mod:`.training`) and RLlib (:mod:`.rllib_engine`, the ``ray`` extra; its names
are imported on first use, so importing this package does not import Ray).
"""

from uwb_env.agents.rl.training import (
    ALGORITHMS,
    PolicyScheduler,
    SchedulerEvalCallback,
    TrainConfig,
    latest_checkpoint,
    load_preset,
    load_scheduler,
    make_vec_env,
    train,
    train_seeds,
)

_RLLIB = ("RLLIB_ALGORITHMS", "MaskedUWBEnv", "RLlibPolicyScheduler", "RLlibTrainConfig", "load_rllib_scheduler",
          "rllib_checkpoints", "train_rllib")  # fmt: skip


def __getattr__(name: str):
    if name in _RLLIB:
        from uwb_env.agents.rl import rllib_engine

        return getattr(rllib_engine, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "ALGORITHMS",
    "PolicyScheduler",
    "SchedulerEvalCallback",
    "TrainConfig",
    "latest_checkpoint",
    "load_preset",
    "load_scheduler",
    "make_vec_env",
    "train",
    "train_seeds",
    *_RLLIB,
]
