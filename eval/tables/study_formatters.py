"""Markdown tables of the studies' files whose rows are settings and whose cells are means over
world seeds with their 95 % intervals (:func:`sfa_gym.intervals.mean_entry`): the localization
studies (``eval/studies/paper_pipeline.py``, ``eval/studies/release_drift.py``,
``eval/studies/appearance_order.py``) and the outdoor world's item density
(``eval/studies/item_density.py``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from eval.tables.formatters import _head, _row

__all__ = [
    "appearance_order_table",
    "item_density_table",
    "paper_pipeline_table",
    "release_drift_table",
]


def _mean_cell(entry: dict[str, Any]) -> str:
    """``mean [lo, hi]``, or the mean alone when the entry has no interval."""
    ci = entry["interval"]
    return f"{entry['mean']:.2f}" + ("" if ci is None else f" [{ci[0]:.2f}, {ci[1]:.2f}]")


def paper_pipeline_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The paper's pipeline with one setting changed per row (``eval/studies/paper_pipeline.py``):
    MAE % (x, y) of linear and quadratic regression on the paper's splits, the mean over the
    world seeds with its 95 % interval, and the paper's figure."""
    lines = _head(["row", "change", "linear x", "linear y", "quadratic x", "quadratic y"])
    for data in files:
        paper = data["paper_mae_percent"]
        lines.append(_row(["paper", "Metka et al. 2013", paper[0], paper[1], "-", "-"]))
        for name, row in data["rows"].items():
            values = [_mean_cell(e) for e in (*row["linear"], *row["quadratic"])]
            lines.append(_row([f"`{name}`", row["change"], *values]))
    return "\n".join(lines)


_DRIFT_ROWS = (
    ("release", "release (`60d3351`)", "turn with the rover"),
    ("rover", "today", "turn with the rover"),
    ("compass", "today", "compass directions"),
)
_DRIFT_REGRESSIONS = {
    "map": "map decoder, penalty chosen",
    "map_plain": "map decoder, no penalty",
    "linear": "linear",
}


def release_drift_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """SFA and |FFT| on the trajectory protocol, the first release's code and camera against
    today's (``eval/studies/release_drift.py``): MAE % (x, y) on one part of the test run (option
    ``part``: ``visited``, the default, or ``excluded``), mean over the world seeds with its
    95 % interval. The release's map decoder had no penalty."""
    part = options.get("part", "visited")
    if part not in ("visited", "excluded"):
        raise ValueError(f"release-drift: part must be 'visited' or 'excluded', got {part!r}")
    lines = _head(["code", "views", "regression", "SFA x", "SFA y", "\\|FFT\\| x", "\\|FFT\\| y"])
    for data in files:
        for key, code, views in _DRIFT_ROWS:
            row = data["rows"].get(key)
            if row is None:
                continue
            for column, regression in _DRIFT_REGRESSIONS.items():
                if column not in row["sfa"]:
                    continue
                if key == "release" and column == "map":
                    regression = _DRIFT_REGRESSIONS["map_plain"]  # the release's own decoder
                cells = [
                    _mean_cell(e) for m in ("sfa", "fft_magnitude") for e in row[m][column][part]
                ]
                lines.append(_row([code, views, regression, *cells]))
    return "\n".join(lines)


_ORDER_ROWS = {
    "one": "the training run alone",
    "frames": "+ a run 3 h earlier, frame by frame",
    "rotations": "+ a run 3 h earlier, inside each frame's rotations",
}
_ORDER_REGRESSIONS = {"linear": "linear", "quadratic": "quadratic", "map": "map decoder"}


def appearance_order_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """SFA on the outdoor protocol trained on one run, or on two runs whose appearances meet
    frame by frame or inside each frame's rotations (``eval/studies/appearance_order.py``): MAE %
    (mean of x and y) per test condition and over the changed conditions, the mean over the
    world seeds with its 95 % interval, and SFA's largest variance over the headings of a
    place (``eta_phi``, mean over the worlds)."""
    lines: list[str] = []
    for data in files:
        conditions = data["conditions"]
        changed = [c for c in conditions if c != "after"]
        head = ["training", "regression", *conditions, "mean of " + ", ".join(changed)]
        lines += _head([*head, "max eta_phi"])
        for regression, label in _ORDER_REGRESSIONS.items():
            for setting, training in _ORDER_ROWS.items():
                row = data["rows"][setting]
                cells = [_mean_cell(row[regression][c]) for c in (*conditions, "changed_mean")]
                eta = row["max_eta_phi"]
                lines.append(_row([training, label, *cells, f"{eta['mean']:.4f}"]))
    return "\n".join(lines)


def item_density_table(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    """The outdoor world's spectrum slope and local contrast with its items' counts multiplied
    (``eval/studies/item_density.py``): per density the mean over the worlds with its 95 % interval,
    and the env step's time against the shipped density's."""
    lines = _head(["items", "alpha", "alpha, world's own", "median local contrast", "step x"])
    for data in files:
        for factor, row in data["rows"].items():
            cells = [_mean_cell(row["alpha"]), _mean_cell(row["alpha_sharp"])]
            cells += [f"{row['contrast_median']:.3f}", f"{row['step_ratio']:.2f}"]
            lines.append(_row([f"x {factor}", *cells]))
    return "\n".join(lines)
