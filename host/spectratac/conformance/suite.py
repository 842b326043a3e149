"""Run every conformance check against one URL and summarise."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from spectratac.conformance import model_checks
from spectratac.conformance.checks import CHECKS, Outcome, run_check
from spectratac.conformance.model_checks import ModelSession, TestModel
from spectratac.device import Sensor
from spectratac.device.errors import DeviceError, DeviceNotFoundError, PermissionDeniedError


@dataclass
class SuiteResult:
    url: str
    rows: list[tuple[str, Outcome]] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return bool(self.rows) and all(o.passed for _, o in self.rows)

    def as_dict(self) -> dict[str, object]:
        return {
            "url": self.url,
            "passed": self.passed,
            "checks": [{"name": n, "passed": o.passed, "detail": o.detail} for n, o in self.rows],
        }


def run_suite(
    url: str,
    timeout: float = 2.0,
    progress: Callable[[str, Outcome], None] | None = None,
    model: TestModel | None = None,
) -> SuiteResult:
    """Every check of checks.CHECKS, then the model checks the device's capabilities call for
    (model_checks; they upload `model`, by default the packaged TestModel, and erase it at
    the end)."""
    result = SuiteResult(url)
    try:
        sensor = Sensor.open(url, timeout=timeout)
    except (DeviceNotFoundError, PermissionDeniedError):
        raise  # nothing to check: an error (exit 3), not a failed check
    except DeviceError as exc:
        outcome = Outcome(False, str(exc))
        result.rows.append(("handshake, version and definition hash", outcome))
        if progress:
            progress(result.rows[0][0], outcome)
        return result
    session = ModelSession(sensor, model or TestModel.packaged(), lambda: _reopen(session, timeout))
    try:
        for name, check in CHECKS:
            _record(result, name, run_check(session.sensor, check), progress)
        for name, model_check in model_checks.applicable(sensor.info.capabilities):
            _record(result, name, run_check(session, model_check), progress)
    finally:
        session.sensor.close()
    return result


def _record(
    result: SuiteResult,
    name: str,
    outcome: Outcome,
    progress: Callable[[str, Outcome], None] | None,
) -> None:
    result.rows.append((name, outcome))
    if progress:
        progress(name, outcome)


def _reopen(session: ModelSession, timeout: float) -> Sensor:
    """Close the link and connect again (a simulated device boots afresh)."""
    url = session.sensor.url
    session.sensor.close()
    return Sensor.open(url, timeout=timeout)
