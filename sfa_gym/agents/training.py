"""Training a navigation agent with stable-baselines3 PPO, resumable.

Into the output folder go ``agent.json`` (the env settings and these, so that evaluating and
recording rebuild the same env), ``learning_curve.csv`` (success, SPL, final distance and return
of the deterministic policy every ``eval_every`` steps, SB3's ``EvalCallback`` on fixed episode
seeds), ``learning_curve.png``, checkpoints ``checkpoints/ppo_<steps>_steps.zip`` (SB3's
``CheckpointCallback``, at every evaluation) and the final ``model.zip``. A run started again
with the same folder resumes from its newest checkpoint: the policy, the optimiser and the step
count continue; the training envs restart with fresh episodes, so a resumed run is not
bit-identical to an uninterrupted one.

The PPO settings default to those of Lange et al. 2024 (arXiv 2402.12067): n_steps 128, lr
2.5e-4, gamma 0.99, GAE 0.95, entropy 0.01, clip 0.1, batch 128.

Model files are SB3's zip, which stores the weights as torch tensors and some objects as
pickles that SB3's loader unpickles: load only model files you made yourself.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sfa_gym._checks import check_finite, check_positive, check_positive_int
from sfa_gym.agents.env import AgentEnv, read_agent_file, write_agent_file

__all__ = ["CURVE", "FIELDS", "MODEL", "Training", "latest_checkpoint", "load_curve", "train"]

CURVE = "learning_curve.csv"
MODEL = "model.zip"
CHECKPOINTS = "checkpoints"
FIELDS = ("steps", "success", "spl", "final_distance", "return", "seconds")
_CHECKPOINT = re.compile(r"ppo_(\d+)_steps\.zip")


@dataclass(frozen=True)
class Training:
    """PPO's budget, evaluation and hyperparameters."""

    total_timesteps: int = 1_000_000
    """training steps"""
    seed: int = 0
    """seed of the policy, the training episodes and the vector envs"""
    n_envs: int = 4
    """environments stepped per PPO update (in this process)"""
    eval_every: int = 50_000
    """steps between evaluations and checkpoints"""
    eval_episodes: int = 50
    """episodes per evaluation"""
    eval_seed: int = 10_000
    """seed of the first evaluation episode (the same episodes at every evaluation)"""
    n_steps: int = 128
    """PPO rollout length per env"""
    learning_rate: float = 2.5e-4
    """PPO learning rate"""
    anneal_lr: bool = False
    """decay the learning rate linearly to 0 over total_timesteps"""
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

    def validate(self) -> None:
        """Raises ValueError naming a bad value and what was expected."""
        for name in ("total_timesteps", "n_envs", "eval_every", "eval_episodes", "n_steps",
                     "batch_size", "n_epochs", "threads"):  # fmt: skip
            check_positive_int(name, getattr(self, name))
        if self.eval_every < self.n_envs:
            raise ValueError(
                f"eval_every must be at least n_envs ({self.n_envs}), got {self.eval_every}"
            )
        for name in ("learning_rate", "clip_range"):
            check_positive(name, getattr(self, name))
        check_finite("ent_coef", self.ent_coef, low=0.0)


def save_curve(curve: list[dict[str, float]], path: Path) -> None:
    from sfa_gym.files import write_atomic

    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(curve)
    data = text.getvalue().encode()
    write_atomic(path, lambda file: file.write(data))


def load_curve(path: Path) -> list[dict[str, float]]:
    """The rows of a learning curve (none when the file does not exist)."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if rows and set(rows[0]) != set(FIELDS):
        raise ValueError(
            f"{path} is not a learning curve: columns {sorted(rows[0])}, expected {FIELDS}"
        )
    return [{k: float(v) for k, v in row.items()} for row in rows]


def latest_checkpoint(out: Path) -> Path | None:
    """The checkpoint of the most steps in ``out/checkpoints``, or None."""
    found = [(int(m.group(1)), p) for p in Path(out, CHECKPOINTS).glob("ppo_*_steps.zip")
             if (m := _CHECKPOINT.fullmatch(p.name))]  # fmt: skip
    return max(found)[1] if found else None


def _schedule(rate: float):
    """SB3 learning-rate schedule: ``rate`` times the fraction of the budget still to go (SB3
    counts it over the whole budget, also when a run resumes)."""
    return lambda remaining: rate * remaining


def _new_model(env: AgentEnv, settings: Training, venv: Any) -> Any:
    from stable_baselines3 import PPO

    rate = settings.learning_rate
    return PPO(
        env.policy, venv, n_steps=settings.n_steps, batch_size=settings.batch_size,
        n_epochs=settings.n_epochs, learning_rate=_schedule(rate) if settings.anneal_lr else rate,
        gamma=0.99, gae_lambda=0.95, ent_coef=settings.ent_coef, clip_range=settings.clip_range,
        seed=settings.seed, device="cpu", verbose=0,
    )  # fmt: skip


def _resume(out: Path, venv: Any) -> Any | None:
    """The model of the newest checkpoint of ``out`` that loads (a checkpoint cut short by a
    crash is skipped with a warning), or None."""
    from stable_baselines3 import PPO

    for path in sorted(Path(out, CHECKPOINTS).glob("ppo_*_steps.zip"), reverse=True,
                       key=lambda p: int(_CHECKPOINT.fullmatch(p.name).group(1))):  # fmt: skip
        try:
            # our own file, written by train(): SB3's loader unpickles parts of it
            return PPO.load(path, env=venv, device="cpu")
        except Exception as error:  # a truncated zip raises whatever its reader hits first
            print(f"warning: skipped checkpoint {path}: {error}", file=sys.stderr)
    return None


def train(
    out: Path, env: AgentEnv, settings: Training, progress: bool = True
) -> list[dict[str, float]]:
    """Train PPO into ``out`` (resuming from its newest checkpoint), evaluating and
    checkpointing every ``eval_every`` steps; returns the learning curve."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import Logger
    from tqdm import tqdm

    from sfa_gym.agents.env import make_env
    from sfa_gym.agents.evaluation import NavigationEvalCallback, eval_env
    from sfa_gym.files import write_atomic

    env.validate()
    settings.validate()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(settings.threads)
    if latest_checkpoint(out) is not None:
        trained, _ = read_agent_file(out)
        if trained.to_json() != env.to_json():
            raise ValueError(
                f"{out} holds an agent trained on other env settings ({trained}); "
                f"expected {env}: choose another output folder or the same settings"
            )
    write_agent_file(out, env, dataclasses.asdict(settings))
    venv = make_vec_env(lambda: make_env(env), n_envs=settings.n_envs, seed=settings.seed)
    model = _resume(out, venv)
    if model is None:
        model, curve = _new_model(env, settings, venv), []
    else:  # rows evaluated after the checkpoint will be evaluated again
        curve = [r for r in load_curve(out / CURVE) if r["steps"] <= model.num_timesteps]
    # the learning curve is the run's record; SB3's own logger would make a folder in the
    # system's temporary directory at every learn() and write nothing there (verbose=0)
    model.set_logger(Logger(folder=None, output_formats=[]))
    before = curve[-1]["seconds"] if curve else 0.0  # wall time of earlier sessions
    started = time.perf_counter()
    bar = tqdm(total=settings.total_timesteps, initial=model.num_timesteps,
               disable=not progress, desc=f"PPO {env.policy}", unit="step")  # fmt: skip

    def record(steps: int, score: dict[str, float]) -> None:
        seconds = round(before + time.perf_counter() - started, 1)
        curve.append({"steps": steps, **score, "seconds": seconds})
        save_curve(curve, out / CURVE)
        bar.write(f"{steps:>9} steps  success {score['success']:.2f}  SPL {score['spl']:.2f}  "
                  f"final distance {score['final_distance']:.2f} m")  # fmt: skip

    class Progress(BaseCallback):
        def _on_step(self) -> bool:
            bar.update(self.training_env.num_envs)
            return True

    every = settings.eval_every // settings.n_envs  # callbacks count calls, n_envs steps each
    evaluation = eval_env(env, settings.eval_seed)
    callbacks = CallbackList([
        Progress(),
        NavigationEvalCallback(evaluation, settings.eval_episodes, every, record, progress),
        CheckpointCallback(every, str(out / CHECKPOINTS), name_prefix="ppo"),
    ])  # fmt: skip
    try:
        remaining = settings.total_timesteps - model.num_timesteps
        if remaining > 0:
            model.learn(remaining, callback=callbacks, reset_num_timesteps=False)
        if not curve or curve[-1]["steps"] != model.num_timesteps:
            from sfa_gym.agents.evaluation import evaluate

            score = evaluate(model, env, settings.eval_episodes, settings.eval_seed, progress)
            record(model.num_timesteps, score)
    finally:
        bar.close()
        venv.close()
        evaluation.close()
    write_atomic(out / MODEL, model.save)
    plot_curve(curve, out / "learning_curve.png",
               title="oracle" if env.oracle else str(env.field or "pixels"))  # fmt: skip
    return curve


def plot_curve(curve: list[dict[str, float]], path: Path, title: str) -> None:
    """Success and SPL against training steps."""
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
