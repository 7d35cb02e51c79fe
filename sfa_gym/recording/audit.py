"""A stored run checked against the recording itself: samples rendered again and compared.

A run file's checksums say only that its chunks are the bytes its header lists; whoever can
write both can change both. Rendering is deterministic (same request, same pixels), so a sample
rendered again from the request is a check that needs nothing stored beside the run:

- a pose-list run (:class:`~sfa_gym.recording.drivers.GridPositions`: the localization grids)
  resets the env once per sample, so every stored pose is compared with the pose list and any
  sample can be rendered alone;
- a driven run reaches sample ``i`` only through the ``i`` steps before it, so only its first
  sample (the reset) is rendered again; its later samples are as good as their checksums.

Which samples are rendered is drawn afresh by every check (from the operating system's
entropy), so that no one can forge exactly the samples that will not be looked at.
"""

from __future__ import annotations

import copy
import random
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

__all__ = ["POSE_TOLERANCE", "SAMPLES", "rerender_mismatch"]

SAMPLES = 2
"""Samples of a pose-list run rendered again per check (besides its first pose)."""

POSE_TOLERANCE = 1e-6
"""The largest difference, metres or radians, between a stored pose and the one asked for."""


def _sample_indices(n: int, pose_list: bool) -> list[int]:
    if not pose_list or n <= 1:
        return [0]
    chosen = random.SystemRandom().sample(range(1, n), min(SAMPLES, n - 1))
    return [0, *sorted(chosen)]


def _pose_difference(found: Sequence[float], stored: Sequence[float]) -> float:
    x, y, yaw = (float(a) - float(b) for a, b in zip(found, stored, strict=True))
    yaw = abs((yaw + np.pi) % (2 * np.pi) - np.pi)
    return max(abs(x), abs(y), yaw)


def _start(env: gym.Env, request: Any) -> dict[str, Any] | None:
    """The reset options of a driven run, as :func:`~sfa_gym.recording.recorder.record` sets
    them (the driver's start pose after its reset; the request's driver is left untouched)."""
    from sfa_gym.recording.drivers import env_attribute
    from sfa_gym.recording.recorder import _control_period

    driver = copy.deepcopy(request.driver)
    driver.reset(env_attribute(env, "arena_bounds"), dt=_control_period(env), seed=request.seed)
    return None if driver.start_pose is None else {"pose": driver.start_pose}


def rerender_mismatch(request: Any, run: Any) -> str | None:
    """Render samples of ``run`` again from ``request`` (a
    :class:`~sfa_gym.recording.cache.RunRequest`) and compare them with the stored ones.

    Returns:
        None if every sample matches (pixels exactly, poses within :data:`POSE_TOLERANCE`),
        else what differs (the sample and the array).
    """
    from sfa_gym.recording.drivers import GridPositions
    from sfa_gym.recording.recorder import _pose_of, _pose_seed

    pose_list = isinstance(request.driver, GridPositions)
    if run.metadata.get("seed") != int(request.seed):
        return f"the run was recorded with seed {run.metadata.get('seed')!r}, not {request.seed}"
    env = gym.make(request.env_id, **request.record_kwargs())
    try:
        if pose_list:
            poses = np.asarray(request.driver.poses(env), dtype=np.float64)
            if len(run) > len(poses):
                return f"{len(run)} samples stored, but the grid has only {len(poses)} poses"
            for i in range(len(run)):
                if _pose_difference(run.poses[i], poses[i]) > POSE_TOLERANCE:
                    return f"sample {i}: stored pose {run.poses[i].tolist()}, asked {poses[i]}"
        for i in _sample_indices(len(run), pose_list):
            if pose_list:
                options = {"pose": tuple(poses[i])}
                obs, info = env.reset(seed=_pose_seed(int(request.seed), i), options=options)
            else:
                obs, info = env.reset(seed=int(request.seed), options=_start(env, request))
            if _pose_difference(_pose_of(info), run.poses[i]) > POSE_TOLERANCE:
                return f"sample {i}: stored pose {run.poses[i].tolist()}, rendered {_pose_of(info)}"
            if not np.array_equal(np.asarray(obs), run.panoramas[i]):
                return f"sample {i}: the stored panorama differs from the one rendered again"
    finally:
        env.close()
    return None
