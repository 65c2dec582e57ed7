"""uwb_env: closed-loop sensor scheduling in UWB multistatic radar networks (see SPEC.md for the map)."""

__version__ = "0.1.0"

from uwb_env.envs import register_envs as _register_envs

_register_envs()
