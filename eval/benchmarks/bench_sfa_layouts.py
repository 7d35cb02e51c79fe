"""Benchmark: the board's SFA (one node per grid row) with its arrays laid out as the products
read them, against the layouts before (the natural ones, copied before each product), in the
same process.

Two changes, both without any change of a bit (checked here on the fitted models and features):

- training (``fit_rotations``): the features of a layer and their differences are formed in the
  group order of :mod:`sfa_gym.sfa._sources` where :func:`~sfa_gym.sfa._sources.groups` used to
  copy them into it;
- inference (``transform_rotations``): a row-shared layer copies each row's node inputs from
  the patch view once, instead of all rows and then each row again.

The reference path is the previous code, patched in for the timing. The board fits and
transforms with one thread per task, so both run with ``n_jobs=1``; CPU seconds, medians of
alternating repeats.

Usage (from the repository root; about 5 minutes)::

    env -u OPENBLAS_CORETYPE .venv/bin/python -m eval.benchmarks.bench_sfa_layouts
"""

from __future__ import annotations

import statistics
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro

import sfa_gym.sfa._rotation_source as rotation_source
import sfa_gym.sfa._sources as sources
import sfa_gym.sfa._training as training
from eval.synthetic import synthetic_panoramas
from sfa_gym.files import write_json_atomic
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.sfa import RankDeficiencyWarning
from sfa_gym.sfa._layers import LayerParams, layer_patches


@dataclass(frozen=True)
class Args:
    locations: int = 600
    """60 x 600 training panoramas (all 120 rotations of each)"""
    panoramas: int = 400
    """panoramas transformed per timing (60 x 600 at 5 columns; 40 x 350 at every column, as
    a navigation field)"""
    repeats: int = 2
    """alternating timings of each path"""
    out: Path = Path("published/benchmarks/sfa_layouts.json")


@contextmanager
def previous_layouts() -> Iterator[None]:
    """The code before: natural layouts (groups() copies), each row's inputs copied twice."""
    expand = sources.reduce_and_expand

    def natural(x: np.ndarray, sharing: str | None = None) -> np.ndarray:
        return np.moveaxis(x, -1, 0)

    def expanded(reduce: Any, x: np.ndarray, sharing: str | None = None) -> np.ndarray:
        return expand(reduce, x)

    def forward(
        self: LayerParams, a: np.ndarray, clip: Any, n_cols=None, col_stride=None, col_dilation=1
    ) -> np.ndarray:
        patches = layer_patches(self.spec, self.grid, a, n_cols, col_stride, col_dilation)
        return self.nodes(patches, clip)

    # every module that holds features_first: the rotation source compares the featurize it
    # is given with its own (the plain linear-SFA pass)
    saved = [
        (sources, "features_first", sources.features_first),
        (rotation_source, "features_first", rotation_source.features_first),
        (training, "features_first", training.features_first),
        (training, "reduce_and_expand", training.reduce_and_expand),
        (LayerParams, "forward", LayerParams.forward),
    ]
    sources.features_first = rotation_source.features_first = training.features_first = natural
    training.reduce_and_expand = expanded
    LayerParams.forward = forward
    try:
        yield
    finally:
        for owner, name, value in saved:
            setattr(owner, name, value)


def _timed(fn: Callable[[], Any]) -> tuple[float, Any]:
    start = time.process_time()
    out = fn()
    return time.process_time() - start, out


def _model_bytes(model: Any) -> bytes:
    parts = []
    for p in model.layer_params_:
        for affine in (p.reduce, p.expand):
            if affine is not None:
                parts += [affine.weight.tobytes(), affine.bias.tobytes(), affine.delta.tobytes()]
    return b"".join(parts)


def main(args: Args) -> None:
    if min(args.locations, args.panoramas, args.repeats) < 1:
        raise SystemExit(f"--locations, --panoramas and --repeats must be >= 1, got {args}")
    warnings.simplefilter("ignore", RankDeficiencyWarning)
    train = synthetic_panoramas(args.locations, 60, 600, 0)
    outdoor = synthetic_panoramas(args.panoramas, 60, 600, 1)
    field_train = synthetic_panoramas(200, 40, 350, 2)
    field = synthetic_panoramas(args.panoramas, 40, 350, 3)

    def fit(panoramas: np.ndarray) -> Any:
        method = SFASettings(network="auto").make_model(*panoramas.shape[1:3], False)
        method.n_jobs = 1
        return method.fit_rotations(panoramas, step=5)

    small = fit(field_train)
    jobs: dict[str, Callable[[], Any]] = {
        "fit_rotations, 60 x 600": lambda: fit(train),
        "transform_rotations, 60 x 600, step 5": lambda: model.transform_rotations(outdoor, 5),
        "transform_rotations, 40 x 350, step 1": lambda: small.transform_rotations(field, 1),
    }
    seconds: dict[str, dict[str, list[float]]] = {n: {"now": [], "before": []} for n in jobs}
    features: dict[str, np.ndarray] = {}
    model: Any = None
    for _ in range(args.repeats):
        for path in ("now", "before"):
            for name, job in jobs.items():
                with previous_layouts() if path == "before" else nullcontext():
                    spent, out = _timed(job)
                seconds[name][path].append(spent)
                if name.startswith("fit"):
                    if model is not None and _model_bytes(out) != _model_bytes(model):
                        raise SystemExit("the two layouts fitted different models")
                    model = out
                else:
                    if not np.array_equal(features.setdefault(name, out), out):
                        raise SystemExit(f"{name}: the two layouts gave different features")
    rows = {}
    for name, s in seconds.items():
        now, before = statistics.median(s["now"]), statistics.median(s["before"])
        rows[name] = {"cpu_s": now, "cpu_s_before": before, "ratio": now / before}
        print(f"{name:<40} {now:7.1f} CPU s, before {before:7.1f}  ratio {now / before:.2f}")
    write_json_atomic(
        args.out,
        {
            "locations": args.locations,
            "panoramas": args.panoramas,
            "repeats": args.repeats,
            "network": "auto (paper_outdoor / paper_sim), one node per row",
            "n_jobs": 1,
            "ratio_to": "before: natural layouts, each row's node inputs copied twice",
            "rows": rows,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
