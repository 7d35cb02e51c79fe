"""Scoring a navigation agent with SB3's ``evaluate_policy`` and ``EvalCallback``: the
deterministic policy on fixed episode seeds, success rate, SPL and final distance.

Episode ``i`` of an evaluation is the env reset with seed ``seed + i`` (:class:`SeededEpisodes`):
every evaluation during training, and ``sfa-gym agent eval`` with the same seed, runs the same
episodes.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import EvalCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.preprocessing import is_image_space, is_image_space_channels_first
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecTransposeImage
from tqdm import tqdm

from sfa_gym._checks import check_positive_int
from sfa_gym.agents.env import AgentEnv, make_env

__all__ = ["EpisodeEnds", "NavigationEvalCallback", "SeededEpisodes", "evaluate", "eval_env"]


class SeededEpisodes(gym.Wrapper):
    """Resets without a seed draw episode ``first, first + 1, ...``; :meth:`restart` goes back to
    ``first``. So an evaluation's episodes do not depend on what ran before it."""

    def __init__(self, env: gym.Env, first: int) -> None:
        super().__init__(env)
        self.first = self.next = first

    def restart(self) -> None:
        self.next = self.first

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        if seed is None:
            seed, self.next = self.next, self.next + 1
        return self.env.reset(seed=seed, options=options)


def eval_env(settings: AgentEnv, seed: int) -> VecEnv:
    """One env of ``settings`` whose episodes are seeded ``seed, seed + 1, ...`` (``Monitor``
    records each episode's return for ``evaluate_policy``); images channels first, as SB3 wraps
    the training envs of a ``CnnPolicy``."""
    venv: VecEnv = DummyVecEnv([lambda: SeededEpisodes(Monitor(make_env(settings)), seed)])
    if is_image_space(venv.observation_space) and not is_image_space_channels_first(
        venv.observation_space
    ):
        venv = VecTransposeImage(venv)
    return venv


class EpisodeEnds:
    """``evaluate_policy``'s per-step callback: keeps each finished episode's last info and
    advances a progress bar (shown unless ``progress`` is False)."""

    def __init__(self, episodes: int, progress: bool, desc: str = "evaluation") -> None:
        self.infos: list[dict[str, Any]] = []
        self.bar = tqdm(total=episodes, disable=not progress, desc=desc, unit="episode",
                        leave=False)  # fmt: skip

    def __call__(self, locals_: dict[str, Any], globals_: dict[str, Any]) -> None:
        if locals_["done"]:
            self.infos.append(locals_["info"])
            self.bar.update(1)

    def close(self) -> dict[str, float]:
        """Closes the bar; returns the score (see :func:`summarize`)."""
        self.bar.close()
        return summarize(self.infos)


def summarize(infos: list[dict[str, Any]]) -> dict[str, float]:
    """Success rate (arrival), mean SPL and mean final geodesic distance (m) of the episodes
    whose last infos are ``infos``."""
    from sfa_gym.navigation.metrics import spl

    if not infos:
        raise ValueError("no episode ended: nothing to score")
    return {
        "success": float(np.mean([i["success"] for i in infos])),
        "spl": float(
            np.mean([spl(i["success"], i["shortest_path"], i["path_length"]) for i in infos])
        ),  # fmt: skip
        "final_distance": float(np.mean([i["geodesic_distance"] for i in infos])),
    }


def evaluate(
    model: Any, settings: AgentEnv, episodes: int, seed: int, progress: bool = True
) -> dict[str, float]:
    """Score the deterministic policy of ``model`` on the episodes ``seed ... seed + episodes -
    1`` of ``settings``'s env: success, SPL, final distance and the mean episode return."""
    check_positive_int("episodes", episodes)
    venv = eval_env(settings, seed)
    ends = EpisodeEnds(episodes, progress)
    try:
        returns, _ = evaluate_policy(
            model, venv, n_eval_episodes=episodes, deterministic=True, callback=ends,
            return_episode_rewards=True,
        )  # fmt: skip
    finally:
        ends.bar.close()
        venv.close()
    return ends.close() | {"return": float(np.mean(returns))}


class NavigationEvalCallback(EvalCallback):
    """SB3's ``EvalCallback`` on the same seeded episodes at every evaluation, also scoring
    success, SPL and final distance; ``record(steps, score)`` receives each evaluation."""

    def __init__(self, venv: VecEnv, episodes: int, every: int, record, progress: bool):
        super().__init__(venv, n_eval_episodes=episodes, eval_freq=every, deterministic=True,
                         verbose=0, warn=False)  # fmt: skip
        self.record, self.progress = record, progress
        self._ends: EpisodeEnds | None = None

    def _on_step(self) -> bool:
        due = self.eval_freq > 0 and self.n_calls % self.eval_freq == 0
        if due:
            self.eval_env.env_method("restart")
            self._ends = EpisodeEnds(self.n_eval_episodes, self.progress)
        go_on = super()._on_step()
        if due and self._ends is not None:
            score = self._ends.close() | {"return": float(self.last_mean_reward)}
            self._ends = None
            self.record(self.num_timesteps, score)
        return go_on

    def _log_success_callback(self, locals_: dict[str, Any], globals_: dict[str, Any]) -> None:
        super()._log_success_callback(locals_, globals_)
        if self._ends is not None:
            self._ends(locals_, globals_)
