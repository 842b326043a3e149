"""`spectratac live` and `spectratac snake` from the command line: what they print, and
the exit codes of bad input (3: the message says what to do)."""

from __future__ import annotations

import json
import urllib.request

import pytest
from spectratac.cli import main

from tests.apps.conftest import PRESSES_URL


@pytest.mark.slow
def test_live_serves_its_page_for_the_given_time(press_model, capsys, tmp_path) -> None:
    code = main(["live", str(press_model), PRESSES_URL + "&speed=1", "--no-browser", "--json",
                 "--duration", "2", "-o", str(tmp_path)])  # fmt: skip
    assert code == 0
    url = json.loads(capsys.readouterr().out.splitlines()[0])["url"]
    assert url.startswith("http://127.0.0.1:")
    with pytest.raises(OSError):  # stopped: nothing listens any more
        urllib.request.urlopen(url, timeout=2)


@pytest.mark.slow
def test_live_without_a_model_serves_raw_counts_and_says_how_to_train(capsys, tmp_path) -> None:
    code = main(["live", PRESSES_URL + "&speed=1", "--no-browser", "--duration", "1.5",
                 "-o", str(tmp_path)])  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    assert "no model: raw counts and reference only" in out and "spectratac train" in out


def test_live_with_only_a_model_says_the_device_url_is_missing(tmp_path, capsys) -> None:
    model = tmp_path / "model.stac"
    assert main(["live", str(model), "--no-browser"]) == 3
    assert "give the device URL after it" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("speed", ["max", "10"])
def test_snake_json_prints_commands_then_the_outcome(press_model, capsys, speed) -> None:
    """--duration is the sensor's clock at any speed (as record's): the same 6.5 s of
    presses give the same three commands at speed=max and at speed=10."""
    code = main(["snake", str(press_model), PRESSES_URL + f"&speed={speed}", "--json",
                 "--duration", "6.5"])  # fmt: skip
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert code == 0
    assert [c["direction"] for c in lines[:-1]] == ["up", "right", "down"]
    assert lines[-1]["outcome"]["alive"] and lines[-1]["outcome"]["steps"] > 0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("args", "message"),
    [(["--grid", "4by4"], "--grid"), (["--map", "1=north"], "direction"),
     ([], "terminal")],
)  # fmt: skip
def test_snake_bad_input_exits_3_saying_what_to_do(press_model, capsys, args, message) -> None:
    assert main(["snake", str(press_model), PRESSES_URL, *args]) == 3  # stdout is no terminal
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(("args", "message"), [(["--threshold", "-1"], "--threshold: -1 is"),
                                               (["--tick", "0"], "--tick: 0 is")])  # fmt: skip
def test_snake_values_out_of_range_are_usage_errors(capsys, args, message) -> None:
    with pytest.raises(SystemExit) as exit_:  # refused by cli.values before the model loads
        main(["snake", "model.stac", PRESSES_URL, *args])
    assert exit_.value.code == 2 and message in capsys.readouterr().err


def test_live_refuses_a_missing_model(tmp_path, capsys) -> None:
    assert main(["live", str(tmp_path / "none.stac"), "sim://", "--no-browser"]) == 3
    assert "none.stac" in capsys.readouterr().err
