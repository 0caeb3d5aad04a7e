//! Choosing and running a channel's decoder from its message encoding and the schema
//! stored in the file: `cdr` + `ros2msg` (our parser and CDR decoder), `json` (any or no
//! schema), `protobuf` + a `FileDescriptorSet` (through `prost-reflect`).

use std::collections::HashMap;
use std::sync::Arc;

use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, ReflectMessage};

use super::cdr;
use super::reader::ChannelInfo;
use super::ros2msg::{self, Schema};
use super::value::Value;

pub enum MessageDecoder {
    Cdr(Schema),
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
                let text = std::str::from_utf8(&schema.data)
                    .map_err(|_| format!("schema '{}' is not UTF-8 text", schema.name))?;
                ros2msg::parse(&schema.name, text)
                    .map(MessageDecoder::Cdr)
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
                 '{schema_encoding}' (supported: cdr+ros2msg, json, protobuf+protobuf)"
            )),
        }
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        match self {
            MessageDecoder::Cdr(schema) => cdr::decode(schema, data).map_err(|e| e.to_string()),
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
    by_channel: HashMap<u16, Result<Arc<MessageDecoder>, String>>,
}

impl Decoders {
    pub fn get(&mut self, channel: &ChannelInfo) -> Result<Arc<MessageDecoder>, String> {
        self.by_channel
            .entry(channel.id)
            .or_insert_with(|| MessageDecoder::for_channel(channel).map(Arc::new))
            .clone()
    }
}
