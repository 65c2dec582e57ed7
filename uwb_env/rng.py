"""Named, independent random streams (one seed, named child streams).

One :class:`numpy.random.SeedSequence` per episode is split into child streams in a fixed order. The truth stream
never depends on the actions taken, so two schedulers run on the same seed face the same targets (common random
numbers). Never reorder :data:`STREAM_NAMES`: it would change every seeded result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STREAM_NAMES: tuple[str, ...] = ("truth", "rcs", "noise", "clutter", "signal", "tracker")


@dataclass(frozen=True, slots=True)
class RngStreams:
    """Independent generators for each random subsystem of one episode."""

    truth: np.random.Generator
    rcs: np.random.Generator
    noise: np.random.Generator
    clutter: np.random.Generator
    signal: np.random.Generator
    tracker: np.random.Generator

    @classmethod
    def from_seed(cls, seed: int | np.random.SeedSequence | None) -> RngStreams:
        """Spawn the named child streams from one seed (``None`` draws fresh OS entropy)."""
        root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        return cls.from_seed_sequence(root)

    @classmethod
    def from_seed_sequence(cls, root: np.random.SeedSequence) -> RngStreams:
        """Spawn the named child streams, in the fixed order of :data:`STREAM_NAMES`."""
        children = root.spawn(len(STREAM_NAMES))
        return cls(*(np.random.default_rng(c) for c in children))

    @classmethod
    def from_generator(cls, parent: np.random.Generator) -> RngStreams:
        """Spawn the named child streams from a parent generator (e.g. a Gymnasium env's ``np_random``)."""
        return cls(*parent.spawn(len(STREAM_NAMES)))
