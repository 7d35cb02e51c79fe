"""The leaderboard: versioned tracks, one command to score a method on them, citable results.

- :mod:`~sfa_gym.leaderboard.tracks`: track files (``tracks/*.json``), loaded and checked.
- :mod:`sfa_gym.plugins`: methods and controllers loaded by name or path (the plug-in contract).
- :mod:`~sfa_gym.recording.cache`: the shared render cache.
- :mod:`~sfa_gym.leaderboard.evaluate`: one (track, method, world seed) task.
- :mod:`sfa_gym.protocols`: what a task scores (the outdoor and navigation tracks call their
  protocol's ``score`` with the render cache); :mod:`~sfa_gym.recording.poses`: the pose sets
  rendered in worlds with obstacles.
- :mod:`~sfa_gym.leaderboard.backends`: running the tasks locally or on Ray.
- :mod:`~sfa_gym.leaderboard.task_files`: each task's file, written as it finishes; a rerun of
  a sweep (:mod:`~sfa_gym.leaderboard.sweep`) runs only the tasks not finished yet.
- :mod:`~sfa_gym.leaderboard.results`: results in one format (a sweep's, a published file's)
  with provenance and intervals, each checked as it is read (its fields, its mean recomputed by
  :func:`sfa_gym.intervals.summarize`);
  :mod:`~sfa_gym.leaderboard.table`: the table built from them;
  :mod:`~sfa_gym.leaderboard.compare`: a rerun checked against a published run.
"""

from __future__ import annotations

from sfa_gym.leaderboard.tracks import DEVELOPMENT_SEEDS, Track, TrackError, list_tracks, load_track
from sfa_gym.recording.cache import RunCache, RunRequest

__all__ = [
    "DEVELOPMENT_SEEDS",
    "RunCache",
    "RunRequest",
    "Track",
    "TrackError",
    "list_tracks",
    "load_track",
]
