"""open_transport dispatches by URL scheme: plug-ins from entry points or run-time
registration, pyserial's own URL handlers, port paths; an unknown scheme is a typed error."""

from __future__ import annotations

from importlib.metadata import entry_points

import pytest
from spectratac.device import (
    DeviceNotFoundError,
    Sensor,
    UnknownSchemeError,
    ground_truth_of,
    open_transport,
    register_transport_scheme,
    transport_schemes,
)
from spectratac.device.transport import ENTRY_POINTS, SerialTransport
from spectratac.url_schemes import SchemeConflictError


def test_the_simulator_plugs_in_through_an_entry_point() -> None:
    [ep] = entry_points(group=ENTRY_POINTS, name="sim")
    assert ep.value == "spectratac.sim.transport:open_sim_transport"
    link = open_transport("sim://?scene=press&speed=max")
    try:
        assert type(link).__module__ == "spectratac.sim.transport"
        assert ground_truth_of(link) is not None
    finally:
        link.close()


def test_schemes_list_plugins_and_pyserial_handlers() -> None:
    assert {"sim", "socket", "rfc2217", "loop"} <= set(transport_schemes())


def test_an_unknown_scheme_names_the_known_ones() -> None:
    with pytest.raises(UnknownSchemeError, match=r"nosuch://x.*sim://.*socket://"):
        open_transport("nosuch://x")
    with pytest.raises(UnknownSchemeError):
        Sensor.open("nosuch://x")


def test_a_scheme_registered_at_run_time_opens_its_urls() -> None:
    opened: list[tuple[str, int]] = []

    def opener(url: str, baudrate: int) -> SerialTransport:
        opened.append((url, baudrate))
        return SerialTransport("loop://", baudrate)

    register_transport_scheme("testloop", opener)
    link = open_transport("testloop://anything", 115_200)
    link.write(b"abc")
    assert link.read(1.0) == b"abc"
    link.close()
    assert opened == [("testloop://anything", 115_200)]
    with pytest.raises(SchemeConflictError, match="testloop"):
        register_transport_scheme("testloop", opener)
    register_transport_scheme("testloop", opener, replace=True)


def test_paths_and_pyserial_urls_still_go_to_pyserial() -> None:
    link = open_transport("loop://")
    assert isinstance(link, SerialTransport)
    link.close()
    with pytest.raises(DeviceNotFoundError, match="no device at"):
        open_transport("/dev/spectratac-does-not-exist")
