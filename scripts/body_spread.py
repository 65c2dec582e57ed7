"""The range spread an extended person adds on a scenario's signal chain (``BodyModelConfig.range_std_m``).

The code is ``uwb_env.agents.studies.body_spread``; ``python scripts/body_spread.py --help`` lists the options.
"""

from uwb_env.agents.studies.body_spread import main

if __name__ == "__main__":
    main()
