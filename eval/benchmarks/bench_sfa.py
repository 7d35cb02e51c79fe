"""Benchmark: our hierarchical SFA engine against MDP 3.6, and the paper's outdoor scale.

Part 1, same architecture and data for both: the ``paper_sim`` preset (four layers) trained on
``--frames`` views of 40 x 350 along a smooth path (seeded synthetic panoramas of
:mod:`eval.synthetic`, or rendered by the env with ``--rendered``); per backend: training
time per frame, peak memory, inference time per panorama, and the agreement of the eight slow
features on held-out views (|corr| per output, and the canonical correlations of the two 8-d
feature spaces).

Part 1b, the paper's training data: ``--rotation-locations`` panoramas of 40 x 350 along a
smooth path, each seen in all its 70 rotated views (5 px steps), in the paper's order (all views
of one location, then the next). MDP has no rotation shortcut: it trains on the materialised
views (``MDPHierarchicalSFA.fit_rotations``). Ours trains twice: with
``HierarchicalSFA.fit_rotations`` (the rotation shortcut, the way this library trains on
rotated views) and with ``fit`` on the same materialised views (the general path). Same
measurements as part 1, per training view.

Part 2, the paper's outdoor scale with our engine only: the ``paper_outdoor`` preset trained
by ``HierarchicalSFA.fit_rotations`` on ``--locations`` panoramas of 60 x 600 (synthetic,
seeded, or rendered) x 120 rotation windows (5 px steps): training time and peak memory.

Every measurement runs in its own child process, so that each peak resident set size
(``ru_maxrss`` of that process) belongs to one backend; the data is written once to a
temporary directory and loaded by the children (their RSS right after loading is reported as
the baseline). The machine may be shared: times are wall-clock and noisy.

Backs docs/speed.md.

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_sfa                               # full: 3000 / 5900
    .venv/bin/python -m eval.benchmarks.bench_sfa --frames 200 --test-frames 50 --locations 40 \
        --rotation-locations 4  # smoke

Writes ``published/benchmarks/bench_sfa.json`` (``--json``) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from eval.synthetic import landmark_panoramas, smooth_path
from sfa_gym.files import write_json_atomic

ROOT = Path(__file__).resolve().parents[2]

N_OUTPUTS = 8
LAYER_VIEWS = 50
"""Held-out views whose outputs are compared layer by layer."""
TARGETS = {
    "speedup_vs_mdp_min": 20.0,
    "paper_scale_seconds_max": 600.0,
    "paper_scale_peak_gb_max": 4.0,
    "inference_ms_per_panorama_max": 2.0,
}


@dataclass(frozen=True)
class BenchConfig:
    """What to run.

    Attributes:
        frames: training views (40 x 350) for the comparison with MDP.
        test_frames: held-out views for inference timing and feature agreement.
        locations: panoramas (60 x 600) for the paper-scale run (120 rotations each).
        rotation_locations: panoramas (40 x 350) for part 1b (70 rotated views each).
        rotation_step: rotation step in columns for the paper-scale run.
        seed: seed of the synthetic world and paths.
        rendered: render the views with the env instead of the synthetic world.
        mdp_batch: frames per MDP training chunk (its memory grows with it).
        mdp_rank_method: how MDP's SFA nodes treat near-singular covariances: ``"relative"``
            (default: drop the directions below our engine's relative rank tolerance, the same
            rule as ours, see ``mdp_bridge.build_mdp_network(rank_tol=...)``), or one of MDP's
            ``rank_deficit_method`` values: ``"none"`` (MDP's default; fails on singular
            covariances) or ``"auto"``/``"pca"`` (absolute threshold, and a pre-check that
            drops the slowest linear term behind every expansion). The paper-sim network's
            upper layers are strongly rank deficient (e.g. ~40 % of layer 3's inputs), and which
            near-null directions a node keeps changes the features above it: with another rule
            the two networks learn different (equally valid) features.
        mdp_blas_threads: ``OPENBLAS_NUM_THREADS`` for the MDP child (0: the library default,
            all cores). Our engine sets BLAS to one thread itself and runs its own threads; on a
            machine shared with other processes, multi-threaded BLAS is much slower than one
            thread (see ``sfa_gym.sfa._parallel``), so ``1`` gives MDP its best case there.
        skip_mdp: run our engine only in parts 1 and 1b (no ratios).
        skip_rotations: skip part 1b.
        skip_paper: skip part 2.
        json_path: where to write the results.
    """

    frames: int = 3000
    test_frames: int = 500
    locations: int = 5900
    rotation_locations: int = 50
    rotation_step: int = 5
    seed: int = 0
    rendered: bool = False
    mdp_batch: int = 250
    mdp_rank_method: str = "relative"
    mdp_blas_threads: int = 0
    skip_mdp: bool = False
    skip_rotations: bool = False
    skip_paper: bool = False
    json_path: str = str(ROOT / "published" / "benchmarks" / "bench_sfa.json")


# -- data ---------------------------------------------------------------------------------------
def rendered_panoramas(
    env_id: str, poses: NDArray[np.floating], progress: bool = True
) -> NDArray[np.uint8]:
    """Panoramas rendered by the env at ``poses`` (unit-square path scaled to the arena)."""
    import gymnasium as gym
    from tqdm.auto import tqdm

    import sfa_gym  # noqa: F401  (registers the envs)

    env = gym.make(env_id)
    try:
        xmin, xmax, ymin, ymax = env.get_wrapper_attr("arena_bounds")
        cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
        hx, hy = 0.45 * (xmax - xmin), 0.45 * (ymax - ymin)
        out = None
        for i, (x, y, yaw) in enumerate(tqdm(poses, desc=f"render {env_id}", disable=not progress)):
            obs, _ = env.reset(seed=0, options={"pose": (cx + hx * x, cy + hy * y, float(yaw))})
            if out is None:
                out = np.empty((len(poses), *obs.shape), dtype=np.uint8)
            out[i] = obs
        return out
    finally:
        env.close()


def blas_cores() -> dict[str, str]:
    """OpenBLAS kernel in use by numpy's and scipy's bundled OpenBLAS (best effort).

    ``OPENBLAS_CORETYPE`` (set on some machines for old OpenBLAS builds) forces a kernel; an
    older kernel than the CPU supports makes every product slower, so the results record it.
    """
    import scipy
    import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS, so that threadpoolctl sees it)
    from threadpoolctl import threadpool_info

    cores = {}
    for lib in threadpool_info():
        for pkg in (np, scipy):
            here = os.path.dirname(lib["filepath"]) == os.path.dirname(pkg.__file__) + ".libs"
            if here and lib["internal_api"] == "openblas" and lib.get("architecture"):
                cores[pkg.__name__] = lib["architecture"]
    return cores


def _ours_rank_tol() -> float:
    """The relative rank tolerance our engine uses with its default settings."""
    from sfa_gym.sfa import HierarchicalSFA, network

    model = HierarchicalSFA([], progress=False)
    return model.rank_tol if model.rank_tol is not None else network.DEFAULT_RANK_TOL[model.dtype]


# -- child processes ----------------------------------------------------------------------------
def _rss_mb() -> float:
    """Peak resident set size of this process so far, MB (Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _inference(model: Any, views: NDArray[np.uint8]) -> tuple[NDArray[np.float64], float, float]:
    """Features of ``views``, ms per panorama in one batch, and ms for a single panorama."""
    model.transform(views[:2])  # warm-up (allocations, first-call overheads)
    t0 = time.perf_counter()
    y = model.transform(views)
    batch_ms = 1e3 * (time.perf_counter() - t0) / len(views)
    reps = min(20, len(views))
    t0 = time.perf_counter()
    for i in range(reps):
        model.transform(views[i : i + 1])
    single_ms = 1e3 * (time.perf_counter() - t0) / reps
    return y, batch_ms, single_ms


def _model(kind: str, mdp_batch: int, mdp_rank_method: str) -> tuple[Any, dict[str, Any]]:
    """The paper-sim network of one backend (``ours*`` or ``mdp*``) and its settings."""
    from sfa_gym.sfa import HierarchicalSFA, presets

    if kind.startswith("ours"):
        from sfa_gym.sfa._parallel import n_workers

        model = HierarchicalSFA(presets.paper_sim(), N_OUTPUTS, progress=False)
        settings = {
            "dtype": model.dtype,
            "memory_mb": model.memory_mb,
            "threads": n_workers(model.n_jobs),
        }
        return model, settings
    from sfa_gym.sfa.reference.mdp import MDPHierarchicalSFA

    relative = mdp_rank_method == "relative"
    model = MDPHierarchicalSFA(
        presets.paper_sim(),
        N_OUTPUTS,
        batch_size=mdp_batch,
        rank_deficit_method="none" if relative else mdp_rank_method,
        rank_tol=_ours_rank_tol() if relative else None,
        progress=False,
    )
    settings = {
        "dtype": "float64",
        "batch_size": mdp_batch,
        "rank_deficit_method": model.rank_deficit_method,
        "rank_tol": model.rank_tol,
        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
    }
    return model, settings


def _rotated_views(panoramas: NDArray[np.uint8], step: int) -> NDArray[np.uint8]:
    """All rotated views of each panorama, location by location (the paper's order)."""
    from sfa_gym.rotation import rotated_views

    return np.concatenate([rotated_views(p, step)[0] for p in panoramas])


def _child(
    kind: str, data_dir: Path, mdp_batch: int, mdp_rank_method: str, step: int
) -> dict[str, Any]:
    from sfa_gym.sfa import HierarchicalSFA, presets

    result: dict[str, Any] = {"kind": kind}
    if kind == "paper":
        panoramas = np.load(data_dir / "paper_panoramas.npy")
        result["rss_after_data_mb"] = _rss_mb()
        model = HierarchicalSFA(presets.paper_outdoor(), N_OUTPUTS, progress=False)
        t0, c0 = time.perf_counter(), time.process_time()
        model.fit_rotations(panoramas, step=step)
        result["fit_seconds"] = time.perf_counter() - t0
        result["fit_cpu_seconds"] = time.process_time() - c0
        result["fit_method"] = model.fit_method_
        result["n_training_views"] = model.n_training_views_
        result["peak_rss_after_fit_mb"] = _rss_mb()
        _, result["infer_ms_batch"], result["infer_ms_single"] = _inference(
            model, panoramas[: min(200, len(panoramas))]
        )
        result["delta_values"] = model.delta_values_.tolist()
        result["peak_rss_mb"] = _rss_mb()
        return result
    test = np.load(data_dir / "test.npy")
    model, result["settings"] = _model(kind, mdp_batch, mdp_rank_method)
    views = None  # the materialised rotated views of part 1b, made once where needed
    if "-rot" in kind:  # part 1b: the rotated views of each location
        panoramas = np.load(data_dir / "rot_panoramas.npy")
        n_train = panoramas.shape[0] * (panoramas.shape[2] // step)
        if kind == "ours-rot-views":
            views = _rotated_views(panoramas, step)
            fit = partial(model.fit, views)
        else:
            fit = partial(model.fit_rotations, panoramas, step=step)
    else:
        train = np.load(data_dir / "train.npy")
        n_train = len(train)
        fit = partial(model.fit, train)
    result["rss_after_data_mb"] = _rss_mb()
    t0, c0 = time.perf_counter(), time.process_time()
    fit()
    result["fit_seconds"] = time.perf_counter() - t0
    result["fit_cpu_seconds"] = time.process_time() - c0
    result["fit_ms_per_frame"] = 1e3 * result["fit_seconds"] / n_train
    result["n_training_views"] = n_train
    if hasattr(model, "fit_method_"):
        result["fit_method"] = model.fit_method_
    result["peak_rss_after_fit_mb"] = _rss_mb()
    y, result["infer_ms_batch"], result["infer_ms_single"] = _inference(model, test)
    np.save(data_dir / f"features_{kind}.npy", y)
    if "-rot" in kind:  # also on every 7th training view
        if views is None:  # made after the fit, so that its memory is not counted there
            views = _rotated_views(panoramas, step)
        y_train = model.transform(views[::7])
        np.save(data_dir / f"train_features_{kind}.npy", y_train)
    n_layers = len(presets.paper_sim())
    grids = {
        f"layer{i}": np.asarray(model.forward(test[:LAYER_VIEWS], i), dtype=np.float32)
        for i in range(1, n_layers + 1)
    }
    np.savez(data_dir / f"layers_{kind}.npz", **grids)
    result["delta_values"] = np.asarray(model.delta_values_).tolist()
    result["peak_rss_mb"] = _rss_mb()
    return result


def _run_child(kind: str, data_dir: Path, cfg: BenchConfig) -> dict[str, Any]:
    cmd = [
        sys.executable,
        "-m",
        "eval.benchmarks.bench_sfa",
        "--_child",
        kind,
        "--_data",
        str(data_dir),
        "--mdp-batch",
        str(cfg.mdp_batch),
        "--mdp-rank-method",
        cfg.mdp_rank_method,
        "--rotation-step",
        str(cfg.rotation_step),
    ]
    env = dict(os.environ)
    if kind.startswith("mdp") and cfg.mdp_blas_threads:
        env["OPENBLAS_NUM_THREADS"] = str(cfg.mdp_blas_threads)
    print(f"[{kind}] running in a child process ...", flush=True)
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env, cwd=ROOT)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"the {kind!r} child failed:\n{proc.stderr[-4000:]}")
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    # the machine may be shared: the 1-minute load average before and after the child
    result["load_average"] = [round(load_before, 2), round(os.getloadavg()[0], 2)]
    print(
        f"[{kind}] fit {result['fit_seconds']:.1f} s, "
        f"peak RSS {result['peak_rss_after_fit_mb']:.0f} MB "
        f"(child process {elapsed:.0f} s)",
        flush=True,
    )
    return result


# -- comparison ---------------------------------------------------------------------------------
def feature_agreement(a: NDArray[np.floating], b: NDArray[np.floating]) -> dict[str, list[float]]:
    """|corr| of matching outputs and canonical correlations of the two feature spaces."""
    k = a.shape[1]
    corr = np.abs(np.corrcoef(a.T, b.T)[:k, k:].diagonal())
    qa, _ = np.linalg.qr(a - a.mean(0))
    qb, _ = np.linalg.qr(b - b.mean(0))
    canon = np.linalg.svd(qa.T @ qb, compute_uv=False)
    return {"abs_corr": corr.round(5).tolist(), "canonical_corr": canon.round(5).tolist()}


def layer_agreement(a_path: Path, b_path: Path) -> dict[str, dict[str, float]]:
    """Per layer: |corr| of each output channel of the two networks over all nodes and views
    (min and median over channels)."""
    out = {}
    with np.load(a_path, allow_pickle=False) as a, np.load(b_path, allow_pickle=False) as b:
        for name in a.files:
            x, y = a[name].astype(np.float64), b[name].astype(np.float64)
            k = x.shape[-1]
            x, y = x.reshape(-1, k), y.reshape(-1, k)
            corr = np.abs(np.corrcoef(x.T, y.T)[:k, k:].diagonal())
            out[name] = {
                "min": round(float(corr.min()), 5),
                "median": round(float(np.median(corr)), 5),
            }
    return out


_ROWS = (
    ("train ms / view", "fit_ms_per_frame", ".2f"),
    ("train total s", "fit_seconds", ".1f"),
    ("train CPU s (all threads)", "fit_cpu_seconds", ".1f"),
    ("peak RSS during fit MB", "peak_rss_after_fit_mb", ".0f"),
    ("RSS after data MB", "rss_after_data_mb", ".0f"),
    ("infer ms / panorama (batch)", "infer_ms_batch", ".3f"),
    ("infer ms (single panorama)", "infer_ms_single", ".2f"),
)


def _comparison(columns: list[tuple[str, dict[str, Any]]], mdp: dict[str, Any] | None) -> list[str]:
    """Rows of :data:`_ROWS` for our runs ``columns`` and MDP's, with MDP / ours ratios."""
    head = ["quantity", *(name for name, _ in columns)]
    if mdp:
        head += ["MDP", *(f"MDP / {name}" for name, _ in columns)]
    rows = [head]
    for label, key, fmt in _ROWS:
        row = [label, *(format(r[key], fmt) for _, r in columns)]
        if mdp:
            row.append(format(mdp[key], fmt))
            row += [f"{mdp[key] / r[key]:.1f}x" if r[key] > 0 else "-" for _, r in columns]
        rows.append(row)
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]


def _agreement_lines(agreement: dict[str, Any], indent: str = "") -> list[str]:
    lines = [
        f"{indent}|corr| per output:    {agreement['abs_corr']}",
        f"{indent}canonical corr:       {agreement['canonical_corr']}",
    ]
    for name, stats in agreement.get("per_layer", {}).items():
        lines.append(
            f"{indent}{name} channels |corr|: min {stats['min']}, median {stats['median']}"
        )
    if "training_views" in agreement:
        lines.append(f"{indent}on training views:")
        lines += _agreement_lines(agreement["training_views"], indent + "  ")
    return lines


def _table(results: dict[str, Any]) -> str:
    lines: list[str] = []
    if "ours" in results:
        n = results["ours"]["n_training_views"]
        lines.append(f"part 1: {n} views 40x350 along a smooth path (fit)")
        lines += _comparison([("ours", results["ours"])], results.get("mdp"))
        if "agreement" in results:
            lines += _agreement_lines(results["agreement"])
    rot = results.get("rotations")
    if rot:
        n = rot["ours"]["n_training_views"]
        lines.append(
            f"part 1b: {n} rotated views 40x350 ({results['config']['rotation_locations']} "
            "locations x all rotations, the paper's order)"
        )
        columns = [("ours shortcut", rot["ours"]), ("ours views", rot["ours_views"])]
        lines += _comparison(columns, rot.get("mdp"))
        lines.append("shortcut vs the general path on the materialised views (held-out views):")
        lines += _agreement_lines(rot["agreement_views"], "  ")
        if "agreement" in rot:
            lines.append("shortcut vs MDP (held-out views):")
            lines += _agreement_lines(rot["agreement"], "  ")
            lines.append("general path vs MDP (held-out views):")
            lines += _agreement_lines(rot["agreement_views_mdp"], "  ")
    loads = {k: results[k]["load_average"] for k in ("ours", "mdp", "paper") if k in results}
    if rot:
        loads |= {f"rot {k}": r["load_average"] for k, r in rot.items() if "load_average" in r}
    if loads:
        lines.append(f"load average (1 min) before/after each run, {os.cpu_count()} CPUs: {loads}")
    paper = results.get("paper")
    if paper:
        lines.append(
            f"paper scale ({paper['n_training_views']} views 60x600, {paper['fit_method']}): "
            f"fit {paper['fit_seconds']:.1f} s (CPU {paper['fit_cpu_seconds']:.0f} s), "
            f"peak RSS {paper['peak_rss_after_fit_mb']:.0f} MB "
            f"(data {paper['rss_after_data_mb']:.0f} MB), "
            f"infer {paper['infer_ms_batch']:.2f} ms / 600x60 panorama"
        )
    return "\n".join(lines)


def _speedup_met(ours: dict[str, Any], mdp: dict[str, Any]) -> bool:
    return mdp["fit_ms_per_frame"] / ours["fit_ms_per_frame"] >= TARGETS["speedup_vs_mdp_min"]


def _checks(results: dict[str, Any]) -> dict[str, bool]:
    checks = {}
    ours, mdp, paper = results.get("ours"), results.get("mdp"), results.get("paper")
    rot = results.get("rotations", {})
    if ours and mdp:
        checks["speedup_vs_mdp"] = _speedup_met(ours, mdp)
    if "mdp" in rot:
        checks["speedup_vs_mdp_rotations"] = _speedup_met(rot["ours"], rot["mdp"])
        checks["speedup_vs_mdp_rotated_views_general_path"] = _speedup_met(
            rot["ours_views"], rot["mdp"]
        )
    if ours:
        checks["inference_ms"] = ours["infer_ms_batch"] <= TARGETS["inference_ms_per_panorama_max"]
    if paper:
        checks["paper_scale_time"] = paper["fit_seconds"] <= TARGETS["paper_scale_seconds_max"]
        checks["paper_scale_memory"] = (
            paper["peak_rss_after_fit_mb"] / 1024 <= TARGETS["paper_scale_peak_gb_max"]
        )
    return checks


def _agreement(data_dir: Path, a: str, b: str) -> dict[str, Any]:
    """Feature and per-layer agreement of the runs ``a`` and ``b`` on the held-out views, and
    (part 1b) on training views."""
    out: dict[str, Any] = feature_agreement(
        np.load(data_dir / f"features_{a}.npy"), np.load(data_dir / f"features_{b}.npy")
    )
    out["per_layer"] = layer_agreement(data_dir / f"layers_{a}.npz", data_dir / f"layers_{b}.npz")
    train_a, train_b = (data_dir / f"train_features_{k}.npy" for k in (a, b))
    if train_a.exists() and train_b.exists():
        out["training_views"] = feature_agreement(np.load(train_a), np.load(train_b))
    return out


def _panoramas(poses: NDArray[np.floating], size: tuple[int, int], seed: int, cfg: BenchConfig,
               progress: bool) -> NDArray[np.uint8]:  # fmt: skip
    """Panoramas ``size = (height, width)`` at ``poses``: rendered by the env or synthetic."""
    if cfg.rendered:
        env_id = {(40, 350): "sfa_gym/OmniRover-v0", (60, 600): "sfa_gym/OmniRoverOutdoorCam-v0"}
        return rendered_panoramas(env_id[size], poses, progress)
    return landmark_panoramas(poses, *size, seed, progress=progress)


def run(cfg: BenchConfig, progress: bool = True) -> dict[str, Any]:
    """Run the benchmark (see the module docstring); returns the JSON-able results."""
    results: dict[str, Any] = {
        "config": asdict(cfg),
        "targets": TARGETS,
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "blas_core": blas_cores(),
            "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
        },
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
    }
    with tempfile.TemporaryDirectory(prefix="bench_sfa_") as tmp:
        data_dir = Path(tmp)
        t0 = time.perf_counter()
        poses = smooth_path(cfg.frames + cfg.test_frames, cfg.seed)
        # test views: a second path, a held-out stretch of the same world
        test_poses = smooth_path(cfg.test_frames, cfg.seed + 100)
        views = _panoramas(np.r_[poses[: cfg.frames], test_poses], (40, 350), cfg.seed, cfg,
                           progress)  # fmt: skip
        np.save(data_dir / "train.npy", views[: cfg.frames])
        np.save(data_dir / "test.npy", views[cfg.frames :])
        results["data_seconds"] = time.perf_counter() - t0
        del views
        results["ours"] = _run_child("ours", data_dir, cfg)
        if not cfg.skip_mdp:
            results["mdp"] = _run_child("mdp", data_dir, cfg)
            results["agreement"] = _agreement(data_dir, "ours", "mdp")
        if not cfg.skip_rotations:
            loc_poses = smooth_path(cfg.rotation_locations, cfg.seed + 300)
            pan = _panoramas(loc_poses, (40, 350), cfg.seed + 300, cfg, progress)
            np.save(data_dir / "rot_panoramas.npy", pan)
            del pan
            rot = {
                "ours": _run_child("ours-rot", data_dir, cfg),
                "ours_views": _run_child("ours-rot-views", data_dir, cfg),
                "agreement_views": _agreement(data_dir, "ours-rot", "ours-rot-views"),
            }
            if not cfg.skip_mdp:
                rot["mdp"] = _run_child("mdp-rot", data_dir, cfg)
                rot["agreement"] = _agreement(data_dir, "ours-rot", "mdp-rot")
                rot["agreement_views_mdp"] = _agreement(data_dir, "ours-rot-views", "mdp-rot")
            results["rotations"] = rot
        if not cfg.skip_paper:
            loc_poses = smooth_path(cfg.locations, cfg.seed + 200)
            pan = _panoramas(loc_poses, (60, 600), cfg.seed + 200, cfg, progress)
            np.save(data_dir / "paper_panoramas.npy", pan)
            del pan
            results["paper"] = _run_child("paper", data_dir, cfg)
    results["checks"] = _checks(results)
    return results


def main(argv: list[str] | None = None) -> int:
    # argparse here, tyro in the other scripts: the script runs itself again in child processes
    # (_run_child) with two options a user never sets; argparse.SUPPRESS hides them from --help
    # and still parses them, which tyro's suppressed fields do not.
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    d = BenchConfig()
    parser.add_argument("--frames", type=int, default=d.frames, help="training views 40x350")
    parser.add_argument("--test-frames", type=int, default=d.test_frames, help="held-out views")
    parser.add_argument("--locations", type=int, default=d.locations, help="60x600 panoramas")
    parser.add_argument(
        "--rotation-locations",
        type=int,
        default=d.rotation_locations,
        help="40x350 panoramas of part 1b (70 rotated views each)",
    )
    parser.add_argument("--rotation-step", type=int, default=d.rotation_step, help="columns")
    parser.add_argument("--seed", type=int, default=d.seed)
    parser.add_argument("--rendered", action="store_true", help="render views with the env")
    parser.add_argument("--mdp-batch", type=int, default=d.mdp_batch, help="MDP chunk (frames)")
    parser.add_argument(
        "--mdp-rank-method",
        default=d.mdp_rank_method,
        choices=["relative", "none", "auto", "pca", "reg", "svd", "ldl"],
        help="MDP's treatment of singular covariances (see BenchConfig)",
    )
    parser.add_argument(
        "--mdp-blas-threads",
        type=int,
        default=d.mdp_blas_threads,
        help="OPENBLAS_NUM_THREADS for the MDP child (0: library default)",
    )
    parser.add_argument("--skip-mdp", action="store_true", help="no MDP run (no ratios)")
    parser.add_argument("--skip-rotations", action="store_true", help="no rotated-views run")
    parser.add_argument("--skip-paper", action="store_true", help="no paper-scale run")
    parser.add_argument("--json", default=d.json_path, help="output JSON path")
    parser.add_argument("--no-progress", action="store_true")
    parser.add_argument("--_child", help=argparse.SUPPRESS)
    parser.add_argument("--_data", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args._child:
        print(
            json.dumps(
                _child(
                    args._child,
                    Path(args._data),
                    args.mdp_batch,
                    args.mdp_rank_method,
                    args.rotation_step,
                )
            )
        )
        return 0
    if args.mdp_blas_threads < 0:
        parser.error(f"--mdp-blas-threads must be >= 0, got {args.mdp_blas_threads}")
    for name in ("frames", "test_frames", "locations", "rotation_locations", "mdp_batch"):
        if getattr(args, name) < 2:
            parser.error(
                f"--{name.replace('_', '-')} must be at least 2, got {getattr(args, name)}"
            )
    cfg = BenchConfig(
        frames=args.frames,
        test_frames=args.test_frames,
        locations=args.locations,
        rotation_locations=args.rotation_locations,
        rotation_step=args.rotation_step,
        seed=args.seed,
        rendered=args.rendered,
        mdp_batch=args.mdp_batch,
        mdp_rank_method=args.mdp_rank_method,
        mdp_blas_threads=args.mdp_blas_threads,
        skip_mdp=args.skip_mdp,
        skip_rotations=args.skip_rotations,
        skip_paper=args.skip_paper,
        json_path=args.json,
    )
    results = run(cfg, progress=not args.no_progress)
    print(_table(results))
    print("targets met:", results["checks"])
    print("BLAS kernel:", results["machine"]["blas_core"])
    path = Path(cfg.json_path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, results, indent=2)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
