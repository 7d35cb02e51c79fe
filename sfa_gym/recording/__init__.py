"""Recording runs: drivers, orderings, the run file format and the recorder/replay loop.

- :mod:`~sfa_gym.recording.drivers`: the scripted drivers and the grid of poses.
- :mod:`~sfa_gym.recording.outdoor_path`: the paper's outdoor training and test paths (planned
  as geometry and timing) and the driver that follows them.
- :mod:`~sfa_gym.recording.ordering`, :mod:`~sfa_gym.recording.runfile`,
  :mod:`~sfa_gym.recording.recorder`: visiting orders, the run format, recording and replay.
"""

from __future__ import annotations

from sfa_gym.recording.outdoor_path import (
    OutdoorPath,
    OutdoorPathDriver,
    plan_outdoor_paths,
    south_west,
)

__all__ = ["OutdoorPath", "OutdoorPathDriver", "plan_outdoor_paths", "south_west"]
