//! Foxglove's protobuf schemas (github.com/foxglove/foxglove-sdk, `schemas/proto`),
//! described in code as the FileDescriptorSet an MCAP schema record carries, and the
//! `foxglove.Grid` messages the tool writes. Field numbers follow the published
//! `.proto` files.

use prost::Message;
use prost_reflect::{DescriptorPool, DynamicMessage, Value as P};
use prost_types::field_descriptor_proto::{Label, Type};
use prost_types::{
    DescriptorProto, EnumDescriptorProto, EnumValueDescriptorProto, FieldDescriptorProto,
    FileDescriptorProto, FileDescriptorSet,
};

use crate::grid::GeoRef;

fn field(name: &str, number: i32, ty: Type, type_name: Option<&str>) -> FieldDescriptorProto {
    FieldDescriptorProto {
        name: Some(name.into()),
        number: Some(number),
        label: Some(Label::Optional as i32),
        r#type: Some(ty as i32),
        type_name: type_name.map(String::from),
        ..Default::default()
    }
}

fn message(name: &str, fields: Vec<FieldDescriptorProto>) -> DescriptorProto {
    DescriptorProto {
        name: Some(name.into()),
        field: fields,
        ..Default::default()
    }
}

/// The Foxglove schemas the tool reads and writes (`foxglove.Grid`, `foxglove.PoseInFrame`
/// and what they use), as a FileDescriptorSet: what an MCAP `protobuf` schema record holds.
pub fn file_descriptor_set() -> Vec<u8> {
    let double = |name: &str, n| field(name, n, Type::Double, None);
    let timestamp = FileDescriptorProto {
        name: Some("google/protobuf/timestamp.proto".into()),
        package: Some("google.protobuf".into()),
        message_type: vec![message(
            "Timestamp",
            vec![
                field("seconds", 1, Type::Int64, None),
                field("nanos", 2, Type::Int32, None),
            ],
        )],
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    let mut fields = field(
        "fields",
        8,
        Type::Message,
        Some(".foxglove.PackedElementField"),
    );
    fields.label = Some(Label::Repeated as i32);
    let numeric = EnumDescriptorProto {
        name: Some("NumericType".into()),
        value: [
            "UNKNOWN", "UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "FLOAT32", "FLOAT64",
        ]
        .iter()
        .enumerate()
        .map(|(i, n)| EnumValueDescriptorProto {
            name: Some((*n).into()),
            number: Some(i as i32),
            ..Default::default()
        })
        .collect(),
        ..Default::default()
    };
    let foxglove = FileDescriptorProto {
        name: Some("foxglove/schemas.proto".into()),
        package: Some("foxglove".into()),
        dependency: vec!["google/protobuf/timestamp.proto".into()],
        message_type: vec![
            message("Vector2", vec![double("x", 1), double("y", 2)]),
            message(
                "Vector3",
                vec![double("x", 1), double("y", 2), double("z", 3)],
            ),
            message(
                "Quaternion",
                vec![
                    double("x", 1),
                    double("y", 2),
                    double("z", 3),
                    double("w", 4),
                ],
            ),
            message(
                "Pose",
                vec![
                    field("position", 1, Type::Message, Some(".foxglove.Vector3")),
                    field(
                        "orientation",
                        2,
                        Type::Message,
                        Some(".foxglove.Quaternion"),
                    ),
                ],
            ),
            message(
                "PoseInFrame",
                vec![
                    field(
                        "timestamp",
                        1,
                        Type::Message,
                        Some(".google.protobuf.Timestamp"),
                    ),
                    field("frame_id", 2, Type::String, None),
                    field("pose", 3, Type::Message, Some(".foxglove.Pose")),
                ],
            ),
            message(
                "PackedElementField",
                vec![
                    field("name", 1, Type::String, None),
                    field("offset", 2, Type::Fixed32, None),
                    field("type", 3, Type::Enum, Some(".foxglove.NumericType")),
                ],
            ),
            message(
                "Grid",
                vec![
                    field(
                        "timestamp",
                        1,
                        Type::Message,
                        Some(".google.protobuf.Timestamp"),
                    ),
                    field("pose", 2, Type::Message, Some(".foxglove.Pose")),
                    field("column_count", 3, Type::Uint32, None),
                    field("cell_size", 4, Type::Message, Some(".foxglove.Vector2")),
                    field("row_stride", 5, Type::Uint32, None),
                    field("cell_stride", 6, Type::Uint32, None),
                    field("frame_id", 7, Type::String, None),
                    fields,
                    field("data", 9, Type::Bytes, None),
                ],
            ),
        ],
        enum_type: vec![numeric],
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    FileDescriptorSet {
        file: vec![timestamp, foxglove],
    }
    .encode_to_vec()
}

fn build(pool: &DescriptorPool, name: &str, fields: Vec<(&str, P)>) -> DynamicMessage {
    let descriptor = pool
        .get_message_by_name(name)
        .expect("the built-in descriptor set defines it");
    let mut message = DynamicMessage::new(descriptor);
    for (field, value) in fields {
        message.set_field_by_name(field, value);
    }
    message
}

/// An encoded `foxglove.Grid` of float32 layers (cells row by row from the south-west
/// corner, as our rasters), at `ns` nanoseconds.
pub fn grid_message(ns: u64, geo: &GeoRef, layers: &[(&str, &[f32])]) -> Vec<u8> {
    let pool = DescriptorPool::decode(file_descriptor_set().as_slice())
        .expect("the built-in descriptor set is valid");
    let b = |name: &str, fields: Vec<(&str, P)>| P::Message(build(&pool, name, fields));
    let cell_stride = 4 * layers.len() as u32;
    let mut data = Vec::with_capacity(geo.cell_count() * layers.len() * 4);
    for i in 0..geo.cell_count() {
        for (_, values) in layers {
            data.extend_from_slice(&values[i].to_le_bytes());
        }
    }
    let fields = layers
        .iter()
        .enumerate()
        .map(|(k, (name, _))| {
            b(
                "foxglove.PackedElementField",
                vec![
                    ("name", P::String((*name).to_string())),
                    ("offset", P::U32(4 * k as u32)),
                    ("type", P::EnumNumber(7)), // FLOAT32
                ],
            )
        })
        .collect();
    let message = build(
        &pool,
        "foxglove.Grid",
        vec![
            (
                "timestamp",
                b(
                    "google.protobuf.Timestamp",
                    vec![
                        ("seconds", P::I64((ns / 1_000_000_000) as i64)),
                        ("nanos", P::I32((ns % 1_000_000_000) as i32)),
                    ],
                ),
            ),
            ("frame_id", P::String(geo.frame.clone())),
            (
                "pose",
                b(
                    "foxglove.Pose",
                    vec![
                        (
                            "position",
                            b(
                                "foxglove.Vector3",
                                vec![("x", P::F64(geo.origin[0])), ("y", P::F64(geo.origin[1]))],
                            ),
                        ),
                        (
                            "orientation",
                            b("foxglove.Quaternion", vec![("w", P::F64(1.0))]),
                        ),
                    ],
                ),
            ),
            ("column_count", P::U32(geo.width)),
            (
                "cell_size",
                b(
                    "foxglove.Vector2",
                    vec![("x", P::F64(geo.resolution)), ("y", P::F64(geo.resolution))],
                ),
            ),
            ("row_stride", P::U32(cell_stride * geo.width)),
            ("cell_stride", P::U32(cell_stride)),
            ("fields", P::List(fields)),
            ("data", P::Bytes(data.into())),
        ],
    );
    message.encode_to_vec()
}
