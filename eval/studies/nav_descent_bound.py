"""Study: how far pure descent on a feature field's cost gets, without any controller.

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

Backs docs/navigation.md (false minima of the cost landscape, ideal slow features); its result
files are ``published/studies/nav_descent_bound_*.json`` (the command behind each is in
``published/README.md``).

Usage (from the repository root; the folder from ``sfa-gym navigate``)::

    .venv/bin/python -m eval.studies.nav_descent_bound --nav results/nav_obs --first-seed 1000 \\
        --episodes 200
    .venv/bin/python -m eval.studies.nav_descent_bound --nav results/nav_obs --radii 0 --ideal
"""

from __future__ import annotations

import heapq
import json
import math
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import tyro
from scipy.ndimage import gaussian_filter
from scipy.sparse import coo_matrix
from tqdm import tqdm

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.navigation.field import FeatureField
from sfa_gym.sfa.graph import laplacian_eigenmaps

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


def free_cell_graph(free: np.ndarray) -> coo_matrix:
    """The adjacency ``(n_free, n_free)`` of the grid graph of ``free`` cells (4 neighbours),
    the cells numbered as ``np.argwhere(free)`` lists them."""
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
    return (adjacency + adjacency.T).tocsc()


def ideal_features(field, free, points, k: int, power: float) -> dict[str, tuple]:
    """``name -> (features on the grid (ny, nx, m), weights (m,))`` of the ideal slow features
    (module docstring)."""
    # the slowest functions of a random walk confined to the free cells, and of one in the box
    confined, lam = laplacian_eigenmaps(free_cell_graph(free), k)
    box, lam_box = laplacian_eigenmaps(free_cell_graph(np.ones_like(free)), k)
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


@dataclass(frozen=True)
class Args:
    nav: Path
    """sfa-gym navigate output folder"""
    first_seed: int = 1000
    """first episode seed"""
    episodes: int = 200
    """episodes (seeds first_seed, first_seed + 1, ...)"""
    smooth: float = 0.3
    """metres (0: no smoothing)"""
    radii: tuple[float, ...] = (0.0, 0.3, 0.6, 1.0)
    """escape radii (m); 0: pure descent"""
    features: str = "sfa"
    """the folder's field_<features>.npz"""
    ideal: bool = False
    """also the ideal slow features (module docstring)"""
    components: int = 8
    """eigenfunctions in the ideal slow features"""
    json: Path | None = None
    """write the figures here"""


def main(args: Args) -> None:
    if args.episodes < 1 or args.smooth < 0 or min(args.radii, default=-1) < 0:
        raise SystemExit(
            f"--episodes must be >= 1, --smooth and --radii >= 0 (and one radius at least), "
            f"got {args.episodes}, {args.smooth}, {list(args.radii)}"
        )
    name = f"field_{args.features}.npz"
    if not (args.nav / name).exists() or not (args.nav / "results.json").exists():
        raise SystemExit(f"{args.nav} holds no {name} and results.json of sfa-gym navigate")

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
        args.json.write_text(json.dumps({
            "nav": str(args.nav), "features": args.features, "first_seed": args.first_seed,
            "episodes": args.episodes, "smooth": args.smooth, "cell": CELL,
            "components": args.components if args.ideal else None,
            "reached": rows[args.features], "ideal": {k: v for k, v in rows.items()
                                                      if k != args.features},
        }, indent=1, allow_nan=False))  # fmt: skip


if __name__ == "__main__":
    main(tyro.cli(Args))
