"""Registry of named scenarios: ``get(name, **overrides)`` and ``names()``.

Each scenario lives in its own module, cites the seed it replicates and says which values are the seed's and which
are ours. Overrides are dotted paths (``get("urban-intersection", **{"sensing.false_alarm_probability": 1e-5})``)
or a nested mapping (``get(name, sensing={"max_range_m": 250.0})``); unknown keys raise ``KeyError``.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from typing import Any

from uwb_env.config import ScenarioConfig, apply_overrides

ScenarioFactory = Callable[[], ScenarioConfig]
_SCENARIOS: dict[str, ScenarioFactory] = {}


def register(name: str) -> Callable[[ScenarioFactory], ScenarioFactory]:
    """Decorator registering a scenario factory under ``name`` (duplicates raise ``KeyError``)."""

    def deco(factory: ScenarioFactory) -> ScenarioFactory:
        if name in _SCENARIOS:
            raise KeyError(f"scenario {name!r} already registered")
        _SCENARIOS[name] = factory
        return factory

    return deco


def names() -> tuple[str, ...]:
    """Registered scenario names, sorted."""
    return tuple(sorted(_SCENARIOS))


def get(name: str, **overrides: Any) -> ScenarioConfig:
    """Build the named scenario, with overrides applied and re-validated."""
    if name not in _SCENARIOS:
        close = difflib.get_close_matches(name, list(_SCENARIOS), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise KeyError(f"unknown scenario {name!r}{hint} (known: {', '.join(names())})")
    return apply_overrides(_SCENARIOS[name](), overrides)


# Registration happens on import of the scenario modules.
from uwb_env.scenarios import (  # noqa: E402, F401
    indoor_monostatic,
    indoor_rsn,
    through_wall,
    urban_crossing,
    urban_distributed,
    urban_intersection,
)

__all__ = ["get", "names", "register"]
