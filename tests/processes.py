"""The processes a test run leaves behind: every live descendant of this process (read from
/proc), and stopping them. A `sim serve` started by a bench script that a timeout killed, or
by a test that failed before its cleanup, must not outlive the suite."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
from pathlib import Path
from typing import Any


def _parent_and_state(pid: int) -> tuple[int, str] | None:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:  # gone meanwhile
        return None
    # "pid (comm) state ppid ...": comm may hold spaces and parentheses; split after the last ")"
    state, ppid = stat[stat.rindex(")") + 2 :].split()[:2]
    return int(ppid), state


def descendants(root: int | None = None) -> dict[int, str]:
    """Live (not zombie) descendants of `root` (this process by default): pid -> command line."""
    root = os.getpid() if root is None else root
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (info := _parent_and_state(int(entry.name))) is not None:
            ppid, state = info
            if state != "Z":
                children.setdefault(ppid, []).append(int(entry.name))
    found: dict[int, str] = {}
    todo = list(children.get(root, []))
    while todo:
        pid = todo.pop()
        found[pid] = command_line(pid)
        todo += children.get(pid, [])
    return found


def command_line(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return "?"
    return raw.replace(b"\0", b" ").decode(errors="replace").strip()


def kill_all(pids: dict[int, str]) -> None:
    """SIGKILL each pid (one by one, by its own id); one already gone is fine."""
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def kill_group(pgid: int) -> None:
    """SIGKILL the process group `pgid` (a child started with start_new_session=True and
    whatever it started); an empty group is fine."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pgid, signal.SIGKILL)


def communicate_group(cmd: list[str], timeout: float, **popen: Any) -> tuple[int, str, str]:
    """Run `cmd` in its own session and return (exit code, stdout, stderr); on a timeout
    (subprocess.TimeoutExpired) or any failure the child and everything it started are
    killed, not orphaned as subprocess.run's kill of the child alone would leave them."""
    proc = subprocess.Popen(cmd, text=True, start_new_session=True, **popen)
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        kill_group(proc.pid)
        proc.wait()
    return proc.returncode, out or "", err or ""
