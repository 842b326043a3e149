"""The public API type-checks: mypy (strict, configured in pyproject's [tool.mypy]) over the
device, F/T and protocol parts and the decoder's public classes fails the suite with its
own report, the way ruff does in test_lint.py."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.subprocess


def _mypy(repo: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """mypy with the project's configuration; its cache lives in the system's temporary
    folder (one per checkout) so that a second run takes a second or two."""
    if subprocess.run([sys.executable, "-m", "mypy", "--version"], capture_output=True).returncode:
        pytest.fail("mypy is a dev dependency; run `make test` to install it")
    key = hashlib.sha256(str(repo.resolve()).encode()).hexdigest()[:12]
    cache = Path(tempfile.gettempdir()) / f"spectratac-mypy-{key}"
    config = ["--config-file", "pyproject.toml", "--cache-dir", str(cache), "--no-error-summary"]
    cmd = [sys.executable, "-m", "mypy", *config, *args]
    return subprocess.run(cmd, cwd=repo, capture_output=True, text=True)


def test_public_api_type_checks(repo: Path) -> None:
    result = _mypy(repo)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_checker_catches_misuse_of_the_public_api(repo: Path, tmp_path: Path) -> None:
    """The configuration is strict enough to matter: wrong uses of the API are reported."""
    misuse = (
        "from spectratac.device import Sensor, RecordQueue\n"
        "from spectratac.protocol.generated import messages as m\n"
        "def f(s: Sensor) -> int:\n"
        "    status: m.Status = s.link.request(m.GetStatus(), m.Config)\n"  # replies are typed
        "    s.configure(estimates='sometimes')\n"
        "    return s.read(10)\n"
        "def g(x):\n"  # untyped definitions are refused
        "    return x\n"
    )
    (tmp_path / "misuse.py").write_text(misuse)
    result = _mypy(repo, str(tmp_path / "misuse.py"))
    assert result.returncode == 1, result.stdout + result.stderr
    for expected in (
        'expression has type "Config", variable has type "Status"',
        'Incompatible return value type (got "ndarray',
        'Argument "estimates" to "configure" of "Sensor" has incompatible type',
        "Function is missing a type annotation",
    ):
        assert expected in result.stdout, result.stdout
