"""Observation wrappers that turn panoramas into slow features."""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from sfa_gym.rotation import n_rotations, rotated_views

__all__ = ["FeatureModel", "SlowFeatureObservation"]


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

    Example:
        A stand-in model (mean colour of the panorama) shows the mechanics; in practice the model
        is a fitted :class:`~sfa_gym.sfa.HierarchicalSFA`.

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
        input_shape = getattr(model, "input_shape_", None)
        if input_shape is None or not callable(getattr(model, "transform", None)):
            raise TypeError(
                "SlowFeatureObservation needs a fitted feature model with input_shape_ and "
                f"transform(views) (e.g. a fitted HierarchicalSFA), got {type(model).__name__}"
                + ("; is it fitted?" if callable(getattr(model, "transform", None)) else "")
            )
        input_shape = tuple(int(d) for d in input_shape)
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
        if self.average_rotations and hasattr(self.model, "transform_rotations"):
            # hierarchical SFA computes all rotations at once, its lower layers only once
            rotations = self.model.transform_rotations(observation[None], step=self.rotation_step)
            features = np.asarray(rotations)[0].mean(axis=0)
        elif self.average_rotations:
            views, _ = rotated_views(observation, step=self.rotation_step, window=self._window)
            features = np.asarray(self.model.transform(views)).mean(axis=0)
        else:
            features = np.asarray(self.model.transform(observation[None]))[0]
        return features.astype(np.float32)
