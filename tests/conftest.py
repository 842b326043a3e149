"""Shared fixtures: paths into the repository, and running a benchmark as a user would; and
the test tiers: tests that use a fixture which spawns processes, builds firmware or boots
QEMU get that marker here, so `make test-fast` leaves them out without each test saying so."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from spectratac import threads

from tests import processes, xdist_plan

REPO = Path(__file__).resolve().parents[1]
# The test process trains beside the processes it starts: it follows the thread policy too,
# before any test imports torch.
threads.apply()

Figures = dict[str, dict[str, Any]]
BENCH_TIMEOUT_S = 600  # generous: a bench script's own runs take seconds to a few minutes

# Fixture -> the markers (pyproject.toml) of every test that uses it, directly or not.
FIXTURE_MARKERS: dict[str, tuple[str, ...]] = {
    "run_bench": ("subprocess",),
    "pty_device": ("subprocess",),
    "tcp_device": ("subprocess",),
    "no_reply_pty": ("subprocess",),
    "image": ("firmware",),
    "native_build": ("firmware",),
    "qemu_port": ("qemu", "subprocess"),
    "press_model": ("train",),  # tests/apps: a decoder trained on scripted presses
}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        for fixture in getattr(item, "fixturenames", ()):
            for marker in FIXTURE_MARKERS.get(fixture, ()):
                item.add_marker(marker)
    if os.environ.get("PYTEST_XDIST_WORKER"):  # make test: the order units go out in
        xdist_plan.order(items)


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture()
def run_bench(repo: Path) -> Callable[..., Figures]:
    """run_bench("ft", "--records", "2000") -> --json figures of `python -m tools.bench.ft` by
    name (the benchmark alone, as the runner `python -m tools.bench` starts it)."""

    def run(module: str, *args: str) -> Figures:
        cmd = [sys.executable, "-m", f"tools.bench.{module}", *args, "--json"]
        try:
            code, out, err = processes.communicate_group(
                cmd, BENCH_TIMEOUT_S, cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.PIPE
            )
        except subprocess.TimeoutExpired:
            raise AssertionError(
                f"{module} {' '.join(args)} ran over {BENCH_TIMEOUT_S} s (stopped, with "
                f"every process it started)"
            ) from None
        if code != 0:  # what failed is on its stderr (the soak names devices)
            raise AssertionError(
                f"{module} {' '.join(args)} exited {code}; its stderr (end):\n{err[-6000:]}"
            )
        return {f["name"]: f for f in map(json.loads, out.splitlines())}

    return run


# CPU seconds each test used (this process and the children it waited for, setup and call),
# as the property cpu_s of the test's report (in --junitxml output): on a loaded machine a
# test's wall time says more about its neighbours than about the test.
def _cpu_seconds() -> float:
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    item.stash[CPU_AT_SETUP] = _cpu_seconds()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    if call.when == "call" and CPU_AT_SETUP in item.stash:
        item.user_properties.append(("cpu_s", round(_cpu_seconds() - item.stash[CPU_AT_SETUP], 3)))
    yield


CPU_AT_SETUP = pytest.StashKey[float]()

# Processes still running when a test process ends: killed, and named in the terminal summary
# so that the test that left them can be found. An xdist worker reaps its own after its session
# fixtures are torn down and tells the controller; the controller (or a serial run) reaps at
# unconfigure, once its workers are gone.
LEFT_BEHIND = "left_behind_processes"
_left_behind: list[str] = []


# multiprocessing's resource tracker is the interpreter's own singleton (started by the first
# spawn context, e.g. training's workers): it ends with this process, so it is not left behind.
_INTERPRETER_HELPERS = ("multiprocessing.resource_tracker",)


def _reap() -> list[str]:
    left = {
        pid: cmd
        for pid, cmd in processes.descendants().items()
        if not any(helper in cmd for helper in _INTERPRETER_HELPERS)
    }
    processes.kill_all(left)
    return [f"pid {pid}: {cmd}" for pid, cmd in left.items()]


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session: pytest.Session) -> None:
    if hasattr(session.config, "workeroutput"):
        session.config.workeroutput[LEFT_BEHIND] = _reap()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: object) -> None:  # xdist's hook, on the controller
    _left_behind.extend(getattr(node, "workeroutput", {}).get(LEFT_BEHIND, []))


def pytest_unconfigure(config: pytest.Config) -> None:
    if hasattr(config, "workeroutput"):
        return
    _left_behind.extend(_reap())
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if _left_behind and reporter is not None:
        reporter.write_sep("=", "processes left running by the tests (killed)", red=True)
        for line in _left_behind:
            reporter.write_line(line)
