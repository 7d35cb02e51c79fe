"""The grid protocol's training panoramas rendered in memory, for scripts that train the
protocol's network on an env they set up themselves (another camera, say) and need no run file.

The poses and the training positions are the grid protocol's own
(:class:`~sfa_gym.recording.drivers.GridPositions` and
:func:`~sfa_gym.experiments.grid.select_positions`), so a network fitted on these panoramas
with ``config.sfa.make_model(...).fit_rotations(panoramas, step=config.step)`` is the one
``sfa-gym localize`` trains on the same world.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from sfa_gym.experiments.grid import GridExperiment, select_positions
from sfa_gym.recording.drivers import GridPositions

__all__ = ["grid_training_panoramas"]


def grid_training_panoramas(
    env: Any, config: GridExperiment, progress: bool = True
) -> NDArray[np.uint8]:
    """The panoramas ``(n_train, H, W, 3)`` of ``config``'s training positions in visiting
    order, each rendered by ``env.reset(options={"pose": pose})``.

    Args:
        env: an OmniRoverEnv (or a wrapper of one) whose observation is the panorama.
        config: the grid protocol's settings (grid, n_train, n_test, order, seed are read).
        progress: show a progress bar.
    """
    config.validate()
    poses = GridPositions(n=config.grid, seed=config.seed, order=config.order).poses(env)
    train, _ = select_positions(config, len(poses))
    return np.stack(
        [
            env.reset(options={"pose": tuple(float(v) for v in poses[i])})[0]
            for i in tqdm(train, desc="training grid", disable=not progress)
        ]
    )
