"""Reinforcement-learning schedulers (stable-baselines3 / sb3-contrib): training, presets, trained-model agents."""

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
)

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
]
