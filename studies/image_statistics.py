"""Study: how natural do our worlds look? The amplitude spectrum's slope and the local contrast
of their panoramas (:mod:`sfa_gym.image_statistics`).

For each world and camera, ``--panoramas`` panoramas at seeded random poses (``env.reset(seed=
i)``, world seed 0); their grey levels' radially averaged amplitude spectrum is fitted by
``1/f^alpha`` (natural scenes: about 1.0; issue 35 asks for 0.9-1.2) and the RMS contrast of
their 8 x 8 patches is summarised by percentiles. The outdoor world is measured flat, with its
generated textures (``sfa_gym/OmniRoverOutdoorTextured-v0``) and textured with the sun's cast
shadows; the campus through both cameras. Every cylindrical view is also rendered at
:data:`SHARP` times its rows and columns and fitted over the same angles: that slope is the
world's own, without the blur of the camera's anti-aliasing at the finest fitted scales. Two
photographs measured the same way calibrate the yardstick at this size: scikit-learn's sample
images (a temple among trees, and a flower before a blurred background), cut into overlapping
strips of the panoramas' 1:10 aspect and shrunk to 60 x 600. Writes ``published/studies/
image_statistics.json`` and ``docs/image_statistics.png`` (the spectra, log-log, beside the
natural-image band).

Usage (from the repository root; a few minutes on 2 cores)::

    .venv/bin/python -m studies.image_statistics
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from sfa_gym.files import write_json_atomic
from sfa_gym.image_statistics import local_contrast, spectrum_slope

ROOT = Path(__file__).resolve().parents[1]

VIEWS: dict[str, tuple[str, dict[str, Any]]] = {
    "paper_sim, 40 x 350": ("sfa_gym/OmniRover-v0", {}),
    "paper_sim, 60 x 600": ("sfa_gym/OmniRoverOutdoorCam-v0", {}),
    "paper_sim_obstacles, 40 x 350": ("sfa_gym/OmniRover-v0", {"world": "paper_sim_obstacles"}),
    "paper_outdoor, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverOutdoor-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False},
    ),
    "paper_outdoor, mirror 60 x 600": ("sfa_gym/OmniRoverOutdoor-v0", {}),
    "paper_outdoor textured, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverOutdoorTextured-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False},
    ),
    "paper_outdoor textured, mirror 60 x 600": ("sfa_gym/OmniRoverOutdoorTextured-v0", {}),
    "paper_outdoor textured, cast shadows, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverOutdoorTextured-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False, "shadows": True},
    ),
    "paper_outdoor textured, cast shadows, mirror 60 x 600": (
        "sfa_gym/OmniRoverOutdoorTextured-v0",
        {"shadows": True},
    ),
    "paper_outdoor textured, cloud sky 0.4, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverOutdoorTextured-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False, "cloud_cover": 0.4},
    ),
    "campus, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverCampus-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False},
    ),
    "campus, mirror 60 x 600": ("sfa_gym/OmniRoverCampus-v0", {}),
    "campus, cloud sky 0.4, cylindrical 60 x 600": (
        "sfa_gym/OmniRoverCampus-v0",
        {"camera": "cylindrical", "mirror": None, "sensor": False, "cloud_cover": 0.4},
    ),
}
"""The worlds and cameras measured: an env id and its kwargs."""

PHOTOGRAPHS = {
    "photograph, temple and trees, 60 x 600 strips": "china.jpg",
    "photograph, flower, 60 x 600 strips": "flower.jpg",
}
"""Reference rows: scikit-learn's sample photographs (``sklearn.datasets.load_sample_image``)."""

SHARP = 4
"""The cylindrical views are rendered again at this many times their rows and columns, and
their slope fitted over the same angular frequencies: the world's own slope, without the
camera's anti-aliasing (its supersampling, box filter and resampling blur the finest
fitted scales of the panorama's own size)."""

NATURAL = (0.9, 1.2)
"""The band of ``alpha`` the worlds should reach (natural scenes: about 1.0)."""


@dataclass
class Args:
    panoramas: int = 24
    """panoramas per world and camera"""
    json: Path = ROOT / "published" / "studies" / "image_statistics.json"
    """where to write the figures"""
    png: Path = ROOT / "docs" / "image_statistics.png"
    """where to draw the spectra"""


def _panoramas(env_id: str, kwargs: dict[str, Any], n: int, scale: int = 1) -> np.ndarray:
    """``n`` panoramas at seeded random poses; ``scale`` > 1: the env's cylindrical panorama
    with ``scale`` times its rows and columns."""
    import dataclasses

    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the envs)

    if scale > 1:
        probe = gym.make(env_id, **kwargs)
        spec = probe.unwrapped.panorama
        probe.close()
        kwargs = {
            **kwargs,
            "panorama": dataclasses.replace(
                spec, width=spec.width * scale, height=spec.height * scale
            ),
        }
    env = gym.make(env_id, **kwargs)
    try:
        return np.stack([env.reset(seed=i)[0] for i in range(n)])
    finally:
        env.close()


def _cylindrical(env_id: str, kwargs: dict[str, Any]) -> bool:
    import gymnasium as gym

    return kwargs.get("camera", gym.spec(env_id).kwargs.get("camera", "cylindrical")) == (
        "cylindrical"
    )


def _strips(photo: str, shape: tuple[int, int] = (60, 600)) -> np.ndarray:
    """Strips of ``photo`` with the panoramas' aspect, half a strip apart, shrunk (box filter)
    to ``shape``."""
    import cv2
    from sklearn.datasets import load_sample_image

    image = load_sample_image(photo)
    rows = image.shape[1] * shape[0] // shape[1]
    starts = range(0, image.shape[0] - rows + 1, rows // 2)
    size = (shape[1], shape[0])
    return np.stack(
        [cv2.resize(image[y : y + rows], size, interpolation=cv2.INTER_AREA) for y in starts]
    )


def measure(n: int) -> dict[str, Any]:
    """``{view: {"alpha", "contrast_percentiles", "spectrum"}}`` of every :data:`VIEWS` and
    :data:`PHOTOGRAPHS`."""
    out = {}
    sources = list(VIEWS.items()) + list(PHOTOGRAPHS.items())
    for name, source in tqdm(sources, desc="worlds"):
        if isinstance(source, str):
            images, where = _strips(source), {"photograph": f"sklearn sample image {source}"}
        else:
            images = _panoramas(source[0], source[1], n)
            where = {"env_id": source[0], "env_kwargs": source[1]}
        spectrum = spectrum_slope(images)
        contrast = local_contrast(images)
        sharp = None
        if not isinstance(source, str) and _cylindrical(*source):
            fine = _panoramas(source[0], source[1], n, SHARP)
            sharp = round(spectrum_slope(fine, f_high=spectrum.f_high / SHARP).alpha, 3)
        out[name] = {
            **where,
            "shape": list(images.shape[1:3]),
            "alpha": round(spectrum.alpha, 3),
            "alpha_sharp": sharp,
            "fitted_cycles_per_pixel": [round(spectrum.f_low, 4), spectrum.f_high],
            "contrast_percentiles": {
                str(q): round(float(np.percentile(contrast, q)), 4) for q in (10, 50, 90)
            },
            "spectrum": {
                "cycles_per_pixel": [round(float(f), 5) for f in spectrum.frequencies],
                "amplitude": [float(f"{a:.5g}") for a in spectrum.amplitude],
            },
        }
        print(
            f"{name:46s} alpha {spectrum.alpha:5.2f} ({SHARP}x sharper: {sharp}), median local "
            "contrast "
            f"{out[name]['contrast_percentiles']['50']:.3f}"
        )
    return out


def draw(found: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
    for name, entry in found.items():
        f = np.asarray(entry["spectrum"]["cycles_per_pixel"])
        a = np.asarray(entry["spectrum"]["amplitude"])
        style = "--" if "photograph" in entry else "-"  # the reference photographs
        ax.loglog(f, a / a[0], style, label=f"{name} (alpha {entry['alpha']:.2f})")
    f = np.geomspace(0.03, 0.35, 10)
    for alpha in NATURAL:
        ax.loglog(f, (f / f[0]) ** -alpha, "k:", lw=0.8)
    ax.text(
        0.97,
        0.95,
        "dotted: natural scenes, alpha 0.9 and 1.2",
        fontsize=8,
        ha="right",
        transform=ax.transAxes,
    )
    ax.set_xlabel("spatial frequency (cycles per pixel)")
    ax.set_ylabel("amplitude (relative to the lowest bin)")
    ax.set_title("Radially averaged amplitude spectra of grey panoramas")
    ax.legend(fontsize=6.5, loc="lower left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def main(args: Args) -> int:
    found = measure(args.panoramas)
    write_json_atomic(
        args.json,
        {
            "study": "image_statistics",
            "panoramas_per_view": args.panoramas,
            "sharp_scale": SHARP,
            "natural_alpha_band": list(NATURAL),
            "views": found,
        },
    )
    draw(found, args.png)
    print(f"wrote {args.json} and {args.png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(tyro.cli(Args)))
