"""PPO (stable-baselines3) on goal-conditioned features or on raw panoramas, navigation envs.

Two observations, one agent:

* **features** (``--field path.npz``): ``Dict(features, goal_features)`` read from a feature
  field of a fitted method (``field_sfa.npz``, ``field_fft_magnitude.npz``, ... written by
  ``sfa-gym navigate``): the env steps physics only, ~2000 steps/s. The features do not
  depend on the heading, so the policy (``MlpPolicy``) also sees a short memory of recent
  features and odometry positions (:class:`FeatureHistory`): what the gradient controller
  estimates its gradient from.
* **pixels** (no ``--field``): the rendered current and goal panoramas stacked along the
  channels, ``(H, W, 6)`` uint8, into SB3's ``CnnPolicy`` (NatureCNN). Rendering costs ~7 ms a
  step, so this agent gets a smaller step budget: say so when you report it.
* **oracle** (``--oracle``, with a field to skip rendering): the goal's position relative to
  the rover from the ground truth: an upper bound that shows the reward and the episodes are
  learnable, not a robot's view.

The action is ``(v, w)``; the episode ends on arrival within the success radius
(``stop_action=False``): a continuous stop action would end most early episodes at random.
Success for these agents is therefore *arrival*, not the Habitat-style arrival plus a stop
decision the gradient controller is scored on. The PPO settings are those of Lange et al. 2024
(arXiv 2402.12067): n_steps 128, lr 2.5e-4, gamma 0.99, GAE 0.95, entropy 0.01, clip 0.1,
batch 128. The reward is the env's: geodesic progress (oracle shaping from the map) plus 1 on
arrival, or sparse.

Every ``eval_every`` steps the deterministic policy runs on fixed episode seeds (``eval_seed``
...) and the learning curve (success, SPL vs steps) is written to ``learning_curve.csv``; the
model is checkpointed beside it. Both are written atomically (a temporary file, then a
rename), and a run started again with the same ``--out`` resumes from the checkpoint.
Resuming continues the policy, the optimiser and the step count; the training envs restart
with fresh episodes, so a resumed run is not bit-identical to an uninterrupted one.

Usage (from the repository root, after ``sfa-gym navigate --out results/nav --baselines
baselines/``)::

    python baselines/agents/ppo_nav.py --field results/nav/field_sfa.npz --out results/ppo/sfa-0
    python baselines/agents/ppo_nav.py --out results/ppo/pixels-0 --total-timesteps 100000

The model files are SB3's zip, which stores the policy's weights as torch tensors and some
objects as pickles; SB3's loader unpickles them, so load only model files you made yourself.
"""

from __future__ import annotations

import csv
import io
import os
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from sfa_gym.navigation.controllers import GradientSettings
from sfa_gym.navigation.feature_gradient import LocalLinearFit, gauss_newton_step

CURVE = "learning_curve.csv"
CHECKPOINT = "checkpoint.zip"
FIELDS = ("steps", "success", "spl", "final_distance", "seconds")
MAX_STEP = 3.0  # m: the longest goal estimate an agent sees (the arena is 6 m across)


@dataclass(frozen=True)
class Args:
    out: Path
    """output folder: learning curve (CSV, PNG), checkpoint and final model"""
    field: Path | None = None
    """feature field (.npz) of the env's world; None: raw panoramas, rendered, CnnPolicy"""
    env_id: str = "sfa_gym/OmniRoverNav-v0"
    """navigation env"""
    world_seed: int = 0
    """world seed (the field's, when there is one)"""
    total_timesteps: int = 1_000_000
    """training steps"""
    seed: int = 0
    """seed of the policy, the training episodes and the vector envs"""
    n_envs: int = 4
    """environments stepped per PPO update (in this process)"""
    reward: str = "geodesic"
    """env reward: geodesic (progress along the shortest path, oracle shaping) or sparse"""
    eval_every: int = 50_000
    """steps between evaluations (and checkpoints)"""
    eval_episodes: int = 50
    """episodes per evaluation"""
    eval_seed: int = 10_000
    """seed of the first evaluation episode (the same episodes at every evaluation)"""
    n_steps: int = 128
    """PPO rollout length per env"""
    learning_rate: float = 2.5e-4
    """PPO learning rate"""
    anneal_lr: bool = False
    """decay the learning rate linearly to 0 over total_timesteps (CleanRL's PPO does): the
    late updates then refine the policy instead of moving it about"""
    batch_size: int = 128
    """PPO minibatch size"""
    n_epochs: int = 10
    """PPO epochs per update"""
    ent_coef: float = 0.01
    """PPO entropy coefficient"""
    clip_range: float = 0.1
    """PPO clip range"""
    threads: int = 1
    """torch threads (1: several runs share the cores without contention)"""
    oracle: bool = False
    """upper bound: observe the goal's position relative to the rover (ground truth) instead
    of features (the field only spares the rendering)"""
    history: int = 8
    """feature agents remember the current step and history - 1 earlier ones: the feature
    change over each of those moves beside the move (odometry, body frame)"""
    history_stride: int = 2
    """steps between the remembered ones"""
    estimate: bool = False
    """feature agents also see where the local linear fit of their recent features against
    odometry puts the goal (the gradient controller's Gauss-Newton step, body frame, m):
    computed from the same senses, so still no ground truth"""
    ranges: bool = False
    """feature agents also see the range sensor's readings (m, the env's front rays): the sense
    the gradient controller keeps off walls and obstacles with"""
    progress: bool = True
    """show a progress bar"""


class StackedPanoramas:
    """Observation transform: the current and the goal panorama as one ``(H, W, 6)`` image."""

    def __init__(self, space: Any) -> None:
        h, w, c = space["panorama"].shape
        self.space = gym.spaces.Box(0, 255, (h, w, 2 * c), np.uint8)

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return np.concatenate([obs["panorama"], obs["goal"]], axis=2)


class FeatureHistory:
    """Observations of a feature field env with a short memory, as one ``float32`` vector.

    The features are rotation-averaged: they say where the rover is, not which way it faces, so
    a memoryless policy cannot tell which way to drive. Like the gradient controller, the agent
    therefore sees its recent past: how the features changed over each of its last
    ``history - 1`` moves (``stride``, ``2 stride``, ... steps back) beside that move, from the
    wheel odometry, in the current body frame (m); the current features; and the goal's minus
    the current ones. Differences, not values, so that a gradient is a few multiplications
    away. Features are standardised by their mean and spread over the field's nodes (no
    labels), so that methods with different scales meet the same MLP. Optionally the goal
    estimate (3, ``estimate``) and the range readings (``rays``). Length
    ``2 k + (history - 1) (k + 2) + 3 estimate + rays``.
    """

    def __init__(
        self, field: Any, history: int, stride: int, estimate: bool = False, rays: int = 0
    ) -> None:
        values = np.asarray(field.values, dtype=np.float64).reshape(-1, field.n_features)
        self.mean = values.mean(axis=0)
        self.scale = np.maximum(values.std(axis=0), 1e-12)
        self.history, self.stride = history, stride
        self.weights = cost_weights(field) if estimate else None
        self.rays = rays
        n = 2 * field.n_features + (history - 1) * (field.n_features + 2) + 3 * estimate + rays
        self.space = gym.spaces.Box(-np.inf, np.inf, (n,), np.float32)
        self._past: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=(history - 1) * stride + 1)

    def standardise(self, features: np.ndarray) -> np.ndarray:
        return (features - self.mean) / self.scale

    def __call__(self, obs: dict[str, np.ndarray], info: dict[str, Any], new: bool) -> np.ndarray:
        entry = (self.standardise(obs["features"]), np.asarray(info["odometry"], dtype=np.float64))
        if new:  # an episode starts: the past is the present
            self._past.extend([entry] * self._past.maxlen)
        self._past.append(entry)
        now, (x, y, yaw) = entry
        turn = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])
        # differences, not values: how far the goal is in feature space, and how the features
        # changed along each recent move, side by side with that move
        parts = [self.standardise(obs["goal_features"]) - now, now]
        for features, pose in list(self._past)[-1 - self.stride :: -self.stride]:
            parts += [now - features, turn @ ((x, y) - pose[:2])]
        if self.weights is not None:
            parts.append(self._goal_estimate(obs, (x, y), turn, new))
        if self.rays:
            parts.append(np.asarray(info["range"], dtype=np.float64))
        return np.concatenate(parts).astype(np.float32)

    def _goal_estimate(self, obs: dict[str, np.ndarray], xy: Any, turn: np.ndarray, new: bool):
        """``(dx, dy, fitted)``: the Gauss-Newton step to the goal features in the body frame
        (m, at most ``MAX_STEP``), and 1 once the recent moves span the plane (0 and a zero step
        before)."""
        s = GradientSettings()
        if new:
            self._local = LocalLinearFit(self.weights, s.memory, s.window, s.prior)
        self._local.remember(np.array(xy, dtype=np.float64), obs["features"].astype(np.float64))
        fit = self._local.fit()
        if fit is None:
            return np.zeros(3)
        a, jacobian, _ = fit
        step = turn @ gauss_newton_step(a, jacobian, obs["goal_features"], self.weights, s.damping)
        length = float(np.linalg.norm(step))
        if length > MAX_STEP:  # the fit extrapolates far from where it was made
            step *= MAX_STEP / length
        return np.array([step[0], step[1], 1.0])


def cost_weights(field: Any) -> np.ndarray:
    """The gradient controller's feature weights, stored with a field by ``sfa-gym navigate``."""
    weights = (field.metadata.get("model_info") or {}).get("cost_weights")
    if weights is None or len(weights) != field.n_features:
        raise ValueError(
            "estimate needs the cost weights that `sfa-gym navigate` stores with a field "
            f"(metadata model_info.cost_weights, {field.n_features} numbers); this field has "
            f"{weights!r}: build it again with `sfa-gym navigate`"
        )
    return np.asarray(weights, dtype=np.float64)


class GoalVector(gym.Wrapper):
    """Upper bound, not a robot's view: the goal's position relative to the rover in its body
    frame (m), from the ground truth in ``info``, and the rover's heading as (cos, sin)."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)

    def reset(self, **kwargs):
        _, info = self.env.reset(**kwargs)
        return self.vector(info), info

    def step(self, action):
        _, reward, terminated, truncated, info = self.env.step(action)
        return self.vector(info), reward, terminated, truncated, info

    @staticmethod
    def vector(info: dict[str, Any]) -> np.ndarray:
        yaw = info["yaw"]
        dx, dy = info["goal"][0] - info["x"], info["goal"][1] - info["y"]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([c * dx + s * dy, c * dy - s * dx, c, s], dtype=np.float32)


class WithHistory(gym.Wrapper):
    """Gives the env the observation of a :class:`FeatureHistory`."""

    def __init__(self, env: gym.Env, history: FeatureHistory) -> None:
        super().__init__(env)
        self.memory = history
        self.observation_space = history.space

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return self.memory(obs, info, new=True), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.memory(obs, info, new=False), reward, terminated, truncated, info


def make_env(args: Args):
    """The env the agent trains and is evaluated on."""
    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.navigation.field import FeatureField

    kwargs: dict[str, Any] = {"world_seed": args.world_seed, "stop_action": False}
    if args.oracle:
        if args.field is None:
            raise ValueError("oracle needs a field: the env steps physics only, without pixels")
        env = GoalVector(gym.make(args.env_id, feature_field=str(args.field), reward=args.reward,
                                  **kwargs))  # fmt: skip
    elif args.field is not None:
        field = FeatureField.load(args.field)
        env = gym.make(args.env_id, feature_field=field, reward=args.reward, **kwargs)
        rays = env.unwrapped.range_rays if args.ranges else 0
        memory = FeatureHistory(field, args.history, args.history_stride, args.estimate, rays)
        env = WithHistory(env, memory)
    else:
        env = gym.make(args.env_id, reward=args.reward, **kwargs)
        transform = StackedPanoramas(env.observation_space)
        env = gym.wrappers.TransformObservation(env, transform, transform.space)
    # PPO's Gaussian starts with unit spread: on the raw (+-0.4 m/s, +-1 rad/s) box most
    # speeds would be clipped to the limits
    return gym.wrappers.RescaleAction(env, -1.0, 1.0)


def evaluate(model: Any, args: Args) -> dict[str, float]:
    """Success rate, SPL and mean final distance (m) of the deterministic policy on the episodes
    ``eval_seed ...``."""
    from sfa_gym.navigation.metrics import spl

    env = make_env(args)
    success, scores, final = [], [], []
    for seed in range(args.eval_seed, args.eval_seed + args.eval_episodes):
        obs, info = env.reset(seed=seed)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        success.append(info["success"])
        scores.append(spl(info["success"], info["shortest_path"], info["path_length"]))
        final.append(info["geodesic_distance"])
    env.close()
    return {
        "success": float(np.mean(success)),
        "spl": float(np.mean(scores)),
        "final_distance": float(np.mean(final)),
    }


def _write_atomic(path: Path, write) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``: readers never see half a file."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def save_curve(curve: list[dict[str, float]], path: Path) -> None:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(curve)
    _write_atomic(path, lambda tmp: tmp.write_text(text.getvalue()))


def load_curve(path: Path) -> list[dict[str, float]]:
    if not path.exists():
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if rows and set(rows[0]) != set(FIELDS):
        raise ValueError(
            f"{path} is not a learning curve: columns {sorted(rows[0])}, expected {FIELDS}"
        )
    return [{k: float(v) for k, v in row.items()} for row in rows]


def train(args: Args) -> list[dict[str, float]]:
    """Train PPO (resuming from ``out`` when it holds a checkpoint), evaluating and
    checkpointing every ``eval_every`` steps; returns the learning curve."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from tqdm import tqdm

    if args.reward not in ("geodesic", "sparse"):
        raise ValueError(f"reward must be 'geodesic' or 'sparse', got {args.reward!r}")
    for name in (
        "total_timesteps", "eval_every", "eval_episodes", "n_envs", "threads", "history",
        "history_stride",
    ):  # fmt: skip
        if getattr(args, name) < 1:
            raise ValueError(f"{name} must be at least 1, got {getattr(args, name)!r}")
    torch.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    venv = make_vec_env(lambda: make_env(args), n_envs=args.n_envs, seed=args.seed)
    policy = "MlpPolicy" if args.field is not None else "CnnPolicy"
    checkpoint = args.out / CHECKPOINT
    curve = load_curve(args.out / CURVE)
    if checkpoint.exists():
        # our own file, written by this script: SB3's loader unpickles parts of it
        model = PPO.load(checkpoint, env=venv, device="cpu")
    else:
        model = PPO(
            policy,
            venv,
            n_steps=args.n_steps,
            batch_size=args.batch_size,
            n_epochs=args.n_epochs,
            learning_rate=_schedule(args.learning_rate) if args.anneal_lr else args.learning_rate,
            gamma=0.99,
            gae_lambda=0.95,
            ent_coef=args.ent_coef,
            clip_range=args.clip_range,
            seed=args.seed,
            device="cpu",
            verbose=0,
        )
        curve = []
    before = curve[-1]["seconds"] if curve else 0.0  # wall time of earlier sessions
    started = time.perf_counter()

    def record() -> None:
        score = evaluate(model, args)
        seconds = round(before + time.perf_counter() - started, 1)
        curve.append({"steps": model.num_timesteps, **score, "seconds": seconds})
        bar.write(
            f"{model.num_timesteps:>9} steps  success {score['success']:.2f}  "
            f"SPL {score['spl']:.2f}  final distance {score['final_distance']:.2f} m"
        )
        _write_atomic(checkpoint, model.save)
        save_curve(curve, args.out / CURVE)

    class Progress(BaseCallback):
        def _on_step(self) -> bool:
            bar.update(self.training_env.num_envs)
            if self.num_timesteps % args.eval_every < self.training_env.num_envs:
                record()
            return True

    remaining = args.total_timesteps - model.num_timesteps
    with tqdm(
        total=args.total_timesteps,
        initial=model.num_timesteps,
        disable=not args.progress,
        desc=f"PPO {policy}",
        unit="step",
    ) as bar:
        if not curve:
            record()  # the untrained policy: the curve's first point
        if remaining > 0:
            model.learn(total_timesteps=remaining, callback=Progress(), reset_num_timesteps=False)
            if curve[-1]["steps"] != model.num_timesteps:
                record()
    model.save(args.out / "model.zip")
    venv.close()
    plot_curve(
        curve,
        args.out / "learning_curve.png",
        title="oracle" if args.oracle else str(args.field or "pixels"),
    )
    return curve


def _schedule(rate: float):
    """SB3 learning-rate schedule: ``rate`` times the fraction of the budget still to go (SB3
    counts it over the whole budget, also when a run resumes)."""
    return lambda remaining: rate * remaining


def plot_curve(curve: list[dict[str, float]], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.2))
    steps = [c["steps"] for c in curve]
    ax.plot(steps, [c["success"] for c in curve], "o-", label="success")
    ax.plot(steps, [c["spl"] for c in curve], "s--", label="SPL")
    ax.set(xlabel="training steps", ylabel="rate", ylim=(-0.02, 1.02), title=title)
    ax.legend()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    import tyro

    train(tyro.cli(Args))
