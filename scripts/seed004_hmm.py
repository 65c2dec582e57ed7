"""Seed 004's replica: HMM estimation of the bistatic delay from cluttered CIRs, and grid localization on it.

The code is ``uwb_env.agents.studies.seed004_hmm``; ``python scripts/seed004_hmm.py --help`` lists the options.
"""

from uwb_env.agents.studies.seed004_hmm import main

if __name__ == "__main__":
    main()
