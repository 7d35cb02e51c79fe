"""Running leaderboard tasks: in this process (``local``, the default: Ray is not imported) or
as Ray tasks (``ray``: one task per (track, method, world seed), on this machine or a cluster).

Each task computes its scores from its own inputs only (track file, method file and arguments,
world seed), so both backends return the same numbers; results are put in the order of the
tasks whichever finished first.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal

from sfa_gym.leaderboard.evaluate import Task, run_task

__all__ = ["BACKENDS", "Backend", "run_tasks"]

Backend = Literal["local", "ray"]
BACKENDS = ("local", "ray")

RAY_HINT = "pip install 'sfa-gym[ray]'"


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as error:
        raise ImportError(
            f"the ray backend needs Ray, which is not installed ({error}); install it with "
            f"{RAY_HINT}"
        ) from None
    return ray


def run_tasks(
    tasks: Sequence[Task],
    backend: Backend = "local",
    *,
    address: str | None = None,
    num_cpus: int | None = None,
    on_done: Callable[[Task, dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run ``tasks`` and return their outputs (:func:`run_task`), in the order of ``tasks``.

    Args:
        backend: "local" (one after the other, in this process) or "ray".
        address: ray only: the cluster to join (``"auto"``, ``"ray://host:10001"``); None
            starts a local Ray (or joins the one ``ray.init`` already started).
        num_cpus: ray only, local Ray only: CPUs it may use (None: all).
        on_done: called with each task and its output as it finishes.

    Raises:
        ValueError: an unknown backend.
        ImportError: ``ray`` without Ray installed (names the pip command).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
    if backend == "local":
        outputs = []
        for task in tasks:
            outputs.append(run_task(task))
            if on_done is not None:
                on_done(task, outputs[-1])
        return outputs

    ray = _import_ray()
    if not ray.is_initialized():
        if address is not None:
            ray.init(address=address)
        else:
            ray.init(num_cpus=num_cpus, include_dashboard=False)
    # one CPU per task: the evaluations run BLAS single-threaded and render on one core
    remote = ray.remote(num_cpus=1, max_retries=0)(run_task)
    pending = {remote.remote(task): i for i, task in enumerate(tasks)}
    outputs: list[dict[str, Any] | None] = [None] * len(tasks)
    waiting = list(pending)
    while waiting:
        done, waiting = ray.wait(waiting, num_returns=1)
        i = pending[done[0]]
        outputs[i] = ray.get(done[0])
        if on_done is not None:
            on_done(tasks[i], outputs[i])
    return [o for o in outputs if o is not None]
