"""`ft stream` ends when a streaming F/T sensor goes quiet: FTStalledError (exit code 3)
naming the sensor and --stall-timeout, after the records that came, instead of a silent
exit 1 (the old code broke off at the first empty read as if the count were reached)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.ft.base import FTSensor


def test_a_quiet_ft_stream_ends_with_the_stall_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real_read = FTSensor.read
    calls = {"n": 0}

    def goes_quiet(self: FTSensor, n: int, timeout: float | None = None) -> np.ndarray:
        calls["n"] += 1
        if calls["n"] == 1:
            return real_read(self, min(n, 5), timeout)
        rows: Any = real_read(self, 0, 0.0)  # the sensor sends nothing more
        return rows

    monkeypatch.setattr(FTSensor, "read", goes_quiet)
    url = "sim://?scene=idle&speed=10&ft=bota"
    code = main(["ft", "stream", url, "--count", "50", "--stall-timeout", "0.2", "--timeout", "5"])
    out, err = capsys.readouterr()
    assert code == 3, err
    assert f"{url} sent no F/T records for 0.2 s after 5" in err
    assert "--stall-timeout S" in err and len(out.splitlines()) >= 5
