"""Net F/T driver against the simulated device, through a fault-injecting UDP proxy, and
against addresses where nothing (or something silent) listens."""

from __future__ import annotations

import socket

import numpy as np
import pytest
from spectratac.ft import (
    FT_RECORD,
    FTConfigError,
    FTSensor,
    FTTimeoutError,
    FTURLError,
    open_ft,
)
from spectratac.sim.ft_netft import NetFTServer
from spectratac.sim.ft_source import FTParams, FTSource

from tests.ft.udp_proxy import FaultyUDPProxy


def read_until(ft: FTSensor, n: int) -> np.ndarray:
    rows = ft.read(n, timeout=10.0)
    assert len(rows) == n, ft.stats
    return rows


def test_streams_records_with_config_from_http(netft: NetFTServer) -> None:
    with open_ft(netft.url, timeout=2.0) as ft:
        assert ft.info.kind == "netft"
        assert ft.info.counts_per_force == 1e6 and ft.info.rate_hz == 1000.0
        assert ft.info.serial == "SIM-NETFT"
        rows = read_until(ft, 300)
    assert rows.dtype == FT_RECORD
    assert np.all(np.diff(rows["sequence"].astype(np.int64)) == 1)
    assert np.allclose(np.diff(rows["sensor_time"]), 1e-3)
    assert np.all(np.diff(rows["host_time"]) >= 0)
    assert ft.stats.lost == 0 and ft.stats.received >= 300


def test_user_counts_override_the_device_page(netft: NetFTServer, world) -> None:
    url = f"netft://127.0.0.1:{netft.port}?cpf=2000000&cpt=2000000&rate=1000"
    with open_ft(url, timeout=2.0, http_port=1) as ft:  # page unreachable: not needed
        assert ft.info.counts_per_force == 2e6
        rows = read_until(ft, 300)
    # the device sends 1e6 counts per N: with 2e6 the driver reads half the true force
    t_scene = (rows["sensor_time"] - 0.05) / (1 + 1e-4)
    normal = world.scene.contact(t_scene).normal
    fz = rows["wrench"][:, 2]
    assert np.median(np.abs(2 * fz + normal)) < 0.1
    pressed = normal > 1.0
    if pressed.any():  # and it is not the unscaled force
        assert np.median(np.abs(fz + normal)[pressed]) > 0.4


def test_missing_counts_and_no_page_is_a_clear_error(netft: NetFTServer) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        closed = s.getsockname()[1]  # nothing accepts HTTP here
    with pytest.raises(FTConfigError, match=r"pass them in the URL.*cpf="):
        open_ft(f"netft://127.0.0.1:{netft.port}?http_port={closed}", timeout=1.0)


def test_nothing_listening_times_out_with_advice() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(FTTimeoutError, match=r"no RDT reply .*connection refused"):
        open_ft(f"netft://127.0.0.1:{port}?cpf=1e6&cpt=1e6", timeout=0.5)


def test_silent_host_times_out() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as hole:
        hole.bind(("127.0.0.1", 0))  # receives requests, never answers
        url = f"netft://127.0.0.1:{hole.getsockname()[1]}?cpf=1e6&cpt=1e6"
        with pytest.raises(FTTimeoutError, match=r"no answer.*firewall"):
            open_ft(url, timeout=0.5)
        assert hole.recv(64)[:2] == b"\x12\x34"  # it was asked, RDT-style


def test_bad_urls_are_refused_by_name() -> None:
    with pytest.raises(FTURLError, match="unknown parameter"):
        open_ft("netft://127.0.0.1?cfp=1")
    with pytest.raises(FTURLError, match="not an F/T URL"):
        open_ft("ati://127.0.0.1")
    with pytest.raises(FTURLError, match="no host"):
        open_ft("netft://")
    with pytest.raises(FTURLError, match="mode="):
        open_ft("netft://127.0.0.1?mode=fast")


def test_proxy_faults_show_as_lost_reordered_duplicate(netft: NetFTServer) -> None:
    proxy = FaultyUDPProxy(
        ("127.0.0.1", netft.port),
        drop={10, 11, 12, 40},
        duplicate={20, 21},
        delay={30},
        garbage_after={50},
    )
    try:
        url = f"netft://127.0.0.1:{proxy.port}?http_port={netft.http_port}"
        with open_ft(url, timeout=2.0) as ft:
            rows = read_until(ft, 95)
            st = ft.stats
        seq = rows["sequence"].tolist()
        # lost: 10-12 and 40; the gap at 30 was filled when the delayed record came
        assert st.lost == 4 and st.gaps == 3
        assert st.reordered == 1 and st.duplicates == 2 and st.bad_frames == 1
        assert len(seq) == len(set(seq))  # duplicates dropped
        assert not {10, 11, 12, 40} & set(seq)
        assert 30 in seq
        missing = set(range(seq[0], max(seq) + 1)) - set(seq)
        assert missing == {10, 11, 12, 40}
    finally:
        proxy.close()


def test_simulated_loss_matches_gaps(world) -> None:
    server = NetFTServer(FTSource(world, FTParams(loss=0.05)))
    try:
        with open_ft(server.url) as ft:
            rows = read_until(ft, 2000)
            ft.stop()
            rows = np.concatenate([rows, ft.read(10**6, timeout=0.3)])  # in flight at stop
            st = ft.stats
        seq = rows["sequence"].astype(np.int64)
        gaps = np.diff(seq) - 1
        assert st.lost == int(gaps.sum()) > 0
        assert st.gaps == int(np.count_nonzero(gaps))
        assert st.lost == pytest.approx(0.05 * (seq[-1] - seq[0]), rel=0.5)
    finally:
        server.stop()


def test_buffered_mode_and_restart_keep_sequence(netft: NetFTServer) -> None:
    with open_ft(netft.url + "&mode=buffered") as ft:
        first = read_until(ft, 200)
        ft.stop()
        ft.read_available()
        ft.start()
        second = read_until(ft, 200)
        assert ft.stats.duplicates == 0
    assert second["sequence"][0] > first["sequence"][-1]
    assert second["sensor_time"][0] > first["sensor_time"][-1]
    assert np.all(np.diff(first["sequence"].astype(np.int64)) == 1)


def test_bias_subtracts_the_load_at_that_moment(netft: NetFTServer, world) -> None:
    with open_ft(netft.url) as ft:
        for _ in range(100):  # wait for a press, so that the bias is not zero
            ft.read_available()  # what queued up on a busy machine is past, not the load now
            rows = ft.read(20, timeout=5.0)
            if np.all(np.abs(rows["wrench"][:, 2]) > 1.0):
                break
        ft.bias()  # type: ignore[attr-defined]
        ft.read(50, timeout=2.0)  # records in flight before the bias took effect
        after = read_until(ft, 200)
    t_scene = (after["sensor_time"] - 0.05) / (1 + 1e-4)
    truth_fz = -world.scene.contact(t_scene).normal
    offset = truth_fz - after["wrench"][:, 2]  # the bias: constant, and the press's load
    assert np.std(offset) < 0.1
    assert abs(np.median(offset)) > 0.5


def test_close_is_idempotent_and_keeps_buffered_rows(netft: NetFTServer) -> None:
    ft = open_ft(netft.url)
    read_until(ft, 10)
    ft.close()
    ft.close()
    assert len(ft.read(5, timeout=0.1)) <= 5
    with pytest.raises(Exception, match="closed"):
        ft.start()
