"""Leaderboard results: one format, read, checked and written (the table built from them is
:mod:`sfa_gym.leaderboard.table`).

A results file holds one result or many::

    {"format": "sfa-gym-leaderboard-results", "schema_version": 3, "description": "...",
     "results": [{"track", "track_version", "quick", "size_params", "method", "method_sha256",
                  "score": {"mean", "ci95": [lo, hi] | null, "interval": "t-clipped", "n",
                            "std", "higher_is_better"},
                  "per_world_seed": {seed: score}, "parts": {part: mean} | null,
                  "parts_per_world_seed": {seed: {part: value}}, "spl": {"mean",
                  "per_world_seed"}, "fingerprints": {seed: fingerprint},
                  "task_seconds", "task_phases", "task_peak_rss_mb", "isolation",
                  "git_commit", "backend", "created", "versions", "cpu_numerics",
                  "content_sha256"}, ...]}

A sweep writes one file per (track, method), ``<results>/<track>/<method label>[.quick].json``,
without a description; ``sfa-gym leaderboard publish`` gathers the results of a folder into one
file with a description (``published/leaderboard/*.json``), each result kept whole. ``parts``
are the means over the world seeds of the score's parts (outdoor tracks: each condition, the
unvisited region), ``parts_per_world_seed`` and ``content_sha256`` are written by sweeps (the
published results gathered before schema 3 lack them; theirs record ``result_sha256``, the
hash of the result file they were gathered from), ``spl`` and ``fingerprints`` are
navigation's (:func:`~sfa_gym.protocols.navigation.episode_fingerprint`). ``versions`` are the
installed versions of the locked packages (``constraints.txt``, :mod:`sfa_gym.lock`),
``cpu_numerics`` what of the CPU decides the last bits beside them; the table marks results off
the lock or off the reference's fingerprints (:mod:`sfa_gym.leaderboard.checks`).

Nothing read is trusted: each result is checked field by field (:func:`check_result`), its mean,
interval and ``n`` recomputed from the seeds' scores by :func:`~sfa_gym.intervals.summarize`
(the shown summary is that one), its ``content_sha256`` recomputed where it records one, and a
sweep's file must lie where its content says. A result that fails is a :class:`ResultError`
naming its file and what is wrong; :func:`load_results` given a ``skipped`` list notes it there
and reads on. Files of schema versions 1 and 2 (result files of one result each, and gathered
files without a format) are refused naming their version; ``scripts/convert_leaderboard_results.py``
converts them.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import math
import os
import subprocess
from pathlib import Path
from typing import Any

import numpy as np

import sfa_gym
from sfa_gym.files import write_json_atomic
from sfa_gym.intervals import INTERVAL, score_range, summarize

__all__ = [
    "FORMAT",
    "REFERENCE",
    "ROUND_OFF",
    "SCHEMA_VERSION",
    "YOURS",
    "ResultError",
    "check_result",
    "content_sha256",
    "git_commit",
    "load_results",
    "make_result",
    "one_per_key",
    "reference_folder",
    "result_key",
    "result_path",
    "write_gathered",
    "write_results",
]

FORMAT = "sfa-gym-leaderboard-results"
SCHEMA_VERSION = 3
YOURS = "yours"
"""The source of the results a user ran (the results folder of ``sfa-gym leaderboard``)."""
REFERENCE = "reference"
"""The source of the committed reference results (:func:`reference_folder`)."""
ROUND_OFF = 1e-6
"""The relative difference allowed between a stored summary and the one recomputed from the
seeds' scores: results keep ten digits of each; an edit of a shown digit is far beyond."""
CONVERTER = "scripts/convert_leaderboard_results.py"


class ResultError(ValueError):
    """A result that cannot be shown; the message names its file and what is wrong with it."""


def git_commit(path: str | os.PathLike[str] | None = None) -> str | None:
    """The commit of the checkout at ``path`` (default: the package's folder), ``+dirty`` if
    tracked files changed; None outside a git checkout or without git."""
    where = Path(path) if path is not None else Path(sfa_gym.__file__).resolve().parent
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=where, capture_output=True, text=True, timeout=10
        )
        if head.returncode != 0:
            return None
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=where,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def method_label(name: str, args: dict[str, Any], defaults: dict[str, Any]) -> str:
    """``name``, plus the arguments that differ from the defaults (``band_means[n_bands=4]``)."""
    changed = [f"{k}={args[k]}" for k in sorted(args) if args[k] != defaults.get(k)]
    return f"{name}[{','.join(changed)}]" if changed else name


def result_path(results: Path, track: str, label: str, quick: bool) -> Path:
    """Where a sweep writes the result of ``label`` on ``track``."""
    safe = "".join(c if c.isalnum() or c in "-_=,.[]+" else "_" for c in label)
    return results / track / f"{safe}{'.quick' if quick else ''}.json"


def _mean_parts(tasks: list[dict[str, Any]]) -> dict[str, float] | None:
    """The mean over the world seeds of each part of the score; None without parts."""
    if not all("parts" in task["scores"] for task in tasks):
        return None
    out = {}
    for part in dict.fromkeys(p for task in tasks for p in task["scores"]["parts"]):
        values = [v for t in tasks if (v := t["scores"]["parts"].get(part)) is not None]
        if values:
            out[part] = float(np.mean(values))
    return out


def make_result(
    *,
    track: Any,
    quick: bool,
    method: dict[str, Any],
    tasks: list[dict[str, Any]],
    higher_is_better: bool,
    backend: str,
    created: str | None = None,
) -> dict[str, Any]:
    """The result of one track and method from its tasks' outputs (see the module docstring),
    with its ``content_sha256``."""
    from sfa_gym.lock import cpu_numerics, installed_versions

    tasks = sorted(tasks, key=lambda t: t["world_seed"])
    seeds = [str(t["world_seed"]) for t in tasks]
    scores = [t["scores"] for t in tasks]
    result = {
        "track": track.name,
        "track_version": track.track_version,
        "quick": quick,
        "size_params": json.loads(json.dumps(track.sized(quick)[1])),
        "method": method["label"],
        "method_sha256": method.get("sha256"),
        "score": summarize([s["score"] for s in scores], higher_is_better),
        "per_world_seed": {seed: s["score"] for seed, s in zip(seeds, scores, strict=True)},
        "parts": _mean_parts(tasks),
    }
    for field, key in (("parts_per_world_seed", "parts"), ("fingerprints", "fingerprint")):
        if all(key in s for s in scores):
            result[field] = {seed: s[key] for seed, s in zip(seeds, scores, strict=True)}
    if all("spl" in s for s in scores):
        spl = {seed: float(s["spl"]) for seed, s in zip(seeds, scores, strict=True)}
        result["spl"] = {"mean": float(np.mean(list(spl.values()))), "per_world_seed": spl}
    now = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    result |= {
        "task_seconds": [t.get("seconds") for t in tasks],
        "task_phases": [t.get("phases") for t in tasks],
        "task_peak_rss_mb": [t.get("peak_rss_mb") for t in tasks],
        "isolation": sorted({str(t.get("isolation")) for t in tasks}),
        "git_commit": git_commit(),
        "backend": backend,
        "created": created or now,
        "versions": installed_versions(),
        "cpu_numerics": cpu_numerics(),
    }
    return {**result, "content_sha256": content_sha256(result)}


def write_results(
    path: Path, results: list[dict[str, Any]], description: str | None = None
) -> None:
    """Write ``results`` (loaded or made: the loader's keys are left out) atomically."""
    data: dict[str, Any] = {"format": FORMAT, "schema_version": SCHEMA_VERSION}
    if description is not None:
        data["description"] = description
    data["results"] = [{k: v for k, v in r.items() if not k.startswith("_")} for r in results]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, data)


def reference_folder() -> Path:
    """The committed reference results: ``published/leaderboard`` of the checkout this sfa_gym
    runs from, else the copy inside the installed package.

    Raises:
        FileNotFoundError: neither exists (an incomplete installation).
    """
    from sfa_gym.data import data_folder

    return data_folder("published") / "leaderboard"


def write_gathered(
    results: str | os.PathLike[str], out: str | os.PathLike[str], description: str
) -> int:
    """Gather every result under ``results`` into one file ``out`` with ``description`` (written
    atomically), the form in which reference results are published; returns the number of
    results. The results of a gathered file under ``results`` are kept whole (checked like every
    result), so that a published file can be extended by a later run: copy it into the run's
    folder and publish again; a sweep's result replaces the gathered result of its track, size
    and method (a published result run again).

    Raises:
        ValueError: ``results`` holds no result, two sweep results (or two gathered results) of
            one track, size and method (results of two runs mixed in one folder), or a result
            whose plug-ins ran unconfined (``isolation`` "process" or "in-process": no
            bubblewrap, or :data:`~sfa_gym.leaderboard.evaluate.IN_PROCESS`), which the plug-in
            could have altered. A result gathered before tasks recorded their isolation is
            published; it says ``"None"``.
    """
    found = load_results(results)
    if not found:
        raise ValueError(f"no leaderboard result files under {results}")
    unconfined = [r["_file"] for r in found if {"process", "in-process"} & set(r["isolation"])]
    if unconfined:
        raise ValueError(
            f"{unconfined[0]} (and {len(unconfined) - 1} more) holds tasks whose plug-ins ran "
            "unconfined (no bubblewrap, or SFA_GYM_PLUGINS_IN_PROCESS=1): a plug-in there can "
            "read and rewrite what the evaluator can, so its results are not published; "
            "install bubblewrap (scripts/setup.sh does) and run again"
        )
    chosen = one_per_key(found, str(results))
    write_results(Path(out), [r for _, r in sorted(chosen.items())], description)
    return len(chosen)


def result_key(result: dict[str, Any]) -> tuple[str, bool, str]:
    """What identifies a result on the board: its track, size (quick or not) and method."""
    return result["track"], result["quick"], result["method"]


def one_per_key(
    results: list[dict[str, Any]], where: str
) -> dict[tuple[str, bool, str], dict[str, Any]]:
    """``results`` (as :func:`load_results` reads them) by :func:`result_key`: a sweep's result
    replaces the gathered result of its key (a published result run again).

    Raises:
        ValueError: two sweep results, or two gathered results, of one key (results of two
            runs mixed in one folder); the message names ``where`` and both files.
    """
    chosen: dict[tuple[str, bool, str], dict[str, Any]] = {}
    for result in sorted(results, key=lambda r: not r["_gathered"]):
        key = result_key(result)
        if key in chosen and chosen[key]["_gathered"] == result["_gathered"]:
            raise ValueError(
                f"{where} holds more than one result of (track, quick, method) {key}: "
                f"{chosen[key]['_file']} and {result['_file']}"
            )
        chosen[key] = result
    return chosen


def load_results(
    results: str | os.PathLike[str], source: str = YOURS, skipped: list[str] | None = None
) -> list[dict[str, Any]]:
    """Every result under ``results`` (recursively; or of the one file ``results``), each
    checked (:func:`check_result`) and marked with ``source`` (``"_source"``), its file
    (``"_file"``) and whether that file is a gathered one (``"_gathered"``: it has a
    description). Files of other sfa-gym formats (task files) are passed over. A folder that
    does not exist holds no results.

    Args:
        skipped: where to note each file or result that cannot be shown (a message naming it
            and what is wrong) and read on; None: raise at the first.

    Raises:
        ResultError: (``skipped`` None) a file that is not valid JSON, not a results file, of
            another schema version, or a result that fails the checks.
    """
    root = Path(results)
    out = []
    for path in [root] if root.is_file() else sorted(root.rglob("*.json")):
        try:
            data = _read_file(path)
        except ResultError as error:
            if skipped is None:
                raise
            skipped.append(str(error))
            continue
        gathered = "description" in data
        for i, entry in enumerate(data.get("results", [])):
            where = f"{path}, entry {i}" if gathered else str(path)
            try:
                check_result(entry, where)
                if not gathered:
                    _check_place(path, entry)
            except ResultError as error:
                if skipped is None:
                    raise
                skipped.append(str(error))
                continue
            out.append(entry | {"_file": str(path), "_source": source, "_gathered": gathered})
    return out


def _read_file(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ResultError(f"{path} cannot be read as JSON: {error}") from None
    kind = data.get("format") if isinstance(data, dict) else None
    if isinstance(kind, str) and kind.startswith("sfa-gym-") and kind != FORMAT:
        old = kind == "sfa-gym-leaderboard-result"
        if not old:
            return {}  # another kind of sfa-gym file (task files): no results
    elif kind is None and isinstance(data, dict) and isinstance(data.get("results"), list):
        old = True  # a gathered file of before schema 3
    elif kind != FORMAT:
        raise ResultError(f"{path} is not a results file (format {FORMAT!r})")
    else:
        old = data.get("schema_version") != SCHEMA_VERSION
    if old:
        version = data.get("schema_version", "2 (a gathered file without a format)")
        raise ResultError(
            f"{path}: leaderboard results of schema_version {version}; this sfa_gym reads "
            f"schema_version {SCHEMA_VERSION}: convert it with {CONVERTER}"
        )
    if not isinstance(data.get("results"), list):
        raise ResultError(f"{path}: 'results' is {data.get('results')!r}; expected a list")
    return data


def _check_place(path: Path, result: dict[str, Any]) -> None:
    """A sweep's file lies where its content says (``<track>/<label>[.quick].json``)."""
    track, quick, label = result_key(result)
    place = result_path(path.parents[1], track, label, quick)
    if place != path:
        raise ResultError(
            f"{path}: it holds track {track!r} at the {'quick' if quick else 'full'} size, "
            f"method {label!r}, whose file is {place.relative_to(path.parents[1])}; a result's "
            "folder and name must agree with its content"
        )


def content_sha256(result: dict[str, Any]) -> str:
    """The SHA-256 of a result's content (canonical JSON, without ``content_sha256`` itself and
    the keys the loader adds, ``_source``, ``_file``, ``_gathered``): an edit after the result was
    written changes it."""
    content = {k: v for k, v in result.items() if k != "content_sha256" and not k.startswith("_")}
    # NaN hashes as NaN; the field checks refuse it with its place named
    text = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _finite(value: Any) -> bool:
    """Whether ``value`` is a finite JSON number (not a bool)."""
    number = isinstance(value, int | float) and not isinstance(value, bool)
    return number and math.isfinite(value)


_KINDS = {
    "text": lambda v: isinstance(v, str),
    "bool": lambda v: isinstance(v, bool),
    "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": _finite,
    "object": lambda v: isinstance(v, dict),
    "list": lambda v: isinstance(v, list),
}


def _get(where: str, data: Any, dotted: str, kind: str, optional: bool = False) -> Any:
    """``data[a][b]`` for ``dotted`` ``"a.b"``, checked to be of ``kind`` (:data:`_KINDS`);
    ``optional``: None where it is missing or null.

    Raises:
        ResultError: the field is missing or of another type (named with ``where``).
    """
    value, keys = data, dotted.split(".")
    for i, key in enumerate(keys):
        if not isinstance(value, dict):
            raise ResultError(f"{where}: {'.'.join(keys[:i])!r} is {value!r}; expected object")
        if key not in value and not optional:
            raise ResultError(f"{where} lacks {'.'.join(keys[: i + 1])!r}")
        value = value.get(key)
    if optional and value is None:
        return None
    if not _KINDS[kind](value):
        raise ResultError(f"{where}: {dotted!r} is {value!r}; expected {kind}")
    return value


def _close(stored: Any, fresh: Any) -> bool:
    """Whether a stored summary value is the recomputed one up to :data:`ROUND_OFF`."""
    if fresh is None or stored is None:
        return stored is None and fresh is None
    if isinstance(fresh, list):
        return (
            isinstance(stored, list)
            and len(stored) == len(fresh)
            and all(_close(a, b) for a, b in zip(stored, fresh, strict=True))
        )
    number = isinstance(stored, int | float) and not isinstance(stored, bool)
    return number and math.isclose(stored, fresh, rel_tol=ROUND_OFF, abs_tol=ROUND_OFF)


def _per_seed(where: str, result: dict[str, Any], field: str, check: Any, expected: str) -> None:
    """``result[field]`` (if there) is ``{seed: value}`` with each value passing ``check``."""
    found = _get(where, result, field, "object", optional=True) or {}
    for seed, value in found.items():
        if not seed.lstrip("-").isdigit():
            raise ResultError(f"{where}: {field!r} has keys {list(found)}; expected seeds")
        if not check(value):
            raise ResultError(f"{where}: {field}[{seed}] is {value!r}; expected {expected}")


def _parts(value: Any) -> bool:
    return isinstance(value, dict) and all(v is None or _finite(v) for v in value.values())


def check_result(result: dict[str, Any], where: str) -> dict[str, Any]:
    """``result`` checked field by field, its score's mean, interval and ``n`` recomputed from
    its seeds' scores (:func:`~sfa_gym.intervals.summarize`) and its ``content_sha256`` where it
    records one; returns it.

    Raises:
        ResultError: a field is missing or of a wrong type, a seed's score leaves the
            :func:`~sfa_gym.intervals.score_range`, the interval method is not today's, or the
            stored mean, interval or ``n`` differ from the recomputed ones beyond
            :data:`ROUND_OFF` (both named, with ``where``).
    """
    if not isinstance(result, dict):
        raise ResultError(f"{where}: the result is {result!r}; expected an object")
    recorded = result.get("content_sha256")
    if recorded is not None and recorded != (actual := content_sha256(result)):
        raise ResultError(
            f"{where}: its content was changed after it was written (content_sha256 "
            f"{str(recorded)[:16]}... does not match the content's {actual[:16]}...)"
        )
    _get(where, result, "track", "text")
    _get(where, result, "quick", "bool")
    if _get(where, result, "track_version", "int") < 1:
        raise ResultError(f"{where}: 'track_version' must be >= 1")
    _get(where, result, "size_params", "object", optional=True)
    _get(where, result, "method", "text")
    _get(where, result, "isolation", "list")
    _get(where, result, "git_commit", "text", optional=True)
    _get(where, result, "versions", "object", optional=True)
    higher = _get(where, result, "score.higher_is_better", "bool")
    low, high = score_range(higher)
    _per_seed(where, result, "per_world_seed", _finite, "a number")
    seeds = _get(where, result, "per_world_seed", "object")
    if not seeds:
        raise ResultError(f"{where}: 'per_world_seed' is empty; expected a score per world seed")
    outside = [(s, v) for s, v in seeds.items() if not low <= v <= high]
    if outside:
        raise ResultError(
            f"{where}: world seed {outside[0][0]}'s score {outside[0][1]!r} leaves the score's "
            f"range [{low}, {high}] ({'success rate' if higher else 'MAE'})"
        )
    if not (result.get("parts") is None or _parts(result["parts"])):
        raise ResultError(f"{where}: 'parts' is {result['parts']!r}; expected {{part: number}}")
    _per_seed(where, result, "parts_per_world_seed", _parts, "{part: number}")
    _per_seed(where, result, "fingerprints", lambda v: isinstance(v, str), "text")
    if result.get("spl") is not None:
        _get(where, result, "spl.mean", "number")
        _per_seed(
            where, result["spl"], "per_world_seed", lambda v: _finite(v) and 0 <= v <= 1, "[0, 1]"
        )
    method = _get(where, result, "score.interval", "text")
    if method != INTERVAL:
        raise ResultError(f"{where}: 'score.interval' is {method!r}; expected {INTERVAL!r}")
    stored, fresh = result["score"], summarize(list(seeds.values()), higher)
    differ = [
        f"score.{k} is {stored.get(k)!r} but its seeds' scores give {fresh[k]!r}"
        for k in ("mean", "n", "ci95")
        if not _close(stored.get(k), fresh[k])
    ]
    if differ:
        raise ResultError(f"{where}: {'; '.join(differ)}")
    return result
