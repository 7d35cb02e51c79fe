"""Study: what moves the spectrum slope of the outdoor world's panoramas, beyond the textures.

Measured as ``eval/studies/image_statistics.py`` measures
(``sfa_gym.image_statistics.spectrum_slope``,
``--panoramas`` panoramas at ``env.reset(seed=i)``, world seed 0, the cylindrical 60 x 600
camera of ``sfa_gym/OmniRoverOutdoor-v0`` without the sensor), for the whole panoramas and for
their upper and lower halves:

* flat and textured (``textures=True``);
* textured with every texture's contrast exaggerated far past physical (each texel's ratio to
  its texture's mean colour raised to the power 2.5): how far texture contrast alone can go;
* flat and textured with 16x anisotropic filtering of every 2-d texture (GL's isotropic
  trilinear filtering blurs surfaces seen at grazing angles, the ground above all);
* a photograph (scikit-learn's temple among trees, in strips shrunk to 60 x 600) blurred by
  Gaussians of growing width: how much a renderer's anti-aliasing blur alone raises ``alpha``.

The two counterfactuals patch the texture encoder and the camera's GL set-up in this process
only. Prints JSON (the figures of docs/notes/2026-11-27-textures.md); about half a minute.

    .venv/bin/python -m eval.studies.texture_levers [--panoramas 24]
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    panoramas: int = 24
    """panoramas per case"""


def _slopes(n: int, **kwargs: Any) -> dict[str, float]:
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.image_statistics import spectrum_slope

    cylinder = {"camera": "cylindrical", "mirror": None, "sensor": False}
    env = gym.make("sfa_gym/OmniRoverOutdoor-v0", **cylinder, **kwargs)
    images = np.stack([env.reset(seed=i)[0] for i in range(n)])
    env.close()
    half = images.shape[1] // 2
    return {
        "all": round(spectrum_slope(images).alpha, 3),
        "upper half": round(spectrum_slope(images[:, :half]).alpha, 3),
        "lower half": round(spectrum_slope(images[:, half:]).alpha, 3),
    }


def main(args: Args) -> None:
    import cv2
    from sklearn.datasets import load_sample_image

    # first: the camera modules choose the GL platform before anything imports mujoco
    import sfa_gym.sim.camera.renderer as renderer
    import sfa_gym.sim.worlds.textures as textures
    from sfa_gym.image_statistics import spectrum_slope

    n, out = args.panoramas, {}
    for flag in (False, True):
        out[f"textures={flag}"] = _slopes(n, textures=flag)

    encode = textures.to_uint8

    def exaggerated(rgb: np.ndarray) -> np.ndarray:
        mean = rgb.reshape(-1, 3).mean(axis=0)
        return encode(mean * (np.clip(rgb, 1e-4, None) / mean) ** 2.5)

    textures.to_uint8 = exaggerated
    try:
        out["textured, contrast ** 2.5"] = _slopes(n, textures=True)
    finally:
        textures.to_uint8 = encode

    nearest = renderer.sample_nearest

    def anisotropic(con: Any, skies: list[int]) -> None:
        from OpenGL import GL

        nearest(con, skies)
        for tex in range(con.ntexture):
            if con.textureType[tex] == renderer.mujoco.mjtTexture.mjTEXTURE_2D:
                GL.glBindTexture(GL.GL_TEXTURE_2D, int(con.texture[tex]))
                GL.glTexParameterf(GL.GL_TEXTURE_2D, 0x84FE, 16.0)  # MAX_ANISOTROPY
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)

    renderer.sample_nearest = anisotropic
    try:
        for flag in (False, True):
            out[f"textures={flag}, 16x anisotropic"] = _slopes(n, textures=flag)
    finally:
        renderer.sample_nearest = nearest

    image = load_sample_image("china.jpg")
    rows = image.shape[1] // 10
    starts = range(0, image.shape[0] - rows + 1, rows // 2)
    strips = [
        cv2.resize(image[y : y + rows], (600, 60), interpolation=cv2.INTER_AREA) for y in starts
    ]
    for sigma in (0.0, 0.4, 0.6, 0.8):
        blurred = np.stack([cv2.GaussianBlur(s, (0, 0), sigma) if sigma else s for s in strips])
        out[f"photograph, blur sigma {sigma} px"] = round(spectrum_slope(blurred).alpha, 3)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
