"""Studies the scripts run: calibration of the parametric model on the signal path, figures, regime checks.

Each module has a ``main()`` (its command line) and the functions it is built from, importable for tests.
"""
