"""Run and tumble: down the feature cost the way a bacterium climbs a scent, without a gradient.

A navigation controller plug-in (the contract: :mod:`sfa_gym.plugins`) and the floor
that gradient following has to beat: it sees what the slow-feature-gradient controller sees (the
features, the goal's features, the wheel odometry, the range sensor) and minimises the same cost,
the weighted squared distance ``sum_i w_i (f_i - g_i)^2``, but it never estimates a gradient. It
only compares the cost at the end of a straight run with the best cost so far:

* a run that lowered the cost is followed by the next one in nearly the same direction (a random
  turn of at most ``keep_deg``) and a longer run;
* a run that did not lower it by at least ``progress`` (relative) is driven back to where it
  started (the best place found so far), and the rover *tumbles*: it turns on the spot by a
  random angle and tries a shorter run;
* a run ends early when the range sensor sees a wall within ``clearance`` ahead;
* after ``patience`` failed runs in a row at the shortest run length it stops: every direction
  around it is uphill, the goal or a false minimum of the cost; it also stops once the cost is
  below ``stop_fraction`` of the episode's first cost.

Run alone on a feature field that ``sfa-gym navigate`` wrote (its cost weights are in the
field's metadata)::

    python baselines/controllers/run_and_tumble.py --field results/nav/field_sfa.npz --episodes 20

On the leaderboard::

    sfa-gym leaderboard run --method baselines/band_means.py --controller \
        baselines/controllers/run_and_tumble.py --quick
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Args:
    speed: float = 0.3
    """forward speed of a run (m/s)"""
    first_run: float = 0.4
    """length of the first run (m)"""
    min_run: float = 0.1
    """shortest run (m): failed runs halve the length down to this"""
    max_run: float = 1.0
    """longest run (m): successful runs grow the length by half up to this"""
    keep_deg: float = 30.0
    """largest random turn (degrees) after a run that lowered the cost"""
    progress: float = 0.02
    """relative decrease of the best cost that counts as downhill (smaller ones are noise)"""
    patience: int = 8
    """failed runs in a row at the shortest length after which the rover stops"""
    stop_fraction: float = 0.01
    """the rover also stops when the cost falls below this fraction of the episode's first
    cost (near the goal the cost falls with the squared distance: 0.01 of it is a tenth of the
    starting distance)"""
    clearance: float = 0.55
    """range (m, from the rover's centre) ahead below which a run ends"""
    seed: int = 0
    """seed of the random turns"""


class RunAndTumble:
    """The controller (see the module docstring) for a ``rover``
    (:class:`sfa_gym.navigation.sensors.Rover`) and cost ``weights`` ``(k,)``."""

    name = "run_and_tumble"

    def __init__(self, rover: Any, weights: np.ndarray, args: Args) -> None:
        if args.min_run <= 0 or not args.min_run <= args.first_run <= args.max_run:
            raise ValueError(
                f"need 0 < min_run <= first_run <= max_run, got {args.min_run}, "
                f"{args.first_run}, {args.max_run}"
            )
        if args.patience < 1:
            raise ValueError(f"patience must be >= 1, got {args.patience}")
        self.rover, self.weights, self.args = rover, np.asarray(weights, float), args
        angles = np.asarray(rover.range_angles, float)
        self.ahead = np.abs(angles) <= math.radians(20)  # the rays that look ahead
        self.rng = np.random.default_rng(args.seed)

    def reset(self, obs: dict, info: dict) -> None:
        self.best = self._cost(obs)
        self.stop_cost = self.args.stop_fraction * self.best
        self.length = self.args.first_run
        self.failures = 0
        self.mode = "run"
        self.origin = np.asarray(info["odometry"], float)  # (x, y, yaw) where the run began
        self.target_yaw = self.origin[2]

    def _cost(self, obs: dict) -> float:
        difference = np.asarray(obs["features"]) - np.asarray(obs["goal_features"])
        return float(np.sum(self.weights * difference**2))

    def _tumble(self, small: bool) -> None:
        limit = math.radians(self.args.keep_deg) if small else math.pi
        turn = self.rng.uniform(-limit, limit)
        if not small:  # a tumble turns at least a quarter turn: the run just failed there
            turn = math.copysign(max(abs(turn), math.pi / 2), turn)
        self.target_yaw = self.origin[2] + turn
        self.mode = "turn"

    def act(self, obs: dict, info: dict) -> np.ndarray:
        a, rover = self.args, self.rover
        x, y, yaw = (float(v) for v in info["odometry"])
        travelled = math.hypot(x - self.origin[0], y - self.origin[1])
        if self.mode == "run":
            blocked = bool(np.any(np.asarray(info["range"])[self.ahead] < a.clearance))
            if travelled >= self.length or (blocked and travelled > 0.02):
                cost = self._cost(obs)
                if cost < self.stop_cost:
                    self.mode = "stop"
                elif cost < self.best * (1 - a.progress):  # downhill: on, a little further
                    self.best, self.failures = cost, 0
                    self.length = min(a.max_run, self.length * 1.5)
                    self.origin = np.array([x, y, yaw])
                    self._tumble(small=True)
                else:  # uphill: back to the best place, then somewhere else
                    # a run a wall cut short says little about the cost: no failure
                    short = blocked and travelled < self.length
                    self.failures += 1 if self.length <= a.min_run and not short else 0
                    self.length = max(a.min_run, self.length / 2)
                    self.mode = "back"
                    # backing up ends at the start of the run, or after as long as the run
                    # took and a second more (wheels that slipped on a wall moved the odometry)
                    self.back_steps = int(travelled / (a.speed * rover.dt)) + 10
            elif blocked:  # a wall right at the start of the run
                self._tumble(small=False)
            else:
                return np.array([a.speed, 0.0, -1.0], dtype=np.float32)
        if self.mode == "back":
            self.back_steps -= 1
            if travelled > 0.02 and self.back_steps > 0:
                return np.array([-a.speed, 0.0, -1.0], dtype=np.float32)
            if self.failures >= a.patience:
                self.mode = "stop"
            else:
                self.origin = np.array([x, y, self.origin[2]])
                self._tumble(small=False)
        if self.mode == "turn":
            error = (self.target_yaw - yaw + math.pi) % math.tau - math.pi
            if abs(error) > math.radians(3):  # full yaw rate, slowing for the last 0.2 rad
                w = float(np.clip(5.0 * error, -rover.w_max, rover.w_max))
                return np.array([0.0, w, -1.0], dtype=np.float32)
            self.origin = np.array([x, y, yaw])
            self.mode = "run"
            return np.array([a.speed, 0.0, -1.0], dtype=np.float32)
        return np.array([0.0, 0.0, 1.0], dtype=np.float32)  # stop


def make_controller(rover: Any, weights: np.ndarray, **kwargs: Any) -> RunAndTumble:
    return RunAndTumble(rover, weights, Args(**kwargs))


def main() -> None:
    import argparse

    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the envs)
    from sfa_gym.navigation.evaluate import run_episodes, summarize
    from sfa_gym.navigation.field import FeatureField
    from sfa_gym.navigation.sensors import Rover
    from sfa_gym.plugins import load_controller_plugin

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--field", type=Path, required=True, help="feature field (.npz)")
    parser.add_argument("--env-id", default="sfa_gym/OmniRoverNav-v0")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=1000, help="seed of the first episode")
    options = parser.parse_args()
    field = FeatureField.load(options.field)
    info = field.metadata.get("model_info") or {}
    weights = np.asarray(info.get("cost_weights", np.ones(field.n_features)), float)
    env = gym.make(options.env_id, world_seed=field.metadata["world_seed"], feature_field=field)
    controller = load_controller_plugin(__file__)(Rover.of(env), weights)
    seeds = range(options.first_seed, options.first_seed + options.episodes)
    scores = summarize(run_episodes(env, controller, seeds))["all"]
    print(
        f"success {scores['success']['mean']:.2f}, SPL {scores['spl']['mean']:.2f} "
        f"over {scores['episodes']} episodes"
    )


if __name__ == "__main__":
    main()
