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
strips of the panoramas' 1:10 aspect and shrunk to 60 x 600. Real panoramas calibrate it for
this camera: Poly Haven's equirectangular HDR photographs of real places (:data:`REAL`, CC0, the
1k files as ``pmndrs/drei-assets`` on GitHub ships them in ``hdri/``), cut to the cylindrical
camera's elevation band (rows uniform in elevation, as the camera's), shrunk to its 60 x 600 with
a box filter, exposed like the camera's auto-exposure (the mean grey level at
``SensorSpec.target``), sRGB-encoded to 8 bits and measured at 12 headings each. Writes
``published/studies/image_statistics.json`` and ``docs/image_statistics.png`` (the spectra,
log-log, beside the natural-image band).

Usage (from the repository root; a few minutes on 2 cores)::

    .venv/bin/python -m eval.studies.image_statistics --hdri path/to/drei-assets/hdri
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from sfa_gym.files import write_json_atomic
from sfa_gym.image_statistics import local_contrast, spectrum_slope

ROOT = Path(__file__).resolve().parents[2]

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

REAL = {
    "real, city square (Potsdamer Platz)": "potsdamer_platz_1k.hdr",
    "real, park": "rooitou_park_1k.hdr",
    "real, forest": "forest_slope_1k.hdr",
    "real, mountain meadow": "immenstadter_horn_1k.hdr",
    "real, dawn landscape": "kiara_1_dawn_1k.hdr",
    "real, waterfront at sunset": "venice_sunset_1k.hdr",
    "real, covered footbridge": "adams_place_bridge_1k.hdr",
    "real, savanna at night": "dikhololo_night_1k.hdr",
    "real indoor, warehouse": "empty_warehouse_01_1k.hdr",
    "real indoor, living room": "lebombo_1k.hdr",
    "real indoor, hall": "st_fagans_interior_1k.hdr",
}
"""Reference rows: real places, Poly Haven's equirectangular HDR panoramas (CC0), by file name;
the first eight outdoors."""

REAL_HEADINGS = 12
"""Each real panorama is measured at this many headings (column shifts), as the worlds at
several poses: the spectrum's window weighs the columns unequally."""

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
    side_by_side: Path = ROOT / "docs" / "real_and_rendered.png"
    """where to show real places above rendered worlds (with ``hdri``)"""
    hdri: Path | None = None
    """folder holding the :data:`REAL` panoramas; without it their rows are left out"""


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


def _exposed(radiance: np.ndarray, target: float) -> np.ndarray:
    """8-bit sRGB of linear ``radiance`` ``(H, W, 3)`` at the exposure whose mean grey level is
    ``target`` (bisection on the log exposure; highlights clip as a camera's do)."""

    def encode(exposure: float) -> np.ndarray:
        v = np.clip(radiance * exposure, 0.0, 1.0)
        return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055) * 255.0

    low, high = -30.0, 30.0  # log exposure; the mean grey level grows with it
    for _ in range(60):
        mid = (low + high) / 2.0
        low, high = (mid, high) if encode(np.exp(mid)).mean() < target else (low, mid)
    return np.round(encode(np.exp((low + high) / 2.0))).astype(np.uint8)


def _real(path: Path) -> np.ndarray:
    """:data:`REAL_HEADINGS` views of the equirectangular HDR panorama ``path`` as the
    cylindrical camera of the outdoor protocol would see them (see the module docstring)."""
    import cv2

    from sfa_gym.sim.camera import PanoramaSpec
    from sfa_gym.sim.camera.sensor import SensorSpec

    radiance = cv2.imread(str(path), cv2.IMREAD_ANYDEPTH | cv2.IMREAD_COLOR)
    if radiance is None:
        raise ValueError(f"{path}: not a readable HDR image (expected a Radiance .hdr file)")
    if radiance.ndim != 3 or radiance.shape[1] != 2 * radiance.shape[0]:
        raise ValueError(
            f"{path}: expected an equirectangular (2:1) colour image, got shape {radiance.shape}"
        )
    spec = PanoramaSpec.paper_outdoor()
    rows = radiance.shape[0]  # 180 degrees of elevation, top row at the zenith
    top = round((90.0 - spec.vfov_deg / 2) / 180.0 * rows)
    bottom = round((90.0 + spec.vfov_deg / 2) / 180.0 * rows)
    band = cv2.resize(
        radiance[top:bottom, :, ::-1], (spec.width, spec.height), interpolation=cv2.INTER_AREA
    ).astype(np.float64)
    exposed = _exposed(band, SensorSpec().target)  # a heading changes no pixel's value
    shifts = range(0, spec.width, spec.width // REAL_HEADINGS)
    return np.stack([np.roll(exposed, k, axis=1) for k in shifts])


def measure(
    n: int, hdri: Path | None = None, examples: dict[str, np.ndarray] | None = None
) -> dict[str, Any]:
    """``{view: {"alpha", "contrast_percentiles", "spectrum"}}`` of every :data:`VIEWS`,
    :data:`PHOTOGRAPHS` and, with ``hdri``, :data:`REAL` panorama; ``examples`` receives the
    first picture of each."""
    out = {}
    sources: list[tuple[str, Any]] = list(VIEWS.items()) + list(PHOTOGRAPHS.items())
    if hdri is not None:
        sources += [(name, hdri / file) for name, file in REAL.items()]
    for name, source in tqdm(sources, desc="worlds"):
        if isinstance(source, Path):
            images = _real(source)
            digest = hashlib.sha256(source.read_bytes()).hexdigest()
            where = {"real_panorama": f"Poly Haven {source.name}", "sha256": digest}
        elif isinstance(source, str):
            images, where = _strips(source), {"photograph": f"sklearn sample image {source}"}
        else:
            images = _panoramas(source[0], source[1], n)
            where = {"env_id": source[0], "env_kwargs": source[1]}
        if examples is not None:
            examples[name] = images[0]
        spectrum = spectrum_slope(images)
        contrast = local_contrast(images)
        sharp = None
        if isinstance(source, tuple) and _cylindrical(*source):
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

    # left: our worlds; right: the references (real places, photographs), on the same axes
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.2), dpi=100, sharex=True, sharey=True)
    f = np.geomspace(0.03, 0.35, 10)
    for ax, title in zip(axes, ("our worlds", "real places and photographs"), strict=True):
        for alpha in NATURAL:
            ax.loglog(f, (f / f[0]) ** -alpha, "k:", lw=0.8)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("spatial frequency (cycles per pixel)")
    for name, entry in found.items():
        f = np.asarray(entry["spectrum"]["cycles_per_pixel"])
        a = np.asarray(entry["spectrum"]["amplitude"])
        reference = "real_panorama" in entry or "photograph" in entry
        style = "--" if "indoor" in name or "photograph" in entry else "-"
        axes[int(reference)].loglog(
            f, a / a[0], style, lw=1.0, label=f"{name} (alpha {entry['alpha']:.2f})"
        )
    axes[0].set_ylabel("amplitude (relative to the lowest bin)")
    axes[1].text(
        0.97, 0.95, "dotted: alpha 0.9 and 1.2", fontsize=8, ha="right", transform=axes[1].transAxes
    )
    for ax in axes:
        ax.legend(fontsize=6, loc="lower left")
    fig.suptitle("Radially averaged amplitude spectra of grey panoramas (60 x 600 unless named)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


SIDE_BY_SIDE = (
    "real, city square (Potsdamer Platz)",
    "campus, cylindrical 60 x 600",
    "real, park",
    "paper_outdoor textured, cylindrical 60 x 600",
    "real, forest",
    "paper_outdoor, cylindrical 60 x 600",
)
"""Real places and rendered worlds shown one above the other, at the camera's size."""


def draw_side_by_side(found: dict[str, Any], examples: dict[str, np.ndarray], path: Path) -> None:
    """The :data:`SIDE_BY_SIDE` pictures at the camera's 60 x 600, each with its slope."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [name for name in SIDE_BY_SIDE if name in examples]
    fig, axes = plt.subplots(len(names), 1, figsize=(12, 1.45 * len(names)), dpi=100)
    for ax, name in zip(np.atleast_1d(axes), names, strict=True):
        ax.imshow(examples[name], interpolation="nearest", aspect="equal")
        ax.set_title(f"{name}: alpha {found[name]['alpha']:.2f}", fontsize=9, loc="left")
        ax.set_axis_off()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(args: Args) -> int:
    if args.hdri is not None and not args.hdri.is_dir():
        raise SystemExit(f"--hdri {args.hdri}: not a folder (expected one holding {REAL})")
    examples: dict[str, np.ndarray] = {}
    found = measure(args.panoramas, args.hdri, examples)
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
    if args.hdri is not None:
        draw_side_by_side(found, examples, args.side_by_side)
        print(f"wrote {args.side_by_side}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(tyro.cli(Args)))
