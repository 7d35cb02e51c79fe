"""Benchmark: how far pure descent on a feature field's cost gets, without any controller.

For each episode (start and goal from ``env.reset(seed)``) the cost ``sum_i w_i (f_i - g_i)^2``
of the SFA feature field that ``sfa-gym navigate`` wrote is laid on a grid of the free cells
(0.05 m), the features first smoothed over the free cells (Gaussian, ``--smooth`` metres: the
gradient controller's local fit smooths over about 0.3 m of path). Steepest descent over the
8 neighbours runs from the start; where it stops in a minimum farther than the success radius
from the goal, a descent with escape radius ``r`` may look through the free cells up to ``r``
metres around for a lower cost and go on from the lowest one. The fraction of episodes that
end within the success radius says how much of a world's failures is the cost landscape (its
false minima) and how much is the controller.

Usage (from the repository root; the folder from ``sfa-gym navigate``)::

    .venv/bin/python eval/nav_descent_bound.py --nav results/nav_obs --first-seed 1000 \\
        --episodes 200
"""

from __future__ import annotations

import argparse
import heapq
import json
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
from scipy.ndimage import gaussian_filter  # noqa: E402
from tqdm import tqdm  # noqa: E402

import sfa_gym  # noqa: E402, F401  (registers the ids)
from sfa_gym._files import write_json_atomic  # noqa: E402
from sfa_gym.navigation.field import FeatureField  # noqa: E402

CELL = 0.05  # metres between the grid's cells
NEIGHBOURS = [(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)]


def smoothed_features(field: FeatureField, free: np.ndarray, points: np.ndarray, smooth: float):
    """Field features at ``points`` (on a grid of shape ``free.shape``), averaged with a
    Gaussian of ``smooth`` metres over the free cells only (walls do not leak in)."""
    features = field(points).reshape(free.shape + (-1,)).astype(np.float64)
    if smooth <= 0:
        return features
    mask = free.astype(np.float64)
    weight = gaussian_filter(mask, smooth / CELL)
    for k in range(features.shape[-1]):
        blurred = gaussian_filter(features[..., k] * mask, smooth / CELL)
        features[..., k] = np.where(weight > 1e-6, blurred / np.maximum(weight, 1e-6), 0.0)
    return features


def lower_cell_within(cost: np.ndarray, free: np.ndarray, cell: tuple[int, int], radius: float):
    """The lowest free cell within ``radius`` metres of ``cell`` through free cells (Dijkstra
    over the 8 neighbours), if its cost is below ``cost[cell]``; else None."""
    reached = {cell: 0.0}
    queue = [(0.0, cell)]
    best = cell
    while queue:
        d, (j, i) = heapq.heappop(queue)
        if d > reached[(j, i)]:
            continue
        if cost[j, i] < cost[best]:
            best = (j, i)
        for a, b in NEIGHBOURS:
            n = (j + a, i + b)
            if not (0 <= n[0] < free.shape[0] and 0 <= n[1] < free.shape[1] and free[n]):
                continue
            nd = d + CELL * math.hypot(a, b)
            if nd <= radius and nd < reached.get(n, math.inf):
                reached[n] = nd
                heapq.heappush(queue, (nd, n))
    return None if best == cell else best


def descend(cost, free, start, goal_cell, success_cells, radius):
    """True if steepest descent (with escapes of ``radius`` m) from ``start`` ends within
    ``success_cells`` cells of ``goal_cell``."""
    j, i = start
    for _ in range(cost.size):  # the cost falls at every move: no cell is visited twice
        lower = [
            (cost[j + a, i + b], (j + a, i + b))
            for a, b in NEIGHBOURS
            if 0 <= j + a < cost.shape[0] and 0 <= i + b < cost.shape[1] and free[j + a, i + b]
        ]
        value, nxt = min(lower, default=(math.inf, None))
        if value < cost[j, i]:
            j, i = nxt
            continue
        if math.hypot(j - goal_cell[0], i - goal_cell[1]) <= success_cells:
            return True
        nxt = lower_cell_within(cost, free, (j, i), radius) if radius > 0 else None
        if nxt is None:
            return False
        j, i = nxt
    return False


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nav", type=Path, required=True, help="sfa-gym navigate output folder")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--smooth", type=float, default=0.3, help="metres (0: no smoothing)")
    parser.add_argument("--radii", type=float, nargs="+", default=[0.0, 0.3, 0.6, 1.0],
                        help="escape radii (m); 0: pure descent")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    if args.episodes < 1 or args.smooth < 0 or min(args.radii) < 0:
        parser.error("--episodes must be >= 1, --smooth and --radii >= 0")
    if not (args.nav / "field_sfa.npz").exists() or not (args.nav / "results.json").exists():
        parser.error(f"{args.nav} holds no field_sfa.npz and results.json of sfa-gym navigate")

    settings = json.loads((args.nav / "results.json").read_text())["settings"]
    field = FeatureField.load(args.nav / "field_sfa.npz")
    weights = np.asarray(field.metadata["model_info"]["cost_weights"])
    env = gym.make(settings["env_id"], world_seed=settings["world_seed"], feature_field=field)
    nav = env.unwrapped
    xmin, xmax, ymin, ymax = nav.occupancy.bounds
    xs, ys = np.arange(xmin, xmax + 1e-9, CELL), np.arange(ymin, ymax + 1e-9, CELL)
    grid_x, grid_y = np.meshgrid(xs, ys)
    points = np.c_[grid_x.ravel(), grid_y.ravel()]
    free = nav.occupancy.is_free(points).reshape(grid_x.shape)
    features = smoothed_features(field, free, points, args.smooth)
    free_cells = np.argwhere(free)

    def cell_of(p):
        c = np.array([(p[1] - ymin) / CELL, (p[0] - xmin) / CELL])
        return tuple(free_cells[np.argmin(np.hypot(*(free_cells - c).T))])

    reached = {r: 0 for r in args.radii}
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    for seed in tqdm(seeds, desc=f"descent {args.nav.name}"):
        obs, info = env.reset(seed=seed)
        cost = np.sum(weights * (features - obs["goal_features"]) ** 2, axis=-1)
        cost[~free] = np.inf
        start, goal = cell_of(info["start"]), cell_of(info["goal"])
        for r in args.radii:
            reached[r] += descend(cost, free, start, goal, nav.success_radius / CELL, r)
    env.close()
    rows = {f"{r:g}": reached[r] / args.episodes for r in args.radii}
    for r, fraction in rows.items():
        print(f"{args.nav} seeds {args.first_seed}+{args.episodes}, smooth {args.smooth:g} m, "
              f"escape radius {r} m: reaches the goal in {fraction:.3f}")  # fmt: skip
    if args.json:
        write_json_atomic(args.json, {
            "nav": str(args.nav), "first_seed": args.first_seed, "episodes": args.episodes,
            "smooth": args.smooth, "cell": CELL, "reached": rows,
        })  # fmt: skip


if __name__ == "__main__":
    main()
