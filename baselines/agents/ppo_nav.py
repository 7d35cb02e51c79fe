"""PPO (stable-baselines3) on goal-conditioned features in the navigation envs.

The agent observes ``Dict(features, goal_features)`` from a feature field (the env steps physics
only, thousands of steps per second) and outputs ``(v, w)``; the episode ends on arrival
(``stop_action=False``: a continuous stop action would end most early episodes at random). The
policy is an MLP on the concatenated current and goal features, with the PPO settings of Lange et
al. 2024 (arXiv 2402.12067). Every ``eval_every`` steps it is evaluated deterministically on fixed
episode seeds; the learning curve (success vs steps) is written as CSV and PNG.

Run it on a field written by ``sfa-gym navigate`` (``field_sfa.npz``, ``field_fft_magnitude.npz``,
...)::

    python baselines/agents/ppo_nav.py --field results/nav/field_sfa.npz --out results/ppo-sfa

The model file is SB3's zip, which stores the policy's weights as torch tensors and some objects
as pickles: SB3's loader unpickles them, so load only model files you made yourself.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Args:
    field: Path
    """feature field file (.npz) of the env's world"""
    out: Path = Path("results/ppo")
    """output folder: learning curve (CSV, PNG) and the final model"""
    env_id: str = "sfa_gym/OmniRoverNav-v0"
    """navigation env"""
    world_seed: int = 0
    """world seed the field was built for"""
    total_timesteps: int = 1_000_000
    """training steps"""
    seed: int = 0
    """seed of the policy, the training episodes and the vector envs"""
    n_envs: int = 4
    """environments stepped per PPO update (in this process)"""
    reward: str = "geodesic"
    """env reward: geodesic (progress along the shortest path, oracle shaping) or sparse"""
    eval_every: int = 50_000
    """steps between evaluations"""
    eval_episodes: int = 50
    """episodes per evaluation (seeds 10000 ...)"""
    n_steps: int = 128
    """PPO rollout length per env"""
    learning_rate: float = 2.5e-4
    """PPO learning rate"""
    batch_size: int = 128
    """PPO minibatch size"""
    ent_coef: float = 0.01
    """PPO entropy coefficient"""
    clip_range: float = 0.1
    """PPO clip range"""


def make_env(args: Args):
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)

    env = gym.make(
        args.env_id,
        world_seed=args.world_seed,
        feature_field=str(args.field),
        stop_action=False,
        reward=args.reward,
    )
    return gym.wrappers.FlattenObservation(env)


def evaluate(model, args: Args) -> dict[str, float]:
    """Success rate and SPL of the deterministic policy on fixed episode seeds."""
    from sfa_gym.navigation.metrics import spl

    env = make_env(args)
    success, scores = [], []
    for seed in range(10_000, 10_000 + args.eval_episodes):
        obs, info = env.reset(seed=seed)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        success.append(info["success"])
        scores.append(spl(info["success"], info["shortest_path"], info["path_length"]))
    env.close()
    return {"success": float(np.mean(success)), "spl": float(np.mean(scores))}


def train(args: Args) -> list[dict[str, float]]:
    """Train PPO, evaluating every ``eval_every`` steps; returns the learning curve."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env

    args.out.mkdir(parents=True, exist_ok=True)
    venv = make_vec_env(lambda: make_env(args), n_envs=args.n_envs, seed=args.seed)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=args.n_steps,
        batch_size=args.batch_size,
        learning_rate=args.learning_rate,
        gamma=0.99,
        gae_lambda=0.95,
        ent_coef=args.ent_coef,
        clip_range=args.clip_range,
        seed=args.seed,
        device="cpu",
        verbose=0,
    )
    curve: list[dict[str, float]] = []
    started = time.perf_counter()

    class Evaluate(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % args.eval_every < args.n_envs:
                score = evaluate(self.model, args)
                curve.append(
                    {"steps": self.num_timesteps, **score, "seconds": time.perf_counter() - started}
                )
                print(
                    f"{self.num_timesteps:>9} steps  success {score['success']:.2f}  "
                    f"SPL {score['spl']:.2f}",
                    flush=True,
                )
            return True

    model.learn(total_timesteps=args.total_timesteps, callback=Evaluate(), progress_bar=True)
    curve.append(
        {
            "steps": model.num_timesteps,
            **evaluate(model, args),
            "seconds": time.perf_counter() - started,
        }
    )
    model.save(args.out / "model.zip")
    with open(args.out / "learning_curve.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(curve[0]))
        writer.writeheader()
        writer.writerows(curve)
    return curve


if __name__ == "__main__":
    import tyro

    train(tyro.cli(Args))
