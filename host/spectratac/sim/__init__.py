"""The simulated device: the real firmware core, built for this host, on the digital twin.

Open one with ``Sensor.open("sim://?scene=tour&seed=3&speed=max")`` or expose it to other
programs with ``spectratac sim serve --pty`` / ``--tcp PORT``.

The host's parts never import this package: it plugs into them. ``pyproject.toml``
registers its openers as entry points (``spectratac.transports``: ``sim`` ->
`transport.open_sim_transport`; ``spectratac.ft_sensors``: ``sim`` ->
`ft_serve.open_sim_ft`), and its transports carry the scene's ground truth
(`ground_truth.SceneTruth`), which the recorder stores. Also here, because they are built
from the twin: `named_scenes` (the one table of scenes by name, for sim:// URLs, `spectratac
twin generate` and populations), `synthetic_recording` (twin sessions written as recordings)
and `twin_dataset` (twin sessions as datasets).
"""

from spectratac.sim.device import SimDevice
from spectratac.sim.runner import DeviceRunner
from spectratac.sim.url import SimOptions, parse_sim_url

__all__ = ["DeviceRunner", "SimDevice", "SimOptions", "parse_sim_url"]
