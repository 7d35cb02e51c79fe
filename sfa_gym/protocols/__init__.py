"""The evaluation protocols, each in one home.

Every protocol module (:mod:`~sfa_gym.protocols.grid`, :mod:`~sfa_gym.protocols.trajectory`,
:mod:`~sfa_gym.protocols.outdoor`, :mod:`~sfa_gym.protocols.navigation`) has

- ``Config``: a frozen dataclass of the protocol's settings, with ``validate()``, the one check of
  each value, run before anything is created. A leaderboard track's ``params`` are
  ``dataclasses.replace(Config(), **params)``; the command line's options are its fields.
- ``score(config, method, world_seed, runs) -> Scores``: fits ``method`` (a feature method) the
  way the protocol says and scores it; it writes no files. ``runs`` gives the rendered runs
  (:class:`RunSource`): the leaderboard passes its shared render cache
  (:class:`~sfa_gym.recording.cache.RunCache`), the command line its output folder
  (:class:`~sfa_gym.recording.cache.RunFolder`). The localization protocols take
  ``regressors=`` (the regressions to score; default: the method's own ``regressor``).
- ``Scores`` (a :class:`~sfa_gym.protocols.scores.MethodScores`): the fitted method, ``entry()``
  (the method's entry of the command line's ``results.json``), ``task_scores()`` (a leaderboard
  task's scores, JSON types) and ``data``, what it was scored on (the figures draw from it).
- ``requests(config, world_seed)``: the runs it renders, by name.

The command line (:mod:`sfa_gym.cli.localize`: output folders, figures, reports) and the
leaderboard (:mod:`sfa_gym.leaderboard`) both call ``score``; neither scores by itself.
:mod:`~sfa_gym.protocols.settings` holds what several protocols share (where they render, the SFA
network), :mod:`~sfa_gym.features` how a method is fitted on rotated views.
"""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["RunSource"]


class RunSource(Protocol):
    """Where a protocol gets its rendered runs: ``get(request)`` returns the
    :class:`~sfa_gym.recording.runfile.Run` of a :class:`~sfa_gym.recording.cache.RunRequest`,
    rendering it first when it has none (e.g. :class:`~sfa_gym.recording.cache.RunCache`)."""

    def get(self, request: Any) -> Any: ...
