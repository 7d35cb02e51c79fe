"""Observation wrappers that turn panoramas into slow features.

Example:
    A stand-in model (mean colour of the panorama) shows the mechanics; in practice the model is
    a fitted :class:`~sfa_gym.sfa.HierarchicalSFA`.

    >>> import gymnasium as gym
    >>> import numpy as np
    >>> import sfa_gym
    >>> class MeanColour:
    ...     input_shape_ = (40, 350, 3)
    ...     def transform(self, views):
    ...         return views.reshape(len(views), -1, 3).mean(axis=1)
    >>> env = SlowFeatureObservation(gym.make("sfa_gym/OmniRover-v0"), MeanColour())
    >>> env.observation_space
    Box(-inf, inf, (3,), float32)
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, obs.dtype, bool(np.all((0 <= obs) & (obs <= 255)))
    ((3,), dtype('float32'), True)
    >>> env.close()
    >>> env = GoalFeatureObservation(gym.make("sfa_gym/OmniRoverNav-v0"), MeanColour())
    >>> obs, info = env.reset(seed=0)
    >>> sorted(obs), obs["features"].shape
    (['features', 'goal_features'], (3,))
    >>> env.close()
"""

from __future__ import annotations

from typing import Any, Literal, Protocol, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from sfa_gym.features import rotation_averaged_features
from sfa_gym.rotation import check_window, n_rotations, rotated_views, rotation_angles

__all__ = [
    "FeatureModel",
    "FeatureProgressReward",
    "GoalFeatureObservation",
    "SimulatedRotation",
    "SlowFeatureObservation",
]


class FeatureModel(Protocol):
    """A fitted feature model: a fitted :class:`~sfa_gym.sfa.HierarchicalSFA`, or any object with
    ``input_shape_ = (H, W, 3)`` and ``transform(views (N, H, W, 3) uint8) -> (N, k) float``."""

    input_shape_: tuple[int, int, int]

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.floating]: ...


class SlowFeatureObservation(
    gym.ObservationWrapper[NDArray[np.float32], Any, NDArray[np.uint8]],
    gym.utils.RecordConstructorArgs,
):
    """Replace each panorama by the features a fitted model computes from it.

    With ``average_rotations=False`` the observation is ``model.transform(panorama[None])[0]``.
    With ``average_rotations=True`` it is the mean of the features of all simulated rotations of
    the panorama (:func:`sfa_gym.rotation.rotated_views` with ``step`` and the model's input
    width as window), which is how the paper averages its estimates over the rotation windows of
    one location; it costs ``W // step`` model evaluations per step.

    The observation space is ``Box(-inf, inf, (k,), float32)``: SFA outputs have zero mean and
    unit variance over the training views, but a view unlike any training view can map anywhere,
    so no finite bound holds.

    Args:
        env: an env whose observations are panoramas, ``Box(0, 255, (H, W, 3), uint8)``.
        model: a fitted feature model (see :class:`FeatureModel`). Without averaging it must have
            been fitted on views of the env's panorama shape; with averaging on views of the same
            height and at most the same width (rotation windows).
        average_rotations: average the features over all simulated rotations of the panorama.
        step: shift between rotations in columns when averaging; must divide the width ``W``.
            ``step=1`` averages over every column: the features then stay the same (to
            rounding) when the rover turns by whole columns (the camera's compass views shift
            the panorama exactly), and wobble far less over arbitrary headings than with the
            paper's 5-column windows (``eval/studies/camera_equivariance.py``); hierarchical SFA
            computes it at about five times the cost of ``step=5``.

    Example: in the module docstring.
    """

    def __init__(
        self,
        env: gym.Env[NDArray[np.uint8], Any],
        model: FeatureModel,
        average_rotations: bool = False,
        step: int = 5,
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self, model=model, average_rotations=average_rotations, step=step
        )
        gym.ObservationWrapper.__init__(self, env)
        space = env.observation_space
        if not isinstance(space, gym.spaces.Box):
            raise TypeError(
                "SlowFeatureObservation needs an env with a panorama observation space "
                f"Box(0, 255, (H, W, 3), uint8), got {space}"
            )
        if space.dtype != np.uint8 or len(space.shape) != 3 or space.shape[2] != 3:
            raise ValueError(
                "SlowFeatureObservation needs an env with a panorama observation space "
                f"Box(0, 255, (H, W, 3), uint8), got shape {space.shape} and dtype {space.dtype}"
            )
        input_shape = _input_shape(
            "SlowFeatureObservation", model, " (e.g. a fitted HierarchicalSFA)"
        )
        if not isinstance(average_rotations, bool):
            raise TypeError(f"average_rotations must be a bool, got {average_rotations!r}")
        height, width, _ = space.shape
        if average_rotations:
            if (
                len(input_shape) != 3
                or input_shape[0] != height
                or input_shape[1] > width
                or input_shape[2] != 3
            ):
                raise ValueError(
                    f"SlowFeatureObservation(average_rotations=True): the model takes views of "
                    f"shape {input_shape}, which are not rotation windows of the env's panoramas "
                    f"of shape {space.shape} (the height and channels must be equal and the width "
                    f"at most {width})"
                )
            try:
                n_rotations(width, step)
            except (TypeError, ValueError) as error:
                raise ValueError(
                    f"SlowFeatureObservation(average_rotations=True, step={step!r}) for panoramas "
                    f"of shape {space.shape}: {error}"
                ) from error
        elif input_shape != space.shape:
            hint = (
                "; the model takes narrower rotation windows: use average_rotations=True"
                if len(input_shape) == 3 and input_shape[0] == height and input_shape[1] < width
                else "; fit the model on this env's panoramas"
            )
            raise ValueError(
                f"SlowFeatureObservation: the env's panoramas have shape {space.shape} but the "
                f"model was fitted on views of shape {input_shape}{hint}"
            )
        self.model = model
        self.average_rotations = average_rotations
        self.rotation_step = step
        self._window = input_shape[1]
        # The feature count is whatever the model returns; one evaluation on a blank view finds it
        # and checks that transform accepts views of the expected shape.
        probe = np.asarray(model.transform(np.zeros((1, *input_shape), dtype=np.uint8)))
        if probe.ndim != 2 or probe.shape[0] != 1 or probe.shape[1] < 1:
            raise ValueError(
                f"SlowFeatureObservation: model.transform of 1 view returned shape {probe.shape}, "
                "expected (1, k) with k >= 1"
            )
        self.observation_space = gym.spaces.Box(
            low=-np.inf, high=np.inf, shape=(probe.shape[1],), dtype=np.float32
        )

    def observation(self, observation: NDArray[np.uint8]) -> NDArray[np.float32]:
        """Features ``(k,)`` float32 of one panorama ``(H, W, 3)`` uint8."""
        if self.average_rotations:
            features = rotation_averaged_features(
                self.model, observation[None], self.rotation_step, self._window
            )[0]
        else:
            features = np.asarray(self.model.transform(observation[None]))[0]
        return features.astype(np.float32)


class SimulatedRotation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Replace each panorama by one simulated rotation of it.

    At every ``reset`` and ``step`` the wrapper picks a view index ``k`` and returns
    ``np.roll(panorama, -k * step, axis=1)[:, :window]``, i.e. what the camera would see had the
    rover been turned by ``phi = 2*pi*k*step/W`` more (counter-clockwise). The pose in ``info``
    stays the rover's true pose; ``info["phi"]`` (radians) and ``info["phi_index"]`` (``k``)
    report the simulated extra rotation.

    Args:
        env: an env whose observation space is a panorama, ``Box(0, 255, (H, W, 3), uint8)``.
        step: shift between rotations, in columns; must divide ``W``.
        window: crop each view to its first ``window`` columns; ``None`` keeps the full width.
        mode: ``"random"``: ``k`` drawn uniformly from ``0 .. W // step - 1`` with
            ``self.np_random`` (the wrapped env's generator, seeded by ``reset(seed=...)``) at
            every reset and step; ``"sequential"``: ``k = 0`` at reset, then ``k + 1`` (modulo
            ``K``) at every step.

    Example:
        >>> import gymnasium as gym
        >>> import sfa_gym
        >>> from sfa_gym.wrappers import SimulatedRotation
        >>> env = SimulatedRotation(gym.make("sfa_gym/OmniRover-v0"), window=175, mode="sequential")
        >>> env.observation_space.shape
        (40, 175, 3)
        >>> obs, info = env.reset(seed=0)
        >>> info["phi_index"], info["phi"]
        (0, 0.0)
        >>> obs, *_, info = env.step(env.action_space.sample())
        >>> info["phi_index"], round(float(np.degrees(info["phi"])), 6)
        (1, 5.142857)
        >>> env.close()
    """

    def __init__(
        self,
        env: gym.Env,
        step: int = 5,
        window: int | None = None,
        mode: Literal["random", "sequential"] = "random",
    ) -> None:
        space = env.observation_space
        if (
            not isinstance(space, gym.spaces.Box)
            or len(space.shape) != 3
            or space.shape[2] != 3
            or space.dtype != np.uint8
        ):
            raise ValueError(
                "SimulatedRotation needs a panorama observation space Box(0, 255, (H, W, 3), "
                f"uint8), got {space}"
            )
        if mode not in ("random", "sequential"):
            raise ValueError(
                f"SimulatedRotation mode must be 'random' or 'sequential', got {mode!r}"
            )
        height, width, _ = space.shape
        try:
            n_views = n_rotations(width, step)
            window = check_window(width, window)
        except (TypeError, ValueError) as error:
            raise type(error)(f"SimulatedRotation: {error}") from None
        gym.utils.RecordConstructorArgs.__init__(self, step=step, window=window, mode=mode)
        gym.ObservationWrapper.__init__(self, env)
        self.n_views = n_views
        self.rotation_step = int(step)
        self.window = window
        self.mode = mode
        self.phis = rotation_angles(width, step)
        self.observation_space = gym.spaces.Box(0, 255, (height, window, 3), np.uint8)
        self._index = 0

    def observation(self, observation: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """View ``self._index`` of ``observation`` ``(H, W, 3)``: ``(H, window, 3)`` uint8."""
        views, _ = rotated_views(observation, self.rotation_step, self.window, [self._index])
        return views[0]

    def _with_phi(self, info: dict[str, Any]) -> dict[str, Any]:
        return {**info, "phi": float(self.phis[self._index]), "phi_index": int(self._index)}

    def _draw(self) -> int:
        return int(self.np_random.integers(self.n_views))

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.uint8], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self._index = self._draw() if self.mode == "random" else 0
        return self.observation(obs), self._with_phi(info)

    def step(
        self, action: Any
    ) -> tuple[NDArray[np.uint8], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.mode == "random":
            self._index = self._draw()
        else:
            self._index = (self._index + 1) % self.n_views
        return self.observation(obs), reward, terminated, truncated, self._with_phi(info)


def _input_shape(wrapper: str, model: Any, example: str = "") -> tuple[int, ...]:
    """``model.input_shape_`` in ints; a TypeError naming ``wrapper`` where ``model`` is not a
    fitted feature model (``example``: one, for the message)."""
    input_shape = getattr(model, "input_shape_", None)
    transforms = callable(getattr(model, "transform", None))
    if input_shape is None or not transforms:
        raise TypeError(
            f"{wrapper} needs a fitted feature model with input_shape_ and transform(views)"
            f"{example}, got {type(model).__name__}" + ("; is it fitted?" if transforms else "")
        )
    return tuple(int(d) for d in input_shape)


def _feature_box(k: int) -> gym.spaces.Box:
    return gym.spaces.Box(low=-np.inf, high=np.inf, shape=(k,), dtype=np.float32)


class GoalFeatureObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Replace the current and the goal panorama of a navigation env by their features.

    The observation ``Dict(panorama, goal)`` of :class:`~sfa_gym.navigation.env.OmniRoverNavEnv`
    becomes ``Dict(features=Box(k), goal_features=Box(k))``: the rotation-averaged features
    (:func:`sfa_gym.features.rotation_averaged_features`) of each panorama, the same observation
    the env gives with a feature field. The goal's features are computed once per episode.

    Args:
        env: a navigation env observing ``Dict(panorama=Box(H, W, 3), goal=Box(H, W, 3))``.
        model: a fitted feature model (see :class:`FeatureModel`): hierarchical SFA, or a
            feature method of ``baselines/`` after ``fit`` (|FFT|, band means, PCA).
        step: rotation step in columns for the average; must divide ``W``. The default 1
            averages over every column, which makes the features the same whichever way the
            rover faces (to rounding, for whole-column headings).

    Example: in the module docstring.
    """

    def __init__(self, env: gym.Env, model: FeatureModel, step: int = 1) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, model=model, step=step)
        gym.Wrapper.__init__(self, env)
        space = env.observation_space
        if not isinstance(space, gym.spaces.Dict) or set(space.spaces) != {"panorama", "goal"}:
            raise TypeError(
                "GoalFeatureObservation needs a navigation env observing Dict(panorama, goal) "
                f"(an OmniRoverNavEnv without a feature field), got {space}"
            )
        height, width, _ = space["panorama"].shape
        input_shape = _input_shape("GoalFeatureObservation", model)
        if input_shape[0] != height or input_shape[1] > width:
            raise ValueError(
                f"GoalFeatureObservation: the model takes views of shape {input_shape}, "
                f"which are not rotation windows of the env's panoramas {space['panorama'].shape}"
            )
        try:
            n_rotations(width, step)
        except (TypeError, ValueError) as error:
            raise ValueError(f"GoalFeatureObservation(step={step!r}): {error}") from error
        self.model = model
        self.rotation_step = step
        self._window = input_shape[1]
        probe = self._features(np.zeros((1, height, width, 3), np.uint8))
        box = _feature_box(probe.shape[1])
        self.observation_space = gym.spaces.Dict({"features": box, "goal_features": box})
        self._goal_features = np.zeros(box.shape, np.float32)

    def _features(self, panoramas: NDArray[np.uint8]) -> NDArray[np.float32]:
        features = rotation_averaged_features(
            self.model, panoramas, self.rotation_step, self._window
        )
        return features.astype(np.float32)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        both = self._features(np.stack([obs["panorama"], obs["goal"]]))
        self._goal_features = both[1]
        return {"features": both[0], "goal_features": self._goal_features}, info

    def step(
        self, action: Any
    ) -> tuple[dict[str, NDArray[np.float32]], SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        features = self._features(obs["panorama"][None])[0]
        obs = {"features": features, "goal_features": self._goal_features}
        return obs, reward, terminated, truncated, info


class FeatureProgressReward(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Reward the decrease of the distance between the current and the goal features.

    What a robot can compute itself, without a map: ``r_t = d_{t-1} - d_t`` with
    ``d = sqrt(sum_i w_i (f_i - g_i)^2)``, plus ``success_reward`` when ``info["success"]``.
    It replaces the env's reward.

    Args:
        env: an env observing ``Dict(features=Box(k), goal_features=Box(k))`` (a navigation env
            with a feature field, or wrapped in :class:`GoalFeatureObservation`).
        weights: ``(k,)`` non-negative feature weights; None weighs every feature 1.
        success_reward: added on success.
    """

    def __init__(self, env: gym.Env, weights: Any = None, success_reward: float = 1.0) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self, weights=weights, success_reward=success_reward
        )
        gym.Wrapper.__init__(self, env)
        space = env.observation_space
        if not isinstance(space, gym.spaces.Dict) or set(space.spaces) != {
            "features",
            "goal_features",
        }:
            raise TypeError(
                "FeatureProgressReward needs an env observing Dict(features, goal_features), "
                f"got {space}"
            )
        k = space["features"].shape[0]
        w = np.ones(k) if weights is None else np.asarray(weights, dtype=np.float64)
        if w.shape != (k,) or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(
                f"weights must be {k} finite non-negative numbers (one a feature), got {weights!r}"
            )
        self.weights = w
        self.success_reward = float(success_reward)
        self._distance = 0.0

    def _feature_distance(self, obs: dict[str, NDArray[np.float32]]) -> float:
        diff = obs["features"].astype(np.float64) - obs["goal_features"]
        return float(np.sqrt(np.sum(self.weights * diff * diff)))

    def reset(self, **kwargs: Any) -> tuple[dict[str, NDArray[np.float32]], dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._distance = self._feature_distance(obs)
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, _, terminated, truncated, info = self.env.step(action)
        previous, self._distance = self._distance, self._feature_distance(obs)
        reward = previous - self._distance
        if info.get("success"):
            reward += self.success_reward
        return obs, reward, terminated, truncated, info
