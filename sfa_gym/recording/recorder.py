"""Recording and replaying runs: the loop that drives an env and writes a run file."""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

import sfa_gym
from sfa_gym.recording.drivers import Driver, GridPositions
from sfa_gym.recording.runfile import (  # noqa: E402
    _ARRAYS,
    _BOOKKEEPING,
    FORMAT,
    HEADER,
    SUFFIX,
    VERSION,
    Run,
    _read_header,
    _write_chunk,
    _write_header,
    load_run,
)

# ------------------------------------------------------------------------- recording


class RunMismatchError(ValueError):
    """An existing run was recorded with other settings than the ones asked for."""


class ReplayMismatchError(RuntimeError):
    """Replaying a stored run did not reproduce its actions or poses (non-determinism)."""


def _jsonable(value: Any) -> Any:
    """A JSON-compatible copy (dataclasses as dicts, tuples as lists, others by repr)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"type": type(value).__name__, **_jsonable(dataclasses.asdict(value))}
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return repr(value)


def _env_metadata(env: gym.Env) -> dict[str, Any]:
    unwrapped = env.unwrapped
    spec = env.spec
    bounds = getattr(unwrapped, "arena_bounds", None)
    dt = _control_period(unwrapped)
    world = getattr(unwrapped, "world", None)
    return _jsonable(
        {
            "env_id": spec.id if spec is not None else type(unwrapped).__name__,
            "env_kwargs": dict(spec.kwargs) if spec is not None else {},
            "world": getattr(world, "name", world),
            "world_seed": getattr(unwrapped, "world_seed", None),
            "panorama": getattr(unwrapped, "panorama", None),
            "arena_bounds": None if bounds is None else [float(b) for b in bounds],
            "dt": None if dt is None else float(dt),
            "shape": list(env.observation_space.shape),
        }
    )


def _control_period(unwrapped: gym.Env) -> float | None:
    """Seconds per env step: ``control_dt`` (sfa_gym envs) or ``dt`` (Gymnasium MuJoCo envs)."""
    for name in ("control_dt", "dt"):
        value = getattr(unwrapped, name, None)
        if isinstance(value, int | float) and value > 0:
            return float(value)
    return None


def _pose_of(info: Mapping[str, Any]) -> NDArray[np.float64]:
    try:
        return np.array([info["x"], info["y"], info["yaw"]], dtype=np.float64)
    except KeyError as error:
        raise KeyError(f"recording needs info with 'x', 'y', 'yaw'; {error} is missing") from None


def _pose_seed(seed: int, index: int) -> int:
    # every pose of a pose-list run gets its own reset seed, so that a resumed run is identical
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


class _Writer:
    """Buffers samples and writes them as chunks, rewriting the header after each."""

    def __init__(
        self,
        directory: Path,
        header: dict[str, Any],
        chunk_size: int,
        compress: bool,
        on_chunk: Callable[[int], None] | None,
    ) -> None:
        self.directory = directory
        self.header = header
        self.chunk_size = chunk_size
        self.compress = compress
        self.on_chunk = on_chunk
        self.buffer: dict[str, list[Any]] = {name: [] for name in _ARRAYS}

    def add(self, obs: Any, pose: NDArray[np.float64], time: float, action: Any) -> None:
        self.buffer["panoramas"].append(np.asarray(obs, dtype=np.uint8))
        self.buffer["poses"].append(pose)
        self.buffer["time"].append(time)
        self.buffer["actions"].append(np.asarray(action, dtype=np.float32))
        if len(self.buffer["poses"]) >= self.chunk_size:
            self.flush()

    def flush(self) -> None:
        n = len(self.buffer["poses"])
        if n == 0:
            return
        arrays = {name: np.asarray(self.buffer[name], dtype=_ARRAYS[name][0]) for name in _ARRAYS}
        name = f"chunk-{len(self.header['chunks']):05d}.npz"
        _write_chunk(self.directory / name, arrays, self.compress)
        self.header["chunks"].append({"file": name, "n": n})
        self.header["n"] += n
        _write_header(self.directory, self.header)
        self.buffer = {name: [] for name in _ARRAYS}
        if self.on_chunk is not None:
            self.on_chunk(self.header["n"])

    def finish(self, end_reason: str) -> None:
        self.flush()
        self.header["complete"] = True
        self.header["end_reason"] = end_reason
        _write_header(self.directory, self.header)


def _check_resumable(directory: Path, wanted: dict[str, Any]) -> dict[str, Any]:
    header = _read_header(directory)
    differences = [
        f"{key}: stored {header.get(key)!r}, requested {wanted.get(key)!r}"
        for key in sorted((header.keys() | wanted.keys()) - _BOOKKEEPING)
        if header.get(key) != wanted.get(key)
    ]
    if differences:
        raise RunMismatchError(
            f"{directory} holds a run recorded with other settings ("
            + "; ".join(differences)
            + "); record into another directory or pass overwrite=True"
        )
    return header


def _clear(directory: Path) -> None:
    """Remove the files of a run (header, chunks, temporaries), nothing else."""
    for file in directory.iterdir():
        name = file.name
        if name == HEADER or (name.startswith("chunk-") and name.endswith(".npz")):
            file.unlink()
    _remove_temporaries(directory)


def _remove_temporaries(directory: Path) -> None:
    for file in directory.glob(".*.tmp"):
        if file.name.startswith((".chunk-", f".{HEADER}.")):
            file.unlink()


def record(
    env: str | gym.Env,
    driver: Driver | GridPositions,
    out_dir: str | os.PathLike[str],
    *,
    n_steps: int | None = None,
    seed: int = 0,
    chunk_size: int = 500,
    compress: bool = False,
    env_kwargs: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    progress: bool = True,
    on_chunk: Callable[[int], None] | None = None,
) -> Run:
    """Record a run of ``env`` driven by ``driver`` into the directory ``out_dir``.

    With a :class:`~sfa_gym.recording.drivers.Driver`: ``env.reset(seed=seed, options={"pose":
    driver.start_pose})`` (no options if the start pose is ``None``), ``driver.reset(bounds,
    dt=..., seed=seed)``, then ``env.step(driver(info))`` until ``n_steps`` samples are stored,
    the driver is done or the episode ends. Actions are clipped to the action space.
    With :class:`~sfa_gym.recording.drivers.GridPositions`: one ``env.reset`` per pose (the first
    ``n_steps`` poses, or all), each with its own seed derived from ``seed``.

    If ``out_dir`` already holds an incomplete run with the same settings, the recording
    resumes (see the module docstring); a complete one is returned as it is.

    Args:
        env: a registered env id (made with ``gym.make(env, **env_kwargs)`` and closed at the
            end) or an env; it must report ``x``, ``y``, ``yaw`` in ``info`` and have
            ``unwrapped.arena_bounds`` for drivers.
        driver: what to drive (or which poses to visit).
        out_dir: the run directory; its name must end with ``.run``.
        n_steps: number of samples to store (the reset counts as one); ``None``: until the
            driver is done (required for open-ended drivers) or all poses are visited.
        seed: seed of the env resets and of the driver.
        chunk_size: samples per chunk file.
        compress: write chunks with ``np.savez_compressed`` (smaller, slower, not mappable).
        env_kwargs: keyword arguments for ``gym.make`` when ``env`` is an id.
        overwrite: delete an existing run in ``out_dir`` instead of resuming it.
        progress: show a tqdm progress bar.
        on_chunk: called with the number of stored samples after each chunk is written.

    Returns:
        The recorded run, as :func:`load_run` returns it.

    Raises:
        RunMismatchError: ``out_dir`` holds a run recorded with other settings.
        ReplayMismatchError: resuming did not reproduce the stored actions or poses.
    """
    directory = Path(out_dir)
    if directory.suffix != SUFFIX:
        raise ValueError(
            f"out_dir must be a directory named '<name>{SUFFIX}', got {str(out_dir)!r}"
        )
    if not isinstance(chunk_size, int) or chunk_size < 1:
        raise ValueError(f"chunk_size must be a positive int, got {chunk_size!r}")
    if n_steps is not None and (not isinstance(n_steps, int) or n_steps < 1):
        raise ValueError(f"n_steps must be a positive int or None, got {n_steps!r}")
    if not isinstance(driver, Driver | GridPositions):
        raise TypeError(
            "driver must be a sfa_gym.recording.drivers.Driver or GridPositions, "
            f"got {type(driver).__name__}"
        )
    if isinstance(driver, Driver) and n_steps is None and type(driver).done is Driver.done:
        raise ValueError(f"{type(driver).__name__} never finishes: give n_steps")

    owns_env = isinstance(env, str)
    if owns_env:
        # the run length is set here, not by the registered time limit
        limit = (n_steps or 0) + 10**9
        env = gym.make(env, max_episode_steps=limit, **dict(env_kwargs or {}))
    elif env_kwargs:
        raise ValueError("env_kwargs only apply when env is an id, not an env instance")
    try:
        wanted = {
            "format": FORMAT,
            "version": VERSION,
            "kind": "poses" if isinstance(driver, GridPositions) else "trajectory",
            **_env_metadata(env),
            "seed": seed,
            "driver": _jsonable(driver.describe()),
            "n_steps": n_steps,
        }
        if overwrite and directory.is_dir():
            _clear(directory)
        if (directory / HEADER).is_file():
            header = _check_resumable(directory, wanted)
            if header["complete"]:
                return load_run(directory)
            _remove_temporaries(directory)
            stored = load_run(directory)
        else:
            directory.mkdir(parents=True, exist_ok=True)
            header = {
                **wanted,
                "sfa_gym_version": sfa_gym.__version__,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "chunks": [],
                "n": 0,
                "complete": False,
                "end_reason": None,
            }
            _write_header(directory, header)
            stored = None
        header["sfa_gym_version"] = sfa_gym.__version__
        writer = _Writer(directory, header, chunk_size, compress, on_chunk)
        try:
            if isinstance(driver, GridPositions):
                end = _record_poses(env, driver, writer, stored, n_steps, seed, progress)
            else:
                end = _record_drive(env, driver, writer, stored, n_steps, seed, progress)
        except BaseException:
            # the buffered samples are whole: keep them for a resume (if the disk lets us)
            with contextlib.suppress(Exception):
                writer.flush()
            raise
        writer.finish(end)
    finally:
        if owns_env:
            env.close()
    return load_run(directory)


def _bar(progress: bool, total: int | None, initial: int, desc: str) -> tqdm:
    return tqdm(total=total, initial=initial, disable=not progress, desc=desc, unit="frame")


def _record_poses(
    env: gym.Env,
    driver: GridPositions,
    writer: _Writer,
    stored: Run | None,
    n_steps: int | None,
    seed: int,
    progress: bool,
) -> str:
    poses = driver.poses(env)
    total = len(poses) if n_steps is None else min(n_steps, len(poses))
    start = 0 if stored is None else len(stored)
    with _bar(progress, total, start, writer.directory.name) as bar:
        for i in range(start, total):
            obs, info = env.reset(seed=_pose_seed(seed, i), options={"pose": tuple(poses[i])})
            writer.add(obs, _pose_of(info), float(i), np.zeros(2, dtype=np.float32))
            bar.update()
    return "n_steps" if total < len(poses) else "driver_done"


def _record_drive(
    env: gym.Env,
    driver: Driver,
    writer: _Writer,
    stored: Run | None,
    n_steps: int | None,
    seed: int,
    progress: bool,
) -> str:
    bounds = getattr(env.unwrapped, "arena_bounds", None)
    if bounds is None:
        raise ValueError(f"{env.unwrapped} has no arena_bounds to drive in")
    dt = _control_period(env.unwrapped)
    if dt is None:
        raise ValueError(f"{env.unwrapped} has no control period (control_dt or dt) in seconds")
    space = env.action_space
    low, high = space.low.astype(np.float32), space.high.astype(np.float32)
    driver.reset(bounds, dt=dt, seed=seed)
    options = None if driver.start_pose is None else {"pose": driver.start_pose}
    obs, info = env.reset(seed=seed, options=options)
    n_done = 0 if stored is None else len(stored)
    if n_done:
        info = _replay(env, driver, stored, info, low, high, progress)
    else:
        writer.add(obs, _pose_of(info), float(info.get("t", 0.0)), np.zeros(2, dtype=np.float32))
        n_done = 1
    end = "n_steps"
    with _bar(progress, n_steps, n_done, writer.directory.name) as bar:
        bar.update(0)
        while n_steps is None or n_done < n_steps:
            if driver.done:
                end = "driver_done"
                break
            action = np.clip(driver(info), low, high)
            obs, _, terminated, truncated, info = env.step(action)
            writer.add(obs, _pose_of(info), float(info.get("t", n_done * dt)), action)
            n_done += 1
            bar.update()
            if terminated or truncated:
                end = "terminated" if terminated else "truncated"
                break
    return end


def _replay(
    env: gym.Env,
    driver: Driver,
    stored: Run,
    info: dict[str, Any],
    low: NDArray[np.float32],
    high: NDArray[np.float32],
    progress: bool,
) -> dict[str, Any]:
    """Drive the stored steps again (not storing them) to restore env and driver state.

    Returns the ``info`` of the last stored sample.

    Raises:
        ReplayMismatchError: the driver chose another action or the env reached another pose.
    """
    advice = "the run cannot be resumed; record into a new directory or pass overwrite=True"

    def check_pose(i: int, info: Mapping[str, Any]) -> None:
        pose = _pose_of(info)
        error = np.abs(pose - stored.poses[i])
        error[2] = abs((pose[2] - stored.poses[i, 2] + np.pi) % (2 * np.pi) - np.pi)
        if error.max() > 1e-6:
            raise ReplayMismatchError(
                f"{stored.path}: replaying sample {i} reached pose {pose.tolist()}, stored "
                f"{stored.poses[i].tolist()}: the env is not deterministic; {advice}"
            )

    check_pose(0, info)
    with _bar(progress, len(stored) - 1, 0, f"replaying {stored.path.name}") as bar:
        for i in range(1, len(stored)):
            action = np.clip(driver(info), low, high)
            if not np.array_equal(action, stored.actions[i]):
                raise ReplayMismatchError(
                    f"{stored.path}: at sample {i} {type(driver).__name__} chose "
                    f"{action.tolist()}, stored {stored.actions[i].tolist()}: the driver is not "
                    f"deterministic; {advice}"
                )
            _, _, _, _, info = env.step(action)
            check_pose(i, info)
            bar.update()
    return info
