"""Monte Carlo evaluation of the tracker (issue 3 figures), round-robin waveforms, parametric sensing.

The code is ``uwb_env.agents.studies.evaluate_tracker``;
``python scripts/evaluate_tracker.py --help`` lists the options.
"""

from uwb_env.agents.studies.evaluate_tracker import main

if __name__ == "__main__":
    main()
