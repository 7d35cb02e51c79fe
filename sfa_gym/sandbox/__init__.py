"""Plug-ins from outside the package out of the evaluator's process: each such file runs in a
worker process of its own (confined by bubblewrap where the machine allows it), every call into
it has a time limit, its address space a memory limit, and only numbers and JSON-type values
come back; the package's own plug-ins run in the evaluator's process (:func:`isolation` decides,
for every loader). See the trust model in :mod:`sfa_gym.plugins`.
"""

from __future__ import annotations

from sfa_gym.sandbox.describe import describe_plugin
from sfa_gym.sandbox.process import (
    IN_PROCESS,
    PluginCrashed,
    PluginFailed,
    PluginOutOfMemory,
    PluginTimeout,
    confinement,
    isolation,
    plugins_isolated,
)
from sfa_gym.sandbox.proxies import (
    TIME_LIMITS,
    InProcess,
    IsolatedController,
    IsolatedMethod,
    Limits,
    check_memory_mb,
    check_time_limits,
)

__all__ = [
    "IN_PROCESS",
    "TIME_LIMITS",
    "InProcess",
    "IsolatedController",
    "IsolatedMethod",
    "Limits",
    "PluginCrashed",
    "PluginFailed",
    "PluginOutOfMemory",
    "PluginTimeout",
    "check_memory_mb",
    "check_time_limits",
    "confinement",
    "describe_plugin",
    "isolation",
    "plugins_isolated",
]
