"""Plot a multi-seed run's learning curves (IQM across seeds, bootstrap band, myopic / round-robin references).

python scripts/learning_curves.py runs/urban-mppo-5seeds     # writes runs/urban-mppo-5seeds/learning_curves.png

The code is ``uwb_env.agents.multiseed``; ``uwb-env-train --seeds N`` writes the same figure when it finishes.
"""

from uwb_env.agents.multiseed import curves_main

if __name__ == "__main__":
    curves_main()
