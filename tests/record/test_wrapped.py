"""The compact channels' protobuf wrapping (record.wrapped): exact bytes back, the same bytes
the protobuf library writes and reads, and a cut or mangled message refused, not misread."""

from __future__ import annotations

import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.record.wrapped import schema, unwrap, wrap


def _message_class():  # type: ignore[no-untyped-def]
    name, data = schema("FTRecords")
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(data).file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name))


MESSAGE = _message_class()


@settings(max_examples=200, deadline=None)
@given(st.binary(min_size=1, max_size=70_000))
def test_wrap_is_the_protobuf_encoding_and_unwrap_its_inverse(data: bytes) -> None:
    wrapped = wrap(data)
    assert wrapped == MESSAGE(data=data).SerializeToString()
    assert MESSAGE.FromString(wrapped).data == data
    assert unwrap(wrapped) == data
    assert len(wrapped) - len(data) <= 4  # the prefix: tag and a varint length


@settings(max_examples=200, deadline=None)
@given(st.binary(min_size=1, max_size=3_000), st.data())
def test_a_cut_or_padded_message_is_refused(data: bytes, draw: st.DataObject) -> None:
    wrapped = wrap(data)
    cut = draw.draw(st.integers(0, len(wrapped) - 1))
    with pytest.raises(ValueError):
        unwrap(wrapped[:cut])
    with pytest.raises(ValueError):
        unwrap(wrapped + b"\x00")


def test_raw_bytes_of_an_older_file_are_not_taken_for_wrapped_ones() -> None:
    frame = bytes([1, 0, 0x84, 7, 0]) + b"\x00" * 40  # a version-4 frame starts 0x01
    with pytest.raises(ValueError, match="no field-1 bytes tag"):
        unwrap(frame)


def test_a_wrapped_message_that_does_not_parse_is_counted_and_the_rest_kept(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Intact on disk but not a wrapped frame (another writer's bug): counted as lost on
    its topic, every other frame read."""
    import warnings

    from spectratac.record import RecordingWriter, read_recording
    from spectratac.record.errors import CorruptedRecordingWarning
    from spectratac.record.format import FRAMES

    path = tmp_path / "s.mcap"
    with RecordingWriter(path, {}, unix_minus_monotonic_ns=0) as w:
        w.frames([(bytes([1, 0, 0x84, i, 0]), float(i)) for i in range(3)])
        channel = w._channels[FRAMES]
        w._mcap.add_message(channel, 5, b"\x01\x00\x84\x09\x00", 5)  # not wrapped
        w.frames([(bytes([1, 0, 0x84, 4, 0]), 4.0)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_recording(path)
    assert [f[3] for f in rec.frames] == [0, 1, 2, 4]
    assert rec.lost_messages == {FRAMES: 1}
    assert any(issubclass(c.category, CorruptedRecordingWarning) for c in caught)
