"""The bring-up plan, in order: each check gets the Bench and gives a Row; a check that raises
is a failed row naming the error, so one broken part of a board never hides the others. The
fault-record and watchdog checks reset the board, so they come last, the watchdog's at the
very end: a board whose watchdog never bites stays hung."""

from __future__ import annotations

import datetime
import functools
import time
from collections.abc import Callable

from spectratac.conformance.bringup import identity, leds, postmortem, sensing, soak, store
from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, SKIPPED, Report, Row
from spectratac.device.errors import DeviceError, DeviceNotFoundError, PermissionDeniedError

Check = Callable[[Bench], Row]
#: seconds of the device's clock the soak streams by default
SOAK_S = 20.0


def plan(soak_s: float = SOAK_S) -> list[tuple[str, Check]]:
    return [
        ("identity", identity.identity),
        ("clock", identity.clock),
        ("reset cause and fault record", postmortem.reset_cause),
        ("brown-out level", postmortem.brownout),
        ("sensors", sensing.sensors),
        ("TRIG latency", postmortem.trig_latency),
        ("sample rate", sensing.sample_rate),
        ("LED channels", leds.led_channels),
        ("model store", store.model_store),
        ("soak", functools.partial(soak.soak, seconds=soak_s)),
        ("clock drift", soak.clock_drift),
        ("fault record", postmortem.fault_record),
        ("watchdog", postmortem.watchdog),
    ]


def run_bringup(
    url: str,
    timeout: float = 2.0,
    soak_s: float = SOAK_S,
    progress: Callable[[str, Row | None], None] | None = None,
    into: Report | None = None,
) -> Report:
    """Run every check of the plan against `url`. Raises DeviceNotFoundError or
    PermissionDeniedError when there is no device to check; any other failure to open it is
    the identity check's failure. The rows go into `into` (a new Report by default), so that
    on Ctrl-C the caller still holds the checks done so far (marked `interrupted`)."""
    report = into if into is not None else Report(url, {})
    report.started_utc = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    checks = plan(soak_s)
    try:
        bench = Bench.open(url, timeout)
    except (DeviceNotFoundError, PermissionDeniedError):
        raise
    except DeviceError as exc:
        report.add(Row("identity", FAIL, f"{type(exc).__name__}: {exc}"))
        for name, _ in checks[1:]:
            report.add(Row(name, SKIPPED, "the device did not identify itself"))
        return report
    report.device = identity.device_facts(bench)
    try:
        for name, check in checks:
            if progress:
                progress(name, None)
            row = run_check(bench, name, check)
            report.add(row)
            if progress:
                progress(name, row)
    except KeyboardInterrupt:
        report.interrupted = True
        raise
    finally:
        bench.sensor.close()
    return report


def run_check(bench: Bench, name: str, check: Check) -> Row:
    started = time.monotonic()
    try:
        row = check(bench)
    except Exception as exc:  # a failing board gives a failed row, not a traceback
        row = Row(name, FAIL, f"{type(exc).__name__}: {exc}")
    row.seconds = time.monotonic() - started
    return row
