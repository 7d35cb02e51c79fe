"""The env a navigation agent trains, is evaluated and is watched on: :func:`make_env` from the
settings :class:`AgentEnv`, which a trained agent keeps beside its model (``agent.json``) so that
evaluating or recording it rebuilds the same env.

Three observations, one agent:

* **features** (``field`` set): the features of a feature field of a fitted method
  (``field_sfa.npz``, ... written by ``sfa-gym navigate``) with a short memory
  (:class:`~sfa_gym.agents.observations.FeatureHistory`); the env steps physics only, ~2000
  steps/s; ``MlpPolicy``.
* **pixels** (no ``field``): the rendered current and goal panoramas stacked on the channels,
  ``(H, W, 6)`` uint8; ``CnnPolicy``. Rendering costs ~7 ms a step.
* **oracle** (``oracle``, with a field to skip rendering): the goal's position relative to the
  rover from the ground truth, the upper bound.

The action is ``(v, w)`` rescaled to ``[-1, 1]``; the episode ends on arrival within the success
radius (``stop_action=False``): a continuous stop action would end most early episodes at random.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from sfa_gym._checks import check_positive_int

__all__ = ["AGENT_FILE", "AgentEnv", "make_env"]

AGENT_FILE = "agent.json"
"""The file beside a trained model that holds its :class:`AgentEnv` and training settings."""
_FORMAT, _VERSION = "sfa-gym-agent", 1


@dataclass(frozen=True)
class AgentEnv:
    """The navigation env and the observation an agent sees."""

    field: Path | None = None
    """feature field (.npz) of the env's world; None: raw panoramas, rendered, CnnPolicy"""
    env_id: str = "sfa_gym/OmniRoverNav-v0"
    """navigation env id"""
    world_seed: int = 0
    """world seed (the field's, when there is one)"""
    reward: str = "geodesic"
    """env reward: geodesic (progress along the shortest path, oracle shaping) or sparse"""
    oracle: bool = False
    """upper bound: observe the goal's position relative to the rover (ground truth) instead of
    features (the field only spares the rendering)"""
    history: int = 8
    """feature agents remember the current step and history - 1 earlier ones: the feature change
    over each of those moves beside the move (odometry, body frame)"""
    history_stride: int = 2
    """steps between the remembered ones"""
    estimate: bool = False
    """feature agents also see where the local linear fit of their recent features against
    odometry puts the goal (the gradient controller's Gauss-Newton step, body frame, m)"""
    ranges: bool = False
    """feature agents also see the range sensor's readings (m, the env's front rays)"""

    @property
    def policy(self) -> str:
        """The SB3 policy for this observation: a CNN on panoramas, else an MLP."""
        return "MlpPolicy" if self.field is not None else "CnnPolicy"

    def validate(self) -> None:
        """Raises ValueError naming a bad value and what was expected."""
        from sfa_gym.navigation.env import REWARDS
        from sfa_gym.registration import NAV_ENV_IDS

        if self.env_id not in NAV_ENV_IDS:
            raise ValueError(f"env_id must be one of {list(NAV_ENV_IDS)}, got {self.env_id!r}")
        if self.reward not in REWARDS:
            raise ValueError(f"reward must be one of {list(REWARDS)}, got {self.reward!r}")
        for name in ("history", "history_stride"):
            check_positive_int(name, getattr(self, name))
        if self.oracle and self.field is None:
            raise ValueError("oracle needs a field: the env steps physics only, without pixels")
        if self.field is not None and not Path(self.field).is_file():
            raise ValueError(f"field {str(self.field)!r} is not a file (a feature field .npz)")

    def to_json(self) -> dict[str, Any]:
        """The settings as JSON values, the field's path made absolute (for ``agent.json``)."""
        out = asdict(self)
        out["field"] = None if self.field is None else str(Path(self.field).resolve())
        return out

    @classmethod
    def from_json(cls, value: dict[str, Any]) -> AgentEnv:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(value) - known)
        if unknown:
            raise ValueError(f"unknown agent env settings {unknown}; expected some of {known}")
        field = value.get("field")
        return cls(**{**value, "field": None if field is None else Path(field)})


def write_agent_file(folder: Path, env: AgentEnv, train: dict[str, Any]) -> None:
    """``folder/agent.json``: what :func:`read_agent_file` needs to rebuild the agent's env."""
    from sfa_gym import __version__
    from sfa_gym.files import write_json_atomic

    header = {"format": _FORMAT, "version": _VERSION, "library_version": __version__}
    write_json_atomic(folder / AGENT_FILE, header | {"env": env.to_json(), "train": train})


def read_agent_file(folder: Path) -> tuple[AgentEnv, dict[str, Any]]:
    """The env settings and training settings of the agent trained into ``folder``."""
    from sfa_gym.files import check_format_header

    path = Path(folder) / AGENT_FILE
    if not path.is_file():
        raise ValueError(
            f"{path} does not exist: not a folder written by `sfa-gym agent train` "
            "(it keeps the agent's env settings there)"
        )
    value = json.loads(path.read_text())
    check_format_header(value, _FORMAT, _VERSION, "an sfa-gym agent file")
    return AgentEnv.from_json(value["env"]), value["train"]


def make_env(settings: AgentEnv, render_mode: str | None = None, **env_kwargs: Any) -> gym.Env:
    """The env the agent trains and is evaluated on, with its observation wrapper.

    Args:
        settings: the env and the observation.
        render_mode: the navigation env's (None or ``"rgb_array"``: the top-down view).
        env_kwargs: further arguments of the navigation env (e.g. ``render_size``).
    """
    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.agents.observations import (
        FeatureHistory,
        GoalVector,
        StackedPanoramas,
        WithHistory,
    )
    from sfa_gym.navigation.field import FeatureField

    settings.validate()
    kwargs: dict[str, Any] = {
        "world_seed": settings.world_seed,
        "stop_action": False,
        "reward": settings.reward,
        "render_mode": render_mode,
        **env_kwargs,
    }
    if settings.oracle:
        env: gym.Env = GoalVector(
            gym.make(settings.env_id, feature_field=os.fspath(settings.field), **kwargs)
        )
    elif settings.field is not None:
        field = FeatureField.load(settings.field)
        env = gym.make(settings.env_id, feature_field=field, **kwargs)
        rays = env.unwrapped.range_rays if settings.ranges else 0
        memory = FeatureHistory(
            field, settings.history, settings.history_stride, settings.estimate, rays
        )
        env = WithHistory(env, memory)
    else:
        env = gym.make(settings.env_id, **kwargs)
        transform = StackedPanoramas(env.observation_space)
        env = gym.wrappers.TransformObservation(env, transform, transform.space)
    # PPO's Gaussian starts with unit spread: on the raw (+-0.4 m/s, +-1 rad/s) box most speeds
    # would be clipped to the limits (float32 bounds: the action box's dtype, no cast warning)
    one = np.ones(env.action_space.shape, np.float32)
    return gym.wrappers.RescaleAction(env, -one, one)
