"""Schedulers (round-robin, fixed, random, lookahead, RL) arrive with the close-the-loop issue."""

__all__: list[str] = []
