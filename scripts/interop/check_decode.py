#!/usr/bin/env python3
"""Decode a rodlog-written MCAP with two independent ROS 2 decoders and compare every field.

Usage: check_decode.py REC.mcap EXPECTED.json

EXPECTED.json (written by rodlog's interop fixture) is a list of
{"topic", "type", "producer", "log_time_ns", "publish_time_ns", "fields"} in file order;
"fields" is the message as JSON (uint8[] as lists of ints). Decoders:
  * mcap-ros2-support (mcap_ros2.decoder.DecoderFactory), from the file's ros2msg schemas;
  * rosbags (typestore built only from the file's schema texts, so they are checked too).
Floats are compared exactly (==). Exit 0 when both decoders agree with rodlog on every field.
"""
import array
import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_types_from_msg, get_typestore


def plain(v):
    """Decoded value -> JSON-like value (dicts, lists, numbers, strings)."""
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, (bytes, bytearray, memoryview)):
        return list(bytes(v))
    if isinstance(v, array.array):
        return v.tolist()
    if hasattr(v, "tolist"):  # numpy arrays and scalars
        return v.tolist()
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if hasattr(v, "__slots__") and not hasattr(v, "__dataclass_fields__"):  # mcap_ros2
        return {k: plain(getattr(v, k)) for k in v.__slots__}
    if hasattr(v, "__dataclass_fields__"):  # rosbags
        return {
            k: plain(getattr(v, k))
            for k in v.__dataclass_fields__
            if not k.isupper() and k != "__msgtype__"
        }
    raise TypeError(f"cannot convert {type(v)}")


def compare(path, want, got, errors):
    if want is None:  # serde unit struct (std_msgs/Empty)
        want = {}
    if isinstance(want, dict):
        if not isinstance(got, dict):
            errors.append(f"{path}: expected a message, got {got!r}")
            return
        # ROS 2 adds a dummy member to empty structures; ignore it.
        got = {k: v for k, v in got.items() if k != "structure_needs_at_least_one_member"}
        if set(want) != set(got):
            errors.append(f"{path}: fields {sorted(want)} != {sorted(got)}")
        for k in want:
            if k in got:
                compare(f"{path}.{k}", want[k], got[k], errors)
    elif isinstance(want, list):
        if not isinstance(got, list) or len(want) != len(got):
            errors.append(f"{path}: expected {len(want)} items, got {got!r:.80}")
            return
        for i, (w, g) in enumerate(zip(want, got)):
            compare(f"{path}[{i}]", w, g, errors)
    elif isinstance(want, bool):
        if got is not want:
            errors.append(f"{path}: {want!r} != {got!r}")
    elif isinstance(want, float) or isinstance(got, float):
        if float(want) != float(got):
            errors.append(f"{path}: {want!r} != {got!r} (exact float comparison)")
    elif want != got:
        errors.append(f"{path}: {want!r} != {got!r}")


def main():
    rec, expected_path = sys.argv[1], sys.argv[2]
    with open(expected_path) as f:
        expected = json.load(f)
    errors = []
    decoded_ros2 = []
    with open(rec, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        if header.profile != "ros2":
            errors.append(f"profile {header.profile!r} != 'ros2'")
        schemas = {}
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            schemas[schema.name] = schema.data.decode()
            decoded_ros2.append((channel, message, plain(decoded)))
    store = get_typestore(Stores.EMPTY)
    for name, text in schemas.items():
        store.register(get_types_from_msg(text, name))
    if len(decoded_ros2) != len(expected):
        errors.append(f"{len(decoded_ros2)} messages in the file, {len(expected)} expected")
    topics = set()
    for (channel, message, ros2), want in zip(decoded_ros2, expected):
        where = f"{want['topic']}@{want['log_time_ns']}"
        topics.add(want["topic"])
        if channel.topic != want["topic"]:
            errors.append(f"{where}: topic {channel.topic!r}")
        if channel.metadata.get("producer") != want["producer"]:
            errors.append(f"{where}: producer {channel.metadata.get('producer')!r}")
        if "offered_qos_profiles" not in channel.metadata:
            errors.append(f"{where}: no offered_qos_profiles")
        if channel.message_encoding != "cdr":
            errors.append(f"{where}: message encoding {channel.message_encoding!r}")
        if message.log_time != want["log_time_ns"] or message.publish_time != want["publish_time_ns"]:
            errors.append(f"{where}: times {message.log_time}/{message.publish_time}")
        compare(f"mcap_ros2 {where}", want["fields"], ros2, errors)
        rb = plain(store.deserialize_cdr(message.data, want["type"]))
        compare(f"rosbags {where}", want["fields"], rb, errors)
    for e in errors[:50]:
        print("MISMATCH", e)
    if errors:
        print(f"FAIL: {len(errors)} mismatches")
        return 1
    print(f"OK: {len(expected)} messages on {len(topics)} topics decoded identically by mcap-ros2-support and rosbags")
    return 0


if __name__ == "__main__":
    sys.exit(main())
