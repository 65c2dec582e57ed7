"""Calibration of the through-wall parametric model on its signal path (seed 001's chain, the scenario's walks).

The code is ``uwb_env.agents.studies.calibrate_through_wall``;
``python scripts/calibrate_through_wall.py --help`` lists the options.
"""

from uwb_env.agents.studies.calibrate_through_wall import main

if __name__ == "__main__":
    main()
