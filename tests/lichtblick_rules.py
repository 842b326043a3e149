"""What Foxglove/Lichtblick opens: a Python port of its channel parser, to judge our files
and the bridge by the player's rules rather than ours.

Ported from Lichtblick's `packages/mcap-support/src/parseChannel.ts` (the dispatch on the
message encoding and schema encoding) and `parseJsonSchema.ts` (what a `jsonschema` may
hold). Each function raises `ChannelRejected` with Lichtblick's own wording where Lichtblick
throws, i.e. where the player raises an alert and drops the channel:

- `json`: no schema, or a `jsonschema` whose root and every nested object has
  `"type": "object"` and a `properties` map (JavaScript's `Object.entries(undefined)` throws);
  each field either a `oneOf` whose alternatives all have a number `const`, or one `type` among
  boolean, string (`contentEncoding` absent or `base64`), number, integer, object (recursed),
  array (`items` of boolean, string without contentEncoding, number, integer, object);
  anything else, a list of types, `"null"` or a field without `type` (a bare `enum`) throws.
- `protobuf` with a `protobuf` schema (a FileDescriptorSet naming the schema's type);
  `ros1` with `ros1msg`; `cdr` with `ros2msg`, `ros2idl` or `omgidl`; `flatbuffer` with
  `flatbuffer`. Any other message encoding: "Unsupported encoding".

Beyond the dispatch, `parse_channel` also decodes the schemas we write in the encodings it
can check here (protobuf with the protobuf library, ros2msg with rosbags), and
`decode_message` decodes one message as the player would (JSON.parse + base64 fields;
protobuf; CDR), so a test can show each channel's messages open too.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


class ChannelRejected(Exception):
    """Lichtblick would raise an alert on this channel and not show its messages."""


@dataclass
class Parsed:
    """What the player keeps of a channel: its datatypes (type name -> field names) and
    how it turns a message's bytes into an object."""

    datatypes: dict[str, list[str]] = field(default_factory=dict)
    deserialize: Callable[[bytes], Any] = lambda data: data


def _path(key_path: list[str], name: str) -> str:
    return ".".join([*key_path, name])


def parse_json_schema(root: Any, root_type_name: str) -> Parsed:
    """parseJsonSchema.ts: the datatypes of a JSON schema and the message post-processing
    (base64 strings to bytes)."""
    datatypes: dict[str, list[str]] = {}

    def add_fields(schema: Any, type_name: str, key_path: list[str]) -> Callable[[Any], Any]:
        posts: list[Callable[[dict[str, Any]], None]] = []
        names: list[str] = []
        if not isinstance(schema, dict) or schema.get("type") != "object":
            got = _js_json(schema.get("type")) if isinstance(schema, dict) else "undefined"
            raise ChannelRejected(f'Expected "type": "object" for schema {type_name}, got {got}')
        properties = schema.get("properties")
        if not isinstance(properties, dict):  # Object.entries(undefined | null) throws
            raise ChannelRejected(
                f"Cannot convert undefined or null to object (properties of {type_name})"
            )
        for name, field_schema in properties.items():
            if not isinstance(field_schema, dict):
                field_schema = {}
            one_of = field_schema.get("oneOf")
            if isinstance(one_of, list):
                if all(isinstance(alt, dict) and _is_js_number(alt.get("const")) for alt in one_of):
                    names += [str(alt.get("title")) for alt in one_of] + [name]
                    continue
                raise ChannelRejected(
                    f"Unsupported type for {_path(key_path, name)}: oneOf alternatives must "
                    f"have number values"
                )
            kind = field_schema.get("type")
            if kind == "boolean" or kind in ("number", "integer"):
                names.append(name)
            elif kind == "string":
                encoding = field_schema.get("contentEncoding")
                if encoding is None:
                    names.append(name)
                elif encoding == "base64":
                    names.append(name)
                    posts.append(_base64_post(name, _path(key_path, name)))
                else:
                    raise ChannelRejected(
                        f"Unsupported contentEncoding {json.dumps(encoding)} in "
                        f"{_path(key_path, name)}"
                    )
            elif kind == "object":
                nested = add_fields(field_schema, f"{type_name}.{name}", [*key_path, name])
                posts.append(_nested_post(name, nested))
                names.append(name)
            elif kind == "array":
                items = field_schema.get("items")
                if not isinstance(items, dict):  # itemSchema.type of undefined throws
                    raise ChannelRejected(
                        f"Cannot read properties of undefined (items of {_path(key_path, name)})"
                    )
                item_kind = items.get("type")
                if item_kind in ("boolean", "number", "integer"):
                    names.append(name)
                elif item_kind == "string":
                    if items.get("contentEncoding") is not None:
                        raise ChannelRejected(
                            f"Unsupported contentEncoding {json.dumps(items['contentEncoding'])}"
                            f" for array item {_path(key_path, name)}"
                        )
                    names.append(name)
                elif item_kind == "object":
                    nested = add_fields(items, f"{type_name}.{name}", [*key_path, name])
                    posts.append(_array_post(name, nested))
                    names.append(name)
                else:
                    raise ChannelRejected(
                        f"Unsupported type {_js_json(item_kind)} for array item "
                        f"{_path(key_path, name)}"
                    )
            else:  # "null", a list of types, no type at all (a bare enum), anything else
                raise ChannelRejected(
                    f"Unsupported type {_js_json(kind)} for {_path(key_path, name)}"
                )
        datatypes[type_name] = names

        def post(value: Any) -> Any:
            if isinstance(value, dict):
                for step in reversed(posts):
                    step(value)
            return value

        return post

    post = add_fields(root, root_type_name, [])
    return Parsed(datatypes, lambda data: post(json.loads(data.decode())))


def _is_js_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _js_json(value: Any) -> str:
    return "undefined" if value is None else json.dumps(value)


def _base64_post(name: str, where: str) -> Callable[[dict[str, Any]], None]:
    import base64
    import binascii

    def post(value: dict[str, Any]) -> None:
        text = value.get(name)
        if isinstance(text, str):
            try:
                value[name] = base64.b64decode(text, validate=True)
            except (binascii.Error, ValueError):
                raise ChannelRejected(f"Failed to decode base64 data for {where}") from None

    return post


def _nested_post(name: str, nested: Callable[[Any], Any]) -> Callable[[dict[str, Any]], None]:
    def post(value: dict[str, Any]) -> None:
        if isinstance(value.get(name), dict):
            value[name] = nested(value[name])

    return post


def _array_post(name: str, nested: Callable[[Any], Any]) -> Callable[[dict[str, Any]], None]:
    def post(value: dict[str, Any]) -> None:
        if isinstance(value.get(name), list):
            value[name] = [nested(v) for v in value[name]]

    return post


# ---------------------------------------------------------------------- parseChannel.ts
def _unsupported(message_encoding: str, schema_encoding: str | None, expected: str) -> str:
    what = "no encoding" if schema_encoding is None else f"schema encoding '{schema_encoding}'"
    return f"Message encoding {message_encoding} with {what} is not supported (expected {expected})"


def parse_channel(
    message_encoding: str, schema_name: str | None, schema_encoding: str | None,
    schema_data: bytes | None,
) -> Parsed:  # fmt: skip
    """parseChannel.ts. `schema_encoding` None: the channel has no schema (schema id 0)."""
    if message_encoding == "json":
        if schema_encoding is not None and schema_encoding != "jsonschema":
            raise ChannelRejected(
                f"Message encoding json with schema encoding '{schema_encoding}' is not "
                f"supported (expected jsonschema or no schema)"
            )
        if schema_encoding is None or not schema_data:
            return Parsed({}, lambda data: json.loads(data.decode()))
        schema = json.loads(schema_data.decode())
        if not isinstance(schema, (dict, list)):  # typeof []: "object", then refused below
            raise ChannelRejected(
                f"Invalid schema, expected JSON object, got {type(schema).__name__}"
            )
        return parse_json_schema(schema, schema_name or "")
    if message_encoding == "flatbuffer":
        if schema_encoding != "flatbuffer":
            raise ChannelRejected(_unsupported(message_encoding, schema_encoding, "flatbuffer"))
        return Parsed()  # the flatbuffer reflection schema is not checked here
    if message_encoding == "protobuf":
        if schema_encoding != "protobuf":
            raise ChannelRejected(_unsupported(message_encoding, schema_encoding, "protobuf"))
        return _parse_protobuf(schema_name or "", schema_data or b"")
    if message_encoding == "ros1":
        if schema_encoding != "ros1msg":
            raise ChannelRejected(_unsupported(message_encoding, schema_encoding, "ros1msg"))
        return Parsed()
    if message_encoding == "cdr":
        if schema_encoding not in ("ros2msg", "ros2idl", "omgidl"):
            raise ChannelRejected(
                _unsupported(message_encoding, schema_encoding, '"ros2msg" or "ros2idl"')
            )
        if schema_encoding == "ros2msg":
            return _parse_ros2msg(schema_name or "", (schema_data or b"").decode())
        return Parsed()
    raise ChannelRejected(f"Unsupported encoding {message_encoding}")


def _parse_protobuf(name: str, data: bytes) -> Parsed:
    """parseProtobufSchema.ts: a FileDescriptorSet that defines the schema's type."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    from google.protobuf.message import DecodeError

    try:
        files = descriptor_pb2.FileDescriptorSet.FromString(data)
        pool = descriptor_pool.DescriptorPool()
        for file in files.file:
            pool.Add(file)
        descriptor = pool.FindMessageTypeByName(name)
    except (DecodeError, KeyError, TypeError) as exc:
        raise ChannelRejected(f"protobuf schema {name!r}: {exc}") from None
    cls = message_factory.GetMessageClass(descriptor)

    def deserialize(message: bytes) -> Any:
        try:
            return cls.FromString(message)
        except DecodeError as exc:
            raise ChannelRejected(f"protobuf message of {name}: {exc}") from None

    return Parsed({name: [f.name for f in descriptor.fields]}, deserialize)


def _parse_ros2msg(name: str, text: str) -> Parsed:
    """@foxglove/rosmsg with ros2: the definition, then `====`-separated dependencies each
    opened by `MSG: pkg/Type`; the CDR reader is rosbags'."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    sections = text.split("\n" + "=" * 80 + "\n")
    types: dict[str, Any] = {}
    try:
        types.update(get_types_from_msg(sections[0], name))
        for section in sections[1:]:
            header, _, body = section.partition("\n")
            if not header.startswith("MSG: "):
                raise ChannelRejected(f"ros2msg {name}: a dependency without 'MSG: ' header")
            types.update(get_types_from_msg(body, header[5:].strip()))
        store.register(types)
    except ChannelRejected:
        raise
    except Exception as exc:  # rosbags' parser errors: the player's parser throws as well
        raise ChannelRejected(f"ros2msg {name}: {exc}") from None

    def deserialize(message: bytes) -> Any:
        try:
            return store.deserialize_cdr(message, name)
        except Exception as exc:  # rosbags' SerdeError and the like
            raise ChannelRejected(f"cdr message of {name}: {exc}") from None

    return Parsed({name: []}, deserialize)


# ---------------------------------------------------------------------- whole files
def check_mcap(path: Any, *, messages: int = 50) -> dict[str, int]:
    """Every channel of the MCAP file at `path` parsed as Lichtblick does, and up to
    `messages` messages of each decoded; returns messages decoded by topic. Raises
    ChannelRejected naming the topic of the first channel the player would drop."""
    from mcap.reader import make_reader

    decoded: dict[str, int] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None, f"{path}: no summary"
        parsed: dict[int, Parsed] = {}
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id) if channel.schema_id else None
            try:
                parsed[channel.id] = parse_channel(
                    channel.message_encoding,
                    None if schema is None else schema.name,
                    None if schema is None else schema.encoding,
                    None if schema is None else schema.data,
                )
            except ChannelRejected as exc:
                raise ChannelRejected(f"{channel.topic}: {exc}") from None
            decoded[channel.topic] = 0
        for _, channel, message in reader.iter_messages():
            if decoded[channel.topic] >= messages:
                continue
            try:
                parsed[channel.id].deserialize(message.data)
            except ChannelRejected as exc:
                raise ChannelRejected(f"{channel.topic}: {exc}") from None
            decoded[channel.topic] += 1
    return decoded


def rejected_channels(path: Any) -> dict[str, str]:
    """Every channel of the MCAP file at `path` the player would drop, with its reason."""
    from mcap.reader import make_reader

    out: dict[str, str] = {}
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None, f"{path}: no summary"
    for channel in summary.channels.values():
        schema = summary.schemas.get(channel.schema_id) if channel.schema_id else None
        try:
            parse_channel(
                channel.message_encoding,
                None if schema is None else schema.name,
                None if schema is None else schema.encoding,
                None if schema is None else schema.data,
            )
        except ChannelRejected as exc:
            out[channel.topic] = str(exc)
    return out
