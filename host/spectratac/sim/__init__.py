"""The simulated device: the real firmware core, built for this host, on the digital twin.

Open one with ``Sensor.open("sim://?scene=tour&seed=3&speed=max")`` or expose it to other
programs with ``spectratac sim serve --pty`` / ``--tcp PORT``.
"""

from spectratac.sim.device import SimDevice
from spectratac.sim.runner import DeviceRunner
from spectratac.sim.url import SimOptions, parse_sim_url

__all__ = ["DeviceRunner", "SimDevice", "SimOptions", "parse_sim_url"]
