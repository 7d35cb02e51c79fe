"""Running leaderboard tasks: in this process (``local``, the default: Ray is not imported) or
as Ray tasks (``ray``: one task per (track, method, world seed), on this machine or a cluster).

Each task computes its scores from its own inputs only (track file, method file and arguments,
world seed), so both backends return the same numbers. :func:`run_each` hands each task's
outcome over as soon as it is known (the sweep writes it at once), and a task that fails gives a
:class:`TaskFailure` instead of stopping the others: an exception raised by a plug-in, or a Ray
worker that died (killed, out of memory, crashed), which Ray retries :data:`RAY_RETRIES` times
first.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from sfa_gym.leaderboard.evaluate import Task, run_task

__all__ = [
    "BACKENDS",
    "RAY_RETRIES",
    "Backend",
    "TaskFailure",
    "check_backend",
    "run_each",
    "run_tasks",
]

Backend = Literal["local", "ray"]
BACKENDS = ("local", "ray")

RAY_HINT = "pip install 'sfa-gym[ray]'"

RAY_RETRIES = 1
"""How often Ray runs a task again whose worker died (an exception raised by the task itself is
not retried: the same inputs raise it again)."""


@dataclass(frozen=True)
class TaskFailure:
    """Why a task gave no scores.

    Attributes:
        error_type: the exception's class name (``RuntimeError``, ``WorkerCrashedError``).
        message: what it said; for a dead Ray worker, that it died and was retried.
        attempts: how often the task was run.
    """

    error_type: str
    message: str
    attempts: int = 1

    def describe(self) -> dict[str, Any]:
        """The failure in JSON types (for the task's file)."""
        return {"type": self.error_type, "message": self.message, "attempts": self.attempts}

    def __str__(self) -> str:
        return f"{self.error_type}: {self.message}"


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as error:
        raise ImportError(
            f"the ray backend needs Ray, which is not installed ({error}); install it with "
            f"{RAY_HINT}"
        ) from None
    return ray


def _failure(error: BaseException) -> TaskFailure:
    return TaskFailure(type(error).__name__, str(error) or repr(error))


def _ray_failure(error: Exception) -> TaskFailure:
    """The failure of a Ray task: the task's own exception (Ray wraps it in a ``RayTaskError``),
    or the worker's death after :data:`RAY_RETRIES` retries."""
    cause = getattr(error, "cause", None)
    if isinstance(cause, BaseException):  # RayTaskError: the task raised
        return _failure(cause)
    first_line = (str(error).strip().splitlines() or [""])[0]
    return TaskFailure(
        type(error).__name__,
        f"the Ray worker running the task died (killed, out of memory or crashed), "
        f"{1 + RAY_RETRIES} times in all, the last with: {first_line}",
        1 + RAY_RETRIES,
    )


def check_backend(backend: str, num_cpus: int | None = None) -> None:
    """Refuse an unknown backend or a ``num_cpus`` below 1 (a Ray with no CPU would wait for
    one forever), before anything starts.

    Raises:
        ValueError: naming the value and what was expected.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
    if num_cpus is not None and (
        isinstance(num_cpus, bool) or not isinstance(num_cpus, int) or num_cpus < 1
    ):
        raise ValueError(
            f"--num-cpus must be an int >= 1 (a Ray without a CPU runs no task and waits "
            f"forever), got {num_cpus!r}"
        )


def run_each(
    tasks: Sequence[Task],
    backend: Backend = "local",
    *,
    address: str | None = None,
    num_cpus: int | None = None,
) -> Iterator[tuple[int, dict[str, Any] | TaskFailure]]:
    """Run ``tasks``; yields ``(index, outcome)`` as each finishes, in the order they finish:
    the task's output (:func:`~sfa_gym.leaderboard.evaluate.run_task`) or a
    :class:`TaskFailure`. A failure never stops the other tasks; a ``KeyboardInterrupt`` does.

    Args:
        backend: "local" (one after the other, in this process) or "ray".
        address: ray only: the cluster to join (``"auto"``, ``"ray://host:10001"``); None
            starts a local Ray (or joins the one ``ray.init`` already started).
        num_cpus: ray only, local Ray only: CPUs it may use (None: all).

    Raises:
        ValueError: an unknown backend, or ``num_cpus`` below 1.
        ImportError: ``ray`` without Ray installed (names the pip command).
    """
    check_backend(backend, num_cpus)
    if backend == "local":
        for i, task in enumerate(tasks):
            try:
                output = run_task(task)
            # a plug-in's exit() fails its task, not the sweep
            except (Exception, SystemExit) as error:
                yield i, _failure(error)
            else:
                yield i, output
        return
    yield from _run_on_ray(tasks, address, num_cpus)


def _run_on_ray(
    tasks: Sequence[Task], address: str | None, num_cpus: int | None
) -> Iterator[tuple[int, dict[str, Any] | TaskFailure]]:
    ray = _import_ray()
    if not tasks:
        return
    if not ray.is_initialized():
        if address is not None:
            ray.init(address=address)
        else:
            ray.init(num_cpus=num_cpus, include_dashboard=False)
    # one CPU per task: the evaluations run BLAS single-threaded and render on one core
    remote = ray.remote(num_cpus=1, max_retries=RAY_RETRIES)(run_task)
    pending = {remote.remote(task): i for i, task in enumerate(tasks)}
    waiting = list(pending)
    try:
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            try:
                output = ray.get(done[0])
            except ray.exceptions.RayError as error:
                yield pending[done[0]], _ray_failure(error)
            else:
                yield pending[done[0]], output
    finally:
        # interrupted (or the caller stopped early): the rest is not wanted any more
        for ref in waiting:
            with contextlib.suppress(Exception):  # Ray may be shutting down already
                ray.cancel(ref, force=True)


def run_tasks(
    tasks: Sequence[Task],
    backend: Backend = "local",
    *,
    address: str | None = None,
    num_cpus: int | None = None,
    on_done: Callable[[Task, dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run ``tasks`` and return their outputs, in the order of ``tasks`` (see :func:`run_each`
    for the arguments); for timing and comparing tasks, where every task must succeed. A sweep
    that keeps what finished is :func:`~sfa_gym.leaderboard.sweep.run_sweep`.

    Args:
        on_done: called with each task and its output as it finishes.

    Raises:
        ValueError, ImportError: see :func:`run_each`.
        RuntimeError: a task failed (after all the others ran), naming it and why.
    """
    outputs: list[dict[str, Any] | None] = [None] * len(tasks)
    failures = []
    for i, outcome in run_each(tasks, backend, address=address, num_cpus=num_cpus):
        if isinstance(outcome, TaskFailure):
            failures.append(f"{tasks[i]}: {outcome}")
            continue
        outputs[i] = outcome
        if on_done is not None:
            on_done(tasks[i], outcome)
    if failures:
        raise RuntimeError(f"{len(failures)} task(s) failed: " + "; ".join(failures))
    return [o for o in outputs if o is not None]
