"""OpenGL for MuJoCo's offscreen rendering, in one place: the backend, forks, contexts, sizes.

- Backend: MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so every module
  of this package that imports ``mujoco`` calls :func:`configure` first. EGL (Mesa llvmpipe on a
  machine without a GPU) is preferred; OSMesa is the fallback.
- Forks: a process forked after it used OpenGL would hang at its first render;
  :func:`check_usable` (called before every render) raises instead, and :func:`check_owner`
  refuses a context that another process created.
- Contexts: :func:`new_context` creates a context that its owner frees explicitly, after
  checking the buffer size against what OpenGL supports (:func:`check_framebuffer`, also used
  at construction time, without GL); :func:`track` closes the owners still open at exit.

This module imports ``mujoco`` only inside :func:`new_context`.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import ctypes.util
import importlib.util
import os
import sys
import weakref
from typing import Any, Protocol

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


# -- fork detection ------------------------------------------------------------------------------

# A process forked after it used OpenGL inherits a GL driver whose worker threads did not
# survive the fork: rendering in the child hangs. Detect it and fail with advice instead.
_used = False
_forked_after_use = False

FORK_ADVICE = (
    "start vector-env workers with 'spawn' or 'forkserver': "
    "gym.make_vec(..., vectorization_mode='async', vector_kwargs={'context': 'spawn'})"
)


def _mark_fork_in_child() -> None:
    global _forked_after_use
    egl = sys.modules.get("mujoco.egl")
    if _used or (egl is not None and getattr(egl, "EGL_DISPLAY", None) is not None):
        _forked_after_use = True


os.register_at_fork(after_in_child=_mark_fork_in_child)


def check_usable() -> None:
    """Call before every use of OpenGL in this process; marks OpenGL as used.

    Raises:
        RuntimeError: this process was forked from one that had already used OpenGL, where
            rendering would hang; the message says how to start workers instead.
    """
    global _used
    if _forked_after_use:
        raise RuntimeError(
            "this process was forked from one that had already rendered with OpenGL, and "
            f"rendering here would hang; {FORK_ADVICE}"
        )
    _used = True


def check_owner(owner_pid: int | None, what: str) -> None:
    """Refuse to use a GL context that process ``owner_pid`` created from another process.

    ``None`` means no context exists yet. Raises:
        RuntimeError: naming ``what`` and the creating process.
    """
    if owner_pid is not None and owner_pid != os.getpid():
        raise RuntimeError(
            f"this {what} was first rendered in process {owner_pid}; OpenGL does not survive "
            f"fork: create the env in the worker, or {FORK_ADVICE}"
        )


# -- framebuffer size ----------------------------------------------------------------------------

MAX_FRAMEBUFFER_SIDE = 16384
"""Largest offscreen framebuffer side (pixels) that sizes are checked against at construction.

It is ``GL_MAX_RENDERBUFFER_SIZE`` of Mesa's llvmpipe (through EGL or OSMesa), and no larger
than that of current desktop GPUs. Checking against a constant keeps construction free of GL
(an env may be built in a process that later forks); when a context is created, the limit
that the driver reports is checked as well (:func:`check_framebuffer` with ``limit=``).
"""

_queried_limit: int | None = None


def check_framebuffer(width: int, height: int, what: str, *, limit: int | None = None) -> None:
    """Refuse an offscreen buffer of ``width x height`` pixels larger than OpenGL supports.

    Args:
        width: the buffer's width, pixels.
        height: the buffer's height, pixels.
        what: what needs the buffer, for the message (e.g. ``"PanoramaSpec(...)"``).
        limit: the largest side; by default the smaller of :data:`MAX_FRAMEBUFFER_SIDE` and
            the limit that a GL driver of this process reported.
    Raises:
        ValueError: naming the size, the limit and ``what``.
    """
    if limit is None:
        limit = min(MAX_FRAMEBUFFER_SIDE, _queried_limit or MAX_FRAMEBUFFER_SIDE)
    if width > limit or height > limit:
        raise ValueError(
            f"{what} needs a {width}x{height} offscreen framebuffer, but OpenGL supports at "
            f"most {limit}x{limit} pixels; make it smaller"
        )


def _driver_limit() -> int | None:
    """``GL_MAX_RENDERBUFFER_SIZE`` of the current context, queried once per process."""
    global _queried_limit
    if _queried_limit is None:
        try:
            from OpenGL import GL  # PyOpenGL comes with mujoco; its platform is set by now

            _queried_limit = int(GL.glGetIntegerv(GL.GL_MAX_RENDERBUFFER_SIZE))
        except Exception:
            return None  # the constant check still applies
    return _queried_limit


# -- contexts ------------------------------------------------------------------------------------

_OWNED_CONTEXT: type | None = None


_llvm_users_loaded = False


def load_llvm_users() -> None:
    """Import ``triton`` (torch's compiler, if installed) before the first GL context exists.

    Mesa's llvmpipe loads its libLLVM with the first context, and triton carries an LLVM of its
    own; should triton load second (torch imports it lazily, e.g. when an optimizer is built),
    its LLVM calls bind to Mesa's library and the process dies with SIGSEGV. Loaded first, each
    keeps its own. Costs about 0.3 s once per process, and nothing where triton is absent.
    Every path to a context of this package calls it (:func:`new_context`, the env's top-down
    renderer).
    """
    global _llvm_users_loaded
    if _llvm_users_loaded:
        return
    _llvm_users_loaded = True
    if importlib.util.find_spec("triton") is None:
        return
    try:
        import triton  # noqa: F401
    except Exception:  # a broken triton is torch's problem, not a reason not to render
        pass


def new_context(width: int, height: int, what: str) -> Any:
    """A current ``mujoco.GLContext`` for an offscreen buffer of ``width x height`` pixels.

    Its owner frees it with ``free()``: unlike ``mujoco.GLContext`` it has no ``__del__``,
    which would free it again, possibly during interpreter teardown. Raises:
        RuntimeError: see :func:`check_usable`.
        ValueError: the buffer exceeds what the driver supports (see :func:`check_framebuffer`).
    """
    global _OWNED_CONTEXT
    check_usable()
    check_framebuffer(width, height, what)
    load_llvm_users()
    import mujoco  # configure() ran when the caller imported mujoco

    if _OWNED_CONTEXT is None:
        base = mujoco.GLContext
        _OWNED_CONTEXT = type(f"_Owned{base.__name__}", (base,), {"__del__": lambda self: None})
    context = _OWNED_CONTEXT(width, height)
    try:
        context.make_current()
        limit = _driver_limit()
        if limit is not None:
            check_framebuffer(width, height, what, limit=limit)
    except BaseException:
        context.free()
        raise
    return context


# -- live resources ------------------------------------------------------------------------------


class Closable(Protocol):
    def close(self) -> None: ...


# Objects holding a GL context, closed at exit while the GL bindings still work (freeing them
# during interpreter teardown makes PyOpenGL print errors).
_LIVE: weakref.WeakSet[Any] = weakref.WeakSet()


def track(resource: Closable) -> None:
    """Close ``resource`` at interpreter exit unless :func:`untrack` was called first."""
    _LIVE.add(resource)


def untrack(resource: Closable) -> None:
    """Forget ``resource`` (it closed itself); a no-op if it was not tracked."""
    _LIVE.discard(resource)


@atexit.register
def _close_live() -> None:
    for resource in list(_LIVE):
        with contextlib.suppress(Exception):
            resource.close()
