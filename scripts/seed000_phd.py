"""Seed 000's case study: the particle PHD tracker on indoor-rsn against the VS-IMM tracker.

The code is ``uwb_env.agents.studies.seed000_phd``; ``python scripts/seed000_phd.py --help`` lists the options.
"""

from uwb_env.agents.studies.seed000_phd import main

if __name__ == "__main__":
    main()
