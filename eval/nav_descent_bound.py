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

``--ideal`` adds what ideal slow features would give: the ``k`` slowest eigenfunctions of the
Laplacian of the free cells' grid graph (a random walk confined to the free space; the slowest
functions SFA could find from such a walk without a restricted function class, weighted by their
eigenvalues to the same power as the field's cost), those of the whole box ignoring obstacles
and walls (what a training order that jumps across them teaches), and the field's own features
projected onto the first set (their part that the ideal functions span). ``--features`` picks
another field of the folder (``sfa_graph`` after ``sfa-gym navigate --train-order walk``).

Usage (from the repository root; the folder from ``sfa-gym navigate``)::

    .venv/bin/python eval/nav_descent_bound.py --nav results/nav_obs --first-seed 1000 \\
        --episodes 200
    .venv/bin/python eval/nav_descent_bound.py --nav results/nav_obs --radii 0 --ideal
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
from scipy.sparse import coo_matrix, diags  # noqa: E402
from scipy.sparse.linalg import eigsh  # noqa: E402
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


def laplacian_eigenfunctions(free: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` slowest non-constant eigenfunctions ``(n_free, k)`` of the random-walk
    Laplacian ``(D - A) v = lambda D v`` of the grid graph of ``free`` cells (4 neighbours),
    and their eigenvalues ``(k,)``."""
    index = -np.ones(free.shape, dtype=np.int64)
    cells = np.argwhere(free)
    index[free] = np.arange(len(cells))
    rows, cols = [], []
    for dj, di in ((0, 1), (1, 0)):
        j, i = cells[:, 0] + dj, cells[:, 1] + di
        inside = (j < free.shape[0]) & (i < free.shape[1])
        both = np.zeros(len(cells), dtype=bool)
        both[inside] = free[j[inside], i[inside]]
        rows.append(index[cells[both, 0], cells[both, 1]])
        cols.append(index[j[both], i[both]])
    n = len(cells)
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    adjacency = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    adjacency = (adjacency + adjacency.T).tocsc()
    degree = diags(np.asarray(adjacency.sum(axis=1)).ravel()).tocsc()
    # shift-invert just below 0 finds the smallest; a fixed start vector keeps it deterministic
    values, vectors = eigsh(
        degree - adjacency, k=k + 1, M=degree, sigma=-1e-6, which="LM", v0=np.ones(n)
    )
    order = np.argsort(values)[1:]
    return vectors[:, order], values[order]


def ideal_features(field, free, points, k: int, power: float) -> dict[str, tuple]:
    """``name -> (features on the grid (ny, nx, m), weights (m,))`` of the ideal slow features
    (module docstring)."""
    confined, lam = laplacian_eigenfunctions(free, k)
    box, lam_box = laplacian_eigenfunctions(np.ones_like(free), k)
    out = {}
    grid = np.zeros(free.shape + (k,))
    grid[free] = confined
    out["laplacian_free"] = (grid.copy(), lam**-power)
    grid[:] = box.reshape(free.shape + (k,))
    out["laplacian_box"] = (grid.copy(), lam_box**-power)
    own = field(points[free.ravel()]).astype(np.float64)
    design = np.column_stack([np.ones(len(confined)), confined])
    coef, *_ = np.linalg.lstsq(design, own, rcond=None)
    projected = np.zeros(free.shape + (own.shape[1],))
    projected[free] = design @ coef
    out["projected"] = (projected, None)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nav", type=Path, required=True, help="sfa-gym navigate output folder")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--smooth", type=float, default=0.3, help="metres (0: no smoothing)")
    parser.add_argument("--radii", type=float, nargs="+", default=[0.0, 0.3, 0.6, 1.0],
                        help="escape radii (m); 0: pure descent")  # fmt: skip
    parser.add_argument("--features", default="sfa",
                        help="the folder's field_<features>.npz (default sfa)")  # fmt: skip
    parser.add_argument("--ideal", action="store_true",
                        help="also the ideal slow features (module docstring)")  # fmt: skip
    parser.add_argument("--components", type=int, default=8,
                        help="eigenfunctions in the ideal slow features")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args()
    if args.episodes < 1 or args.smooth < 0 or min(args.radii) < 0:
        parser.error("--episodes must be >= 1, --smooth and --radii >= 0")
    name = f"field_{args.features}.npz"
    if not (args.nav / name).exists() or not (args.nav / "results.json").exists():
        parser.error(f"{args.nav} holds no {name} and results.json of sfa-gym navigate")

    settings = json.loads((args.nav / "results.json").read_text())["settings"]
    field = FeatureField.load(args.nav / name)
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

    variants = {args.features: (features, weights)}
    if args.ideal:
        power = float(field.metadata["model_info"].get("weight_power", settings["weight_power"]))
        for key, (values, w) in ideal_features(field, free, points, args.components, power).items():
            variants[key] = (values, weights if w is None else w)
    reached = {(key, r): 0 for key in variants for r in args.radii}
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    for seed in tqdm(seeds, desc=f"descent {args.nav.name}"):
        obs, info = env.reset(seed=seed)
        start, goal = cell_of(info["start"]), cell_of(info["goal"])
        for key, (values, w) in variants.items():
            # the field's own cost is to the goal's features as the env gives them; the ideal
            # functions are read at the goal's cell
            target = obs["goal_features"] if key == args.features else values[goal]
            cost = np.sum(w * (values - target) ** 2, axis=-1)
            cost[~free] = np.inf
            for r in args.radii:
                reached[key, r] += descend(cost, free, start, goal, nav.success_radius / CELL, r)
    env.close()
    rows = {
        key: {f"{r:g}": reached[key, r] / args.episodes for r in args.radii} for key in variants
    }
    for key, by_radius in rows.items():
        for r, fraction in by_radius.items():
            print(f"{args.nav} {key} seeds {args.first_seed}+{args.episodes}, smooth "
                  f"{args.smooth:g} m, escape radius {r} m: reaches the goal in "
                  f"{fraction:.3f}")  # fmt: skip
    if args.json:
        write_json_atomic(args.json, {
            "nav": str(args.nav), "features": args.features, "first_seed": args.first_seed,
            "episodes": args.episodes, "smooth": args.smooth, "cell": CELL,
            "components": args.components if args.ideal else None,
            "reached": rows[args.features], "ideal": {k: v for k, v in rows.items()
                                                      if k != args.features},
        })  # fmt: skip


if __name__ == "__main__":
    main()
