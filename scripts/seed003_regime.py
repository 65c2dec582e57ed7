"""Seed 003's regime on urban-intersection: the SNR along the path per waveform, and what it means for detection.

The code is ``uwb_env.agents.studies.seed003_regime``; ``python scripts/seed003_regime.py --help`` lists the options.
"""

from uwb_env.agents.studies.seed003_regime import main

if __name__ == "__main__":
    main()
