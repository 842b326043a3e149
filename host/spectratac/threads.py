"""The thread policy: how many threads the math libraries of each toolkit process may use.

Why: torch's OpenMP pool starts one thread per core and its threads spin while they wait for
each other. Two such processes on two cores, or one beside other work, fight over the cores:
a 5-epoch MLP that takes 0.2 s alone took 35 s each with two processes at once. So:

- a process gets its share of the CPUs it may run on (`os.sched_getaffinity`), divided among
  the worker processes that run at once, and at least one thread;
- `SPECTRATAC_THREADS=N` replaces the share (every process the toolkit starts then uses N);
- child processes inherit the share through OMP_NUM_THREADS, MKL_NUM_THREADS and
  OPENBLAS_NUM_THREADS, and waiting OpenMP threads sleep (OMP_WAIT_POLICY=PASSIVE, unless the
  user chose otherwise) instead of spinning on a core another process needs;
- torch is configured only where it is already imported: this module never imports it, so
  streaming and the live page stay free of torch.

`apply()` runs at the CLI's entry, in the auto recipe's trial workers, in training (before
torch is imported) and in the benchmarks.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Mapping, MutableMapping
from dataclasses import dataclass

from spectratac.errors import SpectraTacError

#: The override: a positive integer, the threads of every toolkit process.
ENV = "SPECTRATAC_THREADS"
#: The math libraries' own thread counts, set for this process and inherited by children.
LIBRARY_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
#: Waiting OpenMP threads sleep rather than spin (kept if the user set it).
WAIT_POLICY = ("OMP_WAIT_POLICY", "PASSIVE")


class ThreadsConfigError(SpectraTacError, ValueError):
    """SPECTRATAC_THREADS holds something other than a positive integer."""


@dataclass(frozen=True)
class ThreadPolicy:
    """The decision for one process: `threads` for its math libraries, and why."""

    threads: int
    cpus: int  # CPUs this process may run on
    workers: int  # worker processes running at once
    source: str  # "share" (cpus // workers) or "SPECTRATAC_THREADS"

    def env(self) -> dict[str, str]:
        """Environment variables that give a process started now the same thread count."""
        return {name: str(self.threads) for name in LIBRARY_VARS}


def decide(cpus: int, workers: int = 1, override: str | None = None) -> ThreadPolicy:
    """The policy as a pure function: the override if given, else each of `workers`
    processes gets an equal share of `cpus`, at least one thread.

    >>> decide(2, 1).threads, decide(2, 2).threads, decide(8, 3).threads, decide(1, 4).threads
    (2, 1, 2, 1)
    """
    cpus, workers = max(1, cpus), max(1, workers)
    if override is not None and override.strip():
        try:
            n = int(override)
        except ValueError:
            n = 0
        if n < 1:
            raise ThreadsConfigError(
                f"{ENV}={override!r}: give a positive integer (threads per process), "
                f"or unset it to share the {cpus} CPU(s) among the toolkit's processes"
            )
        return ThreadPolicy(n, cpus, workers, ENV)
    return ThreadPolicy(max(1, cpus // workers), cpus, workers, "share")


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask, e.g. under taskset or a container's
    cpuset), not every core of the machine."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def policy(workers: int = 1, environ: Mapping[str, str] | None = None) -> ThreadPolicy:
    """The decision for this process when `workers` toolkit processes compute at once."""
    env = os.environ if environ is None else environ
    return decide(usable_cpus(), workers, env.get(ENV))


def child_env(
    workers: int, base: Mapping[str, str] | None = None
) -> tuple[ThreadPolicy, dict[str, str]]:
    """The policy for each of `workers` child processes and the environment to start them
    with (`base`, default os.environ, plus the thread variables)."""
    env = dict(os.environ if base is None else base)
    p = policy(workers, env)
    _set(env, p)
    return p, env


_applied: ThreadPolicy | None = None


def current() -> ThreadPolicy:
    """The policy last applied to this process (e.g. a trial worker's share), else the
    policy of a process that computes alone."""
    return _applied if _applied is not None else policy(1)


def apply(workers: int = 1) -> ThreadPolicy:
    """Apply the policy to this process: its environment (for libraries loaded later and for
    children) and torch's thread pools if torch is already imported."""
    global _applied
    p = _applied = policy(workers)
    _set(os.environ, p)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(p.threads)
        # only possible before torch's first parallel work; after it, torch keeps its pool
        with contextlib.suppress(RuntimeError):
            torch.set_num_interop_threads(1)
    return p


def _set(env: MutableMapping[str, str], p: ThreadPolicy) -> None:
    env.update(p.env())
    env.setdefault(*WAIT_POLICY)
