"""The worker process of one plug-in: ``python -m sfa_gym.sandbox.child``.

It reads messages (:mod:`sfa_gym.sandbox.wire`) from its standard input and answers each on the
file descriptor its standard output had at start; the plug-in's own prints go to standard error,
so that they cannot forge an answer. The first message names the plug-in file, its kind and its
arguments; the worker imports the file, makes the method or controller and answers with what the
evaluator may know of it (name, capabilities, filled-in arguments). A first message with
``"describe": true`` asks only what the file declares (its ``Args`` with their defaults, the
arguments filled in, checked): the evaluator plans a sweep from it without importing the file.
Every later message is one call (``fit``, ``transform``, ``reset``, ``act``) with arrays of views
or observations; the answer is ``{"ok": value}`` or ``{"error": [type names], "message": text}``.

The worker holds only what it was sent: views, panoramas, observations and the rover's own
sensors. One BLAS thread, as the evaluator computes, so that scores do not depend on where a
plug-in runs.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import traceback
from typing import Any, BinaryIO

__all__ = ["main"]


def _read_exactly(stream: BinaryIO, n: int) -> bytearray:
    buffer = bytearray(n)
    view, got = memoryview(buffer), 0
    while got < n:
        count = stream.readinto(view[got:])
        if not count:
            raise EOFError("the evaluator closed the pipe")
        got += count
    return buffer


def _send(stream: BinaryIO, value: Any) -> None:
    from sfa_gym.sandbox.wire import encode

    for part in encode(value):
        stream.write(part)
    stream.flush()


def _params(made: Any) -> dict[str, Any]:
    """``get_params()`` with values that are not JSON types given as their ``repr``."""
    get_params = getattr(made, "get_params", None)
    if not callable(get_params):
        return {}
    out = {}
    for key, value in get_params(deep=False).items():
        plain = value is None or isinstance(value, bool | int | float | str)
        out[str(key)] = value if plain else repr(value)
    return out


def _load(request: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    from pathlib import Path

    import numpy as np

    from sfa_gym.capabilities import get_capabilities
    from sfa_gym.plugins import load_plugin

    plugin = load_plugin(Path(request["path"]), request["kind"])
    arguments = plugin.arguments(request.get("args") or {})
    if request["kind"] == "method":
        made = plugin(**arguments)
    else:
        from sfa_gym.navigation.sensors import Rover

        fields = request["rover"]
        rover = Rover(**{**fields, "range_angles": tuple(fields["range_angles"])})
        weights = np.asarray(request["weights"], dtype=np.float64)
        made = plugin.make(rover, weights, **arguments)
        plugin._check_made(made, ("reset", "act"), "act(obs, info)")
    capabilities = dataclasses.asdict(get_capabilities(made))
    return made, {
        "capabilities": capabilities,
        "name": made.name,
        "arguments": arguments,
        "params": _params(made),
    }


def _describe(request: dict[str, Any]) -> dict[str, Any]:
    from pathlib import Path

    from sfa_gym.plugins import load_plugin

    plugin = load_plugin(Path(request["path"]), request["kind"])
    return plugin.describe(request.get("args"), make=True)


CALLS = {"method": ("fit", "transform"), "controller": ("reset", "act")}


def _call(made: Any, kind: str, request: dict[str, Any]) -> Any:
    call = request["call"]
    if call not in CALLS[kind]:
        raise ValueError(f"no call {call!r} for a {kind} (one of {CALLS[kind]})")
    result = getattr(made, call)(*request.get("args", []))
    return _fitted(made) if call == "fit" else result


def _fitted(made: Any) -> dict[str, Any]:
    """What the evaluator learns of a fitted method: its input shape and parameters."""
    shape = getattr(made, "input_shape_", None)
    return {
        "input_shape_": None if shape is None else [int(n) for n in shape],
        "params": _params(made),
    }


def _error(error: BaseException) -> dict[str, Any]:
    names = [cls.__name__ for cls in type(error).__mro__]
    text = "".join(traceback.format_exception_only(type(error), error)).strip()
    trace = "".join(traceback.format_exception(error)).strip()
    return {"error": names, "message": str(error), "text": text, "traceback": trace}


def _limit_memory(memory_mb: int) -> None:
    """Cap this process's address space at ``memory_mb`` MiB (or the hard limit it already has,
    if lower)."""
    import resource

    wanted = memory_mb * 2**20
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        wanted = min(wanted, hard)
    resource.setrlimit(resource.RLIMIT_AS, (wanted, wanted))


def main() -> None:
    """Serve one plug-in until the evaluator closes the pipe."""
    if len(sys.argv) > 1:
        _limit_memory(int(sys.argv[1]))
    # answers go on a private copy of stdout; the plug-in's prints go to stderr
    answers = os.fdopen(os.dup(1), "wb", buffering=0)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    requests = os.fdopen(os.dup(0), "rb", buffering=0)
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    sys.stdin = open(os.devnull)  # noqa: SIM115 (the plug-in reads nothing from the pipe)

    # what most plug-ins and the loader import, loaded while the worker waits as a spare (see
    # sfa_gym.sandbox.process); the plug-in's own imports come with its first message
    import numpy  # noqa: F401
    from threadpoolctl import threadpool_limits

    import sfa_gym.plugins  # noqa: F401
    from sfa_gym.sandbox.wire import decode

    with contextlib.suppress(ImportError):
        import sklearn.base  # noqa: F401

    threadpool_limits(limits=1)
    made, kind = None, None
    while True:
        try:
            request = decode(lambda n: _read_exactly(requests, n))
        except EOFError:
            return
        try:
            if made is None and request.get("describe"):
                answer = {"ok": _describe(request)}
            elif made is None:
                kind = request["kind"]
                made, about = _load(request)
                answer: Any = {"ok": about}
            else:
                answer = {"ok": _call(made, kind, request)}
            _send(answers, answer)
        except Exception as error:  # the evaluator decides what a failure means
            _send(answers, _error(error))


if __name__ == "__main__":
    main()
