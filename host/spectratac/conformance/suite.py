"""Run every conformance check against one URL and summarise."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from spectratac.conformance.checks import CHECKS, Outcome, run_check
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
) -> SuiteResult:
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
    with sensor:
        for name, check in CHECKS:
            outcome = run_check(sensor, check)
            result.rows.append((name, outcome))
            if progress:
                progress(name, outcome)
    return result
