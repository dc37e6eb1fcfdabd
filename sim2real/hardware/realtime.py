"""Asking the operating system for real-time treatment (Linux), and saying what it granted.

    granted = request_realtime(RealtimeRequest(priority=50, cpu=None, lock_memory=True))
    log(granted.describe())

A control loop that shares two cores with a compiler or an evolution run wakes late when the
scheduler gives the core to someone else: measured on this project's 2-core machine, 977
overruns in 10,000 ticks of 10 ms with CPU hogs running, against 91-231 idle.  Three things
help, each optional and each reported:

* a real-time scheduling class (``SCHED_FIFO``) and priority: the loop's thread runs before
  every ordinary process the moment it wakes (the kernel still keeps 5 % of each second for
  the others, ``/proc/sys/kernel/sched_rt_runtime_us``, so a runaway loop cannot lock the
  machine);
* locked memory (``mlockall``): no page fault on the loop's path;
* a chosen CPU (affinity).

Without the privilege (root or ``CAP_SYS_NICE`` / ``CAP_IPC_LOCK``, or an ``rtprio`` limit
in ``/etc/security/limits.conf``) each request fails on its own and the loop runs as an
ordinary process; :meth:`RealtimeGrant.describe` says so, with the reason.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os
import resource
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Iterator

DEFAULT_PRIORITY = 50  # SCHED_FIFO 1-99: above every ordinary process, below the kernel's own threads
MCL_CURRENT, MCL_FUTURE = 1, 2


@dataclass(frozen=True)
class RealtimeRequest:
    priority: int | None = DEFAULT_PRIORITY  # SCHED_FIFO priority; None: stay an ordinary process
    cpu: int | None = None  # pin to this CPU; None: any
    lock_memory: bool = True

    @classmethod
    def off(cls) -> "RealtimeRequest":
        return cls(priority=None, cpu=None, lock_memory=False)


@dataclass
class RealtimeGrant:
    priority: int | None = None
    cpu: int | None = None
    memory_locked: bool = False
    refused: list[str] = field(default_factory=list)  # what was asked and not granted, with why

    def describe(self) -> str:
        parts = [f"SCHED_FIFO priority {self.priority}" if self.priority else "ordinary scheduling",
                 f"CPU {self.cpu}" if self.cpu is not None else "any CPU",
                 "memory locked" if self.memory_locked else "memory not locked"]
        text = "real-time: " + ", ".join(parts)
        return text + (f" (refused: {'; '.join(self.refused)})" if self.refused else "")

    def summary(self) -> dict:
        return {"priority": self.priority, "cpu": self.cpu, "memory_locked": self.memory_locked,
                "refused": list(self.refused)}


def request_realtime(request: RealtimeRequest) -> RealtimeGrant:
    """Apply what ``request`` asks to the calling thread (scheduling, affinity) and process
    (memory); never raises for a refusal."""
    grant = RealtimeGrant()
    # Memory first, while still ordinarily scheduled: mlockall faults in every mapped page
    # (tens to hundreds of MB once NumPy or MuJoCo is loaded), and done under SCHED_FIFO that
    # work held a core from every other real-time thread of the same priority - another
    # run's simulated bus then went unserved for 100-200 ms (issue 47).
    if request.lock_memory:
        problem = _lock_memory()
        if problem is None:
            grant.memory_locked = True
        else:
            grant.refused.append(f"memory lock: {problem}")
    if request.cpu is not None:
        try:
            os.sched_setaffinity(0, {request.cpu})
            grant.cpu = request.cpu
        except (OSError, AttributeError, ValueError) as exc:
            grant.refused.append(f"CPU {request.cpu}: {_why(exc)}")
    if request.priority is not None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(request.priority))
            grant.priority = request.priority
        except (OSError, AttributeError, ValueError) as exc:
            grant.refused.append(f"SCHED_FIFO priority {request.priority}: {_why(exc)}")
    return grant


def _lock_memory() -> str | None:
    libc_name = ctypes.util.find_library("c")
    if libc_name is None:
        return "no C library"
    libc = ctypes.CDLL(libc_name, use_errno=True)
    if not hasattr(libc, "mlockall"):
        return "mlockall is not available here"
    # MCL_FUTURE under a finite lock limit would make later allocations fail once the limit is
    # reached; lock only what exists then.
    soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    flags = MCL_CURRENT | MCL_FUTURE if os.geteuid() == 0 or soft == resource.RLIM_INFINITY else MCL_CURRENT
    if libc.mlockall(flags) != 0:
        return os.strerror(ctypes.get_errno())
    return None


def _why(exc: BaseException) -> str:
    if isinstance(exc, PermissionError):
        return "not permitted (needs root or CAP_SYS_NICE / an rtprio limit)"
    return str(exc) or type(exc).__name__


def ordinary_scheduling() -> None:
    """Back to SCHED_OTHER for the calling thread (e.g. before slow shutdown work)."""
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (OSError, AttributeError):
        pass


def release_realtime(grant: RealtimeGrant) -> None:
    """Undo what ``grant`` got, for a process that goes on after its real-time part (a dry
    run inside the quickstart, a test): ordinary scheduling, memory unlocked, any CPU."""
    if grant.priority is not None:
        ordinary_scheduling()
    if grant.memory_locked:
        libc_name = ctypes.util.find_library("c")
        if libc_name is not None:
            ctypes.CDLL(libc_name).munlockall()
    if grant.cpu is not None:
        try:
            os.sched_setaffinity(0, range(os.cpu_count() or 1))
        except OSError:
            pass


@contextmanager
def no_garbage_collection() -> Iterator[None]:
    """The cyclic garbage collector off for a block: its pauses (milliseconds on a large heap)
    would land on random ticks.  The loop allocates only short-lived, acyclic arrays, which
    reference counting frees anyway."""
    was_enabled = gc.isenabled()
    gc.collect()
    gc.freeze()  # what exists now is never scanned again
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
        gc.unfreeze()
