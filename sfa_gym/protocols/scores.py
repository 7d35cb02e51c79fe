"""What a localization protocol's ``score`` returns: :class:`MethodScores`, the fitted method,
the invariance of its features and one entry per regression, as ``results.json`` holds them.
Each protocol subclasses it (``Scores``) with the data it scored on and ``task_scores()``, a
leaderboard task's scores."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["MethodScores"]


@dataclass
class MethodScores:
    """What a protocol's ``score`` found for one method.

    Attributes:
        config: the protocol settings it was scored with.
        method: the fitted feature method.
        invariance: ``eta_r``, ``eta_phi`` per output over the training views, ``n_features``.
        regressions: per regression name, its scores (each with ``entry()``: JSON types).
        data: what it was scored on (the command line's figures draw from it).
    """

    config: Any
    method: Any
    invariance: dict[str, Any]
    regressions: dict[str, Any]
    data: Any

    def entry(self) -> dict[str, Any]:
        """The method's entry of ``results.json``: invariance, then one entry per regression."""
        return {**self.invariance, **{n: r.entry() for n, r in self.regressions.items()}}

    def first(self) -> tuple[str, Any]:
        """The first regression's name and scores: the one a leaderboard task reports."""
        return next(iter(self.regressions.items()))
