"""`LiveSession` without a browser: estimates with raw counts, the reference F/T aligned
and scored, the Snake driven, clips saved as CSV and as a recording the dataset builder
reads."""

from __future__ import annotations

import csv
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from spectratac.apps.live.session import NO_MODEL, LiveSession
from spectratac.dataset.build import build_datasets
from spectratac.dataset.labels import CONTACT_N
from spectratac.decode import Decoder
from spectratac.device.records import Sample
from spectratac.errors import SpectraTacError
from spectratac.ft.records import FT_RECORD
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record.reader import read_recording

from tests.apps.conftest import PRESSES_URL


class Received:
    """What the session published, and two moments of it: the scene 2.2 s in (8.8 s of scene
    at speed 4), and the reference caught up with the estimates. The reference F/T arrives on
    its own thread with its own lag; on a loaded host that lag spans dozens of estimates, so a
    session stopped on a host deadline ends with the latest estimates still unscored."""

    def __init__(self) -> None:
        self.messages: list[dict] = []
        self.estimates = self.refs = 0
        self.past_2_2_s = threading.Event()
        self.caught_up = threading.Event()

    def __call__(self, msg: dict) -> None:
        self.messages.append(msg)
        if msg.get("type") != "estimate":
            return
        self.estimates += 1
        self.refs += len(msg.get("refs", []))
        if msg["t"] > 2.2:
            self.past_2_2_s.set()
        if self.refs > CAUGHT_UP * self.estimates:
            self.caught_up.set()

    def wait_for_the_reference(self) -> None:
        """Until a message published from now on finds the reference caught up (bounded)."""
        self.caught_up.clear()
        assert self.caught_up.wait(300), (
            f"the reference F/T stayed behind: {self.refs} windows for {self.estimates} "
            f"estimates after 300 s"
        )


#: Reference windows per estimate at which the session is stopped; the tests ask for 0.8.
CAUGHT_UP = 0.9


@pytest.mark.slow
def test_session_publishes_estimates_reference_and_snake_and_saves_clips(
    press_model, tmp_path
) -> None:
    url = PRESSES_URL + "&speed=4&ft=bota"  # no ft_url: the link pairs its simulated Bota
    session = LiveSession(Decoder.load(press_model), url, out_dir=tmp_path)
    received = Received()
    got = received.messages
    session.start(received)
    assert session.ft_url == url and session.scale == 4.0  # the link's facts (LinkInfo)
    try:
        assert received.past_2_2_s.wait(300), "no estimate 2.2 s into the scene within 300 s"
        csv_clip = session.save(1.5, "csv")
        mcap_clip = session.save(1.5, "mcap")
        again = session.save(1.5, "csv")  # same second, same length: a new name, not over it
        assert again["path"] != csv_clip["path"]
        with pytest.raises(SpectraTacError, match="format"):
            session.save(1.0, "xlsx")
        with pytest.raises(SpectraTacError, match="seconds"):
            session.save(1e6, "csv")
        received.wait_for_the_reference()
    finally:
        session.stop()
    assert not session.running
    est = [m for m in got if m["type"] == "estimate"]
    assert [m["seq"] for m in est] == list(range(len(est)))
    t = np.array([m["t"] for m in est])
    assert t[0] == 0 and (np.diff(t) > 0).all()
    # speed 4: the page's time axis is host time, a quarter of the scene's 50 ms per sample
    assert np.median(np.diff(t)) == pytest.approx(0.05 / 4, rel=0.1)
    n_counts = vocab.N_SENSORS * len(vocab.CHANNELS)  # every channel, IR too
    assert all(len(m["counts"]) == n_counts == len(m["saturated"]) for m in est)
    refs = [r for m in est for r in m.get("refs", [])]
    assert len(refs) > 0.8 * len(est)
    pressed = [r for r in refs if r[4] < -1.5]  # reference Fz of a firm press
    assert pressed, "the scene's presses reach the reference F/T"
    by_seq = {m["seq"]: m for m in est}
    assert all(abs(by_seq[r[0]]["force"][2] - r[4]) < 1.0 for r in pressed)
    mae = est[-1]["mae"]
    assert 0 < mae["Fz"] < 0.5 and mae["Tx"] is None  # torques are not decoded
    # the MAE in contact: over the windows whose reference |F| reaches the dataset
    # builder's contact threshold, recomputed here from what the page received
    in_contact = [r for r in refs if np.linalg.norm(r[2:5]) >= CONTACT_N]
    assert 0 < len(in_contact) < len(refs)
    want = np.mean([abs(by_seq[r[0]]["force"][2] - r[4]) for r in in_contact])
    assert est[-1]["mae_contact"]["Fz"] == pytest.approx(want, abs=2e-4)
    assert est[-1]["mae_contact"]["Fz"] != pytest.approx(mae["Fz"], abs=1e-6)
    lit = [m["region"] for m in est if m["contact"]]
    assert {2, 6, 8} <= set(lit)
    snake = [m for m in est if "snake" in m]
    assert [c["direction"] for m in snake for c in m.get("commands", [])][:3] == [
        "up", "right", "down"
    ]  # fmt: skip
    assert snake[-1]["snake"]["steps"] > 0
    stats = [m for m in got if m["type"] == "stats"]
    assert stats and stats[-1]["link"]["lost"] == 0 and stats[-1]["ft"]["received"] > 1000
    final = session.stats()  # what the session reports: both figures, and over how much
    assert final["mae_contact"]["Fz"] > 0 and final["mae"]["Fz"] > 0
    # a user's session times nothing for a benchmark and tells the page not to report
    assert session.meta()["benchmark"] is False and "latency" not in final
    timed = [session.pipeline.summary(), *session.stages.summary().values()]
    assert [s["n"] for s in timed] == [0, 0, 0]
    assert 0 < final["windows"]["in_contact"] < final["windows"]["scored"]
    # clips
    with open(csv_clip["path"]) as f:
        rows = list(csv.DictReader(f))
    assert 20 <= len(rows) == csv_clip["rows"] <= 160
    assert rows[0]["s0.C"].isdigit() and any(r["ref_Fz"] for r in rows)
    (ds,) = build_datasets([mcap_clip["path"]])
    assert ds.n >= 20 and ds.target_valid.mean() > 0.5
    # the MCAP clip holds the page's estimates too (/spectratac/estimates), as the CSV has them
    clip = read_recording(mcap_clip["path"])
    # on the sensor's clock (record.timeline): at speed=4 its samples span 4x their host time
    from mcap.reader import make_reader

    with open(mcap_clip["path"], "rb") as f:
        found = make_reader(f).iter_messages(topics=["/spectratac/counts"])
        log, pub = np.array([(m.log_time, m.publish_time) for _, _, m in found]).T
    assert np.ptp(log) == pytest.approx(4 * np.ptp(pub), rel=0.1)
    assert len(clip.estimates) >= 20 and {e["source"] for e in clip.estimates} == {"host"}
    csv_fz = {round(float(r["device_time_s"]) * 1e6): float(r["Fz"]) for r in rows}
    shared = [e for e in clip.estimates if e["t_end_us"] in csv_fz]
    assert len(shared) >= 10
    assert all(e["force"]["z"] == pytest.approx(csv_fz[e["t_end_us"]]) for e in shared)
    # ... and a ROS user gets them from the clip without the model: the exporter writes the
    # recorded estimates (rosbags' own reader here, not ours)
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    from spectratac.ros2 import export_rosbag

    summary = export_rosbag(mcap_clip["path"], mcap_clip["path"] + ".bag")
    assert any("estimates as recorded" in n for n in summary.notes)
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(mcap_clip["path"] + ".bag") as reader:
        bag_fz = [
            store.deserialize_cdr(raw, conn.msgtype).wrench.force.z
            for conn, _, raw in reader.messages()
            if conn.topic == "/spectratac/estimate/wrench"
        ]
    valid = [e["force"]["z"] for e in clip.estimates if not e["invalid"]]
    valid = [v for v in valid if v is not None]
    assert 0.9 * len(valid) <= len(bag_fz) <= len(valid)  # each stamped by its own sample
    assert set(np.round(bag_fz, 5)) <= set(np.round(valid, 5))


@pytest.mark.slow
def test_session_without_a_model_publishes_raw_counts_and_the_reference(tmp_path) -> None:
    url = PRESSES_URL + "&speed=4&ft=bota"
    # with the benchmark's instruments on (tools/bench/live.py), which time every sample
    session = LiveSession(None, url, out_dir=tmp_path, benchmark=True)
    received = Received()
    got = received.messages
    session.start(received)
    try:
        assert received.past_2_2_s.wait(300), "no estimate 2.2 s into the scene within 300 s"
        meta = session.meta()
        clip = session.save(1.5, "csv")
        received.wait_for_the_reference()
    finally:
        session.stop()
    assert meta["model"] is None and meta["no_model"]["note"] == NO_MODEL
    assert "spectratac train" in meta["no_model"]["hint"]
    est = [m for m in got if m["type"] == "estimate"]
    assert [m["seq"] for m in est] == list(range(len(est)))
    assert all(m["force"] is None and m["region"] is None for m in est)
    assert all(len(m["counts"]) == vocab.N_SENSORS * len(vocab.CHANNELS) for m in est)
    assert all("mae" not in m and "snake" not in m for m in est)
    refs = [r for m in est for r in m.get("refs", [])]
    assert len(refs) > 0.8 * len(est) and any(r[4] < -1.5 for r in refs)  # the presses
    stats = session.stats()
    assert "mae" not in stats
    # a benchmark's session times each sample's way and reports the page's figures
    assert meta["benchmark"] is True and {"latency", "echo", "bare", "pipeline"} <= set(stats)
    assert stats["pipeline"]["n"] == len(est) <= session.stages.summary()["taken"]["n"]
    with open(clip["path"]) as f:
        rows = list(csv.DictReader(f))
    assert rows and rows[0]["Fz"] == "" and rows[0]["s0.C"].isdigit()
    assert any(r["ref_Fz"] for r in rows)


@pytest.mark.slow
def test_session_refuses_what_it_cannot_open(press_model) -> None:
    session = LiveSession(Decoder.load(press_model), "socket://127.0.0.1:9", timeout=0.5)
    with pytest.raises(SpectraTacError):
        session.start(lambda msg: None)
    assert not session.running and session.sensor is None


@pytest.mark.slow
def test_concurrent_saves_through_the_server_give_distinct_complete_clips(
    press_model, tmp_path
) -> None:
    from concurrent.futures import ThreadPoolExecutor

    from spectratac.apps.live.server import LiveServer, bind
    from spectratac.record.reader import read_recording

    from tests.apps.live.clients import http_request

    session = LiveSession(Decoder.load(press_model), PRESSES_URL + "&speed=4&ft=bota",
                          out_dir=tmp_path)  # fmt: skip
    server = LiveServer(session, bind(0)).start()
    port = server.sock.getsockname()[1]
    headers = {"Content-Type": "application/json", "X-SpectraTac-Token": server.token}

    def save(fmt: str) -> dict:
        body = f'{{"seconds": 1, "format": "{fmt}"}}'.encode()
        answer = http_request(port, "POST", "/api/save", headers=headers, body=body)
        assert answer.status == 200, answer
        return answer.json()

    try:
        deadline = time.monotonic() + 120
        while session.estimates < 40:  # a second of history at speed 4
            assert time.monotonic() < deadline, "no estimates within 120 s"
            time.sleep(0.05)
        with ThreadPoolExecutor(12) as pool:  # all within the same second: the same stem
            clips = list(pool.map(save, ["mcap"] * 8 + ["csv"] * 4))
    finally:
        server.stop()
    paths = [c["path"] for c in clips]
    assert len(set(paths)) == 12
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(Path(p).name for p in paths)
    for clip in clips[:8]:
        rec = read_recording(clip["path"])
        assert not rec.truncated and rec.end is not None, rec.problem
        assert len(rec.frames) == clip["frames"] > 0
    for clip in clips[8:]:
        with open(clip["path"]) as f:
            assert len(list(csv.DictReader(f))) == clip["rows"] > 0


def test_a_clip_name_taken_meanwhile_is_never_overwritten(tmp_path) -> None:
    from spectratac.apps.live.session import _link_unique

    (tmp_path / "clip.csv").write_text("first")
    (tmp_path / "clip-2.csv").write_text("second")
    tmp = tmp_path / ".clip.partial"
    tmp.write_text("third")
    assert _link_unique(tmp, tmp_path, "clip", "csv") == tmp_path / "clip-3.csv"
    assert [(tmp_path / n).read_text() for n in ("clip.csv", "clip-2.csv", "clip-3.csv")] == [
        "first", "second", "third"
    ]  # fmt: skip


@pytest.mark.slow
def test_an_estimate_is_published_before_the_worker_waits_on_the_ft_queue(press_model) -> None:
    """The reference reads the F/T reader's queue (under the lock its thread takes for every
    batch) and averages windows; an estimate no longer waits for that: each one decoded is
    published before the worker touches the F/T queue, and the windows the reference then
    completes (older estimates') go with the next message."""
    url = PRESSES_URL + "&speed=4&ft=bota"
    decoder = Decoder.load(press_model)
    session = LiveSession(decoder, url)
    decoded = 0
    stream = decoder.stream

    def counting(*args, **kwargs):
        nonlocal decoded
        for est in stream(*args, **kwargs):
            decoded += 1
            yield est

    decoder.stream = counting  # type: ignore[method-assign]
    published: list[int] = []
    seen: list[tuple[int, int]] = []  # (decoded, published) whenever the F/T queue is read
    held, release = threading.Event(), threading.Event()

    def publish(msg: dict) -> None:
        if msg["type"] == "estimate":
            published.append(msg["seq"])

    session.start(publish)
    read_available = session.ft.read_available

    def watched():
        seen.append((decoded, len(published)))
        if len(published) >= 20 and not held.is_set():
            held.set()  # the F/T reader holds its lock for a while: the worker waits here
            release.wait(60)
        return read_available()

    session.ft.read_available = watched
    try:
        assert held.wait(300), "no 20 estimates within 300 s"
        time.sleep(0.2)  # whatever the worker could still publish while it waits
        waiting_at = (decoded, len(published))
        release.set()
        deadline = time.monotonic() + 300
        while len(published) < waiting_at[1] + 20:
            assert time.monotonic() < deadline, "the worker did not go on after the F/T wait"
            time.sleep(0.05)
    finally:
        release.set()
        session.stop()
    assert seen and all(d == p for d, p in seen), seen[:5]
    assert waiting_at[0] == waiting_at[1]  # nothing decoded sat unpublished during the wait
    assert published == list(range(len(published)))


class _Backlog:
    """A sensor whose samples all came at once (a worker that fell behind): `buffered` says
    how many wait behind the one taken."""

    def __init__(self, n: int) -> None:
        counts = ((100,) * len(vocab.CHANNELS),) * vocab.N_SENSORS
        self.samples = [Sample(50_000 * (k + 1), 50_000 * k + 10_000, 100.0 + 0.05 * k, k, 0,
                               1, counts, (0,) * vocab.N_SENSORS) for k in range(n)]  # fmt: skip
        self.taken = 0
        self.stats = SimpleNamespace(samples_received=n, sample_gaps=0, crc_errors=0,
                                     cobs_errors=0, other_frame_errors=0, frame_gaps=0,
                                     buffer_overflows=0, reconnects=0)  # fmt: skip

    @property
    def buffered(self) -> int:
        return len(self.samples) - self.taken

    def __iter__(self):
        for sample in self.samples:
            self.taken += 1
            yield sample


class _CountingFT:
    def __init__(self) -> None:
        self.reads = 0
        self.info = SimpleNamespace(extra={})
        self.stats = SimpleNamespace(received=0, lost=0)

    def read_available(self) -> np.ndarray:
        self.reads += 1
        return np.empty(0, dtype=FT_RECORD)


def test_a_worker_behind_decodes_what_waits_before_the_reference_work() -> None:
    # beside other work the worker fell behind (frame read -> taken p99 4.7 s at load 20),
    # and each waiting sample also waited for the reference work of every one before it
    session = LiveSession(None, PRESSES_URL)
    session.sensor, session.ft = _Backlog(12), _CountingFT()  # type: ignore[assignment]
    published: list[dict] = []
    session._decode(published.append)
    assert [m["seq"] for m in published if m["type"] == "estimate"] == list(range(12))
    assert session.ft.reads == 1  # once the backlog was decoded, for all twelve windows


@pytest.mark.parametrize(
    ("where", "error"),
    [("mkdir", PermissionError(13, "Permission denied")), ("write", OSError(28, "No space left"))],
)
def test_a_clip_that_cannot_be_written_is_a_typed_error_and_leaves_nothing(
    tmp_path, monkeypatch: pytest.MonkeyPatch, where: str, error: OSError
) -> None:
    """A read-only or full clip folder (injected: the tests may run as root, where chmod does
    not stop a write) answers with ClipSaveError naming the folder, not an OSError that the
    server would turn into a 500; no partial clip is left behind."""
    from spectratac.apps.live.session import ClipSaveError

    out = tmp_path / "clips"
    session = LiveSession(None, PRESSES_URL, out_dir=out)
    session.sensor = SimpleNamespace()  # as if started: save() reads the history only

    def fail(*_args: object, **_kwargs: object) -> None:
        raise error

    if where == "mkdir":
        monkeypatch.setattr(Path, "mkdir", fail)
    else:
        monkeypatch.setattr(session.history, "save_csv", fail)
    with pytest.raises(ClipSaveError, match=r"cannot save the clip into .*clips: .*-o/--output"):
        session.save(1.0, "csv")
    assert not out.exists() or list(out.iterdir()) == []


@pytest.mark.slow
def test_a_worker_that_never_catches_up_still_scores_in_bounded_batches(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Forced to be always behind, the worker holds at most MAX_UNSCORED estimates for their
    reference and publishes the windows batch by batch (it used to hold every estimate and
    publish no reference at all: memory grew for as long as the page ran)."""
    from spectratac.apps.live import session as live_session

    monkeypatch.setattr(live_session, "MAX_UNSCORED", 20)
    monkeypatch.setattr(LiveSession, "_samples_waiting", lambda self: True)
    batches: list[int] = []
    reference = LiveSession._reference

    def counted(self, tracker, clock, unscored, t0):  # type: ignore[no-untyped-def]
        batches.append(len(unscored))
        return reference(self, tracker, clock, unscored, t0)

    monkeypatch.setattr(LiveSession, "_reference", counted)
    session = LiveSession(None, PRESSES_URL + "&speed=4&ft=bota", out_dir=tmp_path)
    received = Received()
    session.start(received)
    try:
        assert received.past_2_2_s.wait(300), "no estimate 2.2 s into the scene within 300 s"
    finally:
        session.stop()
    assert batches and set(batches) == {20}
    assert received.refs > 0
