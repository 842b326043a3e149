"""Fixtures: a simulated Net F/T server of a shared world, stopped after the test."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from spectratac.sim.ft_netft import NetFTServer
from spectratac.sim.ft_source import FTParams, FTSource
from spectratac.sim.url import parse_sim_url
from spectratac.sim.world import SimWorld


@pytest.fixture
def world() -> Iterator[SimWorld]:
    w = SimWorld.join(parse_sim_url("sim://?scene=calibration&seed=3&speed=5"))
    yield w
    w.release()


@pytest.fixture
def netft(world: SimWorld) -> Iterator[NetFTServer]:
    server = NetFTServer(FTSource(world, FTParams(loss=0.0)))
    yield server
    server.stop()
