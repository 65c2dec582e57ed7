"""uwb_env: closed-loop sensor scheduling in UWB multistatic radar networks (see SPEC.md for the map)."""

__version__ = "0.1.0"
