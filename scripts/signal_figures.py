"""Signal-level fidelity figures and the indoor-rsn accuracy check (issue 5; seed 000 Figs. 5, 6 and 8).

The code is ``uwb_env.agents.studies.signal_figures``; ``python scripts/signal_figures.py --help`` lists the options.
"""

from uwb_env.agents.studies.signal_figures import main

if __name__ == "__main__":
    main()
