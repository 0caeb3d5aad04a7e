"""A rosbag2 MCAP whose schemas are stored as `ros2idl`, as rosbag2 stores a type that has
an `.idl` file and no `.msg`: the same channels and message bytes as a bag with `ros2msg`
schemas, each schema's message definitions turned into the IDL `rosidl_adapter` generates
from them (its msg.idl.em: comments as `@verbatim`, defaults as `@default`, a typedef per
fixed array, a `Name_Constants` module, `structure_needs_at_least_one_member` in empty
structs) and concatenated as rosbag2's `message_definition_encoding` says (each definition
after a line of 80 `=` and `IDL: pkg/msg/Name`). Read and written with Foxglove's `mcap`.

Prints one JSON line: {"schemas": number of schemas converted}.

usage: ros2idl_bag.py ROS2MSG_BAG.mcap OUT.mcap
"""

import json
import sys

from mcap.reader import make_reader
from mcap.writer import Writer

DELIMITER = "=" * 80

PRIMITIVES = {
    "bool": "boolean",
    "byte": "octet",
    "char": "uint8",
    "float32": "float",
    "float64": "double",
    "int8": "int8",
    "uint8": "uint8",
    "int16": "int16",
    "uint16": "uint16",
    "int32": "int32",
    "uint32": "uint32",
    "int64": "int64",
    "uint64": "uint64",
    "string": "string",
    "wstring": "wstring",
}


def split_definitions(name, text):
    """[(pkg/msg/Name, its .msg text)] from a ros2msg schema, the root first."""
    sections, current, lines = [], name, []
    for line in text.splitlines():
        stripped = line.strip()
        if len(stripped) >= 3 and set(stripped) == {"="}:
            sections.append((current, lines))
            current, lines = None, []
        elif stripped.startswith("MSG:") and current is None:
            current = stripped[4:].strip()
        else:
            lines.append(line)
    sections.append((current, lines))
    out = []
    for full, body in sections:
        parts = full.split("/")
        if len(parts) == 2:
            full = f"{parts[0]}/msg/{parts[1]}"
        out.append((full, body))
    return out


def idl_base(base, package):
    """The IDL spelling of a .msg base type (no array part)."""
    for prefix, idl in (("string<=", "string"), ("wstring<=", "wstring")):
        if base.startswith(prefix):
            return f"{idl}<{base[len(prefix):]}>"
    if base in PRIMITIVES:
        return PRIMITIVES[base]
    parts = base.split("/")
    if len(parts) == 1:
        parts = [package, parts[0]]
    return f"{parts[0]}::msg::{parts[-1]}"


def idl_literal(msg_type, text):
    text = text.strip()
    if msg_type == "bool":
        return "TRUE" if text.lower() in ("true", "1") else "FALSE"
    if msg_type.startswith(("string", "wstring")):
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
            text = text[1:-1]
        return json.dumps(text)
    return text


def to_idl(full, body):
    package, _, name = full.split("/")
    includes, typedefs, constants, members, comment = [], [], [], [], []
    pending = []
    for line in body:
        code, _, note = line.partition("#")
        code = code.strip()
        if not code:
            if note.strip() and not members:
                comment.append(note.strip())
            continue
        if note.strip():
            pending.append(note.strip())
        type_text, rest = code.split(None, 1)
        rest = rest.strip()
        base, _, array = type_text.partition("[")
        idl = idl_base(base, package)
        if "::" in idl:
            include = f'#include "{idl.replace("::", "/")}.idl"'
            if include not in includes:
                includes.append(include)
        if "=" in rest and not array:
            constant, value = rest.split("=", 1)
            constants.append(f"const {idl} {constant.strip()} = {idl_literal(base, value)};")
            continue
        field, _, default = rest.partition(" ")
        annotations = []
        if pending:
            text = " ".join(json.dumps(p) for p in pending)
            annotations.append(f'@verbatim (language="comment", text=\n        {text})')
            pending = []
        if default.strip():
            if array:
                items = [idl_literal(base, i) for i in default.strip()[1:-1].split(",")]
                value = json.dumps("(" + ", ".join(items) + ")")
            else:
                value = idl_literal(base, default)
            annotations.append(f"@default (value={value})")
        array = array.rstrip("]")
        if array == "":
            declared = f"sequence<{idl}> {field}" if "[" in type_text else f"{idl} {field}"
        elif array.startswith("<="):
            declared = f"sequence<{idl}, {array[2:]}> {field}"
        else:
            alias = f"{idl.replace('::', '__').replace('<', '').replace('>', '')}__{array}"
            typedef = f"typedef {idl} {alias}[{array}];"
            if typedef not in typedefs:
                typedefs.append(typedef)
            declared = f"{alias} {field}"
        members.append(annotations + [declared + ";"])
    if not members:
        members.append(["uint8 structure_needs_at_least_one_member;"])
    out = [
        DELIMITER,
        f"IDL: {full}",
        "// generated from rosidl_adapter/resource/msg.idl.em",
        f"// with input from {full}.msg",
        "// generated code does not contain a copyright notice",
        "",
        *includes,
        "",
        f"module {package} {{",
        "  module msg {",
    ]
    out += [f"    {t}" for t in typedefs]
    if constants:
        out.append(f"    module {name}_Constants {{")
        out += [f"      {c}" for c in constants]
        out.append("    };")
    if comment:
        text = ' "\\n"\n      '.join(json.dumps(c) for c in comment)
        out.append(f'    @verbatim (language="comment", text=\n      {text})')
    out.append(f"    struct {name} {{")
    for i, member in enumerate(members):
        if i:
            out.append("")
        out += [f"      {line}" for line in member]
    out += ["    };", "  };", "};", ""]
    return "\n".join(out)


def ros2idl(name, text):
    return "\n".join(to_idl(full, body) for full, body in split_definitions(name, text))


def main(source, target):
    converted = 0
    with open(source, "rb") as f, open(target, "wb") as out:
        reader = make_reader(f)
        header = reader.get_header()
        writer = Writer(out)
        writer.start(profile=header.profile, library="ros2idl_bag.py")
        schema_ids, channel_ids = {}, {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema is not None and schema.id not in schema_ids:
                if schema.encoding == "ros2msg":
                    data = ros2idl(schema.name, schema.data.decode()).encode()
                    schema_ids[schema.id] = writer.register_schema(schema.name, "ros2idl", data)
                    converted += 1
                else:
                    schema_ids[schema.id] = writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
            if channel.id not in channel_ids:
                channel_ids[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schema_ids.get(channel.schema_id, 0),
                    dict(channel.metadata),
                )
            writer.add_message(
                channel_ids[channel.id],
                message.log_time,
                message.data,
                message.publish_time,
                message.sequence,
            )
        writer.finish()
    print(json.dumps({"schemas": converted}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
