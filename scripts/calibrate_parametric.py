"""Calibration report: the parametric sensor model against the signal path (issue 5, item 5).

The code is ``uwb_env.agents.studies.calibrate_parametric``;
``python scripts/calibrate_parametric.py --help`` lists the options.
"""

from uwb_env.agents.studies.calibrate_parametric import main

if __name__ == "__main__":
    main()
