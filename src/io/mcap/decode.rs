//! Choosing and running a channel's decoder from its message encoding and the schema
//! stored in the file: `cdr` + `ros2msg` or `ros2idl` and `ros1` + `ros1msg` (our parsers and
//! decoders), `json` (any or no schema), `protobuf` + a `FileDescriptorSet` (through
//! `prost-reflect`).

use std::collections::HashMap;
use std::sync::Arc;

use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, ReflectMessage};

use super::cdr;
use super::reader::{ChannelInfo, SchemaInfo};
use super::ros2idl;
use super::ros2msg::{self, Schema};
use super::value::Value;

pub enum MessageDecoder {
    Cdr(Schema),
    Ros1(Schema),
    Json,
    Protobuf(MessageDescriptor),
}

impl MessageDecoder {
    /// The decoder for a channel, or why there is none.
    pub fn for_channel(channel: &ChannelInfo) -> Result<Self, String> {
        let schema = channel.schema.as_deref();
        let schema_encoding = schema.map_or("", |s| s.encoding.as_str());
        match (channel.message_encoding.as_str(), schema) {
            ("cdr", Some(schema)) if schema_encoding == "ros2msg" => {
                ros2msg::parse(&schema.name, text(schema)?)
                    .map(MessageDecoder::Cdr)
                    .map_err(|e| format!("schema '{}': {e}", schema.name))
            }
            ("cdr", Some(schema)) if schema_encoding == "ros2idl" => {
                ros2idl::parse(&schema.name, text(schema)?)
                    .map(MessageDecoder::Cdr)
                    .map_err(|e| format!("schema '{}': {e}", schema.name))
            }
            ("ros1", Some(schema)) if schema_encoding == "ros1msg" => {
                ros2msg::parse_ros1(&schema.name, text(schema)?)
                    .map(MessageDecoder::Ros1)
                    .map_err(|e| format!("schema '{}': {e}", schema.name))
            }
            ("json", _) => Ok(MessageDecoder::Json),
            ("protobuf", Some(schema)) if schema_encoding == "protobuf" => {
                let pool = DescriptorPool::decode(schema.data.as_slice()).map_err(|e| {
                    format!("schema '{}' is not a FileDescriptorSet: {e}", schema.name)
                })?;
                pool.get_message_by_name(&schema.name)
                    .map(MessageDecoder::Protobuf)
                    .ok_or_else(|| {
                        format!(
                            "schema '{}' does not define message '{}'",
                            schema.name, schema.name
                        )
                    })
            }
            (encoding, _) => Err(format!(
                "no decoder for message encoding '{encoding}' with schema encoding \
                 '{schema_encoding}' (supported: cdr+ros2msg, cdr+ros2idl, ros1+ros1msg, json, \
                 protobuf+protobuf)"
            )),
        }
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        match self {
            MessageDecoder::Cdr(schema) => cdr::decode(schema, data).map_err(|e| e.to_string()),
            MessageDecoder::Ros1(schema) => {
                cdr::decode_ros1(schema, data).map_err(|e| e.to_string())
            }
            MessageDecoder::Json => serde_json::from_slice::<serde_json::Value>(data)
                .map(Value::from)
                .map_err(|e| format!("not JSON: {e}")),
            MessageDecoder::Protobuf(descriptor) => {
                DynamicMessage::decode(descriptor.clone(), data)
                    .map(|m| protobuf_message(&m))
                    .map_err(|e| format!("protobuf: {e}"))
            }
        }
    }
}

fn text(schema: &SchemaInfo) -> Result<&str, String> {
    std::str::from_utf8(&schema.data)
        .map_err(|_| format!("schema '{}' is not UTF-8 text", schema.name))
}

fn protobuf_message(message: &DynamicMessage) -> Value {
    let descriptor = message.descriptor();
    let (names, values): (Vec<Arc<str>>, Vec<Value>) = descriptor
        .fields()
        .map(|field| {
            let value = message.get_field(&field);
            (Arc::from(field.name()), protobuf_value(&value))
        })
        .unzip();
    Value::Struct {
        names: names.into(),
        values,
    }
}

fn protobuf_value(value: &prost_reflect::Value) -> Value {
    use prost_reflect::Value as P;
    match value {
        P::Bool(v) => Value::Bool(*v),
        P::I32(v) | P::EnumNumber(v) => Value::Int((*v).into()),
        P::I64(v) => Value::Int(*v),
        P::U32(v) => Value::Uint((*v).into()),
        P::U64(v) => Value::Uint(*v),
        P::F32(v) => Value::Float32(*v),
        P::F64(v) => Value::Float64(*v),
        P::String(v) => Value::String(v.clone()),
        P::Bytes(v) => Value::Uint8s(v.to_vec()),
        P::Message(m) => protobuf_message(m),
        P::List(items) => Value::List(items.iter().map(protobuf_value).collect()),
        P::Map(map) => {
            let mut entries: Vec<(String, Value)> = map
                .iter()
                .map(|(k, v)| (map_key(k), protobuf_value(v)))
                .collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            let (names, values): (Vec<Arc<str>>, Vec<Value>) = entries
                .into_iter()
                .map(|(k, v)| (Arc::from(k.as_str()), v))
                .unzip();
            Value::Struct {
                names: names.into(),
                values,
            }
        }
    }
}

fn map_key(key: &prost_reflect::MapKey) -> String {
    use prost_reflect::MapKey as K;
    match key {
        K::Bool(v) => v.to_string(),
        K::I32(v) => v.to_string(),
        K::I64(v) => v.to_string(),
        K::U32(v) => v.to_string(),
        K::U64(v) => v.to_string(),
        K::String(v) => v.clone(),
    }
}

/// One decoder per channel, built on first use; a channel without one keeps its reason.
#[derive(Default)]
pub struct Decoders {
    /// Behind a lock so that threads decoding chunks in parallel share one cache.
    by_channel: std::sync::Mutex<HashMap<u16, Result<Arc<MessageDecoder>, String>>>,
}

impl Decoders {
    pub fn get(&self, channel: &ChannelInfo) -> Result<Arc<MessageDecoder>, String> {
        // A panic elsewhere cannot leave the cache half-written: take it as it is.
        let mut cache = self
            .by_channel
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        cache
            .entry(channel.id)
            .or_insert_with(|| MessageDecoder::for_channel(channel).map(Arc::new))
            .clone()
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use prost::Message;
    use prost_reflect::Value as P;

    use super::super::ros2;
    use super::*;

    fn channel(name: &str, encoding: &str, schema_encoding: &str, data: Vec<u8>) -> ChannelInfo {
        ChannelInfo {
            id: 1,
            topic: "/t".into(),
            message_encoding: encoding.into(),
            schema: Some(Arc::new(SchemaInfo {
                id: 1,
                name: name.into(),
                encoding: schema_encoding.into(),
                data,
            })),
            metadata: BTreeMap::new(),
        }
    }

    fn build(pool: &DescriptorPool, name: &str, fields: Vec<(&str, P)>) -> DynamicMessage {
        let mut message = DynamicMessage::new(pool.get_message_by_name(name).unwrap());
        for (field, value) in fields {
            message.set_field_by_name(field, value);
        }
        message
    }

    fn pose(pool: &DescriptorPool, x: f64, y: f64) -> P {
        let position = build(
            pool,
            "foxglove.Vector3",
            vec![("x", P::F64(x)), ("y", P::F64(y))],
        );
        let orientation = build(pool, "foxglove.Quaternion", vec![("w", P::F64(1.0))]);
        P::Message(build(
            pool,
            "foxglove.Pose",
            vec![
                ("position", P::Message(position)),
                ("orientation", P::Message(orientation)),
            ],
        ))
    }

    #[test]
    fn protobuf_channels_decode_foxglove_poses_and_grids() {
        let schemas = super::super::foxglove::file_descriptor_set();
        let pool = DescriptorPool::decode(schemas.as_slice()).unwrap();
        let stamp = build(
            &pool,
            "google.protobuf.Timestamp",
            vec![("seconds", P::I64(12)), ("nanos", P::I32(500))],
        );

        let decoder = MessageDecoder::for_channel(&channel(
            "foxglove.PoseInFrame",
            "protobuf",
            "protobuf",
            schemas.clone(),
        ))
        .unwrap();
        let message = build(
            &pool,
            "foxglove.PoseInFrame",
            vec![
                ("timestamp", P::Message(stamp.clone())),
                ("frame_id", P::String("map".into())),
                ("pose", pose(&pool, 3.5, -1.0)),
            ],
        );
        let value = decoder.decode(&message.encode_to_vec()).unwrap();
        let poses = ros2::poses("foxglove.PoseInFrame", &value, 0).unwrap();
        assert_eq!(poses.len(), 1);
        assert_eq!(
            (
                poses[0].time,
                poses[0].frame.as_str(),
                poses[0].x,
                poses[0].y,
                poses[0].yaw
            ),
            (12_000_000_500, "map", 3.5, -1.0, 0.0)
        );

        // A 3 × 2 grid of (uint8 class, float32 height) cells, rows padded to 12 bytes.
        let mut data = Vec::new();
        for row in 0..2u8 {
            for col in 0..3u8 {
                data.push(row * 3 + col);
                data.extend_from_slice(&(f32::from(col) * 0.5).to_le_bytes());
            }
            data.extend_from_slice(&[0, 0, 0]);
        }
        let element = |name: &str, offset: u32, numeric: i32| {
            P::Message(build(
                &pool,
                "foxglove.PackedElementField",
                vec![
                    ("name", P::String(name.into())),
                    ("offset", P::U32(offset)),
                    ("type", P::EnumNumber(numeric)),
                ],
            ))
        };
        let cell_size = build(
            &pool,
            "foxglove.Vector2",
            vec![("x", P::F64(0.25)), ("y", P::F64(0.25))],
        );
        let grid = build(
            &pool,
            "foxglove.Grid",
            vec![
                ("timestamp", P::Message(stamp)),
                ("frame_id", P::String("map".into())),
                ("pose", pose(&pool, 1.0, 2.0)),
                ("column_count", P::U32(3)),
                ("cell_size", P::Message(cell_size)),
                ("row_stride", P::U32(18)),
                ("cell_stride", P::U32(5)),
                (
                    "fields",
                    P::List(vec![element("class", 0, 1), element("height", 1, 7)]),
                ),
                ("data", P::Bytes(data.into())),
            ],
        );
        let decoder =
            MessageDecoder::for_channel(&channel("foxglove.Grid", "protobuf", "protobuf", schemas))
                .unwrap();
        let value = decoder.decode(&grid.encode_to_vec()).unwrap();
        let map = ros2::grid("foxglove.Grid", &value, "g").unwrap();
        assert_eq!(
            (map.geo.width, map.geo.height, map.geo.resolution),
            (3, 2, 0.25)
        );
        assert_eq!(map.geo.origin, [1.0, 2.0]);
        assert_eq!(map.layers[0].values, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(map.layers[1].values, vec![0.0, 0.5, 1.0, 0.0, 0.5, 1.0]);
    }

    #[test]
    fn json_channels_decode_with_or_without_a_schema() {
        let decoder = MessageDecoder::for_channel(&channel(
            "foxglove.PoseInFrame",
            "json",
            "jsonschema",
            b"{}".to_vec(),
        ))
        .unwrap();
        let text = br#"{"timestamp": {"sec": 1, "nsec": 0}, "frame_id": "map",
            "pose": {"position": {"x": 1, "y": 2.5, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}"#;
        let value = decoder.decode(text).unwrap();
        assert_eq!(
            value.path("pose.position.y").and_then(Value::as_f64),
            Some(2.5)
        );
        let poses = ros2::poses("foxglove.PoseInFrame", &value, 7).unwrap();
        assert_eq!((poses[0].time, poses[0].x), (1_000_000_000, 1.0));
        assert!(
            decoder
                .decode(b"{not json")
                .unwrap_err()
                .contains("not JSON")
        );
        let err = MessageDecoder::for_channel(&channel("x", "cbor", "", Vec::new()))
            .err()
            .unwrap();
        assert!(err.contains("'cbor'"), "{err}");
    }
}
