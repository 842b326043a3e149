"""The port of Lichtblick's channel parser (tests/lichtblick_rules.py) refuses what the player
refuses: each failure issue 33 found in our files, and unknown encodings; it accepts what
the player accepts (Lichtblick's own parseJsonSchema test cases, restated)."""

from __future__ import annotations

import json

import pytest
from spectratac.record.wrapped import schema as wrapped_schema
from spectratac.record.wrapped import wrap

from tests.lichtblick_rules import ChannelRejected, parse_channel, parse_json_schema


def obj(**props: object) -> dict[str, object]:
    return {"type": "object", "properties": props}


@pytest.mark.parametrize(
    ("schema", "why"),
    [
        (obj(fz={"type": ["number", "null"]}), 'Unsupported type \\["number", "null"\\] for fz'),
        (obj(source={"enum": ["device", "host"]}), "Unsupported type undefined for source"),
        (obj(t={"type": "null"}), 'Unsupported type "null" for t'),
        ({"type": "object"}, "Cannot convert undefined or null to object"),
        ({"title": "x"}, 'Expected "type": "object" for schema X, got undefined'),
        (obj(force={"type": "object"}), "Cannot convert undefined"),
        (obj(f=obj(z={"type": ["number", "null"]})), "Unsupported type .* for f.z"),
        (obj(a={"type": "array"}), "items of a"),
        (obj(a={"type": "array", "items": {"type": "null"}}), "for array item a"),
        (obj(b={"type": "string", "contentEncoding": "hex"}), 'contentEncoding "hex" in b'),
        (obj(k={"oneOf": [{"const": "a"}]}), "oneOf alternatives must have number values"),
    ],
)
def test_the_failures_of_issue_33_are_refused(schema: dict[str, object], why: str) -> None:
    with pytest.raises(ChannelRejected, match=why):
        parse_json_schema(schema, "X")


def test_what_lichtblick_accepts_is_accepted() -> None:
    schema = obj(
        ok={"type": "boolean"},
        n={"type": "number"},
        i={"type": "integer", "description": "1..9; -1: none"},
        s={"type": "string"},
        raw={"type": "string", "contentEncoding": "base64"},
        v=obj(x={"type": "number"}),
        empty=obj(),
        xs={"type": "array", "items": {"type": "number"}},
        objs={"type": "array", "items": obj(a={"type": "integer"})},
        kind={"oneOf": [{"title": "A", "const": 1}, {"title": "B", "const": 2}]},
    )
    parsed = parse_json_schema(schema, "T")
    assert parsed.datatypes["T.v"] == ["x"] and parsed.datatypes["T.empty"] == []
    assert parsed.datatypes["T"][-3:] == ["A", "B", "kind"]
    msg = parsed.deserialize(json.dumps({"raw": "AAE=", "v": {"x": 1}}).encode())
    assert msg["raw"] == b"\x00\x01"


@pytest.mark.parametrize(
    ("encoding", "schema_encoding", "why"),
    [
        ("spectratac.frame", None, "Unsupported encoding spectratac.frame"),
        ("json", "protobuf", "expected jsonschema or no schema"),
        ("protobuf", None, "with no encoding is not supported \\(expected protobuf\\)"),
        ("cdr", "jsonschema", 'expected "ros2msg" or "ros2idl"'),
        ("ros1", "ros2msg", "expected ros1msg"),
        ("flatbuffer", None, "expected flatbuffer"),
    ],
)
def test_unknown_or_mismatched_encodings_are_refused(
    encoding: str, schema_encoding: str | None, why: str
) -> None:
    with pytest.raises(ChannelRejected, match=why):
        parse_channel(encoding, "X", schema_encoding, b"{}" if schema_encoding else None)


def test_schemaless_json_and_our_wrapped_protobuf_open() -> None:
    assert parse_channel("json", None, None, None).deserialize(b'{"a": 1}') == {"a": 1}
    name, descriptor = wrapped_schema("Frame")
    parsed = parse_channel("protobuf", name, "protobuf", descriptor)
    assert parsed.datatypes == {"spectratac.Frame": ["data"]}
    assert parsed.deserialize(wrap(b"\x01\x00\x84" * 50)).data == b"\x01\x00\x84" * 50
    with pytest.raises(ChannelRejected, match="not-there"):
        parse_channel("protobuf", "spectratac.not-there", "protobuf", descriptor)


def test_a_ros2msg_schema_with_a_dependency_opens_and_a_broken_one_does_not() -> None:
    text = (
        "std_msgs/Header header\n"
        + "=" * 80
        + "\nMSG: std_msgs/Header\n"
        + ("builtin_interfaces/Time stamp\nstring frame_id\n")
    )
    parse_channel("cdr", "my_msgs/msg/Stamped", "ros2msg", text.encode())
    with pytest.raises(ChannelRejected, match="ros2msg"):
        parse_channel("cdr", "my_msgs/msg/Bad", "ros2msg", b"float64\n")  # no field name
