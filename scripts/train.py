"""Train an RL scheduler (``uwb-env-train``); the code is ``uwb_env.agents.rl.training``.

python scripts/train.py --env uwb_env/UrbanWaveform-v3 --algo maskable-ppo --timesteps 200000 --out runs/urban
"""

from uwb_env.agents.cli import train_main

if __name__ == "__main__":
    train_main()
