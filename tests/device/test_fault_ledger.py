"""The fault layer's ledger counts exactly the samples no host can know of at an unplug:
those after the last one a host decodes. A flipped closing 0x00 joins the next frame to the
damaged one, so that frame is lost too, however intact its own bytes (the soak once counted
it as delivered, and reported it "unaccounted")."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.protocol import StreamDecoder, encode_frame
from spectratac.protocol.generated import messages as m
from spectratac.sim import faults
from spectratac.sim.faults import FaultLayer

FRAME = len(encode_frame(m.Sample(sample_seq=0), 0))

# per frame sent: the byte positions flipped (the last one is the closing 0x00)
flips = st.lists(
    st.sets(st.integers(0, FRAME - 1), max_size=2).map(sorted), min_size=1, max_size=12
)


class ScriptedFlips:
    """The layer's random source, scripted: `expovariate` gives the gaps between the flips
    `damage` names frame by frame, `randrange` flips bit 0 (0x01 flipped into 0x00 splits a
    frame: lost either way)."""

    def __init__(self, damage: list[list[int]]) -> None:
        self.gaps: list[int] = []
        for positions in damage:
            at = -1
            for p in positions:
                self.gaps.append(p - at - 1)
                at = p
            self.gaps.append(10 * FRAME)  # past the frame's end: the next frame's draws

    def expovariate(self, rate: float) -> float:
        return self.gaps.pop(0)

    def randrange(self, n: int) -> int:
        return 0


@settings(max_examples=200, deadline=None)
@given(flips)
def test_lost_at_unplug_is_what_the_host_cannot_decode(damage: list[list[int]]) -> None:
    faults._LEDGERS.pop("sim://?ledger-test", None)
    received = bytearray()
    layer = FaultLayer(
        "sim://?ledger-test", ("corrupt", "unplug"), {"fault_rate": "1e-4"}, 1,
        to_host=lambda data, t: received.extend(data) or True, to_device=lambda data: None,
    )  # fmt: skip
    layer._rng = ScriptedFlips(damage)  # type: ignore[assignment]
    for seq in range(len(damage)):
        layer.from_device(encode_frame(m.Sample(sample_seq=seq), seq), t=seq)
    layer._unplug_at_us = 0
    layer.from_device(encode_frame(m.Sample(sample_seq=99), 99), t=len(damage))  # cable out
    assert layer.ledger.unplugs == 1

    decoded = [f.message.sample_seq for f in StreamDecoder().feed(bytes(received))]
    last = max(decoded, default=-1)
    assert layer.ledger.samples_lost_at_unplug == len(damage) - 1 - last
