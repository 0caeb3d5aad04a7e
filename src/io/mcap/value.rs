//! Decoded messages as a dynamic tree. Arrays of numbers stay typed vectors, so that a
//! 512×512 grid decodes as one copy rather than a quarter of a million boxed values.

use std::sync::Arc;

use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};

#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Null,
    Bool(bool),
    Int(i64),
    Uint(u64),
    Float32(f32),
    Float64(f64),
    String(String),
    /// Fields in definition order; the names are shared with the schema.
    Struct {
        names: Arc<[Arc<str>]>,
        values: Vec<Value>,
    },
    /// Arrays of strings, messages and mixed JSON values.
    List(Vec<Value>),
    Bools(Vec<bool>),
    Int8s(Vec<i8>),
    Uint8s(Vec<u8>),
    Int16s(Vec<i16>),
    Uint16s(Vec<u16>),
    Int32s(Vec<i32>),
    Uint32s(Vec<u32>),
    Int64s(Vec<i64>),
    Uint64s(Vec<u64>),
    Float32s(Vec<f32>),
    Float64s(Vec<f64>),
}

impl Value {
    /// The field `name` of a struct.
    pub fn get(&self, name: &str) -> Option<&Value> {
        match self {
            Value::Struct { names, values } => {
                names.iter().position(|n| &**n == name).map(|i| &values[i])
            }
            _ => None,
        }
    }

    /// Follows a dotted path of field names, e.g. `pose.pose.position.x`.
    pub fn path(&self, dotted: &str) -> Option<&Value> {
        dotted
            .split('.')
            .try_fold(self, |value, name| value.get(name))
    }

    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Value::Int(v) => Some(v as f64),
            Value::Uint(v) => Some(v as f64),
            Value::Float32(v) => Some(f64::from(v)),
            Value::Float64(v) => Some(v),
            _ => None,
        }
    }

    pub fn as_u64(&self) -> Option<u64> {
        match *self {
            Value::Int(v) => u64::try_from(v).ok(),
            Value::Uint(v) => Some(v),
            _ => None,
        }
    }

    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// The elements of an array of messages or strings.
    pub fn as_list(&self) -> Option<&[Value]> {
        match self {
            Value::List(items) => Some(items),
            _ => None,
        }
    }

    /// The number of elements of an array, `None` for other values.
    pub fn array_len(&self) -> Option<usize> {
        Some(match self {
            Value::List(v) => v.len(),
            Value::Bools(v) => v.len(),
            Value::Int8s(v) => v.len(),
            Value::Uint8s(v) => v.len(),
            Value::Int16s(v) => v.len(),
            Value::Uint16s(v) => v.len(),
            Value::Int32s(v) => v.len(),
            Value::Uint32s(v) => v.len(),
            Value::Int64s(v) => v.len(),
            Value::Uint64s(v) => v.len(),
            Value::Float32s(v) => v.len(),
            Value::Float64s(v) => v.len(),
            _ => return None,
        })
    }

    /// Element `i` of a typed array, as a scalar value.
    pub fn item(&self, i: usize) -> Option<Value> {
        Some(match self {
            Value::List(v) => v.get(i)?.clone(),
            Value::Bools(v) => Value::Bool(*v.get(i)?),
            Value::Int8s(v) => Value::Int((*v.get(i)?).into()),
            Value::Uint8s(v) => Value::Uint((*v.get(i)?).into()),
            Value::Int16s(v) => Value::Int((*v.get(i)?).into()),
            Value::Uint16s(v) => Value::Uint((*v.get(i)?).into()),
            Value::Int32s(v) => Value::Int((*v.get(i)?).into()),
            Value::Uint32s(v) => Value::Uint((*v.get(i)?).into()),
            Value::Int64s(v) => Value::Int(*v.get(i)?),
            Value::Uint64s(v) => Value::Uint(*v.get(i)?),
            Value::Float32s(v) => Value::Float32(*v.get(i)?),
            Value::Float64s(v) => Value::Float64(*v.get(i)?),
            _ => return None,
        })
    }

    /// A numeric array as f32 values (grids: occupancy, float layers).
    pub fn to_f32s(&self) -> Option<Vec<f32>> {
        Some(match self {
            Value::Int8s(v) => v.iter().map(|&x| f32::from(x)).collect(),
            Value::Uint8s(v) => v.iter().map(|&x| f32::from(x)).collect(),
            Value::Int16s(v) => v.iter().map(|&x| f32::from(x)).collect(),
            Value::Uint16s(v) => v.iter().map(|&x| f32::from(x)).collect(),
            Value::Int32s(v) => v.iter().map(|&x| x as f32).collect(),
            Value::Uint32s(v) => v.iter().map(|&x| x as f32).collect(),
            Value::Float32s(v) => v.clone(),
            Value::Float64s(v) => v.iter().map(|&x| x as f32).collect(),
            Value::List(items) => items
                .iter()
                .map(|x| x.as_f64().map(|v| v as f32))
                .collect::<Option<Vec<_>>>()?,
            _ => return None,
        })
    }
}

/// Python's spelling of non-finite floats, which JSON cannot hold as numbers.
fn serialize_float<S: Serializer>(value: f64, serializer: S) -> Result<S::Ok, S::Error> {
    if value.is_finite() {
        serializer.serialize_f64(value)
    } else if value.is_nan() {
        serializer.serialize_str("nan")
    } else if value > 0.0 {
        serializer.serialize_str("inf")
    } else {
        serializer.serialize_str("-inf")
    }
}

struct Float(f64);

impl Serialize for Float {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serialize_float(self.0, serializer)
    }
}

fn sequence<S, T, I>(serializer: S, items: I) -> Result<S::Ok, S::Error>
where
    S: Serializer,
    T: Serialize,
    I: ExactSizeIterator<Item = T>,
{
    let mut seq = serializer.serialize_seq(Some(items.len()))?;
    for item in items {
        seq.serialize_element(&item)?;
    }
    seq.end()
}

/// JSON as the Foxglove Python decoder prints it: float32 widened to float64, byte and
/// char arrays as lists of integers, non-finite floats as strings.
impl Serialize for Value {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            Value::Null => serializer.serialize_unit(),
            Value::Bool(v) => serializer.serialize_bool(*v),
            Value::Int(v) => serializer.serialize_i64(*v),
            Value::Uint(v) => serializer.serialize_u64(*v),
            Value::Float32(v) => serialize_float(f64::from(*v), serializer),
            Value::Float64(v) => serialize_float(*v, serializer),
            Value::String(v) => serializer.serialize_str(v),
            Value::Struct { names, values } => {
                let mut map = serializer.serialize_map(Some(values.len()))?;
                for (name, value) in names.iter().zip(values) {
                    map.serialize_entry(&**name, value)?;
                }
                map.end()
            }
            Value::List(v) => sequence(serializer, v.iter()),
            Value::Bools(v) => sequence(serializer, v.iter()),
            Value::Int8s(v) => sequence(serializer, v.iter()),
            Value::Uint8s(v) => sequence(serializer, v.iter()),
            Value::Int16s(v) => sequence(serializer, v.iter()),
            Value::Uint16s(v) => sequence(serializer, v.iter()),
            Value::Int32s(v) => sequence(serializer, v.iter()),
            Value::Uint32s(v) => sequence(serializer, v.iter()),
            Value::Int64s(v) => sequence(serializer, v.iter()),
            Value::Uint64s(v) => sequence(serializer, v.iter()),
            Value::Float32s(v) => sequence(serializer, v.iter().map(|&x| Float(f64::from(x)))),
            Value::Float64s(v) => sequence(serializer, v.iter().map(|&x| Float(x))),
        }
    }
}

impl From<serde_json::Value> for Value {
    fn from(json: serde_json::Value) -> Self {
        match json {
            serde_json::Value::Null => Value::Null,
            serde_json::Value::Bool(b) => Value::Bool(b),
            serde_json::Value::Number(n) => {
                if let Some(i) = n.as_i64() {
                    Value::Int(i)
                } else if let Some(u) = n.as_u64() {
                    Value::Uint(u)
                } else {
                    Value::Float64(n.as_f64().unwrap_or(f64::NAN))
                }
            }
            serde_json::Value::String(s) => Value::String(s),
            serde_json::Value::Array(items) => {
                Value::List(items.into_iter().map(Value::from).collect())
            }
            serde_json::Value::Object(map) => {
                let (names, values): (Vec<Arc<str>>, Vec<Value>) = map
                    .into_iter()
                    .map(|(k, v)| (Arc::from(k.as_str()), Value::from(v)))
                    .unzip();
                Value::Struct {
                    names: names.into(),
                    values,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_widens_float32_and_spells_non_finite_as_python_does() {
        let value = Value::Struct {
            names: vec![Arc::from("a"), Arc::from("b"), Arc::from("c")].into(),
            values: vec![
                Value::Float32(1.1),
                Value::Float64s(vec![f64::NAN, f64::INFINITY, -f64::INFINITY, 0.0]),
                Value::Uint8s(vec![0, 255]),
            ],
        };
        let text = serde_json::to_string(&value).unwrap();
        assert_eq!(
            text,
            r#"{"a":1.100000023841858,"b":["nan","inf","-inf",0.0],"c":[0,255]}"#
        );
        assert_eq!(
            value.path("a").and_then(Value::as_f64),
            Some(f64::from(1.1f32))
        );
    }
}
