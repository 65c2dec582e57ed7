"""Monte Carlo campaign of schedulers (``uwb-env-evaluate``); the code is ``uwb_env.agents.campaign``.

python scripts/evaluate.py --preset seed003 --runs 100 --out results/seed003
"""

from uwb_env.agents.cli import evaluate_main

if __name__ == "__main__":
    evaluate_main()
