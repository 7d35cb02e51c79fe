"""Image-difference descent: home by running down the difference between the current panorama
and the goal's (the "RunDown" of Zeil, Hofmann & Chahl 2003).

Zeil, J., Hofmann, M. I. & Chahl, J. S. (2003). Catchment areas of panoramic snapshots in
outdoor scenes. JOSA A 20(3), 450-469. They found that the RMS pixel difference between a
panorama and a snapshot taken at the goal grows smoothly with the distance from the goal over a
catchment area of metres, and that an agent can home by descending it without knowing where it
is: *RunDown* moves straight while the difference falls and turns by 90 degrees when it rises.

A navigation controller plug-in (the contract: :mod:`sfa_gym.plugins`) that acts on rendered
panoramas (``Capabilities(panoramas=True)``), never on features or poses. The difference is
that of grey levels by default (``colour=False``: the mean of R, G, B; ``colour=True`` compares
the three channels), at the best column shift between the two panoramas: the camera's columns
turn with the rover and the goal panorama was taken at another heading, so the shift that
matches them best is a visual compass and the RMS difference there does not depend on the
rover's heading (:func:`sfa_gym.navigation.homing.rotational_difference`).

The rover drives straight *segments* of ``run`` m and compares the difference at the end of each
with the one at its start:

* lower by at least ``progress`` (relative): on in the same direction;
* not lower: it turns by 90 degrees where it is and drives on (RunDown backs up to nothing):
  first to the left of the heading that failed, then to its right, then back along it;
  after a full round of failures (four segments in a row) it halves the segment length;
* it stops once the difference is below ``stop_fraction`` of the episode's first (near the goal
  the difference falls about in proportion to the distance), or once failures have halved the
  segment below ``min_run``: no direction lowers the difference, the goal (or a local
  minimum of the difference).

A segment also ends early when the range sensor sees a wall within ``clearance`` ahead.

On the leaderboard (it needs a method only because the protocol fits one; it ignores it)::

    python -m sfa_gym.cli leaderboard run --method band_means \
        --controller baselines/controllers/image_difference.py --track nav_open --quick
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
    check_panorama,
    check_speed,
    rotational_difference,
)


@dataclass(frozen=True)
class Args:
    speed: float = 0.3
    """forward speed of a run (m/s)"""
    run: float = 0.3
    """length of a segment (m) at the start of an episode"""
    min_run: float = 0.1
    """the rover stops once failed segments have halved their length below this (m)"""
    stop_fraction: float = 0.3
    """the rover stops once the difference is below this fraction of the episode's first"""
    progress: float = 0.01
    """relative decrease of the image difference that counts as downhill (smaller ones are
    rendering noise: a panorama at the same place differs by a few grey levels after a turn)"""
    colour: bool = False
    """compare colours (R, G, B) instead of grey levels"""
    blur: float = 2.0
    """Gaussian low-pass filter of both panoramas (pixels; 0: none): a smoother difference
    that keeps falling further from the goal (Zeil et al. compared filtered images too)"""
    clearance: float = 0.55
    """range (m, from the rover's centre) ahead below which a segment ends"""


# The turns after failed segments, relative to the heading of the first failure: left, right,
# back; after them the first heading again, with shorter segments.
_TURNS = (math.pi / 2, -math.pi / 2, math.pi, 0.0)


class ImageDifferenceDescent:
    """The controller (see the module docstring) for a ``rover``
    (:class:`sfa_gym.navigation.sensors.Rover`); the feature weights are not used."""

    name = "image_difference"
    capabilities = Capabilities(panoramas=True)

    def __init__(self, rover: Any, args: Args) -> None:
        check_speed(args.speed, rover)
        if not 0 < args.min_run <= args.run:
            raise ValueError(f"need 0 < min_run <= run, got min_run={args.min_run}, run={args.run}")
        if not 0 <= args.progress < 1:
            raise ValueError(f"progress must be in [0, 1), got {args.progress}")
        if not 0 <= args.stop_fraction < 1:
            raise ValueError(f"stop_fraction must be in [0, 1), got {args.stop_fraction}")
        if args.blur < 0:
            raise ValueError(f"blur must be >= 0 pixels, got {args.blur}")
        if args.clearance < 0:
            raise ValueError(f"clearance must be >= 0 m, got {args.clearance}")
        self.rover, self.args = rover, args
        self.ahead = np.abs(np.asarray(rover.range_angles, float)) <= math.radians(20)

    def image(self, obs: dict, key: str) -> np.ndarray:
        return as_image(check_panorama(obs[key], key), self.args.colour, self.args.blur)

    def difference(self, obs: dict) -> float:
        """The rotation-invariant RMS difference between the current and the goal panorama."""
        current = self.image(obs, "panorama")
        if self.goal.shape != current.shape:
            raise ValueError(f"panorama {current.shape} differs from the goal's {self.goal.shape}")
        return rotational_difference(current, self.goal)[0]

    def reset(self, obs: dict, info: dict) -> None:
        self.goal = self.image(obs, "goal_panorama")
        self.last = self.difference(obs)  # at the start of the segment
        self.stop_below = self.args.stop_fraction * self.last
        self.origin = np.asarray(info["odometry"], float)  # (x, y, yaw): the segment's start
        self.failures = 0  # failed segments in a row
        self.failed_yaw = self.target_yaw = self.origin[2]
        self.length = self.args.run
        self.mode = "run"

    def _turn(self, x: float, y: float, yaw: float) -> None:
        """After a failed segment: the next heading of the round, or shorter segments."""
        if self.failures == 1:
            self.failed_yaw = self.target_yaw
        self.target_yaw = self.failed_yaw + _TURNS[(self.failures - 1) % len(_TURNS)]
        if self.failures % len(_TURNS) == 0:  # a full round failed: shorter segments
            self.length /= 2
            if self.length < self.args.min_run:
                self.mode = "stop"
                return
        self.mode = "turn"

    def act(self, obs: dict, info: dict) -> np.ndarray:
        a, rover = self.args, self.rover
        x, y, yaw = (float(v) for v in info["odometry"])
        travelled = math.hypot(x - self.origin[0], y - self.origin[1])
        if self.mode == "run":
            blocked = bool(np.any(np.asarray(info["range"])[self.ahead] < a.clearance))
            if travelled >= self.length or blocked:
                difference = self.difference(obs)
                if difference < self.stop_below:
                    self.mode = "stop"
                elif difference < self.last * (1 - a.progress) and not blocked:
                    self.failures = 0  # downhill: on
                else:
                    self.failures += 1
                    self._turn(x, y, yaw)
                self.last = difference
                self.origin = np.array([x, y, yaw])
        if self.mode == "turn":
            error = wrap_angle(self.target_yaw - yaw)
            if abs(error) > math.radians(3):  # full yaw rate, slowing for the last 0.2 rad
                w = float(np.clip(5.0 * error, -rover.w_max, rover.w_max))
                return np.array([0.0, w, -1.0], dtype=np.float32)
            self.origin = np.array([x, y, yaw])
            self.mode = "run"
        if self.mode == "run":  # straight on, holding the segment's heading against drift
            error = wrap_angle(self.target_yaw - yaw)
            w = float(np.clip(2.0 * error, -rover.w_max, rover.w_max))
            return np.array([a.speed, w, -1.0], dtype=np.float32)
        return STOP.copy()  # stop


def make_controller(rover: Any, weights: np.ndarray, **kwargs: Any) -> ImageDifferenceDescent:
    return ImageDifferenceDescent(rover, Args(**kwargs))
