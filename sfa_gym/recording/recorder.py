"""Recording and replaying runs: the loop that drives an env and writes a run file.

:func:`record` checks everything it can before it writes anything (the output path, the counts,
the env's spaces and attributes, the driver's arguments by planning its drive, the header as
strict JSON), so a refused call leaves no directory behind that would block the corrected one;
the run directory and its header appear with the first block of samples. An interruption by Ctrl-C
(``KeyboardInterrupt``) or by SIGTERM (turned into ``SystemExit(143)`` while recording, when no
other SIGTERM handler is installed) writes the buffered samples first, so that the run resumes
from the last one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import math
import os
import signal
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

import sfa_gym
from sfa_gym._checks import check_int_in, check_positive_int
from sfa_gym.files import strict_json, write_atomic, write_json_atomic
from sfa_gym.recording.drivers import Driver, GridPositions, env_attribute
from sfa_gym.recording.runfile import (
    _ARRAYS,
    _BOOKKEEPING,
    FORMAT,
    HEADER,
    SUFFIX,
    VERSION,
    Run,
    _append_panoramas,
    _read_header,
    load_run,
)

__all__ = ["POSE_TOLERANCE", "record", "RunMismatchError", "ReplayMismatchError", "pose_difference"]

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
    spec = env.spec
    bounds = env_attribute(env, "arena_bounds")
    dt = _control_period(env)
    world = env_attribute(env, "world")
    return _jsonable(
        {
            "env_id": spec.id if spec is not None else type(env.unwrapped).__name__,
            "env_kwargs": dict(spec.kwargs) if spec is not None else {},
            "world": getattr(world, "name", world),
            "world_seed": env_attribute(env, "world_seed"),
            "panorama": env_attribute(env, "panorama"),
            "camera": env_attribute(env, "camera"),
            "mirror": env_attribute(env, "mirror"),
            "rover": env_attribute(env, "rover"),
            "arena_bounds": None if bounds is None else [float(b) for b in bounds],
            "dt": dt,
            "shape": list(env.observation_space.shape),
        }
    )


def _control_period(env: gym.Env) -> float | None:
    """Seconds per env step: ``dt`` (the Gymnasium convention) or ``control_dt``."""
    for name in ("dt", "control_dt"):
        value = env_attribute(env, name)
        if isinstance(value, int | float) and not isinstance(value, bool):
            if math.isfinite(value) and value > 0:
                return float(value)
    return None


def _pose_of(info: Mapping[str, Any]) -> NDArray[np.float64]:
    try:
        return np.array([info["x"], info["y"], info["yaw"]], dtype=np.float64)
    except KeyError as error:
        raise KeyError(f"recording needs info with 'x', 'y', 'yaw'; {error} is missing") from None


POSE_TOLERANCE = 1e-6
"""The largest difference, metres or radians, between a stored pose and the same sample made
again (replayed to resume)."""


def pose_difference(found: Sequence[float], stored: Sequence[float]) -> float:
    """The larger of the position differences and the heading difference (wrapped to
    ``[0, pi]``) between two ``(x, y, yaw)`` poses."""
    x, y, yaw = (float(a) - float(b) for a, b in zip(found, stored, strict=True))
    return max(abs(x), abs(y), abs((yaw + math.pi) % (2 * math.pi) - math.pi))


def _pose_seed(seed: int, index: int) -> int:
    # every pose of a pose-list run gets its own reset seed, so that a resumed run is identical
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


class _Writer:
    """Buffers samples and appends them to the run's files block by block, the header last.

    The directory and the files are created with the first block (or at :meth:`finish`), so
    nothing is written before there is something to keep.
    """

    def __init__(
        self,
        directory: Path,
        header: dict[str, Any],
        stored: Run | None,
        chunk_size: int,
        on_chunk: Callable[[int], None] | None,
    ) -> None:
        self.directory = directory
        self.header = header
        self.chunk_size = chunk_size
        self.on_chunk = on_chunk
        # one tuple per sample, appended in one step: an interruption (Ctrl-C, SIGTERM) at any
        # point leaves whole samples to flush
        self.samples: list[tuple[NDArray[np.uint8], NDArray[np.float64], float, Any]] = []
        # the small arrays so far, rewritten whole after each block
        self.small = {
            name: np.empty((0, *tail), dtype) if stored is None else getattr(stored, name)
            for name, (dtype, tail) in list(_ARRAYS.items())[1:]
        }

    def add(self, obs: Any, pose: NDArray[np.float64], time: float, action: Any) -> None:
        sample = (
            np.asarray(obs, dtype=np.uint8),
            pose,
            time,
            np.asarray(action, dtype=np.float32),
        )
        self.samples.append(sample)
        if len(self.samples) >= self.chunk_size:
            self.flush()

    def flush(self) -> None:
        n = len(self.samples)
        if n == 0:
            return
        columns = zip(*self.samples[:n], strict=True)
        panoramas, *small = (
            np.asarray(column, dtype=dtype)
            for (dtype, _), column in zip(_ARRAYS.values(), columns, strict=True)
        )
        self.directory.mkdir(parents=True, exist_ok=True)
        _append_panoramas(self.directory / "panoramas.npy", panoramas, self.header["n"])
        for name, new in zip(list(self.small), small, strict=True):
            array = self.small[name] = np.concatenate([self.small[name], new])
            write_atomic(self.directory / f"{name}.npy", lambda file, a=array: np.save(file, a))
        self.header["n"] += n
        write_json_atomic(self.directory / HEADER, self.header)
        del self.samples[:n]
        if self.on_chunk is not None:
            self.on_chunk(self.header["n"])

    def finish(self, end_reason: str) -> None:
        self.flush()
        self.header["complete"] = True
        self.header["end_reason"] = end_reason
        self.directory.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.directory / HEADER, self.header)


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


_FILES = (HEADER, *(f"{name}.npy" for name in _ARRAYS))


def _clear(directory: Path, temporaries_only: bool = False) -> None:
    """Remove the files of a run (header, arrays, temporaries), nothing else."""
    for file in directory.iterdir():
        name = file.name
        temporary = name.startswith(tuple(f".{f}." for f in _FILES)) and name.endswith(".tmp")
        if temporary or (name in _FILES and not temporaries_only):
            file.unlink()


def _check_out_dir(directory: Path) -> None:
    """Refuse an output path that cannot become a run directory, before anything is written."""
    if directory.suffix != SUFFIX:
        raise ValueError(
            f"out_dir must be a directory named '<name>{SUFFIX}', got {str(directory)!r}"
        )
    if directory.exists() and not directory.is_dir():
        raise ValueError(f"out_dir {str(directory)!r} exists and is not a directory")
    parent = directory.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ValueError(f"out_dir {str(directory)!r} cannot be created: {parent} is a file")
    if not os.access(directory if directory.is_dir() else parent, os.W_OK | os.X_OK):
        raise ValueError(f"out_dir {str(directory)!r} cannot be written: permission denied")


def _check_env(env: gym.Env, driver: Driver | GridPositions, seed: int) -> None:
    """Check the env's spaces and plan the drive (which checks the driver's arguments)."""
    space = env.observation_space
    if not (
        isinstance(space, gym.spaces.Box)
        and space.dtype == np.uint8
        and len(space.shape) == 3
        and space.shape[2] == 3
    ):
        raise ValueError(
            f"record needs an env whose observation space is a uint8 Box of shape (H, W, 3) "
            f"(RGB panoramas), got {space}"
        )
    if isinstance(driver, GridPositions):
        driver.poses(env)
        return
    space = env.action_space
    if not (isinstance(space, gym.spaces.Box) and space.shape == (2,)):
        raise ValueError(
            f"a driver needs an env whose action space is a Box of shape (2,) = (v, w), got {space}"
        )
    bounds = env_attribute(env, "arena_bounds")
    if bounds is None:
        raise ValueError(f"{env} has no arena_bounds to drive in")
    dt = _control_period(env)
    if dt is None:
        raise ValueError(f"{env} has no control period (dt or control_dt) in seconds")
    driver.reset(bounds, dt=dt, seed=seed)


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """While recording, SIGTERM raises ``SystemExit(128 + SIGTERM)`` so that the buffered
    samples are written as on Ctrl-C. Only where Python can install handlers (the main
    thread) and only over the default action: a handler set by the caller is kept."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def record(
    env: str | gym.Env,
    driver: Driver | GridPositions,
    out_dir: str | os.PathLike[str],
    *,
    n_steps: int | None = None,
    seed: int = 0,
    chunk_size: int = 500,
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

    Every argument is checked before anything is written (see the module docstring). If
    ``out_dir`` already holds an incomplete run with the same settings, the recording resumes
    (see :mod:`.runfile`); a complete one is returned as it is. Ctrl-C and SIGTERM keep the
    samples recorded so far.

    Args:
        env: a registered env id (made with ``gym.make(env, **env_kwargs)`` and closed at the
            end) or an env; it must report ``x``, ``y``, ``yaw`` in ``info``, observe
            ``(H, W, 3)`` uint8 panoramas and, for drivers, offer ``arena_bounds`` and ``dt``
            (or ``control_dt``), through its wrappers (``env.get_wrapper_attr``).
        driver: what to drive (or which poses to visit).
        out_dir: the run directory; its name must end with ``.run``.
        n_steps: number of samples to store (the reset counts as one); ``None``: until the
            driver is done (required for open-ended drivers) or all poses are visited.
        seed: seed of the env resets and of the driver, an int >= 0.
        chunk_size: samples buffered between writes to the files (an interruption keeps the
            samples written).
        env_kwargs: keyword arguments for ``gym.make`` when ``env`` is an id.
        overwrite: delete an existing run in ``out_dir`` instead of resuming it.
        progress: show a tqdm progress bar.
        on_chunk: called with the number of stored samples after each block is written.

    Returns:
        The recorded run, as :func:`~sfa_gym.recording.runfile.load_run` returns it.

    Raises:
        ValueError: a bad argument, env or driver setting (nothing is written then), or a
            non-finite number in the header.
        RunMismatchError: ``out_dir`` holds a run recorded with other settings.
        RunFormatError: resuming found a damaged run.
        ReplayMismatchError: resuming did not reproduce the stored actions or poses.
        SystemExit: SIGTERM arrived (after the samples so far were written).
    """
    directory = Path(out_dir)
    _check_out_dir(directory)
    check_positive_int("chunk_size", chunk_size)
    check_positive_int("n_steps", n_steps, none=True)
    check_int_in("seed", seed, 0)
    if not isinstance(driver, Driver | GridPositions):
        raise TypeError(
            "driver must be a sfa_gym.recording.drivers.Driver or GridPositions, "
            f"got {type(driver).__name__}"
        )
    if isinstance(driver, Driver) and n_steps is None and type(driver).done is Driver.done:
        raise ValueError(f"{type(driver).__name__} never finishes: give n_steps")
    if not isinstance(env, str) and env_kwargs:
        raise ValueError("env_kwargs only apply when env is an id, not an env instance")

    owns_env = isinstance(env, str)
    if owns_env:
        # the run length is set here, not by the registered time limit
        limit = (n_steps or 0) + 10**9
        env = gym.make(env, max_episode_steps=limit, **dict(env_kwargs or {}))
    try:
        _check_env(env, driver, seed)
        wanted = {
            "format": FORMAT,
            "version": VERSION,
            "kind": "poses" if isinstance(driver, GridPositions) else "trajectory",
            **_env_metadata(env),
            "seed": int(seed),
            "driver": _jsonable(driver.describe()),
            "n_steps": n_steps,
        }
        strict_json(wanted)  # a NaN in a setting is refused now, not after recording
        if overwrite and directory.is_dir():
            _clear(directory)
        if (directory / HEADER).is_file():
            header = _check_resumable(directory, wanted)
            if header["complete"]:
                return load_run(directory)
            _clear(directory, temporaries_only=True)
            stored = load_run(directory)
        else:
            header = {
                **wanted,
                "sfa_gym_version": sfa_gym.__version__,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "n": 0,
                "complete": False,
                "end_reason": None,
            }
            stored = None
        header["sfa_gym_version"] = sfa_gym.__version__
        writer = _Writer(directory, header, stored, chunk_size, on_chunk)
        with _sigterm_raises():
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
    bounds = env_attribute(env, "arena_bounds")
    dt = _control_period(env)
    if bounds is None or dt is None:  # checked by _check_env
        raise ValueError(f"{env} has no arena_bounds or no control period")
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
        if pose_difference(pose, stored.poses[i]) > POSE_TOLERANCE:
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
