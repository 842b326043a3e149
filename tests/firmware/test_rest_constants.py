"""The search for rest has its constants in three places that must agree: the host's
(decode/assemble.py), the firmware interpreter's (firmware/core/stac_model.c) and the C
export's (written from the host's). A change to one without the others would make the device
find rest on other samples than the host does."""

from __future__ import annotations

import re

from spectratac.decode import assemble

from tests.firmware.conftest import REPO


def test_the_interpreter_searches_for_rest_with_the_hosts_constants() -> None:
    text = (REPO / "firmware" / "core" / "stac_model.c").read_text(encoding="utf-8")
    found = dict(re.findall(r"#define REST_(JOIN|DROP|STILL|HOLD) ([0-9.]+)u?", text))
    assert found.keys() == {"JOIN", "DROP", "STILL", "HOLD"}
    for name, value in found.items():
        assert float(value) == float(getattr(assemble, name)), name
