"""``sfa-gym agent train|eval|play``: a navigation agent trained with stable-baselines3 PPO,
scored on seeded episodes, and watched as a GIF or MP4 (:mod:`sfa_gym.agents`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import tyro

from sfa_gym.agents.env import AgentEnv
from sfa_gym.agents.training import Training

__all__ = ["Agent", "AgentEval", "AgentPlay", "AgentTrain"]


def _require(*modules: str) -> None:
    """Raises ImportError naming the extra to install when one of ``modules`` is missing."""
    import importlib.util

    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise ImportError(
            f"sfa-gym agent needs {', '.join(missing)}: pip install 'sfa-gym[sb3]' "
            "(stable-baselines3, imageio, imageio-ffmpeg)"
        )


@dataclass(frozen=True)
class AgentTrain:
    """Train PPO on a navigation env into a folder: agent.json (the env settings), the learning
    curve (CSV, PNG: success and SPL on fixed episode seeds every --eval-every steps), checkpoints
    and model.zip. The same command run again resumes from the newest checkpoint."""

    out: Path
    """output folder (created)"""
    env: tyro.conf.OmitArgPrefixes[AgentEnv] = AgentEnv()
    """the env and what the agent observes"""
    training: tyro.conf.OmitArgPrefixes[Training] = Training()
    """PPO's budget, evaluation and hyperparameters"""
    quiet: bool = False
    """no progress bars"""

    def run(self) -> int:
        _require("stable_baselines3")
        from sfa_gym.agents.training import MODEL, train

        curve = train(self.out, self.env, self.training, progress=not self.quiet)
        last = curve[-1]
        print(
            f"{int(last['steps'])} steps: success {last['success']:.2f}, SPL {last['spl']:.2f}, "
            f"final distance {last['final_distance']:.2f} m; model in {self.out / MODEL}"
        )
        return 0


@dataclass(frozen=True)
class AgentEval:
    """Score a trained agent: the deterministic policy on --episodes episodes seeded --seed,
    --seed + 1, ...: success rate (arrival), SPL, final geodesic distance and mean return."""

    run_folder: Annotated[Path, tyro.conf.arg(name="run")]
    """the output folder of `sfa-gym agent train` (its agent.json says which env)"""
    model: Path | None = None
    """the model to load (default: <run>/model.zip; a checkpoint of the run works too)"""
    episodes: int = 50
    """episodes to score"""
    seed: int = 10_000
    """seed of the first episode (training evaluates on 10000 ...)"""
    quiet: bool = False
    """no progress bar"""

    def run(self) -> int:
        _require("stable_baselines3")
        from sfa_gym.agents.env import read_agent_file
        from sfa_gym.agents.evaluation import evaluate
        from sfa_gym.agents.rollout import load_model

        settings, _ = read_agent_file(self.run_folder)
        model = load_model(self.model or self.run_folder / "model.zip")
        score = evaluate(model, settings, self.episodes, self.seed, progress=not self.quiet)
        print(
            f"{self.episodes} episodes (seeds {self.seed}-{self.seed + self.episodes - 1}): "
            f"success {score['success']:.2f}, SPL {score['spl']:.2f}, final distance "
            f"{score['final_distance']:.2f} m, return {score['return']:.2f}"
        )
        return 0


@dataclass(frozen=True)
class AgentPlay:
    """Record one episode of a trained agent as a GIF or an MP4: the top-down view beside the
    rover's panorama. A feature agent still acts on its field's features; the panorama is
    rendered for the recording only (a field env renders none), so recording runs at the
    renderer's speed, not the field's."""

    run_folder: Annotated[Path, tyro.conf.arg(name="run")]
    """the output folder of `sfa-gym agent train`"""
    out: Path
    """the recording: .gif (Pillow, no system packages) or .mp4 (needs imageio-ffmpeg)"""
    model: Path | None = None
    """the model to load (default: <run>/model.zip)"""
    seed: int = 10_000
    """the episode's seed"""
    max_steps: int | None = None
    """stop after this many steps (default: the env's episode limit)"""
    render_size: int = 256
    """side of the top-down view, pixels"""
    quiet: bool = False
    """no progress bar"""

    def run(self) -> int:
        _require("stable_baselines3", "imageio")
        from sfa_gym.agents.rollout import record_rollout

        done = record_rollout(
            self.run_folder, self.out, self.model, self.seed, self.max_steps, self.render_size,
            progress=not self.quiet,
        )  # fmt: skip
        outcome = "arrived" if done.success else "did not arrive"
        print(
            f"{done.frames} frames in {self.out}: {outcome} after {done.steps} steps, "
            f"{done.path_length:.2f} m driven, {done.final_distance:.2f} m from the goal"
        )
        return 0


@dataclass(frozen=True)
class Agent:
    """Navigation agents (stable-baselines3 PPO): train one (train), score it on seeded
    episodes (eval), record a rollout as a GIF or MP4 (play). Needs the sb3 extra. Models are
    SB3's zip, which SB3's loader partly unpickles: load only model files you made yourself."""

    command: (
        Annotated[AgentTrain, tyro.conf.subcommand("train")]
        | Annotated[AgentEval, tyro.conf.subcommand("eval")]
        | Annotated[AgentPlay, tyro.conf.subcommand("play")]
    )

    def run(self) -> int:
        return self.command.run()
