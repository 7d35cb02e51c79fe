"""Markdown tables for the committed result files that no other module formats.

The protocols format their own ``results.json`` (:func:`sfa_gym.cli.results.format_table`,
:func:`sfa_gym.cli.navigate.format_navigation_table`); the formatters here cover the
other kinds of result file under ``published/``: the leaderboard's reference board (one record
per track and method), the navigation studies' episode sets (rows of ``variant``, ``env_id``,
``world_seed``, ``first_seed`` and the scores), the descent bounds, the navigation step rates,
the outdoor world's cost per step, the SFA engine against MDP, the leaderboard's timings and
the camera's rotation equivariance. Each takes the parsed JSON of one or more files and the
options of its marker, and returns markdown.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from sfa_gym.intervals import format_interval

__all__ = [
    "appearance_change_table",
    "board_parts_table",
    "board_time_table",
    "board_table",
    "descent_bound_table",
    "equivariance_table",
    "leaderboard_timings_table",
    "nav_controllers_table",
    "nav_sets_table",
    "nav_steps_table",
    "outdoor_cost_table",
    "quick_vs_full_table",
    "sfa_engine_table",
]

WORLDS = {
    "sfa_gym/OmniRoverNav-v0": "open",
    "sfa_gym/OmniRoverNavObstacles-v0": "obstacles",
    "sfa_gym/OmniRoverNavMaze-v0": "maze",
}
"""Navigation env ids by the short name of their world, as the tables print them."""


def _row(cells: Sequence[object]) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _head(cells: Sequence[str]) -> list[str]:
    return [_row(cells), "|" + "---|" * len(cells)]


def _records(files: Sequence[dict[str, Any]], option: str) -> list[dict[str, Any]]:
    """The board records of every file (``{"results": [...]}``), in file order."""
    out: list[dict[str, Any]] = []
    for data in files:
        if not isinstance(data.get("results"), list):
            raise ValueError(f"{option}: expected a board file with a 'results' list")
        out += data["results"]
    return out


def _split(value: str | None) -> list[str] | None:
    return None if value is None else [v for v in value.split(",") if v]


def board_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Tracks as rows, methods as columns: the mean score over the track's world seeds, the
    best of each row in bold (lowest MAE, highest success).

    Options: ``tracks=a,b`` and ``methods=a,b`` choose and order rows and columns (default:
    all, as they come in the file); ``intervals=1`` adds each mean's 95 % interval across the
    world seeds, ``[lo, hi]`` or ``(n=2)`` (:func:`_interval`).
    """
    records = _records(files, "board")
    tracks = _split(options.get("tracks")) or list(dict.fromkeys(r["track"] for r in records))
    methods = _split(options.get("methods")) or list(dict.fromkeys(r["method"] for r in records))
    cells = {(r["track"], r["method"]): r for r in records}
    missing = [t for t in tracks if not any((t, m) in cells for m in methods)]
    if missing:
        raise ValueError(f"board: track {missing[0]!r} has no result in the file")
    lines = _head(["track (version)", "score", *methods])
    for t in tracks:
        found = [cells.get((t, m)) for m in methods]
        present = [r for r in found if r is not None]
        higher = present[0]["score"]["higher_is_better"]
        means = [r["score"]["mean"] for r in present]
        best = max(means) if higher else min(means)
        row = [f"`{t}` ({present[0]['track_version']})", "success" if higher else "MAE %"]
        for r in found:
            if r is None:
                row.append("-")
            else:
                text = f"{r['score']['mean']:.2f}"
                bold = f"**{text}**" if f"{best:.2f}" == text else text
                row.append(f"{bold} {_interval(r)}" if options.get("intervals") == "1" else bold)
        lines.append(_row(row))
    return "\n".join(lines)


def nav_controllers_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Navigation tracks' success rate and SPL per method (a label ``method+controller`` for a
    controller plug-in on a method's field), from board files: a row per method, two columns per
    track. Options ``tracks=a,b`` and ``methods=a,b`` choose and order them (default: every
    navigation result in the files)."""
    records = [r for r in _records(files, "nav-controllers") if r.get("spl") is not None]
    if not records:
        raise ValueError("nav-controllers: no navigation result with an SPL in the files")
    tracks = _split(options.get("tracks")) or list(dict.fromkeys(r["track"] for r in records))
    methods = _split(options.get("methods")) or list(dict.fromkeys(r["method"] for r in records))
    cells = {(r["track"], r["method"]): r for r in records}
    lines = _head(["method", *(f"`{t}` {what}" for t in tracks for what in ("success", "SPL"))])
    for m in methods:
        row = [m]
        for t in tracks:
            r = cells.get((t, m))
            row += (
                ["-", "-"]
                if r is None
                else [
                    f"{r['score']['mean']:.2f} {_interval(r)}",
                    f"{r['spl']['mean']:.2f}",
                ]
            )
        lines.append(_row(row))
    return "\n".join(lines)


def board_seeds_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """One track's score on each world seed, a row per method (option ``track=name``; option
    ``methods=a,b`` chooses and orders them). With ``minus=m`` each other method also gets a
    row of its difference from ``m`` on the same world: the paired comparison that the means'
    intervals, taken across worlds, do not show."""
    track = options.get("track")
    if track is None:
        raise ValueError("board-seeds needs track=NAME")
    records = {r["method"]: r for r in _records(files, "board-seeds") if r["track"] == track}
    methods = _split(options.get("methods")) or list(records)
    reference = options.get("minus")
    named = [*methods, *([reference] if reference is not None else [])]
    missing = [m for m in named if m not in records]
    if missing:
        raise ValueError(f"board-seeds: no result of {missing} on track {track!r} in the files")
    scores = {m: records[m]["per_world_seed"] for m in named}
    seeds = list(scores[methods[0]])
    for m, own in scores.items():
        if set(own) != set(seeds):  # a pairing needs the same worlds in every row
            raise ValueError(
                f"board-seeds: {m!r} on track {track!r} has world seeds {sorted(own)}, "
                f"expected those of {methods[0]!r}: {sorted(seeds)}"
            )
    lines = _head(["method", *(f"world {s}" for s in seeds)])
    for m in methods:
        lines.append(_row([m, *(f"{scores[m][s]:.2f}" for s in seeds)]))
    if reference is not None:
        for m in (m for m in methods if m != reference):
            differences = (f"{scores[m][s] - scores[reference][s]:+.2f}" for s in seeds)
            lines.append(_row([f"{m} - {reference}", *differences]))
    return "\n".join(lines)


def _interval(record: dict[str, Any]) -> str:
    """The 95 % interval of a board record's mean, ``[lo, hi]`` or ``(n=2)``, recomputed from
    its seeds' scores by today's method (as ``sfa-gym leaderboard table`` shows it), whichever
    method the file recorded."""
    from sfa_gym.intervals import summarize

    values = list(record["per_world_seed"].values())
    score = summarize(values, record["score"]["higher_is_better"])
    return format_interval(score["ci95"], score["n"])


def quick_vs_full_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Per track, Kendall's tau between the quick and the full board's method orders and both
    orders (``eval/studies/quick_vs_full.py``'s file)."""
    lines = _head(["track", "Kendall tau", "quick order (best first)", "full order"])
    for row in _one_with(files, "tracks", "quick-vs-full"):
        cells = [
            f"{row['kendall_tau']:.2f}",
            *(" > ".join(row[k]) for k in ("quick_order", "full_order")),
        ]
        lines.append(_row([f"`{row['track']}`", *cells]))
    return "\n".join(lines)


def board_parts_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """One track's parts (for the outdoor tracks: each test condition and the unvisited
    region), methods as rows, MAE % as the mean over the world seeds. Option ``track=name``."""
    track = options.get("track")
    if track is None:
        raise ValueError("board-parts needs track=NAME")
    found = [r for r in _records(files, "board-parts") if r["track"] == track and "parts" in r]
    if not found:
        raise ValueError(f"board-parts: no result of track {track!r} with parts in the file")
    parts = list(dict.fromkeys(p for r in found for p in r["parts"]))
    lines = _head(["method", *parts])
    for r in found:
        values = [r["parts"].get(p) for p in parts]
        lines.append(_row([r["method"], *("-" if v is None else f"{v:.2f}" for v in values)]))
    return "\n".join(lines)


def _mean_and_range(values: Sequence[float]) -> str:
    if len(values) == 1:
        return f"{values[0]:.2f}"
    return f"{np.mean(values):.2f} ({min(values):.3g}-{max(values):.3g})"


def nav_sets_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Navigation episode sets: per world, features and variant the mean over the sets, with
    the lowest and highest set in brackets (``sets=mean``, the default); or one row per set,
    success on all pairs with SPL in brackets (``sets=each``).

    ``runs=hilbert,walk,...`` names each file's training run (the study files do not record
    it); the table then has a column for it and keeps the files' sets apart.
    """
    runs = _split(options.get("runs"))
    if runs is not None and len(runs) != len(files):
        raise ValueError(f"nav-sets: runs= names {len(runs)} training runs for {len(files)} files")
    mode = options.get("sets", "mean")
    if mode not in ("mean", "each"):
        raise ValueError(f"nav-sets: sets={mode!r}; expected 'mean' or 'each'")
    groups: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for i, data in enumerate(files):
        if not isinstance(data.get("rows"), list):
            raise ValueError("nav-sets: expected a study file with a 'rows' list")
        for r in data["rows"]:
            key = (WORLDS.get(r["env_id"], r["env_id"]), r.get("features", "sfa"), r["variant"])
            if mode == "each":
                last = r["first_seed"] + data["episodes"] - 1
                key += (str(r["world_seed"]), f"{r['first_seed']}-{last}")
            groups.setdefault(key if runs is None else (runs[i], *key), []).append(r)
    head = ["world", "features", "variant"]
    head = head if runs is None else ["training run", *head]
    if mode == "each":
        lines = _head([*head, "world seed", "episode seeds", "success (SPL)"])
        for key, (r,) in groups.items():
            lines.append(_row([*key, f"{r['success_all']:.3g} ({r['spl_all']:.2f})"]))
        return "\n".join(lines)
    scores = ("success_all", "spl_all", "success_interior", "spl_interior")
    lines = _head([*head, "sets", "success, all", "SPL, all", "success, interior", "SPL, interior"])
    for key, group in groups.items():
        cells = [_mean_and_range([g[k] for g in group]) for k in scores]
        lines.append(_row([*key, len(group), *cells]))
    return "\n".join(lines)


_CURVES = {
    "laplacian_box": "ideal: the box's eigenfunctions",
    "laplacian_free": "ideal: the free space's eigenfunctions",
    "projected": "features projected onto the free space's",
}


def descent_bound_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Share of starts from which steepest descent on a field's smoothed cost reaches the goal:
    a row per features (and ideal eigenfunctions), a column per escape radius (0: pure
    descent)."""
    entries: list[tuple[str, dict[str, float]]] = []
    for data in files:
        if "reached" not in data:
            raise ValueError("descent-bound: expected a file with 'reached'")
        where = f"{data['nav']}, {data.get('features', 'sfa')}"
        entries.append((where, data["reached"]))
        for curve, reached in data.get("ideal", {}).items():
            entries.append((f"{data['nav']}, {_CURVES.get(curve, curve)}", reached))
    radii = sorted({r for _, reached in entries for r in reached}, key=float)
    names = ["pure descent" if float(r) == 0 else f"{r} m escape" for r in radii]
    lines = _head(["field, cost on", *names])
    for where, reached in entries:
        lines.append(_row([where, *(f"{reached[r]:.3g}" if r in reached else "-" for r in radii)]))
    return "\n".join(lines)


def nav_steps_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Steps per second of each navigation env in each mode, the ratio to physics alone in
    brackets."""
    lines: list[str] = []
    for data in files:
        rates = data["steps_per_second"]
        # the rates are the numbers; the nested objects (ratios, added time) are derived
        first = next(iter(rates.values()))
        modes = [m for m, value in first.items() if not isinstance(value, dict)]
        lines += _head(["env", *modes])
        for env, entry in rates.items():
            ratio = entry.get("ratio to physics", {})
            cells = [
                f"{entry[m]:.0f}" + (f" ({ratio[m]:.2f})" if m in ratio and ratio[m] != 1 else "")
                for m in modes
            ]
            lines.append(_row([f"`{env.removeprefix('sfa_gym/')}`", *cells]))
    return "\n".join(lines)


def outdoor_cost_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Milliseconds per env step and each row's ratio to its reference: the static
    ``paper_sim`` (``eval/benchmarks/bench_outdoor.py``) or the flat env of its pair
    (``eval/benchmarks/bench_textures.py``)."""
    lines = _head(["env, 600 x 60", "ms per step", "ratio"])
    for data in files:
        for name, row in data["rows"].items():
            lines.append(_row([name, f"{row['ms_per_step']:.1f}", f"{row['ratio']:.2f}"]))
    return "\n".join(lines)


def textures_build_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """CPU seconds to build the outdoor world and to construct its env, flat and textured
    (``eval/benchmarks/bench_textures.py``)."""
    lines = _head(["paper_outdoor", "build_world (CPU s)", "env construction (CPU s)"])
    for data in files:
        for name, row in data["build"].items():
            cells = [f"{row['build_world_s']:.3f}", f"{row['env_construction_s']:.3f}"]
            lines.append(_row([name, *cells]))
    return "\n".join(lines)


def image_statistics_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The amplitude spectrum's slope and the local contrast's percentiles of each world and
    camera (``eval/studies/image_statistics.py``)."""
    scale = files[0].get("sharp_scale", "-") if files else "-"
    sharp = f"alpha, {scale}x sharper (the world's own)"
    lines = _head(["world, camera", "alpha", sharp, "local contrast: 10 %", "median", "90 %"])
    for data in files:
        for name, view in data["views"].items():
            p = view["contrast_percentiles"]
            fine = view.get("alpha_sharp")
            cells = [f"{view['alpha']:.2f}", "-" if fine is None else f"{fine:.2f}"]
            lines.append(_row([name, *cells, p["10"], p["50"], p["90"]]))
    return "\n".join(lines)


def appearance_change_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Per appearance track and condition, the mean grey-level change of a panorama at a fixed
    pose, that over the study's distance, and their ratio (``eval/studies/appearance_change.py``);
    option ``conditions=a,b``: those conditions only."""
    lines = _head(["track", "condition", "fixed pose", "moved", "ratio", "pose offset (cm)"])
    chosen = _split(options.get("conditions"))
    for data in files:
        for result in data["results"]:
            for condition, row in result["conditions"].items():
                if chosen and condition not in chosen:
                    continue
                cells = [f"{row['fixed_pose']:.2f}", f"{result['moved']:.2f}"]
                cells += [f"{row['ratio']:.2f}", f"{100 * row['pose_offset_max_m']:.1f}"]
                lines.append(_row([result["track"], condition, *cells]))
    return "\n".join(lines)


_SFA_RUNS = (
    ("views along a smooth path, ours", ("ours",)),
    ("views along a smooth path, MDP", ("mdp",)),
    ("rotated views, ours, rotation shortcut", ("rotations", "ours")),
    ("rotated views, ours, every view", ("rotations", "ours_views")),
    ("rotated views, MDP", ("rotations", "mdp")),
    ("paper_outdoor scale, ours, rotation shortcut", ("paper",)),
)


def sfa_engine_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """SFA training against MDP (``eval/benchmarks/bench_sfa.py``): training views, training time
    per view, peak memory and inference time of each run the file holds."""
    lines = _head(["run", "views", "training ms per view", "peak GB", "inference ms (batch)"])
    for data in files:
        for label, path in _SFA_RUNS:
            run: Any = data
            for key in path:
                run = run.get(key) if isinstance(run, dict) else None
            if not run:
                continue
            per_view = 1000 * run["fit_seconds"] / run["n_training_views"]
            infer = run.get("infer_ms_batch")
            cells = [
                label,
                run["n_training_views"],
                f"{per_view:.3g}",
                f"{run['peak_rss_mb'] / 1024:.2f}",
                "-" if infer is None else f"{infer:.2f}",
            ]
            lines.append(_row(cells))
    return "\n".join(lines)


def leaderboard_timings_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """Wall time of the leaderboard (``eval/benchmarks/bench_leaderboard.py``) for ``part=quick``
    (each quick track, one method, cold cache), ``part=full`` (one task per full-size track,
    times its world seeds) or ``part=ray`` (the same tasks on 1 and 2 Ray workers)."""
    part = options.get("part", "quick")
    key = {"quick": "quick_board", "full": "full_size", "ray": "ray"}.get(part)
    if key is None:
        raise ValueError(f"leaderboard-timings: part={part!r}; expected quick, full or ray")
    data = _one_with(files, key, "leaderboard-timings")
    if part == "ray":
        lines = _head(["local Ray", "wall time s", "sum of the tasks' own times s"])
        for run in data["runs"]:
            cells = [
                f"{run['num_cpus']} CPU",
                f"{run['seconds']:.1f}",
                f"{run['task_seconds_sum']:.1f}",
            ]
            lines.append(_row(cells))
        first, *rest = data["runs"]
        for run in rest:
            speedup = first["seconds"] / run["seconds"]
            lines.append(_row([f"speed-up at {run['num_cpus']} CPUs", f"{speedup:.2f}x", ""]))
        return "\n".join(lines)
    if part == "quick":
        lines = _head([f"quick track, {data['method']}", "wall time s", "of which rendering s"])
        for t in data["tracks"]:
            cells = [f"{t['seconds']:.1f}", f"{t['render_seconds']:.1f}"]
            lines.append(_row([f"`{t['track']}`", *cells]))
        lines.append(_row(["every track", f"{data['seconds']:.0f}", ""]))
        return "\n".join(lines)
    lines = _head(
        [f"full-size track, {data['method']}", "one world seed s", "of which rendering s"]
        + ["world seeds", "track min"]
    )
    for t in data["tracks"]:
        cells = [f"{t['seconds']:.0f}", f"{t['render_seconds']:.0f}", t["world_seeds"]]
        lines.append(_row([f"`{t['track']}`", *cells, f"{t['estimated_track_seconds'] / 60:.1f}"]))
    hours = data["estimated_board_seconds"] / 3600
    lines.append(_row(["the full board, one method", "", "", "", f"{hours:.1f} h"]))
    return "\n".join(lines)


def _wall_cell(row: dict[str, Any] | None) -> str:
    """A track's wall minutes in the several-methods board-time table."""
    if row is None:
        return "-"
    return "covered" if not row["tasks"] else f"{row['wall_minutes']:.1f}"


def board_time_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """A whole sweep's time per track (``eval/benchmarks/board_time.py``). One file: when each
    track's tasks ran (minutes from the sweep's start), its wall span and task seconds, the
    tasks scored with another track's (``covered``). Several files (one per method): each
    track's wall minutes, a column per method, and each whole board's."""
    for data in files:
        if "tracks" not in data or "wall_minutes" not in data:
            raise ValueError("board-time: expected a file of eval/benchmarks/board_time.py")
    if len(files) > 1:
        methods = [data["method"] for data in files]
        tracks = list(dict.fromkeys(row["track"] for data in files for row in data["tracks"]))
        spans = [{row["track"]: row for row in data["tracks"]} for data in files]
        lines = _head(["track: wall min", *methods])
        for t in tracks:
            lines.append(_row([f"`{t}`", *(_wall_cell(found.get(t)) for found in spans)]))
        total = [f"**{data['wall_minutes']:.1f}**" for data in files]
        lines.append(_row(["**the whole board**", *total]))
        return "\n".join(lines)
    (data,) = files
    columns = ["from min", "to min", "wall min", "task s", "of which render s", "covered"]
    lines = _head(["track", *columns])
    render = 0.0
    for row in data["tracks"]:
        ran = row["tasks"] > 0
        render += row["phases"]["render"]
        cells = [
            f"{row['from_minutes']:.1f}" if ran else "-",
            f"{row['to_minutes']:.1f}" if ran else "-",
            f"{row['wall_minutes']:.1f}",
            f"{row['task_seconds']:.0f}",
            f"{row['phases']['render']:.0f}",
            row["covered"] or "",
        ]
        lines.append(_row([f"`{row['track']}`", *cells]))
    total = [f"**{data['wall_minutes']:.1f}**", f"{data['task_seconds']:.0f}", f"{render:.0f}", ""]
    lines.append(_row([f"**the whole board, {data['method']}**", "", "", *total]))
    cpus = data["machine"]["cpus"]
    floor = f"{render / cpus / 60:.1f}"
    lines.append(_row([f"rendering alone, spread over {cpus} cores", "", "", floor, "", "", ""]))
    return "\n".join(lines)


def _one_with(files: Sequence[dict[str, Any]], key: str, name: str) -> dict[str, Any]:
    """The ``key`` entry of the one file that has it."""
    found = [data[key] for data in files if key in data]
    if len(found) != 1:
        raise ValueError(f"{name}: expected one file with {key!r}, found {len(found)}")
    return found[0]


_CAMERAS = {
    "compass": "compass views (the camera)",
    "rover": "views turning with the rover (version 0.1)",
    "reference": "reference: 8 compass views, 4x supersampling",
}


def _spread(values: Sequence[float]) -> str:
    low, high = min(values), max(values)
    return f"{low:.1f}" if f"{low:.1f}" == f"{high:.1f}" else f"{low:.1f}-{high:.1f}"


def equivariance_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The camera's rotation equivariance (``eval/studies/camera_equivariance.py``).

    ``part=pixels``: per camera and panorama size, the error of a turned panorama shifted back
    (worst row / whole panorama, grey levels, the lowest-highest over the turns), for turns by
    whole columns and by fractions of a column. ``part=wobble``: the rotation-averaged
    features' wobble over headings, median (max) over the positions, averaged over the views
    every 5 columns and over every column.
    """
    data = _one_with(files, "pixels", "equivariance")
    part = options.get("part", "pixels")
    if part == "wobble":
        wobble = _one_with(files, "wobble", "equivariance")
        lines = _head(["camera", "views every 5 columns", "every column (step 1)"])
        for camera, steps in wobble.items():
            cells = [
                f"{steps[s]['median']:.2f} ({steps[s]['max']:.2f})" for s in ("step_5", "step_1")
            ]
            lines.append(_row([_CAMERAS.get(camera, camera), *cells]))
        return "\n".join(lines)
    if part != "pixels":
        raise ValueError(f"equivariance: part={part!r}; expected pixels or wobble")
    sizes = list(data)
    head = ["camera"]
    for kind in ("whole columns", "fractions of a column"):
        head += [f"{kind}, {size}" for size in sizes]
    lines = _head(head)
    cameras = list(dict.fromkeys(c for size in sizes for c in data[size]["cameras"]))
    for camera in cameras:
        cells = []
        for whole in (True, False):
            for size in sizes:
                turns = data[size]["headings"]
                found = data[size]["cameras"].get(camera)
                if found is None:
                    cells.append("-")
                    continue
                picked = [i for i, k in enumerate(turns) if (k == int(k)) == whole]
                worst = [found["worst_row"][i] for i in picked]
                mean = [found["mean"][i] for i in picked]
                cells.append(f"{_spread(worst)} / {_spread(mean)}")
        lines.append(_row([_CAMERAS.get(camera, camera), *cells]))
    return "\n".join(lines)
