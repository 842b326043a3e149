"""The core's modules depend on each other one way (firmware/README.md, "Layers"): a module is a
.c/.h pair, it depends on every core header either file includes, and those dependencies form
no cycle, with the application on top of commands and acquisition, both on top of the state.
The HAL names its seams for their job."""

from __future__ import annotations

import graphlib
import re
from pathlib import Path

CORE = Path(__file__).resolve().parents[2] / "firmware" / "core"


def module_graph() -> dict[str, set[str]]:
    """module -> core modules it includes (generated/ counts as one module, `generated`)."""
    graph: dict[str, set[str]] = {}
    for path in [*CORE.glob("*.[ch]"), *CORE.glob("generated/*.[ch]")]:
        module = "generated" if path.parent.name == "generated" else path.stem
        deps = graph.setdefault(module, set())
        for name in re.findall(r'^#include "([^"]+)"', path.read_text(), flags=re.M):
            dep = "generated" if name.startswith("generated/") else Path(name).stem
            if dep != module:
                deps.add(dep)
    return graph


def test_no_include_cycle() -> None:
    order = list(graphlib.TopologicalSorter(module_graph()).static_order())  # raises on a cycle
    assert order.index("stac_state") < order.index("stac_acquisition") < order.index("stac_cmd")
    assert order.index("stac_cmd") < order.index("stac_app")


def test_state_does_not_reach_up() -> None:
    graph = module_graph()
    assert graph["stac_app"] >= {"stac_cmd", "stac_acquisition", "stac_state"}
    assert graph["stac_cmd"] == {"stac_acquisition", "stac_state"}
    assert (
        "stac_cmd" not in graph["stac_acquisition"] and "stac_app" not in graph["stac_acquisition"]
    )
    assert graph["stac_state"].isdisjoint({"stac_app", "stac_cmd", "stac_acquisition"})


def hal_members(text: str) -> list[str]:
    """The function-pointer members of the HAL structure, in order."""
    return re.findall(r"\(\*(\w+)\)\(", text)


def test_the_hal_names_the_host_link_for_its_job() -> None:
    """The host link is USB CDC-ACM on the default STM32 image, so the HAL says `link`, not
    `uart` (the STM32 port's USART driver keeps its own name)."""
    members = hal_members((CORE / "stac_hal.h").read_text())
    assert {"link_write", "link_read", "i2c_transfer", "pwm_set", "clock_us"} <= set(members)
    assert not [m for m in members if m.startswith("uart")]
    assert hal_members("uint32_t (*uart_write)(void *ctx);") == ["uart_write"]
