"""Headless OpenGL selection for MuJoCo's offscreen renderer.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so every module of
this package that imports ``mujoco`` calls :func:`configure` first. EGL (Mesa llvmpipe on
a machine without a GPU) is preferred; OSMesa is the fallback.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

DEBIAN_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"

_LIBRARIES = {
    "egl": ("EGL", "libEGL.so.1"),
    "osmesa": ("OSMesa", "libOSMesa.so.8", "libOSMesa.so.6"),
}


class HeadlessGLError(RuntimeError):
    """No OpenGL library that MuJoCo can render with offscreen could be loaded."""


def _loads(names: tuple[str, ...]) -> bool:
    for name in names:
        path = ctypes.util.find_library(name) if "." not in name else name
        if not path:
            continue
        try:
            ctypes.CDLL(path)
        except OSError:
            continue
        return True
    return False


def configure() -> str:
    """Choose the GL backend before ``mujoco`` is imported; return its name.

    A ``MUJOCO_GL`` already set by the user is respected. Raises:
        HeadlessGLError: neither EGL nor OSMesa can be loaded; the message names the
            Debian packages that provide them.
    """
    chosen = os.environ.get("MUJOCO_GL")
    if chosen:
        if "mujoco" not in sys.modules and chosen in _LIBRARIES and not _loads(_LIBRARIES[chosen]):
            raise HeadlessGLError(
                f"MUJOCO_GL={chosen!r} but its library ({_LIBRARIES[chosen][0]}) cannot be "
                f"loaded; install it (Debian: apt-get install {DEBIAN_PACKAGES}) or unset "
                "MUJOCO_GL to let sfa_gym pick egl or osmesa"
            )
        return chosen
    for backend, names in _LIBRARIES.items():
        if _loads(names):
            os.environ["MUJOCO_GL"] = backend
            if backend == "osmesa":
                os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
            return backend
    raise HeadlessGLError(
        "no headless OpenGL library found (tried EGL and OSMesa); on Debian/Ubuntu run "
        f"'apt-get install {DEBIAN_PACKAGES}'"
    )
