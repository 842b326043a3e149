"""Bota driver: against the simulated sensor (real frames on a pty, its command set), and
against a scripted port that sends garbage, damaged frames, or nothing at all."""

from __future__ import annotations

import re
import threading

import numpy as np
import pytest
from spectratac.ft import (
    FTDisconnectedError,
    FTNotFoundError,
    FTSensor,
    FTTimeoutError,
    FTURLError,
    botaframe,
    open_ft,
)
from spectratac.sim.ft_bota import BotaServer
from spectratac.sim.ft_source import FTParams, FTSource
from spectratac.sim.url import parse_sim_url
from spectratac.sim.world import SimWorld

from tests.ft.fake_bota import FakePort


def frames(first: int, n: int, period_us: int = 1000) -> bytes:
    k = np.arange(first, first + n)
    forces = np.zeros((n, 6))
    forces[:, 2] = -k  # Fz tells which frame it was
    return botaframe.encode_frames(np.zeros(n), forces, k * period_us + 500, np.full(n, 30.0))


def test_sim_handshake_and_stream(world: SimWorld) -> None:
    server = BotaServer(FTSource(world, FTParams(loss=0.0)))
    try:
        with open_ft(server.url, timeout=2.0) as ft:
            assert ft.info.kind == "bota"
            rows = ft.read(500, timeout=10.0)
            assert ft.temperature_c == pytest.approx(31.5)  # type: ignore[attr-defined]
        assert len(rows) == 500
        assert ft.info.rate_hz == pytest.approx(1000.0)
        assert np.all(np.diff(rows["sequence"].astype(np.int64)) == 1)
        np.testing.assert_allclose(np.diff(rows["sensor_time"]), 1e-3, atol=2e-6)
        assert ft.stats.lost == 0 and ft.stats.crc_errors == 0
    finally:
        server.stop()


def test_sim_writes_paced_frames_in_batches_like_a_usb_adapter() -> None:
    # one write per 1 kHz frame woke the simulation and the host's reader 1,000 times a
    # second each: GIL hand-overs that delayed the live page's threads in the same process
    world = SimWorld.join(parse_sim_url("sim://?scene=calibration&seed=3&speed=1"))
    server = BotaServer(FTSource(world, FTParams(loss=0.0)))
    sizes: list[int] = []
    write = server._write

    def counted(data: bytes) -> bool:
        if len(data) % botaframe.FRAME_SIZE == 0:  # frames, not a command's reply
            sizes.append(len(data) // botaframe.FRAME_SIZE)
        return write(data)

    server._write = counted  # type: ignore[method-assign]
    try:
        with open_ft(server.url, timeout=2.0) as ft:
            rows = ft.read(400, timeout=10.0)
        assert len(rows) == 400 and np.all(np.diff(rows["sequence"].astype(np.int64)) == 1)
        # 10 ms of 1 kHz frames per write (more when the thread runs late), never one by one
        assert len(sizes) >= 10 and np.median(sizes) >= 8, sizes
    finally:
        server.stop()
        world.release()


def test_sim_filter_setup_sets_the_rate(world: SimWorld) -> None:
    server = BotaServer(FTSource(world, FTParams(loss=0.0)))
    try:
        with open_ft(server.url + "?sinc=128") as ft:  # 128 / 51200 s = 2.5 ms
            rows = ft.read(50, timeout=10.0)
        assert ft.info.rate_hz == 400.0
        np.testing.assert_allclose(np.diff(rows["sensor_time"]), 2.5e-3, atol=2e-6)
        assert np.all(np.diff(rows["sequence"].astype(np.int64)) == 1)
    finally:
        server.stop()


def test_sim_loss_shows_as_crc_errors_and_gaps(world: SimWorld) -> None:
    server = BotaServer(FTSource(world, FTParams(loss=0.03)))
    try:
        with open_ft(server.url) as ft:
            rows = ft.read(3000, timeout=10.0)
            ft.stop()
            rows = np.concatenate([rows, ft.read(10**6, timeout=0.3)])
            st = ft.stats
        gaps = np.diff(rows["sequence"].astype(np.int64)) - 1
        assert st.lost == int(gaps.sum()) > 0
        assert 0 < st.crc_errors <= st.lost  # damaged frames are lost frames too
        assert server.corrupted > 0 and server.dropped > 0
    finally:
        server.stop()


def scripted(port: FakePort, *chunks: bytes) -> FTSensor:
    """A driver on the fake port without the command handshake; the chunks then arrive."""
    ft = open_ft(f"bota://{port.path}?configure=0&rate=1000")
    ft.start()
    for c in chunks:
        port.write(c)
    return ft


def test_garbage_and_damage_lose_only_damaged_frames() -> None:
    port = FakePort()
    try:
        damaged = bytearray(frames(5, 1))
        damaged[10] ^= 0x40
        ft = scripted(
            port,
            b"App Init\r\n" + frames(0, 3),
            b"noise\xaa\xaa\x13" + frames(3, 2),  # noise with false headers between frames
            bytes(damaged) + frames(6, 4)[:50],  # a bad CRC, then a frame split in two writes
            frames(6, 4)[50:] + frames(10, 5)[:-3],  # ...and a truncated last frame
        )
        with ft:
            rows = ft.read(13, timeout=5.0)
            assert ft.read(1, timeout=0.2).size == 0  # the truncated frame never completes
        got = (-rows["wrench"][:, 2]).astype(int).tolist()
        assert got == [0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11, 12, 13]  # 5 damaged, 14 truncated
        assert rows["sequence"].tolist() == got
        assert ft.stats.crc_errors == 1 and ft.stats.bad_frames == 1  # damage, lost sync
        assert ft.stats.lost == 1 and ft.stats.gaps == 1
    finally:
        port.close()


def test_timestamps_unwrap_past_32_bits() -> None:
    port = FakePort()
    try:
        k = np.arange(5)
        ts = (2**32 - 2500 + k * 1000) % 2**32  # wraps between the 3rd and 4th frame
        wire = botaframe.encode_frames(np.zeros(5), np.zeros((5, 6)), ts, np.full(5, 25.0))
        with scripted(port, wire) as ft:
            rows = ft.read(5, timeout=5.0)
        np.testing.assert_allclose(np.diff(rows["sensor_time"]), 1e-3)
        assert rows["sequence"].tolist() == [0, 1, 2, 3, 4]
    finally:
        port.close()


def test_silent_port_times_out_with_advice() -> None:
    port = FakePort()
    try:
        with pytest.raises(FTTimeoutError, match=r"no reply 'r,0,C,0' .*Bota"):
            open_ft(f"bota://{port.path}", timeout=0.5)
        assert b"C" in port.read_available()  # it asked, more than once
    finally:
        port.close()


def test_unplugged_port_raises_after_rows_are_read() -> None:
    port = FakePort()
    ft = scripted(port, frames(0, 20))
    try:
        first = ft.read(20, timeout=5.0)
        assert len(first) == 20
        port.close()
        with pytest.raises(FTDisconnectedError, match="reopen"):
            for _ in range(50):
                ft.read(1, timeout=0.1)
    finally:
        ft.close()


def test_missing_port_and_bad_options() -> None:
    with pytest.raises(FTNotFoundError, match="no serial port /dev/ttyNOPE"):
        open_ft("bota:///dev/ttyNOPE")
    with pytest.raises(FTURLError, match="baud=1234"):
        open_ft("bota:///dev/ttyNOPE?baud=1234")
    with pytest.raises(FTURLError, match="no serial port"):
        open_ft("bota://")


def test_reader_thread_is_safe_with_concurrent_readers() -> None:
    port = FakePort()
    try:
        ft = scripted(port)
        got: list[np.ndarray] = []

        def reader() -> None:
            for _ in range(15):
                got.append(ft.read(25, timeout=0.05))

        threads = [threading.Thread(target=reader) for _ in range(3)]
        for t in threads:
            t.start()
        for i in range(0, 1000, 100):
            port.write(frames(i, 100))
        for t in threads:
            t.join()
        rest = ft.read(10**6, timeout=0.5)
        ft.close()
        seqs = np.concatenate([g["sequence"] for g in got] + [rest["sequence"]])
        assert sorted(seqs.tolist()) == list(range(1000))  # each record exactly once
    finally:
        port.close()


def test_line_noise_values_are_dropped_and_counted(capsys: pytest.CaptureFixture[str]) -> None:
    """Frames whose CRC holds but whose values are not measurements (1e35 N, NaN, a
    temperature no board reaches) never reach the records; stats and `ft stream` count them."""
    from spectratac.cli import main

    n = 6
    forces = np.zeros((n, 6))
    forces[:, 2] = -np.arange(n)
    forces[1, 0] = 1e35  # line noise that passed the CRC
    forces[2, 4] = np.nan
    forces[3, 2] = 3000.0  # beyond RANGE_MARGIN (4) x the 500 N given below
    temperature = np.full(n, 30.0)
    temperature[4] = 9e9
    ts = np.arange(n) * 1000 + 500
    wire = botaframe.encode_frames(np.zeros(n), forces, ts, temperature)
    port = FakePort()
    try:
        ft = open_ft(f"bota://{port.path}?configure=0&rate=1000&force_range=500&torque_range=10")
        ft.start()
        port.write(wire)
        with ft:
            rows = ft.read(n, timeout=5.0)
            assert ft.read(1, timeout=0.2).size == 0
            stats = ft.stats
        assert (-rows["wrench"][:, 2]).astype(int).tolist() == [0, 5]
        assert stats.implausible == 4 and stats.crc_errors == 0
        assert np.isfinite(rows["wrench"]).all()
    finally:
        port.close()
    port = FakePort()
    done = threading.Event()

    def send() -> None:  # the port flushes input on open: keep sending until the CLI is done
        k = 0
        while not done.is_set():
            port.write(botaframe.encode_frames(np.zeros(n), forces, ts + k * n * 1000, temperature))
            k += 1
            done.wait(0.05)

    sender = threading.Thread(target=send)
    sender.start()
    try:
        main(["ft", "stream", f"bota://{port.path}?configure=0&rate=1000", "--count", "6"])
    finally:
        done.set()
        sender.join()
        port.close()
    err = capsys.readouterr().err
    # the default range keeps the 3000 N frame and drops the other three of each repetition
    dropped = int(re.search(r"implausible (\d+)", err).group(1))  # type: ignore[union-attr]
    assert dropped >= 3


def test_range_options_are_checked() -> None:
    for bad in ("force_range=0", "torque_range=-1"):
        with pytest.raises(FTURLError, match="rated range"):
            open_ft(f"bota:///dev/ttyNOPE?{bad}")
    for bad in ("force_range=nan", "torque_range=inf"):  # refused by the option parser itself
        with pytest.raises(FTURLError, match="finite number"):
            open_ft(f"bota:///dev/ttyNOPE?{bad}")
