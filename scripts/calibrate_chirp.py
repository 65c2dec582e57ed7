"""Calibrate the parametric chirp model on the chirp signal path (urban-intersection): writes report.md and figures.

The code is ``uwb_env.agents.studies.calibrate_chirp``; ``python scripts/calibrate_chirp.py --help`` lists the options.
"""

from uwb_env.agents.studies.calibrate_chirp import main

if __name__ == "__main__":
    main()
