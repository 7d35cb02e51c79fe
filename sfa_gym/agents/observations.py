"""Observation wrappers of the navigation agents: what a policy sees of the navigation env.

* :class:`FeatureHistory` (with :class:`WithHistory`): a feature field's features with a short
  memory of feature changes beside odometry moves, optionally the gradient controller's goal
  estimate and the range readings; one ``float32`` vector for an ``MlpPolicy``.
* :class:`StackedPanoramas`: the current and the goal panorama stacked on the channels, for a
  ``CnnPolicy``.
* :class:`GoalVector`: the goal's position relative to the rover from the ground truth, the
  upper bound (not a robot's view).

:func:`sfa_gym.agents.env.make_env` puts them on the env.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np

from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.navigation.feature_gradient import LocalLinearFit, gauss_newton_step

__all__ = [
    "MAX_STEP",
    "FeatureHistory",
    "GoalVector",
    "StackedPanoramas",
    "WithHistory",
    "cost_weights",
]

MAX_STEP = 3.0
"""m: the longest goal estimate an agent sees (the arena is 6 m across)."""


class StackedPanoramas:
    """Observation transform: the current and the goal panorama as one ``(H, W, 6)`` image."""

    def __init__(self, space: Any) -> None:
        h, w, c = space["panorama"].shape
        self.space = gym.spaces.Box(0, 255, (h, w, 2 * c), np.uint8)

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return np.concatenate([obs["panorama"], obs["goal"]], axis=2)


class FeatureHistory:
    """Observations of a feature field env with a short memory, as one ``float32`` vector.

    The features are rotation-averaged: they say where the rover is, not which way it faces, so
    a memoryless policy cannot tell which way to drive. Like the gradient controller, the agent
    therefore sees its recent past: how the features changed over each of its last
    ``history - 1`` moves (``stride``, ``2 stride``, ... steps back) beside that move, from the
    wheel odometry, in the current body frame (m); the current features; and the goal's minus
    the current ones. Differences, not values, so that a gradient is a few multiplications
    away. Features are standardised by their mean and spread over the field's nodes (no
    labels), so that methods with different scales meet the same MLP. Optionally the goal
    estimate (3, ``estimate``) and the range readings (``rays``). Length
    ``2 k + (history - 1) (k + 2) + 3 estimate + rays``.
    """

    def __init__(
        self, field: Any, history: int, stride: int, estimate: bool = False, rays: int = 0
    ) -> None:
        values = np.asarray(field.values, dtype=np.float64).reshape(-1, field.n_features)
        self.mean = values.mean(axis=0)
        self.scale = np.maximum(values.std(axis=0), 1e-12)
        self.history, self.stride = history, stride
        self.weights = cost_weights(field) if estimate else None
        self.rays = rays
        n = 2 * field.n_features + (history - 1) * (field.n_features + 2) + 3 * estimate + rays
        self.space = gym.spaces.Box(-np.inf, np.inf, (n,), np.float32)
        self._past: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=(history - 1) * stride + 1)

    def standardise(self, features: np.ndarray) -> np.ndarray:
        return (features - self.mean) / self.scale

    def __call__(self, obs: dict[str, np.ndarray], info: dict[str, Any], new: bool) -> np.ndarray:
        entry = (self.standardise(obs["features"]), np.asarray(info["odometry"], dtype=np.float64))
        if new:  # an episode starts: the past is the present
            self._past.extend([entry] * self._past.maxlen)
        self._past.append(entry)
        now, (x, y, yaw) = entry
        turn = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])
        # differences, not values: how far the goal is in feature space, and how the features
        # changed along each recent move, side by side with that move
        parts = [self.standardise(obs["goal_features"]) - now, now]
        for features, pose in list(self._past)[-1 - self.stride :: -self.stride]:
            parts += [now - features, turn @ ((x, y) - pose[:2])]
        if self.weights is not None:
            parts.append(self._goal_estimate(obs, (x, y), turn, new))
        if self.rays:
            parts.append(np.asarray(info["range"], dtype=np.float64))
        return np.concatenate(parts).astype(np.float32)

    def _goal_estimate(self, obs: dict[str, np.ndarray], xy: Any, turn: np.ndarray, new: bool):
        """``(dx, dy, fitted)``: the Gauss-Newton step to the goal features in the body frame
        (m, at most ``MAX_STEP``), and 1 once the recent moves span the plane (0 and a zero step
        before)."""
        s = GradientSettings()
        if new:
            self._local = LocalLinearFit(self.weights, s.memory, s.window, s.prior)
        self._local.remember(np.array(xy, dtype=np.float64), obs["features"].astype(np.float64))
        fit = self._local.fit()
        if fit is None:
            return np.zeros(3)
        a, jacobian, _ = fit
        step = turn @ gauss_newton_step(a, jacobian, obs["goal_features"], self.weights, s.damping)
        length = float(np.linalg.norm(step))
        if length > MAX_STEP:  # the fit extrapolates far from where it was made
            step *= MAX_STEP / length
        return np.array([step[0], step[1], 1.0])


def cost_weights(field: Any) -> np.ndarray:
    """The gradient controller's feature weights, stored with a field by ``sfa-gym navigate``."""
    weights = (field.metadata.get("model_info") or {}).get("cost_weights")
    if weights is None or len(weights) != field.n_features:
        raise ValueError(
            "estimate needs the cost weights that `sfa-gym navigate` stores with a field "
            f"(metadata model_info.cost_weights, {field.n_features} numbers); this field has "
            f"{weights!r}: build it again with `sfa-gym navigate`"
        )
    return np.asarray(weights, dtype=np.float64)


class GoalVector(gym.Wrapper):
    """Upper bound, not a robot's view: the goal's position relative to the rover in its body
    frame (m), from the ground truth in ``info``, and the rover's heading as (cos, sin)."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)

    def reset(self, **kwargs):
        _, info = self.env.reset(**kwargs)
        return self.vector(info), info

    def step(self, action):
        _, reward, terminated, truncated, info = self.env.step(action)
        return self.vector(info), reward, terminated, truncated, info

    @staticmethod
    def vector(info: dict[str, Any]) -> np.ndarray:
        yaw = info["yaw"]
        dx, dy = info["goal"][0] - info["x"], info["goal"][1] - info["y"]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([c * dx + s * dy, c * dy - s * dx, c, s], dtype=np.float32)


class WithHistory(gym.Wrapper):
    """Gives the env the observation of a :class:`FeatureHistory`."""

    def __init__(self, env: gym.Env, history: FeatureHistory) -> None:
        super().__init__(env)
        self.memory = history
        self.observation_space = history.space

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return self.memory(obs, info, new=True), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.memory(obs, info, new=False), reward, terminated, truncated, info
