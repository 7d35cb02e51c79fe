"""A plug-in's worker process: started (confined when the machine allows), called with a
deadline, stopped.

Confinement: where bubblewrap (``bwrap``) can make namespaces, the worker runs with the whole
filesystem read-only, its own scratch folder the only writable place, the folders it must not
read (the render cache, the results) hidden behind empty ones, no network and its own PID
namespace (it sees no other process). Elsewhere it is a plain child process in a scratch folder,
which :func:`confinement` says once on standard error.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sfa_gym.memory import tree_peak_mb
from sfa_gym.sandbox.wire import WireError, decode, encode

__all__ = [
    "IN_PROCESS",
    "PluginCrashed",
    "PluginFailed",
    "PluginOutOfMemory",
    "PluginTimeout",
    "Worker",
    "confinement",
    "isolation",
    "plugins_isolated",
]


class PluginTimeout(TimeoutError):
    """A call into a plug-in ran past its time limit; its worker was stopped."""


class PluginCrashed(RuntimeError):
    """A plug-in's worker died (or answered with something that is not a message)."""


class PluginFailed(RuntimeError):
    """A plug-in raised an exception of a type the evaluator does not rebuild (the message
    names the type)."""


class PluginOutOfMemory(MemoryError):
    """A plug-in ran out of its worker's memory limit (the message names the plug-in, the call
    and the limit); the evaluator's own memory is untouched."""


# Exceptions raised in a worker that are raised again in the evaluator with their own type (so a
# plug-in's ValueError for a bad argument stays a ValueError); any other becomes PluginFailed.
def _known_errors() -> dict[str, type[Exception]]:
    from sfa_gym.plugin_files import PluginError

    known: list[type[Exception]] = [
        PluginError,
        FileNotFoundError,
        NotImplementedError,
        KeyError,
        IndexError,
        ValueError,
        TypeError,
        AttributeError,
        MemoryError,
        ArithmeticError,
        AssertionError,
        OSError,
        RuntimeError,
    ]
    return {cls.__name__: cls for cls in known}


def _rebuilt(answer: dict[str, Any], label: str, what: str) -> Exception:
    """The exception a worker reported, of its own type when :func:`_known_errors` has it, with
    the worker's traceback as a note (shown under the evaluator's traceback)."""
    names, message = answer["error"], str(answer.get("message", ""))
    known = _known_errors()
    found = next((known[n] for n in names if n in known), None) if isinstance(names, list) else None
    error: Exception
    if found is None:
        error = PluginFailed(f"the plug-in {label} failed in {what}: {answer.get('text')}")
    else:
        error = found(message)
    trace = answer.get("traceback")
    if isinstance(trace, str):
        error.add_note(f"in the worker process of the plug-in {label} ({what}):\n{trace}")
    return error


# No network, no view of other processes or their shared memory, and no capabilities: bwrap run
# by root keeps them all by default, with which a worker could remount the filesystem writable.
BWRAP_FLAGS = (
    "--unshare-net",
    "--unshare-pid",
    "--unshare-ipc",
    "--unshare-uts",
    "--cap-drop",
    "ALL",
    "--die-with-parent",
    "--new-session",
)


@functools.cache
def confinement() -> str | None:
    """The path of a working ``bwrap``, or None (said once on standard error): then workers run
    as plain child processes."""
    bwrap = shutil.which("bwrap")
    if bwrap is not None:
        probe = [bwrap, "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc", *BWRAP_FLAGS]
        try:
            done = subprocess.run([*probe, "true"], capture_output=True, timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            done = None
        if done is not None and done.returncode == 0:
            return bwrap
        why = "bwrap cannot make namespaces here" + (
            f" ({done.stderr.decode(errors='replace').strip()})" if done is not None else ""
        )
    else:
        why = "bubblewrap (bwrap) is not installed"
    print(
        f"sfa-gym: plug-ins run in plain worker processes, not confined: {why}; they cannot see "
        "the evaluator's objects but can read and write what this user can",
        file=sys.stderr,
    )
    return None


def _command(scratch: Path, hidden: Sequence[Path], memory_mb: int | None) -> list[str]:
    command = [sys.executable, "-m", "sfa_gym.sandbox.child"]
    if memory_mb is not None:
        command.append(str(memory_mb))
    bwrap = confinement()
    if bwrap is None:
        return command
    confine = [bwrap, "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc"]
    for folder in hidden:
        if folder.is_dir():  # an empty folder over it: the worker cannot read what it holds
            confine += ["--tmpfs", str(folder)]
    confine += ["--bind", str(scratch), str(scratch), "--chdir", str(scratch), *BWRAP_FLAGS]
    return [*confine, "--", *command]


BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _spawn(hidden: tuple[Path, ...], memory_mb: int | None) -> tuple[subprocess.Popen[bytes], Path]:
    """Start a worker process (it imports its libraries, then waits for its first message)."""
    import sfa_gym

    scratch = Path(tempfile.mkdtemp(prefix="sfa-gym-plugin-"))
    package_parent = str(Path(sfa_gym.__file__).resolve().parent.parent)
    path = os.environ.get("PYTHONPATH")
    env = {
        **os.environ,
        # the worker imports the evaluator's own copy of sfa_gym, wherever it runs from
        "PYTHONPATH": package_parent + (os.pathsep + path if path else ""),
        "TMPDIR": str(scratch),
        "HOME": str(scratch),
        # one BLAS thread in every BLAS the plug-in loads, as the evaluator computes (a limit
        # set from inside would miss the libraries imported after it)
        **dict.fromkeys(BLAS_THREAD_VARIABLES, "1"),
    }
    process = subprocess.Popen(
        _command(scratch, hidden, memory_mb),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        cwd=scratch,
        env=env,
        bufsize=0,
        start_new_session=True,  # its own process group: stopped as a whole
    )
    os.set_blocking(process.stdin.fileno(), False)  # type: ignore[union-attr]
    return process, scratch


# One worker started ahead, while the current one works, for the next plug-in with the same
# confinement, limit and environment: its interpreter start and library imports (about a second
# per task) are then off the evaluator's path. A worker serves one plug-in only, and the spare
# has run no plug-in code yet.
_spare: dict[Any, tuple[subprocess.Popen[bytes], Path]] = {}


def _end(process: subprocess.Popen[bytes], scratch: Path) -> int | None:
    """Kill a worker's process group and remove its scratch folder; its exit code (None: it
    was still running)."""
    code = process.poll()
    if code is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    for stream in (process.stdin, process.stdout):
        if stream is not None:
            stream.close()
    shutil.rmtree(scratch, ignore_errors=True)
    return code


def _discard_spares() -> None:
    for process, scratch in _spare.values():
        _end(process, scratch)
    _spare.clear()


atexit.register(_discard_spares)


def _take_spare(
    hidden: tuple[Path, ...], memory_mb: int | None
) -> tuple[subprocess.Popen[bytes], Path]:
    """A started worker for ``hidden`` and ``memory_mb`` (the spare, if it was started with
    these and this process's environment and is alive), and a new spare behind it."""
    key = (hidden, memory_mb, confinement(), tuple(sorted(os.environ.items())))
    taken = _spare.pop(key, None)
    _discard_spares()  # a spare of other settings is not going to be asked for
    if taken is not None and taken[0].poll() is not None:
        _end(*taken)
        taken = None
    if taken is None:
        taken = _spawn(hidden, memory_mb)
    _spare[key] = _spawn(hidden, memory_mb)
    return taken


class Worker:
    """One plug-in's worker process.

    Args:
        label: how messages name the plug-in (its file).
        hidden: folders the worker must not read (confined workers only).
        memory_mb: the worker's memory limit, MiB (its address space, set before the plug-in
            is imported); None: no limit.
    """

    def __init__(
        self,
        label: str,
        hidden: Sequence[str | os.PathLike[str]] = (),
        memory_mb: int | None = None,
    ) -> None:
        self.label = label
        self.memory_mb = memory_mb
        self.peak_rss_mb: float | None = None
        """the worker's peak RSS, MiB, read when it is stopped
        (:func:`~sfa_gym.memory.tree_peak_mb`)"""
        self.process: subprocess.Popen[bytes] | None
        self.process, self.scratch = _take_spare(
            tuple(Path(h).resolve() for h in hidden), memory_mb
        )

    def call(self, request: dict[str, Any], limit: float, what: str) -> Any:
        """Send ``request``, wait at most ``limit`` seconds for the answer, return its value.

        Raises:
            PluginTimeout: no answer within ``limit`` (the worker is stopped).
            PluginCrashed: the worker died or answered with a malformed message.
            PluginError, ValueError, TypeError, ...: the plug-in raised it (see
                :func:`_known_errors`); PluginFailed: it raised something else.
        """
        if self.process is None:
            raise PluginCrashed(f"the plug-in {self.label}'s worker is already stopped")
        deadline = time.monotonic() + limit
        try:
            self._write(encode(request), deadline)
            answer = decode(lambda n: self._read_exactly(n, deadline))
        except TimeoutError:
            self.stop()
            raise PluginTimeout(
                f"the plug-in {self.label} took longer than its limit of {limit:g} s for "
                f"{what}; its worker was stopped"
            ) from None
        except (EOFError, BrokenPipeError, WireError) as error:
            try:  # a worker that closed its pipe is exiting: its exit code says how
                self.process.wait(5)  # type: ignore[union-attr]
            except subprocess.TimeoutExpired:
                pass
            code = self.stop()
            how = f"died with exit code {code}" if code else f"sent a malformed answer ({error})"
            if code and self.memory_mb is not None:  # native code may abort when refused memory
                how += f" (its memory limit is {self.memory_mb} MiB)"
            raise PluginCrashed(f"the plug-in {self.label}'s worker {how} during {what}") from None
        if not isinstance(answer, dict) or not ({"ok"} == set(answer) or "error" in answer):
            self.stop()
            raise PluginCrashed(f"the plug-in {self.label} sent a malformed answer to {what}")
        if "error" in answer:
            names = answer["error"] if isinstance(answer["error"], list) else []
            if "MemoryError" in names and self.memory_mb is not None:
                raise PluginOutOfMemory(
                    f"the plug-in {self.label} ran out of its memory limit of {self.memory_mb} "
                    f"MiB in {what} ({answer.get('text')}); raise it with --memory-limit-mb "
                    "or the track's memory_limit_mb"
                ) from None
            raise _rebuilt(answer, self.label, what)
        return answer["ok"]

    def _write(self, parts: list[bytes | memoryview], deadline: float) -> None:
        fd = self.process.stdin.fileno()  # type: ignore[union-attr]
        for part in parts:
            view, sent = memoryview(part).cast("B"), 0
            while sent < len(view):
                _wait(fd, deadline, write=True)
                try:
                    sent += os.write(fd, view[sent : sent + 2**20])
                except BlockingIOError:
                    continue

    def _read_exactly(self, n: int, deadline: float) -> bytearray:
        fd = self.process.stdout.fileno()  # type: ignore[union-attr]
        buffer = bytearray(n)
        view, got = memoryview(buffer), 0
        while got < n:
            _wait(fd, deadline, write=False)
            count = os.readv(fd, [view[got:]])
            if count == 0:
                raise EOFError
            got += count
        return buffer

    def stop(self) -> int | None:
        """Kill the worker and its process group, remove its scratch folder; its exit code."""
        process, self.process = self.process, None
        if process is None:
            return None
        if process.poll() is None:  # the kernel forgets a process's peak when it exits
            self.peak_rss_mb = tree_peak_mb(process.pid)
        return _end(process, self.scratch)

    def close(self) -> None:
        """End the worker. It is killed rather than asked to exit: it owes the evaluator nothing
        more, and an interpreter that unloads scipy and sklearn takes a few tenths of a second
        to exit, every task."""
        self.stop()

    def __del__(self) -> None:
        if getattr(self, "process", None) is not None:
            self.stop()


def _wait(fd: int, deadline: float, *, write: bool) -> None:
    """Block until ``fd`` is ready, or raise TimeoutError at ``deadline``."""
    remaining = deadline - time.monotonic()
    if remaining <= 0:
        raise TimeoutError
    waiting = ([], [fd]) if write else ([fd], [])
    ready = select.select(*waiting, [], remaining)
    if not any(ready):
        raise TimeoutError


IN_PROCESS = "SFA_GYM_PLUGINS_IN_PROCESS"
"""Set to ``1``, the evaluator (a leaderboard task, the command line's protocols) imports every
plug-in into its own process, with its full rights: for debugging a plug-in of one's own (a
debugger stops in it), or a test in which a plug-in stands for a failure of the evaluator itself
(a worker that dies, a signal to the sweep). Never for a board of others' plug-ins."""


def plugins_isolated() -> bool:
    """Whether plug-ins from outside the package run in worker processes (the default; see
    :data:`IN_PROCESS`)."""
    return os.environ.get(IN_PROCESS, "") != "1"


def isolation(method: str | os.PathLike[str] | None = None, controller: Any = None) -> str:
    """Where the plug-ins ``method`` and ``controller`` (files or built-in names; None: not
    used) run, the one decision every loader follows: ``"built-in"`` (all are the package's own
    files: in the evaluator's process, :class:`~sfa_gym.sandbox.InProcess`), ``"bwrap"``
    (worker processes confined by bubblewrap), ``"process"`` (plain worker processes: no
    bubblewrap here) or ``"in-process"`` (:data:`IN_PROCESS`). With neither given, how a file
    from outside runs. Only ``"bwrap"`` and ``"built-in"`` results can be published."""
    from sfa_gym.plugin_files import builtin

    if not plugins_isolated():
        return "in-process"
    given = [(s, k) for s, k in ((method, "method"), (controller, "controller")) if s is not None]
    if given and all(builtin(s, k) for s, k in given):  # type: ignore[arg-type]
        return "built-in"
    return "bwrap" if confinement() is not None else "process"
