"""`LiveSession` without a browser: estimates with raw counts, the reference F/T aligned
and scored, the Snake driven, clips saved as CSV and as a recording the dataset builder
reads."""

from __future__ import annotations

import csv
import threading

import numpy as np
import pytest
from spectratac.apps.live.session import LiveSession
from spectratac.dataset.build import build_datasets
from spectratac.decode import Decoder
from spectratac.errors import SpectraTacError

from tests.apps.conftest import PRESSES_URL


@pytest.mark.slow
def test_session_publishes_estimates_reference_and_snake_and_saves_clips(
    press_model, tmp_path
) -> None:
    url = PRESSES_URL + "&speed=4&ft=bota"  # no ft_url: the link pairs its simulated Bota
    session = LiveSession(Decoder.load(press_model), url, out_dir=tmp_path)
    got: list[dict] = []
    done = threading.Event()

    def publish(msg: dict) -> None:
        got.append(msg)
        if msg.get("type") == "estimate" and msg["t"] > 2.2:  # 8.8 s of scene at speed 4
            done.set()

    session.start(publish)
    assert session.ft_url == url and session.scale == 4.0  # the link's facts (LinkInfo)
    try:
        assert done.wait(120)
        csv_clip = session.save(1.5, "csv")
        mcap_clip = session.save(1.5, "mcap")
        again = session.save(1.5, "csv")  # same second, same length: a new name, not over it
        assert again["path"] != csv_clip["path"]
        with pytest.raises(SpectraTacError, match="format"):
            session.save(1.0, "xlsx")
        with pytest.raises(SpectraTacError, match="seconds"):
            session.save(1e6, "csv")
    finally:
        session.stop()
    assert not session.running
    est = [m for m in got if m["type"] == "estimate"]
    assert [m["seq"] for m in est] == list(range(len(est)))
    t = np.array([m["t"] for m in est])
    assert t[0] == 0 and (np.diff(t) > 0).all()
    # speed 4: the page's time axis is host time, a quarter of the scene's 50 ms per sample
    assert np.median(np.diff(t)) == pytest.approx(0.05 / 4, rel=0.1)
    assert all(len(m["counts"]) == 12 and len(m["saturated"]) == 12 for m in est)
    refs = [r for m in est for r in m.get("refs", [])]
    assert len(refs) > 0.8 * len(est)
    pressed = [r for r in refs if r[4] < -1.5]  # reference Fz of a firm press
    assert pressed, "the scene's presses reach the reference F/T"
    by_seq = {m["seq"]: m for m in est}
    assert all(abs(by_seq[r[0]]["force"][2] - r[4]) < 1.0 for r in pressed)
    mae = est[-1]["mae"]
    assert 0 < mae["Fz"] < 0.5 and mae["Tx"] is None  # torques are not decoded
    lit = [m["region"] for m in est if m["contact"]]
    assert {2, 6, 8} <= set(lit)
    snake = [m for m in est if "snake" in m]
    assert [c["direction"] for m in snake for c in m.get("commands", [])][:3] == [
        "up", "right", "down"
    ]  # fmt: skip
    assert snake[-1]["snake"]["steps"] > 0
    stats = [m for m in got if m["type"] == "stats"]
    assert stats and stats[-1]["link"]["lost"] == 0 and stats[-1]["ft"]["received"] > 1000
    # clips
    with open(csv_clip["path"]) as f:
        rows = list(csv.DictReader(f))
    assert 20 <= len(rows) == csv_clip["rows"] <= 160
    assert rows[0]["s0.C"].isdigit() and any(r["ref_Fz"] for r in rows)
    (ds,) = build_datasets([mcap_clip["path"]])
    assert ds.n >= 20 and ds.target_valid.mean() > 0.5


@pytest.mark.slow
def test_session_refuses_what_it_cannot_open(press_model) -> None:
    session = LiveSession(Decoder.load(press_model), "socket://127.0.0.1:9", timeout=0.5)
    with pytest.raises(SpectraTacError):
        session.start(lambda msg: None)
    assert not session.running and session.sensor is None
