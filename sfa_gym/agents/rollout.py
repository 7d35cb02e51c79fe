"""Watching a trained navigation agent: one episode of its deterministic policy recorded as a
GIF or an MP4, each frame the env's top-down view (``render_mode="rgb_array"``) beside the
rover's panorama, with the step and the distance to the goal written on it.

A feature agent acts on its field's features, as it was trained; its env then renders no
panoramas (that is what makes it fast), so the recording renders the camera's panorama for
each frame besides (:meth:`~sfa_gym.navigation.env.OmniRoverNavEnv.render_panorama`), which the
agent does not see. GIFs are written by imageio with Pillow (no system packages); MP4 needs the
``imageio-ffmpeg`` package, which ships its own ffmpeg.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["FORMATS", "Rollout", "compose_frame", "load_model", "record_rollout"]

FORMATS = (".gif", ".mp4")


@dataclass(frozen=True)
class Rollout:
    """What the recorded episode did."""

    frames: int
    steps: int
    success: bool
    path_length: float
    final_distance: float


def load_model(path: Path) -> Any:
    """The PPO model of ``path``, a file written by ``sfa-gym agent train``: SB3's loader
    unpickles parts of the zip, so load only files you made yourself."""
    from stable_baselines3 import PPO

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"model {str(path)!r} is not a file (expected a model.zip of a run)")
    return PPO.load(path, device="cpu")


def compose_frame(top_down: NDArray[np.uint8], panorama: NDArray[np.uint8], caption: str):
    """The top-down view with ``caption`` on it, the panorama beside it (scaled by a whole
    number so that it keeps its pixels), on black, padded to even sides (video codecs need
    them). Height ``max(S, k h)`` and width ``S + k w`` before padding, for a top-down view of
    side ``S``, a panorama ``h x w`` and ``k = max(1, S // (3 h))``."""
    import cv2

    side = top_down.shape[0]
    h, w = panorama.shape[:2]
    k = max(1, side // (3 * h))
    big = np.repeat(np.repeat(panorama, k, axis=0), k, axis=1)
    height, width = max(side, k * h), side + k * w
    frame = np.zeros((height + height % 2, width + width % 2, 3), np.uint8)
    frame[:side, :side] = top_down
    top = (height - k * h) // 2
    frame[top : top + k * h, side:width] = big
    scale = max(0.3, side / 640)
    cv2.putText(frame, caption, (4, int(22 * scale) + 2), cv2.FONT_HERSHEY_SIMPLEX, scale,
                (255, 255, 255), 1, cv2.LINE_AA)  # fmt: skip
    return frame


def _writer(path: Path, fps: float):
    import imageio.v2 as imageio

    if path.suffix == ".gif":
        return imageio.get_writer(path, mode="I", duration=1000.0 / fps, loop=0)  # ms a frame
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        raise ImportError(
            f"writing {path.name} (MP4) needs the imageio-ffmpeg package (pip install "
            "imageio-ffmpeg, it ships its own ffmpeg); or record a .gif"
        ) from None
    return imageio.get_writer(path, fps=fps, macro_block_size=2)


def record_rollout(
    folder: Path,
    out: Path,
    model_path: Path | None = None,
    seed: int = 10_000,
    max_steps: int | None = None,
    render_size: int = 256,
    progress: bool = True,
) -> Rollout:
    """Record one episode (seed ``seed``) of the agent trained into ``folder`` to ``out``.

    Args:
        folder: the output folder of ``sfa-gym agent train`` (its ``agent.json``).
        out: the recording, ``.gif`` or ``.mp4``.
        model_path: the model to load (default ``folder/model.zip``; a checkpoint works too).
        seed: the episode's seed (those of the evaluations start at 10000).
        max_steps: stop after this many steps (default: the env's episode limit).
        render_size: side of the top-down view, pixels.
    """
    from tqdm import tqdm

    from sfa_gym.agents.env import make_env, read_agent_file

    out = Path(out)
    if out.suffix not in FORMATS:
        raise ValueError(f"out must end in one of {list(FORMATS)}, got {str(out)!r}")
    if max_steps is not None and (isinstance(max_steps, bool) or max_steps < 1):
        raise ValueError(f"max_steps must be at least 1 or None, got {max_steps!r}")
    settings, _ = read_agent_file(folder)
    model = load_model(Path(folder, "model.zip") if model_path is None else model_path)
    env = make_env(settings, render_mode="rgb_array", render_size=render_size)
    if model.observation_space.shape != env.observation_space.shape:
        env.close()
        raise ValueError(
            f"the model observes shape {model.observation_space.shape}, the agent's env "
            f"{env.observation_space.shape}: the model is not of the run in {folder}"
        )
    nav = env.unwrapped
    limit = max_steps or env.spec.max_episode_steps
    obs, info = env.reset(seed=seed)
    steps, done = 0, False
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = _writer(out, env.metadata.get("render_fps", 10))
    frames = 0
    try:
        with tqdm(total=limit, disable=not progress, desc="rollout", unit="step") as bar:
            while True:
                caption = f"step {steps}  {info['geodesic_distance']:.2f} m to goal"
                writer.append_data(compose_frame(env.render(), nav.render_panorama(), caption))
                frames += 1
                if done or steps >= limit:
                    break
                action, _ = model.predict(obs, deterministic=True)
                obs, _, terminated, truncated, info = env.step(action)
                done = terminated or truncated
                steps += 1
                bar.update(1)
    finally:
        writer.close()
        env.close()
    return Rollout(frames, steps, bool(info["success"]), float(info["path_length"]),
                   float(info["geodesic_distance"]))  # fmt: skip
