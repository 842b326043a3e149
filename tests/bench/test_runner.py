"""The suite's runner, `python -m tools.bench`: it lists every registered benchmark, every
script of tools/bench is registered (no orphans), a --quick run prints a ratio per benchmark
and keeps the results, two commits' results compare figure by figure, and --log appends rows
in the measurements log's format (to a copy here, never to the committed log)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tools.bench import __main__ as runner
from tools.bench import registry, results

ROW = re.compile(
    r"^\| (\d{4}-\d\d-\d\d) \| ([0-9a-f]{7}(?:-dirty)?|unknown) \| ([^|]+) \| ([^|]+) \| "
    r"([^|]+) \| (\d+\.\d) \| `python -m tools\.bench\.[a-z_]+[^`]*--json` \|$"
)


def bench(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "tools.bench", *args], cwd=cwd, capture_output=True, text=True,
        check=False,
    )  # fmt: skip


@pytest.mark.subprocess
def test_list_names_every_benchmark_with_its_commands(repo: Path) -> None:
    out = bench("--list", "--json", cwd=repo)
    assert out.returncode == 0, out.stderr
    listed = [json.loads(line) for line in out.stdout.splitlines()]
    assert [e["name"] for e in listed] == [b.name for b in registry.BENCHMARKS]
    for entry in listed:
        assert entry["description"] and entry["figure"]
        module = f"tools.bench.{registry.by_name()[entry['name']].module}"
        assert entry["quick"][:3] == entry["full"][:3] == ["python", "-m", module]
        assert entry["quick"][-1] == entry["full"][-1] == "--json"
    human = bench("--list", cwd=repo).stdout
    assert all(f"\n{b.name} " in f"\n{human}" for b in registry.BENCHMARKS)


def test_every_script_is_a_benchmark_or_a_helper(repo: Path) -> None:
    modules = {p.stem for p in (repo / "tools" / "bench").glob("*.py")}
    registered = {b.module for b in registry.BENCHMARKS}
    assert modules - registered - set(registry.HELPERS) == set(), "orphan scripts"
    assert registered - modules == set(), "registered but missing"
    assert len(registry.by_name()) == len(registry.BENCHMARKS), "a name registered twice"


def test_every_headline_is_a_regular_expression_of_a_name() -> None:
    for b in registry.BENCHMARKS:
        re.compile(b.headline)
        assert b.headline.startswith("^") and b.headline.endswith("$"), b.name


def test_an_unknown_name_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        runner.main(["no-such-bench"])
    assert exit_.value.code == 2 and "unknown benchmark no-such-bench" in capsys.readouterr().err


@pytest.mark.subprocess
def test_a_quick_run_prints_ratios_keeps_results_and_logs(repo: Path, tmp_path: Path) -> None:
    log = tmp_path / "MEASUREMENTS.md"
    if results.MEASUREMENTS.exists():
        shutil.copy(results.MEASUREMENTS, log)
    else:
        results.append_log(log, [])  # the header alone
    before = log.read_text().splitlines()
    kept = tmp_path / "results"
    out = bench("sim-device", "protocol", "--quick", "--json", "--results", str(kept), "--log",
                "--log-file", str(log), cwd=repo)  # fmt: skip
    assert out.returncode == 0, out.stderr
    lines = [json.loads(line) for line in out.stdout.splitlines()]  # --json: only JSON
    assert [r["bench"] for r in lines] == ["sim-device", "protocol"]
    by = {r["bench"]: r for r in lines}
    assert by["protocol"]["name"] == "incremental decoder" and by["protocol"]["ok"]
    for r in lines:
        assert r["ratio"] == pytest.approx(r["value"] / r["reference_value"]) and r["quick"]
    (path,) = kept.glob("*-quick.json")
    stored = json.loads(path.read_text())
    assert path.name == f"{stored['commit']}-quick.json" and stored["quick"] is True
    proto = stored["benchmarks"]["protocol"]
    assert proto["headline"] == "incremental decoder" and proto["returncode"] == 0
    assert {"date", "loadavg", "python", "machine"} <= set(proto)
    assert proto["command"] == registry.by_name()["protocol"].command(quick=True)
    # one row per figure, appended to the log's table, nothing else changed
    after = log.read_text().splitlines()
    n_figures = sum(len(r["figures"]) for r in lines)
    assert after[: len(before)] == before and len(after) == len(before) + n_figures
    for row in after[len(before) :]:
        assert ROW.match(row), row
    assert any("| protocol: incremental decoder |" in row for row in after[len(before) :])


def kept_results(path: Path, commit: str, ratios: dict[str, dict[str, float]]) -> Path:
    runs: dict[str, Any] = {}
    for bench_name, figures in ratios.items():
        runs[bench_name] = {
            "headline": next(iter(figures)),
            "figures": [
                {"name": n, "value": r, "unit": "s", "reference_name": "ref",
                 "reference_value": 1.0, "ratio": r, "extra": {}}
                for n, r in figures.items()
            ],
        }  # fmt: skip
    return results.save(path, commit, False, False, runs)


def test_compare_gives_the_ratio_of_ratios_per_figure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = kept_results(tmp_path, "a" * 40, {"twin": {"gen": 2.0, "pop": 4.0}, "ft": {"p": 1.0}})
    b = kept_results(tmp_path, "b" * 40, {"twin": {"pop": 5.0, "gen": 1.0}, "demo": {"d": 1.0}})
    assert runner.main(["compare", str(a), str(b), "--json"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [(r["bench"], r["figure"], r["headline"]) for r in rows] == [
        ("twin", "gen", True), ("twin", "pop", False)
    ]  # only what both measured, headline first
    assert rows[0]["b_over_a"] == 0.5 and rows[1]["b_over_a"] == 1.25
    # commits are found in the results folder by name; none kept is an error that says so
    assert runner.main(["compare", "a" * 40, "b" * 40, "--results", str(tmp_path)]) == 0
    assert "B/A 0.500" in capsys.readouterr().out
    with pytest.raises(SystemExit, match=f"no kept results of {'c' * 40}"):
        runner.main(["compare", "a" * 40, "c" * 40, "--results", str(tmp_path)])


def test_results_of_a_later_run_at_the_same_commit_are_merged(tmp_path: Path) -> None:
    kept_results(tmp_path, "a" * 40, {"twin": {"gen": 2.0}, "ft": {"p": 1.0}})
    path = kept_results(tmp_path, "a" * 40, {"twin": {"gen": 3.0}})
    kept = json.loads(path.read_text())["benchmarks"]
    assert kept["twin"]["figures"][0]["ratio"] == 3.0 and kept["ft"]["figures"][0]["ratio"] == 1.0


def test_log_rows_go_into_the_table_and_a_missing_log_is_created(tmp_path: Path) -> None:
    run = {
        "date": "2026-12-06T08:00:00+00:00", "loadavg": [1.234, 1.0, 1.0],
        "command": ["-m", "tools.bench.twin", "--rounds", "1", "--json"],
        "figures": [{"name": "gen | x", "value": 0.94, "unit": "s", "reference_name": "alloc",
                     "reference_value": 0.0069, "ratio": 136.2, "extra": {}}],
    }  # fmt: skip
    rows = results.log_rows("twin", run, "0123456789abcdef", dirty=True)
    assert rows == [
        "| 2026-12-06 | 0123456-dirty | twin: gen \\| x | 0.94 s (136.2×) | alloc: 0.0069 | 1.2 "
        "| `python -m tools.bench.twin --rounds 1 --json` |"
    ]
    assert ROW.match(rows[0].replace("\\|", "/"))
    fresh = tmp_path / "new" / "MEASUREMENTS.md"
    assert results.append_log(fresh, rows) == 1
    lines = fresh.read_text().splitlines()
    assert lines[-3].startswith("| date | commit | what | figure | reference (same run) | load |")
    assert lines[-1] == rows[0]
    # rows join the last table even when prose follows it
    trailing = tmp_path / "trailing.md"
    trailing.write_text("# Log\n\n| a |\n|---|\n| old |\n\nA closing note.\n")
    results.append_log(trailing, ["| new |"])
    assert trailing.read_text() == "# Log\n\n| a |\n|---|\n| old |\n| new |\n\nA closing note.\n"
