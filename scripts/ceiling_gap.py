"""How far each open-loop schedule is from the ceiling (``uwb_env.ceiling``), per window of the truth recursion.

The code is ``uwb_env.agents.studies.ceiling_gap``; ``python scripts/ceiling_gap.py --help`` lists the options.
"""

from uwb_env.agents.studies.ceiling_gap import main

if __name__ == "__main__":
    main()
