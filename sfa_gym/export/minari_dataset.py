"""A recorded run as a Minari dataset, the Farama format of offline-RL data.

One run becomes a dataset of one episode (Minari's conventions: ``N`` observations, ``N - 1``
steps):

- ``observations``: the run's ``N`` panoramas ``(N, H, W, 3)`` uint8, stored losslessly (Minari's
  JPEG encoding of images is turned off, so the pixels read back are the recorded ones);
- ``actions``: ``actions[1:]``, ``(N - 1, 2)`` float32 ``(v, w)``: step ``i`` is the command that
  led from panorama ``i`` to panorama ``i + 1`` (the run's ``actions[0]`` belongs to the reset);
- ``rewards``: zeros (a recording has no task);
- ``terminations``/``truncations``: all false but the last step: terminated if the env ended the
  episode (``end_reason`` ``"terminated"``), else truncated (the requested length was reached,
  the driver finished, the time limit struck, or the recording was interrupted);
- ``infos``: ``x``, ``y``, ``yaw`` (m, rad) and ``t`` (s since the reset), one per observation,
  the keys of the env's own ``info``.

The dataset's observation space is the panoramas' ``Box(0, 255, (H, W, 3), uint8)``; the action
space is that of the run's env (made from its id and the header's plain keyword arguments), or
an unbounded ``Box`` of shape ``(2,)`` when the env cannot be made here. The env spec (id and the
header's keyword arguments, so ``dataset.recover_environment()`` rebuilds the env when they are
plain values, as ``sfa-gym record`` writes them; keyword arguments that were objects, such as a
``PanoramaSpec``, are stored in their JSON form and must be rebuilt by hand) and the whole run
header (``metadata["sfa_gym_run"]``) are kept in the dataset's metadata.

Pose-list runs (kind ``"poses"``) are refused: their samples are independent poses, each from its
own reset, with no action leading from one to the next, so they hold no transition for an
episode to be made of (:func:`~sfa_gym.recording.runfile.load_run` reads their panoramas and
poses as arrays).

The episode is written in blocks of at most ``block_size`` samples, each copied from the run's
memory-mapped panoramas and appended to the episode, so the memory an export takes does not
grow with the run's length. The file is as large as the panoramas (a 20,000-sample 60x600
run: 2.2 GB), as Minari's HDF5 storage does not compress.
"""

from __future__ import annotations

import dataclasses
import shutil
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_positive_int
from sfa_gym.recording.runfile import Run, load_run

__all__ = ["MINARI_EXTRA", "check_dataset_id", "export_minari"]

MINARI_EXTRA = "pip install 'sfa-gym[minari]'"
"""The command that installs what :func:`export_minari` needs (minari and its HDF5 storage)."""

_MIN_VERSION = (0, 5, 4)  # the first Minari that can store images without JPEG's loss
_ID_RULE = (
    "Minari dataset ids are (namespace/)name-v<version>: letters, digits, '-' and '_', an optional "
    "namespace of the same characters and '/', and a version number, e.g. 'sfa-gym/lawnmower-v0'"
)
# Minari's advice to fill in metadata fields left out on purpose (author, permalink, ...)
_NONE_WARNINGS = r"(`\w+` is set to None|env_spec is None)"


def _minari() -> Any:
    """The minari module, or ImportError naming the extra to install."""
    try:
        import h5py  # noqa: F401  (Minari's HDF5 storage; minari itself imports without it)
        import minari
    except ImportError as error:
        raise ImportError(
            f"exporting a Minari dataset needs minari>=0.5.4 with h5py ({error}); install them "
            f"with {MINARI_EXTRA}"
        ) from None
    version = tuple(int(p) for p in minari.__version__.split(".")[:3] if p.isdigit())
    if version < _MIN_VERSION:
        raise ImportError(
            f"minari {minari.__version__} is installed; exporting needs minari>=0.5.4 "
            f"({MINARI_EXTRA})"
        )
    return minari


def check_dataset_id(dataset_id: Any) -> str:
    """``dataset_id`` if Minari accepts it as a local dataset id; ValueError naming the rule."""
    _minari()
    from minari.dataset.minari_dataset import parse_dataset_id

    if not isinstance(dataset_id, str):
        raise ValueError(f"the dataset id must be a string, got {dataset_id!r}; {_ID_RULE}")
    try:
        parse_dataset_id(dataset_id)  # without a version it fails with a TypeError
    except (ValueError, TypeError):
        raise ValueError(f"bad dataset id {dataset_id!r}: {_ID_RULE}") from None
    return dataset_id


def _check_run(run: Run, incomplete: bool) -> None:
    """ValueError if the run cannot be one episode (see the module docstring)."""
    kind = run.metadata.get("kind")
    if kind == "poses":
        raise ValueError(
            f"{run.path} is a pose-list run (kind 'poses'): its samples are independent poses "
            "with no action leading from one to the next, not a trajectory, so they make no "
            "Minari episode; export a run recorded by a driver (sfa-gym record --driver "
            "lawnmower|loop|randomwalk), or read this one with sfa_gym.recording.runfile.load_run"
        )
    if kind != "trajectory":
        raise ValueError(f"{run.path} has kind {kind!r}; expected 'trajectory' or 'poses'")
    if not run.complete and not incomplete:
        raise ValueError(
            f"{run.path} is incomplete ({len(run)} samples; its recording was interrupted): "
            "run the same sfa-gym record command again to finish it, or export what is there "
            "with incomplete=True (--incomplete), its episode then ends truncated"
        )
    if len(run) < 2:
        raise ValueError(
            f"{run.path} holds {len(run)} sample(s); an episode needs at least 2 (one step)"
        )


def _action_space(metadata: dict[str, Any]) -> gym.spaces.Box:
    """The action space of the run's env, or an unbounded ``(2,)`` Box if it cannot be made.

    Only the header's plain keyword arguments are passed on (those that were objects are stored
    as JSON and do not change the action space of the sfa-gym envs: ``v_max`` and ``w_max`` are
    plain numbers)."""
    unbounded = gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    env_id = metadata.get("env_id")
    if not isinstance(env_id, str) or env_id not in gym.registry:
        return unbounded
    plain = {
        k: v
        for k, v in (metadata.get("env_kwargs") or {}).items()
        if v is None or isinstance(v, bool | int | float | str)
    }
    try:
        env = gym.make(env_id, **plain)
    except Exception as error:  # any failure of a foreign env: fall back, but say why
        warnings.warn(
            f"{env_id} cannot be made here ({error}); the dataset's action space is unbounded",
            stacklevel=3,
        )
        return unbounded
    try:
        space = env.action_space
    finally:
        env.close()
    if not isinstance(space, gym.spaces.Box) or space.shape != (2,):
        return unbounded
    return space


def _env_spec_json(metadata: dict[str, Any]) -> str | None:
    """The registered spec of the run's env id with the header's keyword arguments, as JSON."""
    env_id = metadata.get("env_id")
    if not isinstance(env_id, str) or env_id not in gym.registry:
        return None
    spec = dataclasses.replace(gym.spec(env_id), kwargs=dict(metadata.get("env_kwargs") or {}))
    return spec.to_json()


def _ends(run: Run) -> tuple[bool, bool]:
    """``(terminated, truncated)`` of the episode's last step."""
    terminated = run.metadata.get("end_reason") == "terminated"
    return terminated, not terminated


def _block(
    run: Run, start: int, panoramas: NDArray[np.uint8], last: tuple[bool, bool]
) -> dict[str, Any]:
    """The episode's data for the samples from ``start`` on with these ``panoramas``: their
    observations and infos, and the steps that lead to them (sample 0, the reset, has none)."""
    stop = start + len(panoramas)
    first = max(start, 1)
    steps = stop - first
    terminations = np.zeros(steps, dtype=bool)
    truncations = np.zeros(steps, dtype=bool)
    if stop == len(run):
        terminations[-1], truncations[-1] = last
    return {
        "observations": panoramas,
        "actions": np.ascontiguousarray(run.actions[first:stop]),
        "rewards": np.zeros(steps, dtype=np.float64),
        "terminations": terminations,
        "truncations": truncations,
        "infos": {
            "x": run.poses[start:stop, 0].copy(),
            "y": run.poses[start:stop, 1].copy(),
            "yaw": run.poses[start:stop, 2].copy(),
            "t": run.time[start:stop].copy(),
        },
    }


def export_minari(
    run_path: str | Path,
    dataset_id: str,
    *,
    overwrite: bool = False,
    incomplete: bool = False,
    description: str | None = None,
    author: str | None = None,
    author_email: str | None = None,
    code_permalink: str | None = None,
    block_size: int = 256,
) -> Any:
    """Write the run at ``run_path`` as the local Minari dataset ``dataset_id``.

    The dataset goes where Minari keeps local datasets (``$MINARI_DATASETS_PATH``, default
    ``~/.minari/datasets``) and loads with ``minari.load_dataset(dataset_id)``; the module
    docstring says what the episode holds.

    Args:
        run_path: a ``<name>.run`` directory written by
            :func:`~sfa_gym.recording.recorder.record` (kind ``"trajectory"``).
        dataset_id: ``(namespace/)name-v<version>``, e.g. ``"sfa-gym/lawnmower-v0"``.
        overwrite: replace an existing dataset of that id (else it is refused); the old one is
            deleted once the run has been checked, before the new one is written.
        incomplete: export an interrupted recording as it is (its episode ends truncated).
        description: the dataset's description (default: one naming the run, env and driver).
        author: the dataset's author (Minari's metadata).
        author_email: the author's email (Minari's metadata).
        code_permalink: a link to the code that made the dataset (Minari's metadata).
        block_size: samples appended to the episode at once, >= 2.

    Returns:
        The ``minari.MinariDataset``, as ``minari.load_dataset(dataset_id)`` reads it.

    Raises:
        ImportError: minari (or h5py) is not installed; names the pip command.
        ValueError: a bad dataset id (names the rule), an existing dataset without
            ``overwrite``, a pose-list, incomplete or one-sample run.
        FileNotFoundError, RunFormatError: ``run_path`` is not a readable run.
    """
    minari = _minari()
    from minari.data_collector import EpisodeBuffer
    from minari.storage import get_dataset_path

    check_dataset_id(dataset_id)
    if check_positive_int("block_size", block_size) < 2:
        raise ValueError(
            f"block_size must be >= 2 (the first block holds a step), got {block_size}"
        )
    run = load_run(run_path)
    _check_run(run, incomplete)
    where = get_dataset_path(dataset_id)
    if where.exists() and not overwrite:
        raise ValueError(
            f"a Minari dataset {dataset_id!r} already exists ({where}); choose another id or "
            "version, or replace it with overwrite=True (--overwrite)"
        )
    meta = run.metadata
    observation_space = gym.spaces.Box(0, 255, run.panoramas.shape[1:], np.uint8)
    action_space = _action_space(meta)
    driver = (meta.get("driver") or {}).get("type", "unknown driver")
    if description is None:
        description = (
            f"sfa-gym run {run.path.name}: {len(run)} panoramas {tuple(run.panoramas.shape[1:])} "
            f"of {meta.get('env_id')} (world {meta.get('world')}, world seed "
            f"{meta.get('world_seed')}), driven by {driver} with seed {meta.get('seed')}"
        )
    if where.exists():
        shutil.rmtree(where)
    last = _ends(run)
    try:
        for start in range(0, len(run), block_size):
            # the first block holds a step (block_size >= 2), as Minari needs to create the episode
            data = _block(run, start, run.panoramas[start : start + block_size], last)
            if start == 0:
                buffer = EpisodeBuffer(id=0, seed=meta.get("seed"), **data)
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", _NONE_WARNINGS, UserWarning)
                    dataset = minari.create_dataset_from_buffers(
                        dataset_id,
                        [buffer],
                        observation_space=observation_space,
                        action_space=action_space,
                        algorithm_name=f"sfa-gym {driver}",
                        author=author,
                        author_email=author_email,
                        code_permalink=code_permalink,
                        description=description,
                        data_format="hdf5",
                        jpeg_encoding=False,
                    )
                storage = dataset.storage
            else:
                # the same episode id appends to the episode (Minari's HDF5 storage)
                storage.update_episodes([EpisodeBuffer(id=0, **data)])
        # each append set the episode's step count to that of its block
        storage.update_episode_metadata([{"total_steps": len(run) - 1}], [0])
        extra: dict[str, Any] = {"sfa_gym_run": meta}
        spec = _env_spec_json(meta)
        if spec is not None:
            # not given at creation: Minari would make the env from it to read the spaces,
            # which come from the run instead
            extra["env_spec"] = spec
        storage.update_metadata(extra)
    except BaseException:
        shutil.rmtree(where, ignore_errors=True)  # no half-written dataset
        raise
    return minari.load_dataset(dataset_id)
