"""Leaderboard tracks: versioned JSON files that fix what a method is scored on.

A track file (``tracks/<name>.json``) is a JSON object::

    {"schema_version": 1,
     "name": "train_test",            # equals the file's stem
     "track_version": 1,              # bumped whenever a change would change scores
     "kind": "localization" | "navigation",
     "evaluation": "paper_splits" | "train_test" | "few_labels" | "unvisited_region"
                   | "unseen_worlds" | "outdoor" | "navigation",
     "description": "...",
     "world": "paper_sim",            # a world spec name in envs/
     "world_seeds": [100, 101, ...],  # scoring worlds; one task each; the interval is across them
     "seed": 7001,                    # headings, train/test selection, splits, episodes
     "params": {...},                 # the evaluation's settings (see PROTOCOLS)
     "quick": {"world_seeds": 2, "params": {...}},  # the reduced size: the first n world
                                                    # seeds and parameter overrides
     "time_limits": {"fit": 3600},    # optional: seconds per kind of call into a plug-in
     "memory_limit_mb": 8192}         # optional: each plug-in worker's memory limit, MiB

``time_limits`` (names: :data:`~sfa_gym.sandbox.TIME_LIMITS`) and ``memory_limit_mb`` override
the defaults of :class:`~sfa_gym.sandbox.Limits` for the track's tasks (``sfa-gym leaderboard
run --time-limits/--memory-limit-mb`` override them in turn). They bound what a plug-in may
spend, not what it scores, so they are no part of a task's identity.

The ``params`` of an evaluation scored by a protocol (:data:`PROTOCOLS`) are fields of that
protocol's ``Config``: the track's settings are ``dataclasses.replace(Config(), world=world,
seed=seed, **params)`` (lists as tuples; the fields an evaluation fixes, :data:`FIXED_SETTINGS`,
added), checked by ``Config.validate()`` at both sizes when the file is loaded; a field left
out takes the ``Config``'s default.
``unseen_worlds`` adds ``"fit_world_seeds"`` (one per scoring world: the world the method is
fitted on). The ``params`` of ``outdoor`` and ``navigation`` are fields of the protocol's
``Config`` (:class:`sfa_gym.protocols.outdoor.Config`, :class:`sfa_gym.protocols.navigation.Config`;
the track's ``seed`` is its ``seed``), the others at their defaults, checked by its
``validate()`` at both sizes when the file is loaded; ``navigation`` gives every field of
``params.gradient`` (:class:`~sfa_gym.navigation.controllers.GradientSettings`), so that the
library's defaults can change without changing a track's scores.

Every seed of a track must stay clear of :data:`DEVELOPMENT_SEEDS`, the seeds the tests, the
examples and the README use: a method tuned on those would otherwise be scored on what it was
tuned on. :func:`load_track` refuses a file with an unknown schema version, a missing or
unknown field, or a colliding seed, with a :class:`TrackError` (a ValueError) naming the file,
the field and the value.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

__all__ = [
    "DEVELOPMENT_SEEDS",
    "EVALUATIONS",
    "PROTOCOLS",
    "SCHEMA_VERSION",
    "Track",
    "TrackError",
    "default_track_folder",
    "list_tracks",
    "load_track",
    "protocol_module",
    "track_from_dict",
]

SCHEMA_VERSION = 1
"""The track file schema this sfa_gym reads."""

DEVELOPMENT_SEEDS: Mapping[str, frozenset[int]] = {
    # world seeds of tests, examples and README figures
    "world": frozenset(range(10)),
    # position/heading seeds (tests, `sfa-gym localize` default 0), navigation episode seeds of
    # the README (1000-1099, 2000-2099) and the PPO evaluation episodes (10000-10049)
    "episode": frozenset(range(10))
    | frozenset(range(1000, 1100))
    | frozenset(range(2000, 2100))
    | frozenset(range(10000, 10050)),
}
"""Seeds in development use, which no track may score on (the one place they are listed)."""

Kind = Literal["localization", "navigation"]
Evaluation = Literal[
    "paper_splits",
    "train_test",
    "few_labels",
    "unvisited_region",
    "unseen_worlds",
    "outdoor",
    "navigation",
]

PROTOCOLS: Mapping[str, str] = {
    "paper_splits": "sfa_gym.protocols.grid",
    "train_test": "sfa_gym.protocols.grid",
    "few_labels": "sfa_gym.protocols.grid",
    "unseen_worlds": "sfa_gym.protocols.grid",
    "unvisited_region": "sfa_gym.protocols.trajectory",
    "outdoor": "sfa_gym.protocols.outdoor",
    "navigation": "sfa_gym.protocols.navigation",
}
"""The protocol module (:mod:`sfa_gym.protocols`) that scores each evaluation: a track's
``params`` are fields of its ``Config`` (see :meth:`Track.config`) and its ``score`` scores a
task."""

FIXED_SETTINGS: Mapping[str, Mapping[str, Any]] = {
    "paper_splits": {"evaluations": ("paper_splits",)},
    "train_test": {"evaluations": ("train_test",)},
    "few_labels": {"evaluations": ("few_labels",)},
    "unseen_worlds": {"evaluations": ("train_test",)},
}
"""Settings of the protocol's ``Config`` that an evaluation fixes (its ``params`` may not)."""

TRACK_SETTINGS = ("world", "seed")
"""``Config`` fields that come from the track's own fields of the same names (where the
``Config`` has them: the outdoor and navigation protocols take their world from their env)."""

EVALUATIONS: Mapping[str, str] = {
    "paper_splits": "localization",
    "train_test": "localization",
    "few_labels": "localization",
    "unvisited_region": "localization",
    "unseen_worlds": "localization",
    "outdoor": "localization",
    "navigation": "navigation",
}
"""Each evaluation and the kind of track it belongs to."""

_FIELDS = (
    "schema_version",
    "name",
    "track_version",
    "kind",
    "evaluation",
    "description",
    "world",
    "world_seeds",
    "seed",
    "params",
    "quick",
)
_OPTIONAL_FIELDS = ("time_limits", "memory_limit_mb")
"""Fields a track file may leave out (``unseen_worlds`` adds ``fit_world_seeds``)."""


class TrackError(ValueError):
    """A track file that this sfa_gym cannot score on; the message names the file and field."""


@dataclass(frozen=True)
class Track:
    """One loaded track (see the module docstring for the fields).

    Attributes:
        path: the file it was read from (None when built from a dict).
        fit_world_seeds: ``unseen_worlds`` only: the world the method is fitted on, per scoring
            world; empty otherwise.
    """

    name: str
    track_version: int
    kind: Kind
    evaluation: Evaluation
    description: str
    world: str
    world_seeds: tuple[int, ...]
    seed: int
    params: Mapping[str, Any]
    quick: Mapping[str, Any]
    fit_world_seeds: tuple[int, ...] = ()
    time_limits: Mapping[str, float] = dataclasses.field(default_factory=dict)
    memory_limit_mb: int | None = None
    path: Path | None = None

    def sized(self, quick: bool) -> tuple[tuple[int, ...], dict[str, Any]]:
        """The scoring world seeds and the parameters at full size or at the ``quick`` size."""
        if not quick:
            return self.world_seeds, dict(self.params)
        n = self.quick["world_seeds"]
        return self.world_seeds[:n], {**self.params, **self.quick.get("params", {})}

    def config(self, quick: bool) -> Any:
        """The protocol ``Config`` of the track at full size or at the ``quick`` size (see the
        module docstring).

        Raises:
            TrackError: the evaluation has no protocol (:data:`PROTOCOLS`).
        """
        if self.evaluation not in PROTOCOLS:
            raise TrackError(f"evaluation {self.evaluation!r} is not scored by a protocol Config")
        _, params = self.sized(quick)
        return _protocol_config(self.evaluation, self.world, self.seed, params)

    def fit_world_seed(self, world_seed: int) -> int:
        """The world the method is fitted on when scored on ``world_seed`` (itself, except on
        ``unseen_worlds``)."""
        if not self.fit_world_seeds:
            return world_seed
        return self.fit_world_seeds[self.world_seeds.index(world_seed)]

    def describe(self) -> dict[str, Any]:
        """The track as its file holds it (JSON types), for results' provenance."""
        out = {k: v for k, v in dataclasses.asdict(self).items() if k != "path"}
        for name in _OPTIONAL_FIELDS:  # as the file has them: left out when it leaves them out
            if not out[name]:
                del out[name]
        out["world_seeds"] = list(self.world_seeds)
        out["fit_world_seeds"] = list(self.fit_world_seeds)
        return out


def protocol_module(evaluation: str) -> Any:
    """The protocol module (:data:`PROTOCOLS`) that scores ``evaluation``."""
    import importlib

    return importlib.import_module(PROTOCOLS[evaluation])


def _protocol_config(evaluation: str, world: str, seed: int, params: Mapping[str, Any]) -> Any:
    """The checked ``Config`` of one size of a track: the protocol's defaults, the track's
    :data:`TRACK_SETTINGS` where the ``Config`` has them, the evaluation's
    :data:`FIXED_SETTINGS`, then ``params`` (:func:`~sfa_gym._json_types.dataclass_from_json`:
    lists as tuples, objects as nested settings), checked by ``validate()``."""
    from sfa_gym._json_types import dataclass_from_json

    config_type = protocol_module(evaluation).Config
    names = {f.name for f in dataclasses.fields(config_type)}
    track = {name: value for name, value in (("world", world), ("seed", seed)) if name in names}
    default = dataclasses.replace(config_type(), **track, **FIXED_SETTINGS.get(evaluation, {}))
    config = dataclass_from_json(config_type, params, noun="setting", base=default)
    config.validate()
    return config


def _check_protocol_params(
    where: str, data: dict[str, Any], params: dict[str, Any], overrides: dict[str, Any]
) -> None:
    """Refuse ``params`` (and ``quick.params``) that are not fields of the evaluation's protocol
    ``Config``, fields the track or the evaluation sets, or values its ``validate()`` refuses."""
    evaluation = data["evaluation"]
    config_type = protocol_module(evaluation).Config
    names = [f.name for f in dataclasses.fields(config_type)]
    fixed = {*TRACK_SETTINGS, *FIXED_SETTINGS.get(evaluation, {})}
    for size, given in (("params", params), ("quick.params", overrides)):
        for name in given:
            if name not in names:
                raise TrackError(
                    f"{where}: unknown field '{size}.{name}' for {evaluation}; the settings of "
                    f"{config_type.__module__}.Config are {[n for n in names if n not in fixed]}"
                )
            if name in fixed:
                raise TrackError(
                    f"{where}: field '{size}.{name}' is set by the track or by the "
                    f"{evaluation} evaluation, not by params"
                )
    for size, sized in (("params", params), ("quick.params", {**params, **overrides})):
        try:
            config = _protocol_config(evaluation, data["world"], data["seed"], sized)
        except (TypeError, ValueError) as error:
            raise TrackError(f"{where}: {size}: {error}") from None
        if "world" not in names:  # the protocol renders in its env's world: it must be the track's
            _check_env_world(where, evaluation, data["world"], config)


def _check_env_world(where: str, evaluation: str, world: str, config: Any) -> None:
    import gymnasium as gym

    env_id = getattr(config, "env_id", None) or protocol_module(evaluation).ENV_ID
    expected = gym.spec(env_id).kwargs["world"]
    if world != expected:
        raise TrackError(
            f"{where}: world {world!r}: the {evaluation} track renders in {env_id}, whose "
            f"world is {expected!r}"
        )


def _int(where: str, name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TrackError(f"{where}: {name} must be an int, got {value!r}")
    return value


def _seeds(where: str, name: str, value: Any) -> tuple[int, ...]:
    if not isinstance(value, list) or not value:
        raise TrackError(f"{where}: {name} must be a non-empty list of ints, got {value!r}")
    seeds = tuple(_int(where, f"{name}[{i}]", s) for i, s in enumerate(value))
    if len(set(seeds)) != len(seeds):
        raise TrackError(f"{where}: {name} {list(seeds)} repeats a seed")
    return seeds


def _check_clear(where: str, name: str, seeds: tuple[int, ...], pool: str) -> None:
    clash = sorted(set(seeds) & DEVELOPMENT_SEEDS[pool])
    if clash:
        raise TrackError(
            f"{where}: {name} {clash[0]} is a development seed (tests, examples and the README "
            f"use {pool} seeds {_ranges(DEVELOPMENT_SEEDS[pool])}); scoring seeds must be "
            "disjoint from them"
        )


def _ranges(seeds: frozenset[int]) -> str:
    out, ordered = [], sorted(seeds)
    start = prev = ordered[0]
    for s in [*ordered[1:], None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        out.append(f"{start}-{prev}" if prev != start else f"{start}")
        if s is not None:
            start = prev = s
    return ", ".join(out)


def track_from_dict(data: Any, where: str = "track", path: Path | None = None) -> Track:
    """Check a parsed track file and build its :class:`Track`.

    Raises:
        TrackError: an unknown schema version, a missing or unknown field, a wrong type, or a
            seed among :data:`DEVELOPMENT_SEEDS`; the message names ``where`` and the field.
    """
    if not isinstance(data, dict):
        raise TrackError(f"{where}: a track file holds a JSON object, got {type(data).__name__}")
    version = data.get("schema_version")
    if version != SCHEMA_VERSION:
        raise TrackError(
            f"{where}: unknown schema_version {version!r}; this sfa_gym reads track files of "
            f"schema version {SCHEMA_VERSION}"
        )
    evaluation = data.get("evaluation")
    optional = ("fit_world_seeds",) if evaluation == "unseen_worlds" else ()
    for name in _FIELDS + optional:
        if name not in data:
            raise TrackError(f"{where}: missing field {name!r}")
    unknown = sorted(set(data) - set(_FIELDS) - set(optional) - set(_OPTIONAL_FIELDS))
    if unknown:
        raise TrackError(
            f"{where}: unknown field {unknown[0]!r}; the fields are "
            f"{[*_FIELDS, *optional, *_OPTIONAL_FIELDS]}"
        )
    if evaluation not in EVALUATIONS:
        raise TrackError(f"{where}: evaluation {evaluation!r} is not one of {sorted(EVALUATIONS)}")
    if data["kind"] != EVALUATIONS[evaluation]:
        raise TrackError(
            f"{where}: kind {data['kind']!r} does not match evaluation {evaluation!r} "
            f"(a {EVALUATIONS[evaluation]} evaluation)"
        )
    for name in ("name", "world", "description"):
        if not isinstance(data[name], str) or (name != "description" and not data[name]):
            raise TrackError(f"{where}: {name} must be a non-empty string, got {data[name]!r}")
    if path is not None and data["name"] != path.stem:
        raise TrackError(f"{where}: name {data['name']!r} differs from the file name {path.stem!r}")
    track_version = _int(where, "track_version", data["track_version"])
    if track_version < 1:
        raise TrackError(f"{where}: track_version must be >= 1, got {track_version}")
    world_seeds = _seeds(where, "world_seeds", data["world_seeds"])
    _check_clear(where, "world_seeds", world_seeds, "world")
    seed = _int(where, "seed", data["seed"])
    _check_clear(where, "seed", (seed,), "episode")
    fit_world_seeds: tuple[int, ...] = ()
    if optional:
        fit_world_seeds = _seeds(where, "fit_world_seeds", data["fit_world_seeds"])
        _check_clear(where, "fit_world_seeds", fit_world_seeds, "world")
        if len(fit_world_seeds) != len(world_seeds) or set(fit_world_seeds) & set(world_seeds):
            raise TrackError(
                f"{where}: fit_world_seeds {list(fit_world_seeds)} must pair one world each "
                f"with world_seeds {list(world_seeds)}, none of them scored on"
            )
    params = data["params"]
    if not isinstance(params, dict):
        raise TrackError(f"{where}: params must be an object, got {params!r}")
    if evaluation == "navigation":
        _check_controller(where, params.get("gradient"))
    if "episode_seed" in params:
        first = _int(where, "params.episode_seed", params["episode_seed"])
        episodes = _int(where, "params.episodes", params["episodes"])
        _check_clear(where, "params.episode_seed", tuple(range(first, first + episodes)), "episode")
    quick = data["quick"]
    if not isinstance(quick, dict) or "world_seeds" not in quick:
        raise TrackError(f"{where}: missing field 'quick.world_seeds'")
    n_quick = _int(where, "quick.world_seeds", quick["world_seeds"])
    if not 1 <= n_quick <= len(world_seeds):
        raise TrackError(
            f"{where}: quick.world_seeds must be in [1, {len(world_seeds)}], got {n_quick}"
        )
    overrides = quick.get("params", {})
    if not isinstance(overrides, dict):
        raise TrackError(f"{where}: quick.params must be an object, got {overrides!r}")
    _check_protocol_params(where, data, params, overrides)
    time_limits, memory_limit_mb = _limits(where, data)
    return Track(
        name=data["name"],
        track_version=track_version,
        kind=data["kind"],
        evaluation=evaluation,
        description=data["description"],
        world=data["world"],
        world_seeds=world_seeds,
        seed=seed,
        params=params,
        quick=quick,
        fit_world_seeds=fit_world_seeds,
        time_limits=time_limits,
        memory_limit_mb=memory_limit_mb,
        path=path,
    )


def _limits(where: str, data: dict[str, Any]) -> tuple[dict[str, float], int | None]:
    """The track's optional ``time_limits`` and ``memory_limit_mb``, checked (see
    :func:`~sfa_gym.sandbox.check_time_limits`)."""
    from sfa_gym.sandbox import check_memory_mb, check_time_limits

    try:
        time_limits = check_time_limits(data.get("time_limits", {}), f"{where}: time_limits")
        memory = data.get("memory_limit_mb")
        if memory is not None:
            check_memory_mb(memory, f"{where}: memory_limit_mb")
    except ValueError as error:
        raise TrackError(str(error)) from None
    return time_limits, memory


def _check_controller(where: str, controller: Any) -> None:
    """``params.gradient`` must give every setting of the gradient controller: a change of the
    library's defaults must not change a track's scores (the values are checked with the
    protocol's Config)."""
    from sfa_gym.navigation.controllers import GradientSettings

    names = {f.name for f in dataclasses.fields(GradientSettings)}
    if not isinstance(controller, dict):
        raise TrackError(f"{where}: params.gradient must be an object, got {controller!r}")
    missing = sorted(names - set(controller))
    if missing:
        raise TrackError(f"{where}: missing field 'params.gradient.{missing[0]}'")


def load_track(path: str | os.PathLike[str]) -> Track:
    """Read and check one track file (see :func:`track_from_dict`).

    Raises:
        FileNotFoundError: no such file.
        TrackError: not valid JSON, or not a valid track.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise TrackError(f"{path} is not valid JSON: {error}") from None
    return track_from_dict(data, str(path), path)


def default_track_folder() -> Path:
    """``tracks/`` of the checkout this sfa_gym runs from, else the copy in the wheel
    (:func:`sfa_gym.data.data_folder`).

    Raises:
        FileNotFoundError: neither exists (name a folder of track files with --tracks instead).
    """
    from sfa_gym.data import data_folder

    return data_folder("tracks")


def list_tracks(folder: str | os.PathLike[str] | None = None) -> list[Track]:
    """Every track file of ``folder`` (default: :func:`default_track_folder`), sorted by name."""
    folder = default_track_folder() if folder is None else Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"no track folder {folder}")
    return [load_track(p) for p in sorted(folder.glob("*.json"))]
