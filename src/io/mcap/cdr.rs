//! Dynamic decoding and encoding of ROS messages, driven by a parsed message schema, in
//! the two wire formats:
//!
//! - CDR (OMG XCDR1, as ROS 2 serialises messages). A message starts with a 4-byte
//!   encapsulation header (kind in byte 1: bit 0 set means little endian; bytes 2–3 are
//!   options, ignored); primitives are aligned to their size counted from the end of that
//!   header; sequences and strings carry a u32 length (strings include their terminating
//!   NUL); empty messages hold one dummy byte; `wstring` is a u32 count of UTF-32 code
//!   units (Fast-CDR's `wchar_t` on Linux).
//! - ROS 1 serialisation: the same walk, little endian, packed (no header, no alignment),
//!   strings a u32 byte count without NUL (bytes that are not UTF-8 become U+FFFD, as
//!   genpy reads them), empty messages empty.

use std::fmt;

use super::ros2msg::{Arity, BaseType, Field, Primitive, Schema};
use super::value::Value;

const HEADER: usize = 4;

/// How a message is laid out in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wire {
    Cdr,
    Ros1,
}

/// Where in a message decoding failed, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct CdrError {
    /// Field names from the root down to the failing field (array items as `[i]`).
    pub path: Vec<String>,
    pub offset: usize,
    pub problem: String,
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "at byte {}: {}", self.offset, self.problem)
        } else {
            let mut path = String::new();
            for part in self.path.iter().rev() {
                if !path.is_empty() && !part.starts_with('[') {
                    path.push('.');
                }
                path.push_str(part);
            }
            write!(f, "field {path} at byte {}: {}", self.offset, self.problem)
        }
    }
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    little: bool,
    wire: Wire,
}

macro_rules! read_number {
    ($name:ident, $ty:ty) => {
        fn $name(&mut self) -> Result<$ty, CdrError> {
            const SIZE: usize = std::mem::size_of::<$ty>();
            self.align(SIZE);
            let bytes: [u8; SIZE] = self.take(SIZE)?.try_into().expect("took SIZE bytes");
            Ok(if self.little {
                <$ty>::from_le_bytes(bytes)
            } else {
                <$ty>::from_be_bytes(bytes)
            })
        }
    };
}

macro_rules! read_numbers {
    ($name:ident, $ty:ty) => {
        fn $name(&mut self, count: usize) -> Result<Vec<$ty>, CdrError> {
            const SIZE: usize = std::mem::size_of::<$ty>();
            if count > 0 {
                self.align(SIZE);
            }
            let bytes = self.take(
                count
                    .checked_mul(SIZE)
                    .ok_or_else(|| self.fail("array too long"))?,
            )?;
            let chunks = bytes.chunks_exact(SIZE);
            Ok(if self.little {
                chunks
                    .map(|c| <$ty>::from_le_bytes(c.try_into().expect("chunk of SIZE")))
                    .collect()
            } else {
                chunks
                    .map(|c| <$ty>::from_be_bytes(c.try_into().expect("chunk of SIZE")))
                    .collect()
            })
        }
    };
}

impl<'a> Reader<'a> {
    fn fail(&self, problem: impl Into<String>) -> CdrError {
        CdrError {
            path: Vec::new(),
            offset: self.pos,
            problem: problem.into(),
        }
    }

    fn align(&mut self, size: usize) {
        if self.wire == Wire::Ros1 {
            return;
        }
        let misalignment = (self.pos - HEADER) % size;
        if misalignment != 0 {
            self.pos += size - misalignment;
        }
    }

    fn take(&mut self, count: usize) -> Result<&'a [u8], CdrError> {
        let end = self
            .pos
            .checked_add(count)
            .filter(|&e| e <= self.data.len());
        let Some(end) = end else {
            return Err(self.fail(format!(
                "the message ends at byte {} but {count} more bytes are needed",
                self.data.len()
            )));
        };
        let bytes = &self.data[self.pos..end];
        self.pos = end;
        Ok(bytes)
    }

    read_number!(u16, u16);
    read_number!(i16, i16);
    read_number!(u32, u32);
    read_number!(i32, i32);
    read_number!(u64, u64);
    read_number!(i64, i64);
    read_number!(f32, f32);
    read_number!(f64, f64);
    read_numbers!(u16s, u16);
    read_numbers!(i16s, i16);
    read_numbers!(u32s, u32);
    read_numbers!(i32s, i32);
    read_numbers!(u64s, u64);
    read_numbers!(i64s, i64);
    read_numbers!(f32s, f32);
    read_numbers!(f64s, f64);

    fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.take(1)?[0])
    }

    /// A sequence length, checked against the bytes left (each element takes at least
    /// `min_size` bytes) so that corrupt lengths fail instead of allocating. Elements
    /// that take no bytes (ROS 1's empty messages) are held to `MAX_EMPTY_ITEMS`.
    fn length(&mut self, min_size: usize) -> Result<usize, CdrError> {
        let length = self.u32()? as usize;
        self.fits(length, min_size)?;
        Ok(length)
    }

    /// Whether `length` elements of at least `min_size` bytes each can follow.
    fn fits(&self, length: usize, min_size: usize) -> Result<(), CdrError> {
        const MAX_EMPTY_ITEMS: usize = 1 << 16;
        let left = self.data.len() - self.pos.min(self.data.len());
        if min_size == 0 && length > MAX_EMPTY_ITEMS {
            return Err(self.fail(format!(
                "an array of {length} empty messages is longer than {MAX_EMPTY_ITEMS}"
            )));
        }
        if length.saturating_mul(min_size) > left {
            return Err(self.fail(format!(
                "a length of {length} does not fit in the {left} bytes left"
            )));
        }
        Ok(())
    }

    fn string(&mut self) -> Result<String, CdrError> {
        let length = self.length(1)?;
        let bytes = self.take(length)?;
        if self.wire == Wire::Ros1 {
            return Ok(String::from_utf8_lossy(bytes).into_owned());
        }
        // Serialisers differ on whether an empty string has its NUL (length 0 or 1).
        let text = match bytes.split_last() {
            Some((0, text)) => text,
            _ => bytes,
        };
        String::from_utf8(text.to_vec()).map_err(|_| self.fail("string is not UTF-8"))
    }

    fn wstring(&mut self) -> Result<String, CdrError> {
        let length = self.length(4)?;
        let units = self.u32s(length)?;
        let text: Option<String> = units
            .into_iter()
            .take_while(|&u| u != 0)
            .map(char::from_u32)
            .collect();
        text.ok_or_else(|| self.fail("wstring holds an invalid code point"))
    }
}

/// Decodes one CDR message of the schema's root type.
pub fn decode(schema: &Schema, data: &[u8]) -> Result<Value, CdrError> {
    if data.len() < HEADER {
        return Err(CdrError {
            path: Vec::new(),
            offset: 0,
            problem: format!(
                "{} bytes cannot hold the 4-byte CDR encapsulation header",
                data.len()
            ),
        });
    }
    let kind = data[1];
    if kind > 1 {
        return Err(CdrError {
            path: Vec::new(),
            offset: 1,
            problem: format!(
                "encapsulation kind {kind} is not plain CDR (0 big endian, 1 little endian)"
            ),
        });
    }
    let mut reader = Reader {
        data,
        pos: HEADER,
        little: kind & 1 == 1,
        wire: Wire::Cdr,
    };
    decode_message(schema, schema.root, &mut reader)
}

/// Decodes one ROS 1 message of the schema's root type.
pub fn decode_ros1(schema: &Schema, data: &[u8]) -> Result<Value, CdrError> {
    let mut reader = Reader {
        data,
        pos: 0,
        little: true,
        wire: Wire::Ros1,
    };
    decode_message(schema, schema.root, &mut reader)
}

fn decode_message(
    schema: &Schema,
    index: usize,
    reader: &mut Reader<'_>,
) -> Result<Value, CdrError> {
    let def = &schema.messages[index];
    if def.fields.is_empty() && reader.wire == Wire::Cdr {
        // ROS 2 gives empty messages a `uint8 structure_needs_at_least_one_member`.
        reader.u8()?;
    }
    let mut values = Vec::with_capacity(def.fields.len());
    for field in &def.fields {
        let value = decode_field(schema, field, reader).map_err(|mut e| {
            e.path.push(field.name.to_string());
            e
        })?;
        values.push(value);
    }
    Ok(Value::Struct {
        names: def.field_names.clone(),
        values,
    })
}

fn decode_field(
    schema: &Schema,
    field: &Field,
    reader: &mut Reader<'_>,
) -> Result<Value, CdrError> {
    let item_size = || match field.base {
        BaseType::Primitive(p) => p.min_size(),
        // A CDR message takes a byte at least (an empty one its dummy byte).
        BaseType::Message(inner) if reader.wire == Wire::Cdr => {
            schema.messages[inner].min_size.max(1)
        }
        BaseType::Message(inner) => schema.messages[inner].min_size,
    };
    let count = match field.arity {
        Arity::Single => None,
        Arity::Fixed(n) => {
            reader.fits(n, item_size())?;
            Some(n)
        }
        Arity::Unbounded | Arity::Bounded(_) => Some(reader.length(item_size())?),
    };
    match (&field.base, count) {
        (BaseType::Message(inner), None) => decode_message(schema, *inner, reader),
        (BaseType::Message(inner), Some(n)) => (0..n)
            .map(|i| {
                decode_message(schema, *inner, reader).map_err(|mut e| {
                    e.path.push(format!("[{i}]"));
                    e
                })
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Value::List),
        (BaseType::Primitive(p), None) => decode_primitive(*p, reader),
        (BaseType::Primitive(p), Some(n)) => decode_primitives(*p, n, reader),
    }
}

fn decode_primitive(primitive: Primitive, reader: &mut Reader<'_>) -> Result<Value, CdrError> {
    Ok(match primitive {
        Primitive::Bool => Value::Bool(reader.u8()? != 0),
        Primitive::Byte | Primitive::Uint8 => Value::Uint(reader.u8()?.into()),
        Primitive::Char | Primitive::Int8 => Value::Int((reader.u8()? as i8).into()),
        Primitive::Int16 => Value::Int(reader.i16()?.into()),
        Primitive::Uint16 => Value::Uint(reader.u16()?.into()),
        Primitive::Int32 => Value::Int(reader.i32()?.into()),
        Primitive::Uint32 => Value::Uint(reader.u32()?.into()),
        Primitive::Int64 => Value::Int(reader.i64()?),
        Primitive::Uint64 => Value::Uint(reader.u64()?),
        Primitive::Float32 => Value::Float32(reader.f32()?),
        Primitive::Float64 => Value::Float64(reader.f64()?),
        Primitive::String => Value::String(reader.string()?),
        Primitive::WString => Value::String(reader.wstring()?),
    })
}

fn decode_primitives(
    primitive: Primitive,
    count: usize,
    reader: &mut Reader<'_>,
) -> Result<Value, CdrError> {
    Ok(match primitive {
        Primitive::Bool => Value::Bools(reader.take(count)?.iter().map(|&b| b != 0).collect()),
        Primitive::Byte | Primitive::Uint8 => Value::Uint8s(reader.take(count)?.to_vec()),
        Primitive::Char | Primitive::Int8 => {
            Value::Int8s(reader.take(count)?.iter().map(|&b| b as i8).collect())
        }
        Primitive::Int16 => Value::Int16s(reader.i16s(count)?),
        Primitive::Uint16 => Value::Uint16s(reader.u16s(count)?),
        Primitive::Int32 => Value::Int32s(reader.i32s(count)?),
        Primitive::Uint32 => Value::Uint32s(reader.u32s(count)?),
        Primitive::Int64 => Value::Int64s(reader.i64s(count)?),
        Primitive::Uint64 => Value::Uint64s(reader.u64s(count)?),
        Primitive::Float32 => Value::Float32s(reader.f32s(count)?),
        Primitive::Float64 => Value::Float64s(reader.f64s(count)?),
        Primitive::String | Primitive::WString => {
            let mut items = Vec::with_capacity(count.min(1 << 16));
            for i in 0..count {
                let item = decode_primitive(primitive, reader).map_err(|mut e| {
                    e.path.push(format!("[{i}]"));
                    e
                })?;
                items.push(item);
            }
            Value::List(items)
        }
    })
}

/// Writes messages little endian, in CDR (the layout ROS 2 records) or ROS 1's layout.
struct Writer {
    out: Vec<u8>,
    wire: Wire,
}

impl Writer {
    fn align(&mut self, size: usize) {
        while self.wire == Wire::Cdr && !(self.out.len() - HEADER).is_multiple_of(size) {
            self.out.push(0);
        }
    }

    fn put<const N: usize>(&mut self, bytes: [u8; N]) {
        self.align(N);
        self.out.extend_from_slice(&bytes);
    }

    fn put_all<const N: usize, T: Copy>(&mut self, items: &[T], to_bytes: impl Fn(T) -> [u8; N]) {
        if !items.is_empty() {
            self.align(N);
        }
        for &item in items {
            self.out.extend_from_slice(&to_bytes(item));
        }
    }

    fn length(&mut self, length: usize) -> Result<(), String> {
        let length = u32::try_from(length).map_err(|_| "array longer than 2^32".to_string())?;
        self.put(length.to_le_bytes());
        Ok(())
    }

    fn string(&mut self, text: &str) -> Result<(), String> {
        let nul = usize::from(self.wire == Wire::Cdr);
        self.length(text.len() + nul)?;
        self.out.extend_from_slice(text.as_bytes());
        self.out.resize(self.out.len() + nul, 0);
        Ok(())
    }
}

/// Encodes `value`, a struct of the schema's root type, as little-endian CDR.
pub fn encode(schema: &Schema, value: &Value) -> Result<Vec<u8>, String> {
    let mut writer = Writer {
        out: vec![0, 1, 0, 0],
        wire: Wire::Cdr,
    };
    encode_message(schema, schema.root, value, &mut writer)?;
    Ok(writer.out)
}

/// Encodes `value`, a struct of the schema's root type, in ROS 1's layout.
pub fn encode_ros1(schema: &Schema, value: &Value) -> Result<Vec<u8>, String> {
    let mut writer = Writer {
        out: Vec::new(),
        wire: Wire::Ros1,
    };
    encode_message(schema, schema.root, value, &mut writer)?;
    Ok(writer.out)
}

fn encode_message(
    schema: &Schema,
    index: usize,
    value: &Value,
    writer: &mut Writer,
) -> Result<(), String> {
    let def = &schema.messages[index];
    if def.fields.is_empty() && writer.wire == Wire::Cdr {
        writer.out.push(0);
    }
    for field in &def.fields {
        let item = value
            .get(&field.name)
            .ok_or_else(|| format!("{} has no field '{}'", def.name, field.name))?;
        encode_field(schema, field, item, writer).map_err(|e| format!("{}: {e}", field.name))?;
    }
    Ok(())
}

fn encode_field(
    schema: &Schema,
    field: &Field,
    value: &Value,
    writer: &mut Writer,
) -> Result<(), String> {
    let length = value.array_len().unwrap_or(0);
    match field.arity {
        Arity::Single => {}
        Arity::Fixed(n) if n != length => {
            return Err(format!("holds {length} values, the array has {n}"));
        }
        Arity::Fixed(_) => {}
        Arity::Bounded(n) if length > n => {
            return Err(format!("holds {length} values, more than the bound {n}"));
        }
        Arity::Unbounded | Arity::Bounded(_) => writer.length(length)?,
    }
    match (&field.base, field.arity, value) {
        (BaseType::Message(inner), Arity::Single, _) => {
            encode_message(schema, *inner, value, writer)
        }
        (BaseType::Message(inner), _, Value::List(items)) => items
            .iter()
            .try_for_each(|item| encode_message(schema, *inner, item, writer)),
        (BaseType::Primitive(p), Arity::Single, _) => encode_primitive(*p, value, writer),
        (BaseType::Primitive(Primitive::Uint8 | Primitive::Byte), _, Value::Uint8s(v)) => {
            writer.out.extend_from_slice(v);
            Ok(())
        }
        (BaseType::Primitive(Primitive::Float32), _, Value::Float32s(v)) => {
            writer.put_all(v, f32::to_le_bytes);
            Ok(())
        }
        (BaseType::Primitive(Primitive::Float64), _, Value::Float64s(v)) => {
            writer.put_all(v, f64::to_le_bytes);
            Ok(())
        }
        (BaseType::Primitive(p), _, Value::List(items)) => items
            .iter()
            .try_for_each(|item| encode_primitive(*p, item, writer)),
        (BaseType::Primitive(p), _, typed) => (0..length).try_for_each(|i| {
            let item = typed.item(i).ok_or("not an array")?;
            encode_primitive(*p, &item, writer)
        }),
        _ => Err("array of a kind the encoder does not write".to_string()),
    }
}

fn encode_primitive(
    primitive: Primitive,
    value: &Value,
    writer: &mut Writer,
) -> Result<(), String> {
    let int = || match *value {
        Value::Int(v) => Ok(i128::from(v)),
        Value::Uint(v) => Ok(i128::from(v)),
        Value::Bool(v) => Ok(i128::from(v)),
        _ => Err(format!("expected an integer, found {value:?}")),
    };
    let float = || {
        value
            .as_f64()
            .ok_or_else(|| format!("expected a number, found {value:?}"))
    };
    let out_of_range = |v: i128| format!("{v} is out of range for {primitive:?}");
    match primitive {
        Primitive::Bool => writer.out.push(u8::from(int()? != 0)),
        Primitive::Byte | Primitive::Uint8 => {
            let v = int()?;
            writer
                .out
                .push(u8::try_from(v).map_err(|_| out_of_range(v))?);
        }
        Primitive::Char | Primitive::Int8 => {
            let v = int()?;
            writer
                .out
                .push(i8::try_from(v).map_err(|_| out_of_range(v))? as u8);
        }
        Primitive::Int16 => {
            let v = int()?;
            writer.put(i16::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Uint16 => {
            let v = int()?;
            writer.put(u16::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Int32 => {
            let v = int()?;
            writer.put(i32::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Uint32 => {
            let v = int()?;
            writer.put(u32::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Int64 => {
            let v = int()?;
            writer.put(i64::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Uint64 => {
            let v = int()?;
            writer.put(u64::try_from(v).map_err(|_| out_of_range(v))?.to_le_bytes());
        }
        Primitive::Float32 => writer.put((float()? as f32).to_le_bytes()),
        Primitive::Float64 => writer.put(float()?.to_le_bytes()),
        Primitive::String => writer.string(value.as_str().ok_or("expected a string")?)?,
        Primitive::WString => {
            let text = value.as_str().ok_or("expected a string")?;
            let units: Vec<u32> = text.chars().map(u32::from).chain([0]).collect();
            writer.length(units.len())?;
            writer.put_all(&units, u32::to_le_bytes);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::ros2msg::{parse, parse_ros1};
    use super::*;
    use proptest::prelude::*;

    const SCHEMA: &str = "\
uint8 a
float64 b
string s
int16[] v
Inner[2] inner
wstring w
bool[3] flags
Empty e
================================================================================
MSG: p/Inner
char c
float32[<=4] f
string[] names
================================================================================
MSG: p/Empty
int32 ONLY_A_CONSTANT=1
";

    /// SCHEMA in ROS 1's words: no wstring or bounds, and `char` is unsigned there.
    const SCHEMA_ROS1: &str = "\
uint8 a
float64 b
string s
int16[] v
Inner[2] inner
string w
bool[3] flags
Empty e
================================================================================
MSG: p/Inner
int8 c
float32[] f
string[] names
================================================================================
MSG: p/Empty
int32 ONLY_A_CONSTANT=1
";

    #[test]
    fn ros1_is_packed_headerless_and_reads_strings_as_genpy_does() {
        let schema = parse_ros1(
            "p/M",
            "uint8 a\nfloat64 b\nstring s\nEmpty e\nuint8 z\n\
                                        ===\nMSG: p/Empty\n",
        )
        .unwrap();
        let mut data = vec![7];
        data.extend_from_slice(&2.5f64.to_le_bytes());
        data.extend_from_slice(&[3, 0, 0, 0, b'a', 0xff, b'b', 9]);
        let value = decode_ros1(&schema, &data).unwrap();
        assert_eq!(value.get("b"), Some(&Value::Float64(2.5)));
        // Bytes that are not UTF-8 become U+FFFD; the empty message takes no byte.
        assert_eq!(value.get("s"), Some(&Value::String("a\u{fffd}b".into())));
        assert_eq!(value.get("z"), Some(&Value::Uint(9)));

        // Empty messages take no bytes, so their count is held to a bound of its own.
        let schema = parse_ros1("p/M", "Empty[] e\n===\nMSG: p/Empty\n").unwrap();
        let many = decode_ros1(&schema, &[0, 0, 1, 0]).unwrap();
        assert_eq!(many.get("e").and_then(Value::array_len), Some(65536));
        let err = decode_ros1(&schema, &[1, 0, 1, 0]).unwrap_err();
        assert!(err.problem.contains("longer than 65536"), "{err}");
        // Fixed arrays are checked against the bytes left before anything is built.
        let schema = parse_ros1("p/M", "float64[100000000] big").unwrap();
        let err = decode_ros1(&schema, &[0; 64]).unwrap_err();
        assert!(err.problem.contains("does not fit"), "{err}");
    }

    #[test]
    fn aligns_after_the_header_and_reads_big_endian_too() {
        let schema = parse("p/msg/M", "uint8 a\nfloat64 b").unwrap();
        let mut le = vec![0, 1, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        le.extend_from_slice(&2.5f64.to_le_bytes());
        let mut be = vec![0, 0, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        be.extend_from_slice(&2.5f64.to_be_bytes());
        for data in [le, be] {
            let value = decode(&schema, &data).unwrap();
            assert_eq!(value.get("a"), Some(&Value::Uint(7)));
            assert_eq!(value.get("b"), Some(&Value::Float64(2.5)));
        }
    }

    #[test]
    fn ignores_option_bytes_and_names_the_field_that_runs_short() {
        let schema = parse("p/msg/M", SCHEMA).unwrap();
        let err = decode(&schema, &[0, 1, 0, 3, 9]).unwrap_err();
        assert_eq!(err.path, vec!["b".to_string()]);
        assert!(err.to_string().starts_with("field b at byte 12"), "{err}");
        let err = decode(
            &schema,
            &[0, 1, 0, 0, 9, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        )
        .unwrap_err();
        assert!(err.to_string().contains("field s"), "{err}");
        let err = decode(&schema, &[0, 7, 0, 0]).unwrap_err();
        assert!(err.problem.contains("kind 7"), "{err}");
    }

    fn arbitrary_message() -> impl Strategy<Value = Value> {
        let inner = (
            any::<i8>(),
            prop::collection::vec(any::<f32>().prop_filter("finite", |x| x.is_finite()), 0..=4),
            prop::collection::vec("[a-z]{0,6}", 0..3),
        )
            .prop_map(|(c, f, names)| Value::Struct {
                names: vec!["c".into(), "f".into(), "names".into()].into(),
                values: vec![
                    Value::Int(c.into()),
                    Value::Float32s(f),
                    Value::List(names.into_iter().map(Value::String).collect()),
                ],
            });
        (
            any::<u8>(),
            any::<f64>().prop_filter("finite", |x| x.is_finite()),
            "\\PC{0,12}",
            prop::collection::vec(any::<i16>(), 0..9),
            [inner.clone(), inner],
            "\\PC{0,5}",
            [any::<bool>(), any::<bool>(), any::<bool>()],
        )
            .prop_map(|(a, b, s, v, inner, w, flags)| Value::Struct {
                names: ["a", "b", "s", "v", "inner", "w", "flags", "e"]
                    .map(std::sync::Arc::<str>::from)
                    .to_vec()
                    .into(),
                values: vec![
                    Value::Uint(a.into()),
                    Value::Float64(b),
                    Value::String(s),
                    Value::Int16s(v),
                    Value::List(inner.to_vec()),
                    Value::String(w),
                    Value::Bools(flags.to_vec()),
                    Value::Struct {
                        names: Vec::new().into(),
                        values: Vec::new(),
                    },
                ],
            })
    }

    proptest! {
        #[test]
        fn decode_inverts_encode(message in arbitrary_message()) {
            let schema = parse("p/msg/M", SCHEMA).unwrap();
            let bytes = encode(&schema, &message).unwrap();
            prop_assert_eq!(decode(&schema, &bytes).unwrap(), message);
        }

        #[test]
        fn ros1_decode_inverts_encode(message in arbitrary_message()) {
            let schema = parse_ros1("p/M", SCHEMA_ROS1).unwrap();
            let bytes = encode_ros1(&schema, &message).unwrap();
            prop_assert_eq!(decode_ros1(&schema, &bytes).unwrap(), message);
        }

        #[test]
        fn arbitrary_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..200)) {
            let schema = parse("p/msg/M", SCHEMA).unwrap();
            let _ = decode(&schema, &data);
            let schema = parse_ros1("p/M", SCHEMA_ROS1).unwrap();
            let _ = decode_ros1(&schema, &data);
        }

        #[test]
        fn truncated_messages_fail_cleanly(message in arbitrary_message(), cut in 0usize..1000) {
            let schema = parse("p/msg/M", SCHEMA).unwrap();
            let bytes = encode(&schema, &message).unwrap();
            let cut = cut % bytes.len();
            prop_assert!(decode(&schema, &bytes[..cut]).is_err());
            let schema = parse_ros1("p/M", SCHEMA_ROS1).unwrap();
            let bytes = encode_ros1(&schema, &message).unwrap();
            let cut = cut % bytes.len();
            prop_assert!(decode_ros1(&schema, &bytes[..cut]).is_err());
        }
    }
}
