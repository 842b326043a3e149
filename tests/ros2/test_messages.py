"""The exporter's vectorised CDR payloads are byte for byte what rosbags' typestore writes."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from spectratac.ft.ros_time import NS_PER_S, SEC_MAX, SEC_MIN, to_stamp
from spectratac.ros2.messages import (
    TYPESTORE,
    UINT16_ARRAY,
    WRENCH_STAMPED,
    uint16_arrays,
    wrench_stamped,
)

T = TYPESTORE.types
FRAME = st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=40)
STAMP = st.integers(SEC_MIN * NS_PER_S, SEC_MAX * NS_PER_S + NS_PER_S - 1)


def reference_wrench(ns: int, w: np.ndarray, frame_id: str) -> bytes:
    sec, nanosec = to_stamp(ns)
    v = T["geometry_msgs/msg/Vector3"]
    msg = T[WRENCH_STAMPED](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
        ),
        wrench=T["geometry_msgs/msg/Wrench"](
            force=v(x=w[0], y=w[1], z=w[2]), torque=v(x=w[3], y=w[4], z=w[5])
        ),
    )
    return bytes(TYPESTORE.serialize_cdr(msg, WRENCH_STAMPED))


@settings(max_examples=60, deadline=None)
@given(st.lists(STAMP, min_size=1, max_size=8), FRAME, st.data())
def test_wrench_stamped_payloads_match_the_typestore(
    stamps: list[int], frame_id: str, data: st.DataObject
) -> None:
    wrenches = data.draw(
        hnp.arrays(np.float64, (len(stamps), 6), elements=st.floats(allow_nan=False, width=64))
    )
    got = wrench_stamped(np.array(stamps, dtype=np.int64), wrenches, frame_id)
    assert got == [reference_wrench(s, w, frame_id) for s, w in zip(stamps, wrenches, strict=True)]
    back = TYPESTORE.deserialize_cdr(got[0], WRENCH_STAMPED)
    assert back.header.frame_id == frame_id
    assert back.header.stamp.nanosec >= 0


@settings(max_examples=40, deadline=None)
@given(
    hnp.arrays(np.uint16, st.tuples(st.integers(1, 4), st.integers(1, 3), st.integers(1, 5))),
    st.tuples(FRAME, FRAME),
)
def test_uint16_array_payloads_match_the_typestore(
    values: np.ndarray, labels: tuple[str, str]
) -> None:
    got = uint16_arrays(values, labels)
    dim = T["std_msgs/msg/MultiArrayDimension"]
    _, a, b = values.shape
    for row, payload in zip(values, got, strict=True):
        layout = T["std_msgs/msg/MultiArrayLayout"](
            dim=[
                dim(label=labels[0], size=a, stride=a * b),
                dim(label=labels[1], size=b, stride=b),
            ],
            data_offset=0,
        )
        msg = T[UINT16_ARRAY](layout=layout, data=row.reshape(-1))
        assert payload == bytes(TYPESTORE.serialize_cdr(msg, UINT16_ARRAY))
