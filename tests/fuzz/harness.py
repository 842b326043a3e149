"""The fuzz loop: a fixed number of seeded mutations per target, any failure saved as a
regression input under tests/fuzz/regressions/<target>/.

The budget is SPECTRATAC_FUZZ_SECONDS (default DEFAULT_SECONDS: the whole fuzz suite then
takes about a minute on the CI machine): the host readers share PYTHON_SHARE of it by weight,
the native libFuzzer run the rest; each share becomes a fixed iteration count through the
target's measured rate. The count, not the clock, ends the loop, so a run
is the same on a fast and a slow machine and the same seed finds the same inputs.
"""

from __future__ import annotations

import hashlib
import os
import traceback
import tracemalloc
import warnings
from dataclasses import dataclass
from pathlib import Path

from tests.fuzz.mutate import Mutator
from tests.fuzz.targets import TARGETS, Target

REGRESSIONS = Path(__file__).resolve().with_name("regressions")
BUDGET_ENV = "SPECTRATAC_FUZZ_SECONDS"
SEED_ENV = "SPECTRATAC_FUZZ_SEED"
DEFAULT_SECONDS = 60.0
#: Every MEMORY_EVERY-th input runs under tracemalloc: its peak allocation must stay within
#: the target's memory_base + MEMORY_PER_BYTE x its size (bounded work: no header or length
#: field may make a reader allocate gigabytes).
MEMORY_EVERY = 16
MEMORY_PER_BYTE = 256
#: The host readers' share of the budget; the native libFuzzer run (test_native_fuzz) the rest.
PYTHON_SHARE = 0.75
#: libFuzzer runs per second of the core harness on the CI machine (measured: 12-25k).
NATIVE_PER_SECOND = 20_000.0


def budget_seconds() -> float:
    raw = os.environ.get(BUDGET_ENV)
    if raw is None:
        return DEFAULT_SECONDS
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"{BUDGET_ENV}={raw!r}: give the fuzz budget in seconds") from None
    if not value > 0:
        raise ValueError(f"{BUDGET_ENV}={raw!r}: the budget must be > 0 seconds")
    return value


def iterations(target: Target, seconds: float | None = None) -> int:
    """The fixed iteration count of `target` for a budget (whole suite) in seconds."""
    total_weight = sum(t.weight for t in TARGETS.values())
    total = budget_seconds() if seconds is None else seconds
    share = total * PYTHON_SHARE * target.weight / total_weight
    return max(10, int(share * target.per_second))


def native_runs(seconds: float | None = None) -> int:
    """The fixed libFuzzer run count of the native core harness for a budget in seconds."""
    total = budget_seconds() if seconds is None else seconds
    return max(1000, int(total * (1 - PYTHON_SHARE) * NATIVE_PER_SECOND))


@dataclass
class Finding:
    target: str
    path: Path
    error: str


def check_one(
    target: Target, data: bytes, workdir: Path, *, measure_memory: bool = False
) -> str | None:
    """None if `target` answered `data` with a result or an allowed error (within the memory
    bound when `measure_memory`); else what went wrong."""
    if measure_memory:
        tracemalloc.start()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # warnings are answers too (e.g. unit mismatch)
            target.run(data, workdir)
    except target.allowed:
        pass
    except Exception:  # the property under test: nothing else may escape
        return traceback.format_exc(limit=-3)
    finally:
        if measure_memory:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    if measure_memory and peak > target.memory_base + MEMORY_PER_BYTE * len(data):
        return f"MemoryBound: peak allocation {peak / 1e6:.0f} MB for {len(data)} input bytes"
    return None


def save_regression(target: Target, data: bytes) -> Path:
    folder = REGRESSIONS / target.name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{hashlib.sha1(data).hexdigest()[:16]}.bin"
    path.write_bytes(data)
    return path


def fuzz(target: Target, workdir: Path, count: int, seed: int = 0) -> list[Finding]:
    """Run `count` mutated inputs through `target`; save and return the failing ones (at
    most one per distinct error location, so one bug does not flood the folder)."""
    pool = target.make_seeds(workdir)
    mutator = Mutator(seed)
    findings: list[Finding] = []
    seen: set[str] = set()
    for data in pool:  # the seeds themselves must pass
        error = check_one(target, data, workdir)
        if error is not None:
            findings.append(Finding(target.name, save_regression(target, data), error))
    for i in range(count):
        base = mutator.rng.choice(pool)
        data = target.mutate(mutator, base, pool)
        error = check_one(target, data, workdir, measure_memory=i % MEMORY_EVERY == 0)
        if error is None:
            continue
        lines = error.strip().splitlines()
        where = lines[-1].split(":")[0] + (lines[-3] if len(lines) >= 3 else "")
        if where in seen:
            continue
        seen.add(where)
        findings.append(Finding(target.name, save_regression(target, data), error))
    return findings


def regression_inputs() -> list[tuple[str, Path]]:
    return (
        [
            (folder.name, path)
            for folder in sorted(REGRESSIONS.iterdir())
            if folder.is_dir() and folder.name in TARGETS
            for path in sorted(folder.glob("*.bin"))
        ]
        if REGRESSIONS.is_dir()
        else []
    )
