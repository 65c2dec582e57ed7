"""Seed 001's replica: through-wall tracking of two persons with a 1 Tx + 2 Rx radar, with and without ToA association.

The code is ``uwb_env.agents.studies.seed001_through_wall``; ``python scripts/seed001_through_wall.py --help`` lists
the options.
"""

from uwb_env.agents.studies.seed001_through_wall import main

if __name__ == "__main__":
    main()
