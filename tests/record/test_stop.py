"""The stop request a signal handler makes: the old mechanism (Event.set in the handler)
deadlocks when the signal lands while the waiting thread holds the event's lock; the
StopRequest cannot, wherever the signal lands in its wait."""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any

import pytest
from spectratac.record.stop import StopRequest, stop_handler, stopping_on

GENEROUS_S = 10.0  # bounds waits that end at once when the code is right


def _old_handler(stop: threading.Event) -> Callable[[int, Any], None]:
    """record_cmd's handler before issue 25: Event.set() inside the signal handler."""

    def handler(_signum: int, _frame: Any) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()

    return handler


def test_event_set_in_a_handler_deadlocks_while_wait_holds_the_lock() -> None:
    """The reproduction: Python runs the handler in the thread that was interrupted; if
    that thread was inside Event.wait, holding the event's non-reentrant lock, set() waits
    for itself forever."""
    stop = threading.Event()
    handler = _old_handler(stop)

    def waiting_thread_interrupted_inside_wait() -> None:
        with stop._cond:  # type: ignore[attr-defined]  # what Event.wait holds around its checks
            handler(signal.SIGINT, None)

    t = threading.Thread(target=waiting_thread_interrupted_inside_wait, daemon=True)
    t.start()
    t.join(2.0)
    assert t.is_alive(), "Event.set() in a handler should deadlock here (the issue's bug)"
    # (the daemon thread stays blocked on a lock nobody else uses; it ends with the process)


def _signal_at_line(
    line: int, run: Callable[[], object], handler: Callable[[int, Any], None], names: set[str]
) -> tuple[bool, list[object]]:
    """Run `run` in a worker thread (bounded by GENEROUS_S), invoking `handler` at the
    `line`-th line event inside the functions named `names`, as a signal landing exactly
    there would; whether it fired, and what `run` returned."""
    seen = 0
    fired = False

    def tracer(frame: FrameType, event: str, _arg: Any) -> Any:
        nonlocal seen, fired
        if frame.f_code.co_name not in names:
            return tracer if event == "call" else None
        if event == "line":
            if seen == line and not fired:
                fired = True
                handler(signal.SIGINT, frame)
            seen += 1
        return tracer

    box: list[object] = []

    def body() -> None:
        sys.settrace(tracer)
        try:
            box.append(run())
        finally:
            sys.settrace(None)

    t = threading.Thread(target=body, daemon=True)
    t.start()
    t.join(GENEROUS_S)
    assert not t.is_alive(), f"deadlocked with the signal at line event {line}"
    return fired, box


def _signal_at_every_line(
    run: Callable[[], object], handler: Callable[[int, Any], None], names: set[str]
) -> list[object]:
    """`_signal_at_line` for every line event of `names` in turn; every run's result."""
    results: list[object] = []
    line = 0
    while True:
        fired, box = _signal_at_line(line, run, handler, names)
        if not fired:
            return results
        results.extend(box)
        line += 1


def test_a_signal_anywhere_in_stop_request_wait_cannot_deadlock() -> None:
    """The same landing spots as above, for every line of StopRequest.wait: the handler
    returns, and the wait reports the stop (a short bound: a signal landing after `select`
    returned is seen by the `return` line)."""
    holder: list[StopRequest] = []

    def fresh_wait() -> object:
        stop = StopRequest()
        holder.append(stop)
        try:
            return stop.wait(0.5)
        finally:
            stop.close()

    def handler(signum: int, frame: Any) -> None:
        stop_handler(holder[-1])(signum, frame)

    outcomes = _signal_at_every_line(fresh_wait, handler, {"wait"})
    assert len(outcomes) >= 3  # the check, the select, the return
    assert all(outcomes), "every wait that the signal reached reports the stop"


def test_a_real_signal_wakes_the_wait_at_once() -> None:
    with StopRequest() as stop, stopping_on(stop, (signal.SIGUSR2,)):
        threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGUSR2)).start()
        assert stop.wait(GENEROUS_S) is True  # woken by the self-pipe, not by the bound
        with pytest.raises(KeyboardInterrupt):  # a second signal: the user insists
            os.kill(os.getpid(), signal.SIGUSR2)
            stop.wait(GENEROUS_S)
    assert signal.getsignal(signal.SIGUSR2) is signal.SIG_DFL  # the old handler is back


def test_set_from_another_thread_wakes_every_waiter() -> None:
    with StopRequest() as stop:
        woke: list[bool] = []
        waiters = [
            threading.Thread(target=lambda: woke.append(stop.wait(GENEROUS_S))) for _ in range(3)
        ]
        for w in waiters:
            w.start()
        stop.set()
        for w in waiters:
            w.join(GENEROUS_S)
        assert woke == [True, True, True]
