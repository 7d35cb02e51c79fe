"""The average landmark vector (ALV) model: home along the difference of two landmark vectors.

Lambrinos, D., Möller, R., Labhart, T., Pfeifer, R. & Wehner, R. (2000). A mobile robot
employing insect strategies for navigation. Robotics and Autonomous Systems 30, 39-64; Möller,
R. (2000). Insect visual homing strategies in a robot with analog processing. Biological
Cybernetics 83, 231-243. The ALV of a place is the mean of the unit vectors pointing to the
landmarks seen there, in compass directions; the *home vector* ``ALV(current) - ALV(goal)``
points towards the goal (moving away from the goal turns every landmark's bearing away from its
bearing at the goal), and the goal needs only its ALV, two numbers, to be remembered.

A navigation controller plug-in (the contract: :mod:`sfa_gym.plugins`) that acts on rendered
panoramas (``Capabilities(panoramas=True)``), never on features or poses.

* **Landmarks** are the dark things against the sky: in a band of rows above the horizon
  (``band``, fractions of the panorama height from the top; the horizon is at 0.5), a pixel
  darker than ``dark`` times the band's bright sky (its 90th percentile of grey) is a landmark
  pixel, and each run of adjacent columns holding one is a landmark, seen at the run's centre.
  One unit vector per landmark, as in Lambrinos et al.: weighting by pixels would let a near
  landmark's growing size outweigh its bearing, and the home vector points the wrong way.
* **Compass.** The goal's ALV is turned into the rover's frame by the visual compass of
  :mod:`sfa_gym.navigation.homing` (the camera's columns turn with the rover, and the goal
  panorama was taken at another heading).
* **Driving.** The rover turns towards the home vector and drives at ``speed`` times the cosine
  of the heading error (none while it points more than 90 degrees away); it stops once the home
  vector's length has stayed below ``stop_length`` for ``stop_steps`` steps in a row (near the
  goal the length falls in proportion to the distance: about 0.065 per metre in the open arena).

On the leaderboard (it needs a method only because the protocol fits one; it ignores it)::

    python -m sfa_gym.cli leaderboard run --method band_means \
        --controller baselines/controllers/average_landmark_vector.py --track nav_open --quick
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sfa_gym.capabilities import Capabilities
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
    """the rows where landmarks are looked for: from, to, as fractions of the panorama height
    from the top (0.5 is the horizon)"""
    dark: float = 0.75
    """a pixel darker than this fraction of the band's sky level (its 90th percentile) belongs
    to a landmark"""
    turn_gain: float = 2.0
    """yaw rate per radian of heading error (1/s)"""
    stop_length: float = 0.015
    """the rover stops when the home vector is shorter than this ..."""
    stop_steps: int = 3
    """... for this many steps in a row"""
    compass_blur: float = 2.0
    """Gaussian low-pass filter (pixels) of the grey panoramas the visual compass compares"""


def landmark_vector(
    panorama: np.ndarray, band: tuple[float, float], dark: float
) -> tuple[np.ndarray, int]:
    """The ALV ``(2,)`` of ``panorama`` in its own frame (x ahead, y to the left) and the number
    of landmarks it averages (``0``: none found, the zero vector)."""
    grey = as_image(panorama, colour=False)
    height, width = grey.shape
    rows = grey[int(round(band[0] * height)) : int(round(band[1] * height))]
    landmark = (rows < dark * np.percentile(rows, 90)).any(axis=0)
    if landmark.all() or not landmark.any():  # one landmark all around, or none
        return np.zeros(2), 0
    start = int(np.argmin(landmark))  # a free column: runs do not wrap around from there
    steps = np.diff(np.concatenate([[0], np.roll(landmark, -start).astype(np.int8), [0]]))
    first, after = np.flatnonzero(steps == 1), np.flatnonzero(steps == -1)
    centres = ((first + after - 1) / 2 + start) % width
    azimuths = centres * (2 * math.pi / width)  # column c looks at 2 pi c / W from the heading
    return np.array([np.cos(azimuths).mean(), np.sin(azimuths).mean()]), len(centres)


class AverageLandmarkVector:
    """The controller (see the module docstring) for a ``rover``
    (:class:`sfa_gym.navigation.sensors.Rover`); the feature weights are not used."""

    name = "average_landmark_vector"
    capabilities = Capabilities(panoramas=True)

    def __init__(self, rover: Any, args: Args) -> None:
        check_speed(args.speed, rover)
        check_band(args.band)
        if not 0 < args.dark < 1:
            raise ValueError(f"dark must be in (0, 1), got {args.dark}")
        if args.turn_gain <= 0:
            raise ValueError(f"turn_gain must be > 0, got {args.turn_gain}")
        if args.stop_length < 0:
            raise ValueError(f"stop_length must be >= 0, got {args.stop_length}")
        if args.stop_steps < 1:
            raise ValueError(f"stop_steps must be >= 1, got {args.stop_steps}")
        if args.compass_blur < 0:
            raise ValueError(f"compass_blur must be >= 0 pixels, got {args.compass_blur}")
        self.rover, self.args = rover, args

    def reset(self, obs: dict, info: dict) -> None:
        goal = check_panorama(obs["goal_panorama"], "goal_panorama")
        self.goal_alv, self.goal_landmarks = landmark_vector(goal, self.args.band, self.args.dark)
        self.goal_grey = as_image(goal, colour=False, blur=self.args.compass_blur)
        self.below = 0  # steps in a row with a short home vector

    def home_vector(self, obs: dict) -> np.ndarray:
        """``ALV(current) - ALV(goal)`` in the rover's frame (x ahead, y to the left)."""
        panorama = check_panorama(obs["panorama"], "panorama")
        current = as_image(panorama, colour=False, blur=self.args.compass_blur)
        if current.shape != self.goal_grey.shape:
            raise ValueError(f"panorama {panorama.shape} differs from the goal's")
        _, shift = rotational_difference(current, self.goal_grey)
        # the goal's ALV, turned from the goal's frame into the rover's
        turn = -heading_difference(shift, current.shape[1])
        c, s = math.cos(turn), math.sin(turn)
        goal = np.array([[c, -s], [s, c]]) @ self.goal_alv
        return landmark_vector(panorama, self.args.band, self.args.dark)[0] - goal

    def act(self, obs: dict, info: dict) -> np.ndarray:
        a, rover = self.args, self.rover
        home = self.home_vector(obs)
        self.below = self.below + 1 if float(np.hypot(*home)) < a.stop_length else 0
        if self.below >= a.stop_steps:
            return STOP.copy()
        error = math.atan2(home[1], home[0])
        return steer(error, a.speed, a.turn_gain, rover.w_max)


def make_controller(rover: Any, weights: np.ndarray, **kwargs: Any) -> AverageLandmarkVector:
    return AverageLandmarkVector(rover, Args(**kwargs))
