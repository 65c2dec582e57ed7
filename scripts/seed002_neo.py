"""Seed 002's navigation study: NEO curves of the particle filter on indoor-monostatic (Figs. 2-4).

The code is ``uwb_env.agents.studies.seed002_neo``; ``python scripts/seed002_neo.py --help`` lists the options.
"""

from uwb_env.agents.studies.seed002_neo import main

if __name__ == "__main__":
    main()
