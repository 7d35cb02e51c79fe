"""A stored run checked against the recording itself: the run made again and compared.

A run file's checksums say only that its chunks are the bytes its header lists; whoever can
write both can change both. Recording is deterministic (same request, same poses, same pixels),
so samples made again from the request are a check that needs nothing stored beside the run:

- a pose-list run (:class:`~sfa_gym.recording.drivers.GridPositions`: the localization grids)
  resets the env once per sample: every stored pose is compared with the pose list, and the
  first panorama and :data:`SAMPLES` more are rendered again;
- a driven run is driven again without rendering (neither the driver nor the physics looks at
  pixels): every stored action and pose is compared, a few seconds for the 8,700 frames of the
  outdoor protocol against minutes for their render. Its first panorama is rendered again, and
  :data:`SAMPLES` more where the camera has no state that carries from frame to frame (a
  sensor's exposure does; then the first panorama only).

Which samples are rendered is drawn afresh by every check (from the operating system's
entropy), so that no one can forge exactly the samples that will not be looked at.
"""

from __future__ import annotations

import copy
import random
from typing import Any

import gymnasium as gym
import numpy as np

from sfa_gym.recording.recorder import POSE_TOLERANCE, pose_difference

__all__ = ["SAMPLES", "rerender_mismatch"]

SAMPLES = 2
"""Panoramas rendered again per check besides the first."""


def _sample_indices(n: int) -> set[int]:
    chosen = random.SystemRandom().sample(range(1, n), min(SAMPLES, n - 1)) if n > 1 else []
    return {0, *chosen}


def _compare(i: int, obs: Any, info: Any, run: Any, render: bool) -> str | None:
    from sfa_gym.recording.recorder import _pose_of

    if pose_difference(_pose_of(info), run.poses[i]) > POSE_TOLERANCE:
        return f"sample {i}: stored pose {run.poses[i].tolist()}, made again {_pose_of(info)}"
    if render and not np.array_equal(np.asarray(obs), run.panoramas[i]):
        return f"sample {i}: the stored panorama differs from the one rendered again"
    return None


def rerender_mismatch(request: Any, run: Any) -> str | None:
    """Make samples of ``run`` again from ``request`` (a
    :class:`~sfa_gym.recording.cache.RunRequest`) and compare them with the stored ones (see
    the module docstring).

    Returns:
        None if everything compared matches (pixels and actions exactly, poses within
        :data:`~sfa_gym.recording.recorder.POSE_TOLERANCE`), else what differs (the sample and
        the array).
    """
    from sfa_gym.recording.drivers import GridPositions

    if run.metadata.get("seed") != int(request.seed):
        return f"the run was recorded with seed {run.metadata.get('seed')!r}, not {request.seed}"
    # as record() makes it: the run's length is the request's, not the registered time limit
    limit = (request.n_steps or 0) + 10**9
    env = gym.make(request.env_id, max_episode_steps=limit, **request.record_kwargs())
    try:
        if isinstance(request.driver, GridPositions):
            return _pose_list_mismatch(env, request, run)
        return _drive_mismatch(env, request, run)
    finally:
        env.close()


def _pose_list_mismatch(env: gym.Env, request: Any, run: Any) -> str | None:
    from sfa_gym.recording.recorder import _pose_seed

    poses = np.asarray(request.driver.poses(env), dtype=np.float64)
    if len(run) > len(poses):
        return f"{len(run)} samples stored, but the grid has only {len(poses)} poses"
    for i in range(len(run)):
        if pose_difference(run.poses[i], poses[i]) > POSE_TOLERANCE:
            return f"sample {i}: stored pose {run.poses[i].tolist()}, asked {poses[i]}"
    for i in sorted(_sample_indices(len(run))):
        seed = _pose_seed(int(request.seed), i)
        obs, info = env.reset(seed=seed, options={"pose": tuple(poses[i])})
        found = _compare(i, obs, info, run, render=True)
        if found is not None:
            return found
    return None


def _drive_mismatch(env: gym.Env, request: Any, run: Any) -> str | None:
    from sfa_gym.recording.drivers import env_attribute
    from sfa_gym.recording.recorder import _control_period

    driver = copy.deepcopy(request.driver)  # the request's own is left untouched
    dt = _control_period(env)
    driver.reset(env_attribute(env, "arena_bounds"), dt=dt, seed=request.seed)
    options = None if driver.start_pose is None else {"pose": driver.start_pose}
    obs, info = env.reset(seed=int(request.seed), options=options)
    found = _compare(0, obs, info, run, render=True)
    if found is not None:
        return found
    base = env.unwrapped
    stateless = getattr(base, "_sensor", None) is None
    samples = _sample_indices(len(run)) if stateless else {0}
    observe = base._observe
    blank = np.zeros(run.panoramas.shape[1:], dtype=np.uint8)
    low = env.action_space.low.astype(np.float32)
    high = env.action_space.high.astype(np.float32)
    try:
        for i in range(1, len(run)):
            action = np.clip(driver(info), low, high)
            if not np.array_equal(action, run.actions[i]):
                return f"sample {i}: stored action {run.actions[i].tolist()}, made {action}"
            # the physics and the driver never look at pixels: render only the samples
            base._observe = observe if i in samples else (lambda _dt: blank.copy())
            obs, _, _, _, info = env.step(action)
            found = _compare(i, obs, info, run, render=i in samples)
            if found is not None:
                return found
    finally:
        vars(base).pop("_observe", None)  # the class's method again
    return None
