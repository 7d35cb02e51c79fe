"""Registration of the sfa_gym environments with Gymnasium (ids ``sfa_gym/...``).

Entry points are strings, so registering imports neither MuJoCo nor the env module; the
env is imported by the first ``gym.make``.
"""

from __future__ import annotations

import gymnasium as gym

ENV_IDS = (
    "sfa_gym/OmniRover-v0",
    "sfa_gym/OmniRoverOutdoorCam-v0",
    "sfa_gym/OmniRoverOutdoor-v0",
    "sfa_gym/OmniRoverOutdoorTextured-v0",
    "sfa_gym/OmniRoverCampus-v0",
)
"""Exploration envs: no task, panorama observations."""
NAV_ENV_IDS = (
    "sfa_gym/OmniRoverNav-v0",
    "sfa_gym/OmniRoverNavObstacles-v0",
    "sfa_gym/OmniRoverNavMaze-v0",
    "sfa_gym/OmniRoverNavCampus-v0",
)
"""Image-goal navigation envs."""

SCENE_ENV_IDS = {"sfa_gym/OmniRoverNavCampus-v0": "sfa_gym/OmniRoverCampus-v0"}
"""For a navigation env whose camera is not the plain cylinder of ``sfa_gym/OmniRover-v0``, the
exploration env that renders what it sees (its world given apart): the navigation protocol
records the training grid and the feature field's nodes with it."""


def scene_env_id(nav_env_id: str | None) -> str:
    """The exploration env that renders the panoramas of navigation env ``nav_env_id``."""
    return SCENE_ENV_IDS.get(nav_env_id or "", "sfa_gym/OmniRover-v0")


_ENTRY_POINT = "sfa_gym.sim.env:OmniRoverEnv"
_NAV_ENTRY_POINT = "sfa_gym.navigation.env:OmniRoverNavEnv"
# 100 s of driving at the default control period of 0.1 s.
_MAX_EPISODE_STEPS = 1000
# The campus square is 20 m x 30 m: 5 min of driving.
_CAMPUS_STEPS = 3000
# Navigation: 60 s, 24 m at full speed, three times the arena's diagonal; the maze's detours
# around the arms get 100 s.
_NAV_STEPS = 600
_MAZE_STEPS = 1000


def register_envs() -> None:
    """Register the sfa_gym ids; calling it again changes nothing.

    * ``sfa_gym/OmniRover-v0``: the ``paper_sim`` world, 350 x 40 panoramas (the paper's
      simulator).
    * ``sfa_gym/OmniRoverOutdoorCam-v0``: the same world seen at the paper's outdoor camera
      resolution, 600 x 60.
    * ``sfa_gym/OmniRoverNav-v0``: image-goal navigation in the open ``paper_sim`` arena
      (:class:`~sfa_gym.navigation.env.OmniRoverNavEnv`), 600 steps.
    * ``sfa_gym/OmniRoverNavObstacles-v0``: the same with seeded obstacles inside the arena
      (``paper_sim_obstacles``), 600 steps.
    * ``sfa_gym/OmniRoverNavMaze-v0``: the same with a plus-shaped wall through the arena
      (``paper_sim_maze``): straight lines between quadrants are blocked; 1000 steps.
    * ``sfa_gym/OmniRoverNavCampus-v0``: image-goal navigation on the campus (the world, camera,
      dynamics and textures of ``sfa_gym/OmniRoverCampus-v0``, panoramas of 350 x 40 like the
      other navigation envs'): the way between its areas turns round the wings; 3000 steps.
    * ``sfa_gym/OmniRoverOutdoor-v0``: the ``paper_outdoor`` world through the mirror camera
      (60 x 600 unwarped panoramas), with its dynamics (sun over the day, clouds, movers) and
      the camera's auto-exposure and noise, on the sprung mast of ``RoverSpec.outdoor()`` (the
      view tilts at turning points); each effect can be switched off by a kwarg.
    * ``sfa_gym/OmniRoverOutdoorTextured-v0``: the same with generated surface textures
      (``textures=True``: asphalt, grass, paving, brick and plaster facades, bark, foliage;
      :mod:`sfa_gym.sim.worlds.textures`); the same places, poses and everything else.
    * ``sfa_gym/OmniRoverCampus-v0``: the ``campus`` world (a 20 m x 30 m square split by
      two building wings into three areas joined by paths; buildings that repeat two
      designs; :mod:`sfa_gym.sim.worlds.facades`), textured, with the outdoor camera, sensor
      and dynamics; 3000 steps.
    """
    outdoor = {
        "world": "paper_outdoor",
        "panorama": "paper_outdoor",
        "camera": "mirror",
        "mirror": "paper_outdoor",
        "dynamics": True,
        "sensor": True,
        "rover": "outdoor",
    }
    campus = {**outdoor, "world": "campus", "textures": True}
    # navigation at the navigation envs' 350 x 40 (the mirror unwarps to it): the methods fit
    # on every rotation of the training run, which at 600 x 60 would not fit in memory
    nav_campus = {**campus, "panorama": "paper_sim"}
    specs = {
        "sfa_gym/OmniRover-v0": (_ENTRY_POINT, _MAX_EPISODE_STEPS, {"world": "paper_sim"}),
        "sfa_gym/OmniRoverOutdoorCam-v0": (
            _ENTRY_POINT,
            _MAX_EPISODE_STEPS,
            {"world": "paper_sim", "panorama": "paper_outdoor"},
        ),
        "sfa_gym/OmniRoverNav-v0": (_NAV_ENTRY_POINT, _NAV_STEPS, {"world": "paper_sim"}),
        "sfa_gym/OmniRoverNavObstacles-v0": (
            _NAV_ENTRY_POINT,
            _NAV_STEPS,
            {"world": "paper_sim_obstacles"},
        ),
        "sfa_gym/OmniRoverNavMaze-v0": (_NAV_ENTRY_POINT, _MAZE_STEPS, {"world": "paper_sim_maze"}),
        "sfa_gym/OmniRoverOutdoor-v0": (_ENTRY_POINT, _MAX_EPISODE_STEPS, dict(outdoor)),
        "sfa_gym/OmniRoverOutdoorTextured-v0": (
            _ENTRY_POINT,
            _MAX_EPISODE_STEPS,
            {**outdoor, "textures": True},
        ),
        "sfa_gym/OmniRoverCampus-v0": (_ENTRY_POINT, _CAMPUS_STEPS, campus),
        "sfa_gym/OmniRoverNavCampus-v0": (_NAV_ENTRY_POINT, _CAMPUS_STEPS, nav_campus),
    }
    for env_id, (entry_point, steps, kwargs) in specs.items():
        if env_id in gym.registry:
            continue
        kwargs.setdefault("panorama", "paper_sim")
        gym.register(id=env_id, entry_point=entry_point, max_episode_steps=steps, kwargs=kwargs)
