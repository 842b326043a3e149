"""Property tests: every message type survives encode -> wire -> decode unchanged."""

from __future__ import annotations

from unittest.mock import patch

import pytest
from hypothesis import given
from hypothesis import strategies as st
from spectratac.protocol import (
    ShortPayloadError,
    StreamDecoder,
    decode_frame,
    decode_samples,
    encode_frame,
    encode_raw,
)
from spectratac.protocol.generated import messages
from spectratac.protocol.schema import fit_payload

from .strategies import any_message, message_of, same


@pytest.mark.parametrize("cls", messages.MESSAGES, ids=lambda c: c.NAME)
def test_roundtrip_each_type(cls: type[messages.Message]) -> None:
    @given(message_of(cls), st.integers(0, 0xFFFF))
    def check(msg: messages.Message, seq: int) -> None:
        wire = encode_frame(msg, seq)
        assert wire.count(0) == 1 and wire[-1] == 0
        assert len(wire) <= messages.MAX_FRAME
        assert len(msg.pack()) == msg.PAYLOAD_SIZE
        frame = decode_frame(wire[:-1])
        assert frame.seq == seq and same(frame.message, msg)
        assert same(type(msg).from_dict(msg.to_dict()), msg)

    check()


@given(st.lists(st.tuples(any_message, st.integers(0, 0xFFFF)), max_size=20), st.data())
def test_stream_decoder_any_chunking(items: list, data: st.DataObject) -> None:
    wire = b"".join(encode_frame(msg, seq) for msg, seq in items)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(wire)), max_size=10)))
    decoder = StreamDecoder()
    got = []
    for a, b in zip([0, *cuts], [*cuts, len(wire)], strict=True):
        got += decoder.feed(wire[a:b])
    assert [f.seq for f in got] == [seq for _, seq in items]
    assert all(same(f.message, msg) for f, (msg, _) in zip(got, items, strict=True))
    assert decoder.stats.dropped == 0


@given(st.lists(message_of(messages.Sample), min_size=1, max_size=30))
def test_bulk_matches_incremental(samples: list[messages.Sample]) -> None:
    wire = b"".join(encode_frame(s, i) for i, s in enumerate(samples))
    wire += encode_frame(messages.Ack(), 0)  # other types are skipped, counted
    result = decode_samples(wire)
    assert result.other == 1 and len(result.samples) == len(samples)
    for row, s in zip(result.samples, samples, strict=True):
        assert row["sample_seq"] == s.sample_seq
        assert row["counts"].tolist() == [list(c) for c in s.counts]
        assert row["sensor_status"].tolist() == list(s.sensor_status)
        assert (row["t_start_us"], row["t_end_us"]) == (s.t_start_us, s.t_end_us)


@given(message_of(messages.Sample), st.binary(max_size=40), st.integers(1, 15))
def test_future_minor_trailing_bytes_ignored(
    msg: messages.Sample, extra: bytes, minor: int
) -> None:
    wire = encode_raw(msg.TYPE_ID, msg.pack() + extra, seq=5, version=(1, minor))
    assert decode_frame(wire[:-1]).message == msg
    assert decode_samples(wire).samples["sample_seq"].tolist() == [msg.sample_seq]


@given(message_of(messages.Status), st.data())
def test_payload_short_of_the_senders_layout_is_refused_everywhere(
    msg: messages.Status, data: st.DataObject
) -> None:
    cut = data.draw(st.integers(0, msg.required_size(0) - 1))  # short of the 1.0 layout
    wire = encode_raw(msg.TYPE_ID, msg.pack()[:cut], seq=1)
    with pytest.raises(ShortPayloadError, match=r"STATUS payload of \d+ B from a 1\.0 sender"):
        decode_frame(wire[:-1])
    decoder = StreamDecoder()
    assert decoder.feed(wire) == [] and decoder.stats.short_payload == 1


@pytest.mark.parametrize("cut", [0, 2, messages.Sample.PAYLOAD_SIZE - 1])
def test_a_short_sample_is_counted_not_zero_filled(cut: int) -> None:
    sample = messages.Sample(sample_seq=5, t_start_us=10, t_end_us=20)
    wire = encode_raw(sample.TYPE_ID, sample.pack()[:cut], seq=3) + encode_frame(sample, 4)
    bulk = decode_samples(wire)
    assert bulk.samples["sample_seq"].tolist() == [5] and bulk.stats.short_payload == 1
    decoder = StreamDecoder()
    assert [f.seq for f in decoder.feed(wire)] == [4] and decoder.stats.dropped == 1


def test_only_fields_newer_than_the_sender_are_zero_filled() -> None:
    status = messages.Status(uptime_ms=1000, device_time_us=2000, streaming=1, config_id=4)
    old_layout = status.pack()[:11]  # as if the fields after byte 11 came with minor 1
    with patch.object(messages.Status, "LAYOUT_SIZES", (11, status.PAYLOAD_SIZE)):
        frame = decode_frame(encode_raw(status.TYPE_ID, old_layout, seq=1, version=(1, 0))[:-1])
        assert frame.message.pack() == fit_payload(old_layout, status.PAYLOAD_SIZE)
        with pytest.raises(ShortPayloadError):  # a 1.1 sender must send the 1.1 fields
            decode_frame(encode_raw(status.TYPE_ID, old_layout, seq=2, version=(1, 1))[:-1])
        bulk = decode_samples(encode_raw(status.TYPE_ID, old_layout, seq=3, version=(1, 0)))
        assert bulk.other == 1 and bulk.stats.dropped == 0


def test_a_receiver_that_does_not_know_estimate_skips_and_counts_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A 1.0 host gets ESTIMATE from a 1.1 device: an unknown type, counted; samples go on."""
    monkeypatch.delitem(messages.MESSAGES_BY_ID, messages.Estimate.TYPE_ID)
    sample = messages.Sample(sample_seq=1)
    wire = (
        encode_frame(sample, 1, (1, 1))
        + encode_frame(messages.Estimate(sample_seq=1), 2, (1, 1))
        + encode_frame(messages.Sample(sample_seq=2), 3, (1, 1))
    )
    decoder = StreamDecoder()
    frames = decoder.feed(wire)
    assert [f.message.sample_seq for f in frames] == [1, 2]
    assert decoder.stats.unknown_type == 1 and decoder.stats.seq_gaps == 0
    bulk = decode_samples(wire)
    assert bulk.samples["sample_seq"].tolist() == [1, 2]
