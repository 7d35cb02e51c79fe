"""Min-warping: home along the movement that best warps the goal panorama onto the current one.

Franz, M. O., Schölkopf, B., Mallot, H. A. & Bülthoff, H. H. (1998). Where did I take that
snapshot? Scene-based homing by image matching. Biological Cybernetics 79, 191-202; Möller, R.
(2009). Local visual homing by warping of two-dimensional images. Robotics and Autonomous
Systems 57, 87-101. If the rover moved from the goal in direction ``alpha`` (in the goal's
frame), a landmark the goal saw at bearing ``theta`` is now seen between ``theta`` (a landmark
far away) and ``alpha + pi`` (one close by), on the same side of ``alpha``: bearings move away
from the direction of movement. For each candidate ``alpha`` min-warping matches every goal
column with the best current column inside its allowed interval (the minimum over the unknown
distance ratio) and adds up the column differences; the ``alpha`` with the smallest sum is the
estimated movement, and the goal lies at ``alpha + pi``.

A navigation controller plug-in (the contract: :mod:`sfa_gym.plugins`) that acts on rendered
panoramas (``Capabilities(panoramas=True)``), never on features or poses.

* **Columns** are those of a band of rows above the horizon (``band``, fractions of the height
  from the top; the horizon is at 0.5), grey, low-pass filtered (``blur``), every ``stride``-th
  column, each with its mean removed; they are compared as they are: Möller's scale planes (the
  vertical magnification of a column as the rover nears it) are left out, as in Franz et al.'s
  one-row warping. The column differences are squared Euclidean distances.
* **Compass.** The current panorama is turned into the goal's frame by the visual compass of
  :mod:`sfa_gym.navigation.homing` (reliable within about 2 m of the goal in the open arena);
  min-warping with a compass then searches only the movement direction.
* **Driving.** Every ``every`` steps the home direction is estimated again (one estimate costs
  about as much as a render); between estimates odometry turns it with the rover. The rover
  turns towards it and drives at ``speed`` times the cosine of the heading error. It stops once
  the rotation-invariant image difference is below ``stop_fraction`` of the episode's first
  (near the goal the difference falls about in proportion to the distance).

On the leaderboard (it needs a method only because the protocol fits one; it ignores it)::

    python -m sfa_gym.cli leaderboard run --method band_means \
        --controller baselines/controllers/min_warping.py --track nav_open --quick
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sfa_gym.capabilities import Capabilities
from sfa_gym.geometry import wrap_angle
from sfa_gym.navigation.homing import (
    STOP,
    as_image,
    check_band,
    check_panorama,
    check_speed,
    heading_difference,
    rotational_difference,
    steer,
)


@dataclass(frozen=True)
class Args:
    speed: float = 0.3
    """largest forward speed (m/s)"""
    band: tuple[float, float] = (0.1, 0.5)
    """the rows compared: from, to, as fractions of the panorama height from the top"""
    blur: float = 1.0
    """Gaussian low-pass filter of the grey panoramas (pixels; 0: none)"""
    stride: int = 2
    """every stride-th column is compared (the search costs stride ** -2)"""
    directions: int = 72
    """candidate movement directions, evenly over the circle"""
    every: int = 3
    """steps between two estimates of the home direction"""
    turn_gain: float = 2.0
    """yaw rate per radian of heading error (1/s)"""
    stop_fraction: float = 0.3
    """the rover stops once the image difference is below this fraction of the episode's first"""


def movement_direction(current: np.ndarray, goal: np.ndarray, directions: int) -> float:
    """The direction (rad, in the goal's frame: column ``c`` at ``2*pi*c/W``) in which the rover
    moved from the goal, by min-warping the goal's columns ``(H, W)`` onto the current ones
    (the current panorama turned into the goal's frame)."""
    width = goal.shape[1]
    # differences[i, j]: goal column i against current column j
    differences = (
        np.sum(goal * goal, axis=0)[:, None]
        + np.sum(current * current, axis=0)[None, :]
        - 2.0 * goal.T @ current
    )
    columns = np.arange(width)
    best, best_alpha = np.inf, 0.0
    for n in range(directions):
        alpha = 2.0 * math.pi * n / directions
        back = int(round((alpha + math.pi) / (2.0 * math.pi) * width)) % width  # alpha + pi
        # goal columns left of alpha (theta - alpha in (0, pi)) move counter-clockwise up to
        # ``back``: the smallest difference over current columns i .. back
        offset = (columns - alpha * width / (2.0 * math.pi)) % width
        left = (offset > 0) & (offset < width / 2)
        ahead = np.roll(differences, -(back + 1), axis=1)[:, ::-1]
        to_back = np.minimum.accumulate(ahead, axis=1)[:, ::-1]
        # the others move clockwise down to ``back``: over current columns back .. i
        behind = np.minimum.accumulate(np.roll(differences, -back, axis=1), axis=1)
        cost = np.where(
            left,
            to_back[columns, (columns - back - 1) % width],
            behind[columns, (columns - back) % width],
        ).sum()
        if cost < best:
            best, best_alpha = cost, alpha
    return best_alpha


class MinWarping:
    """The controller (see the module docstring) for a ``rover``
    (:class:`sfa_gym.navigation.sensors.Rover`); the feature weights are not used."""

    name = "min_warping"
    capabilities = Capabilities(panoramas=True)

    def __init__(self, rover: Any, args: Args) -> None:
        check_speed(args.speed, rover)
        check_band(args.band)
        if args.blur < 0:
            raise ValueError(f"blur must be >= 0 pixels, got {args.blur}")
        for name in ("stride", "directions", "every"):
            if getattr(args, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(args, name)}")
        if args.turn_gain <= 0:
            raise ValueError(f"turn_gain must be > 0, got {args.turn_gain}")
        if not 0 <= args.stop_fraction < 1:
            raise ValueError(f"stop_fraction must be in [0, 1), got {args.stop_fraction}")
        self.rover, self.args = rover, args

    def _grey(self, obs: dict, key: str) -> np.ndarray:
        return as_image(check_panorama(obs[key], key), colour=False, blur=self.args.blur)

    def _columns(self, grey: np.ndarray) -> np.ndarray:
        height = grey.shape[0]
        top, bottom = (int(round(f * height)) for f in self.args.band)
        band = grey[top:bottom, :: self.args.stride]
        return band - band.mean(axis=0)

    def reset(self, obs: dict, info: dict) -> None:
        self.goal = self._grey(obs, "goal_panorama")
        self.goal_columns = self._columns(self.goal)
        self.first = None  # the episode's first image difference
        self.steps = 0
        self.home = 0.0  # the home direction in the odometry frame

    def _estimate(self, obs: dict, yaw: float) -> bool:
        """Estimate the home direction again; False when the rover has arrived."""
        current = self._grey(obs, "panorama")
        if current.shape != self.goal.shape:
            raise ValueError(f"panorama {current.shape} differs from the goal's {self.goal.shape}")
        difference, shift = rotational_difference(current, self.goal)
        self.first = difference if self.first is None else self.first
        if difference < self.args.stop_fraction * self.first:
            return False
        # the current panorama turned into the goal's frame (np.roll(current, -shift) matches)
        aligned = self._columns(np.roll(current, -shift, axis=1))
        alpha = movement_direction(aligned, self.goal_columns, self.args.directions)
        # the goal's frame is the rover's turned by -heading difference; the goal at alpha + pi
        home_in_rover = wrap_angle(alpha + math.pi - heading_difference(shift, current.shape[1]))
        self.home = yaw + home_in_rover
        return True

    def act(self, obs: dict, info: dict) -> np.ndarray:
        a, rover = self.args, self.rover
        yaw = float(info["odometry"][2])
        if self.steps % a.every == 0 and not self._estimate(obs, yaw):
            return STOP.copy()
        self.steps += 1
        error = wrap_angle(self.home - yaw)
        return steer(error, a.speed, a.turn_gain, rover.w_max)


def make_controller(rover: Any, weights: np.ndarray, **kwargs: Any) -> MinWarping:
    return MinWarping(rover, Args(**kwargs))
