"""Registration of the sfa_gym environments with Gymnasium (ids ``sfa_gym/...``).

Entry points are strings, so registering imports neither MuJoCo nor the env module; the
env is imported by the first ``gym.make``.
"""

from __future__ import annotations

import gymnasium as gym

ENV_IDS = ("sfa_gym/OmniRover-v0", "sfa_gym/OmniRoverOutdoorCam-v0")

_ENTRY_POINT = "sfa_gym.sim.env:OmniRoverEnv"
# 100 s of driving at the default control period of 0.1 s.
_MAX_EPISODE_STEPS = 1000


def register_envs() -> None:
    """Register the sfa_gym ids; calling it again changes nothing.

    * ``sfa_gym/OmniRover-v0``: the ``paper_sim`` world, 350 x 40 panoramas (the paper's
      simulator).
    * ``sfa_gym/OmniRoverOutdoorCam-v0``: the same world seen at the paper's outdoor camera
      resolution, 600 x 60.
    """
    specs = {
        "sfa_gym/OmniRover-v0": {"world": "paper_sim", "panorama": "paper_sim"},
        "sfa_gym/OmniRoverOutdoorCam-v0": {"world": "paper_sim", "panorama": "paper_outdoor"},
    }
    for env_id, kwargs in specs.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=_ENTRY_POINT,
            max_episode_steps=_MAX_EPISODE_STEPS,
            kwargs=kwargs,
        )
