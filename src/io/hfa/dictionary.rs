//! The self-describing object model of an Imagine file: its data dictionary (each
//! type's fields: `{1:lwidth,1:e3:thematic,athematic,...,layerType,...}Eimg_Layer,`) and
//! the values a node's bytes decode to under it, as GDAL's `HFADictionary` and
//! `HFAField` read them; and the sample types of layers and base data.

use std::collections::HashMap;

/// The deepest nesting of types and objects.
pub(super) const MAX_DEPTH: usize = 16;

/// One field of a type in the data dictionary: `count:[p|*]kind[...]name`.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Field {
    name: String,
    /// The number of items (for a pointer field, the file says how many).
    count: usize,
    /// Whether the items follow a count and an offset (`p` or `*`).
    pointer: bool,
    /// The item's type letter (`c` char, `e` enum, `l` long, `d` double, `o` object...).
    kind: u8,
    /// An enum's value names.
    names: Vec<String>,
    /// An object's type.
    object: Option<String>,
}

/// The data dictionary: each type's fields, in order.
pub(super) type Dictionary = HashMap<String, Vec<Field>>;

/// A reader over the dictionary's text.
struct Text<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Text<'_> {
    fn peek(&mut self) -> Option<u8> {
        while self
            .bytes
            .get(self.at)
            .is_some_and(|b| b.is_ascii_whitespace())
        {
            self.at += 1;
        }
        self.bytes.get(self.at).copied()
    }

    fn byte(&mut self) -> std::result::Result<u8, String> {
        let byte = self
            .peek()
            .ok_or("its data dictionary ends inside a type")?;
        self.at += 1;
        Ok(byte)
    }

    /// The text up to `end` (consumed, not returned).
    fn until(&mut self, end: u8) -> std::result::Result<String, String> {
        let rest = &self.bytes[self.at.min(self.bytes.len())..];
        let length = rest
            .iter()
            .position(|&b| b == end)
            .ok_or("its data dictionary ends inside a type")?;
        self.at += length + 1;
        Ok(String::from_utf8_lossy(&rest[..length]).trim().to_string())
    }

    fn number(&mut self) -> std::result::Result<usize, String> {
        let text = self.until(b':')?;
        text.parse()
            .map_err(|_| format!("its data dictionary has '{text}' where a count should be"))
    }
}

/// The types a data dictionary defines (`{fields}Name,` ... `.`).
pub(super) fn parse_dictionary(bytes: &[u8]) -> std::result::Result<Dictionary, String> {
    let mut types = Dictionary::new();
    let mut text = Text { bytes, at: 0 };
    while let Some(next) = text.peek() {
        match next {
            b'{' => {
                parse_type(&mut text, &mut types, 0)?;
            }
            b'.' | 0 => break,
            other => {
                return Err(format!(
                    "its data dictionary has '{}' where a type should open",
                    other as char
                ));
            }
        }
    }
    Ok(types)
}

/// One type (`{fields}Name,`), defined in `types`; returns its name.
fn parse_type(
    text: &mut Text,
    types: &mut Dictionary,
    depth: usize,
) -> std::result::Result<String, String> {
    if depth > MAX_DEPTH {
        return Err("its data dictionary nests types too deeply".into());
    }
    if text.byte()? != b'{' {
        return Err("its data dictionary has a type that does not open with '{'".into());
    }
    let mut fields = Vec::new();
    while text.peek() != Some(b'}') {
        let count = text.number()?;
        let mut kind = text.byte()?;
        let pointer = matches!(kind, b'p' | b'*');
        if pointer {
            kind = text.byte()?;
        }
        let (mut names, mut object) = (Vec::new(), None);
        match kind {
            b'e' => {
                let values = text.number()?;
                for _ in 0..values {
                    names.push(text.until(b',')?);
                }
            }
            b'o' => object = Some(text.until(b',')?),
            b'x' => object = Some(parse_type(text, types, depth + 1)?),
            _ => {}
        }
        let name = text.until(b',')?;
        fields.push(Field {
            name,
            count,
            pointer,
            kind,
            names,
            object,
        });
    }
    text.byte()?;
    let name = text.until(b',')?;
    types.insert(name.clone(), fields);
    Ok(name)
}

/// A node's data, decoded by its type.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Value {
    Number(f64),
    /// Characters (`c`, `C`) as stored.
    Bytes(Vec<u8>),
    /// An enum's value name.
    Name(String),
    List(Vec<Value>),
    Object(Vec<(String, Value)>),
}

impl Value {
    /// The value at a dotted path of field names (`upperLeftCenter.x`); a list of one
    /// item (a pointer to one object) is that item.
    pub(super) fn get(&self, path: &str) -> Option<&Value> {
        path.split('.').try_fold(self, |value, name| match value {
            Value::Object(fields) => fields.iter().find(|(n, _)| n == name).map(|(_, v)| v),
            Value::List(items) if items.len() == 1 => items[0].get(name),
            _ => None,
        })
    }

    pub(super) fn number(&self, path: &str) -> Option<f64> {
        match self.get(path)? {
            Value::Number(n) => Some(*n),
            Value::List(items) => match items.first()? {
                Value::Number(n) => Some(*n),
                _ => None,
            },
            _ => None,
        }
    }

    /// Characters up to their first NUL, or an enum's name.
    pub(super) fn text(&self, path: &str) -> Option<String> {
        match self.get(path)? {
            Value::Bytes(bytes) => {
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                Some(String::from_utf8_lossy(&bytes[..end]).trim().to_string())
            }
            Value::Name(name) => Some(name.clone()),
            _ => None,
        }
    }

    pub(super) fn numbers(&self, path: &str) -> Vec<f64> {
        match self.get(path) {
            Some(Value::List(items)) => items
                .iter()
                .filter_map(|v| match v {
                    Value::Number(n) => Some(*n),
                    _ => None,
                })
                .collect(),
            Some(Value::Number(n)) => vec![*n],
            _ => Vec::new(),
        }
    }
}

pub(super) fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

pub(super) const TRUNCATED: &str = "a node's data ends before its type does";

/// An object of type `name` at the start of `bytes`, and the bytes it takes.
pub(super) fn decode_object(
    types: &Dictionary,
    name: &str,
    bytes: &[u8],
    depth: usize,
) -> std::result::Result<(Value, usize), String> {
    if depth > MAX_DEPTH {
        return Err("its nodes nest objects too deeply".into());
    }
    let fields = types
        .get(name)
        .ok_or_else(|| format!("its data dictionary does not define the type {name}"))?;
    let mut at = 0;
    let mut values = Vec::with_capacity(fields.len());
    for field in fields {
        let rest = bytes.get(at..).ok_or(TRUNCATED)?;
        let (value, used) = decode_field(types, field, rest, depth)?;
        at += used;
        values.push((field.name.clone(), value));
    }
    Ok((Value::Object(values), at))
}

/// The bytes of one item of a basic type letter.
fn basic_size(kind: u8) -> std::result::Result<usize, String> {
    Ok(match kind {
        b'1' | b'2' | b'4' | b'c' | b'C' => 1,
        b'e' | b's' | b'S' => 2,
        b't' | b'l' | b'L' | b'f' => 4,
        b'd' | b'm' => 8,
        b'M' => 16,
        other => {
            return Err(format!(
                "its data dictionary has a field of unknown type '{}'",
                other as char
            ));
        }
    })
}

/// One field at the start of `bytes`, and the bytes it takes.
fn decode_field(
    types: &Dictionary,
    field: &Field,
    bytes: &[u8],
    depth: usize,
) -> std::result::Result<(Value, usize), String> {
    let (count, mut at) = if field.pointer {
        (u32_at(bytes, 0).ok_or(TRUNCATED)? as usize, 8)
    } else {
        (field.count, 0)
    };
    // Every item takes at least a byte: a count beyond the data is malformed.
    if count > bytes.len() {
        return Err(TRUNCATED.into());
    }
    match field.kind {
        b'c' | b'C' => {
            let chars = bytes.get(at..at + count).ok_or(TRUNCATED)?;
            Ok((Value::Bytes(chars.to_vec()), at + count))
        }
        b'b' => {
            if count == 0 {
                return Ok((Value::List(Vec::new()), at));
            }
            let (values, used) = base_data(bytes.get(at..).ok_or(TRUNCATED)?)?;
            Ok((Value::List(values), at + used))
        }
        b'o' | b'x' => {
            let object = field.object.as_deref().unwrap_or_default();
            let mut items = Vec::new();
            for _ in 0..count {
                let (item, used) =
                    decode_object(types, object, bytes.get(at..).ok_or(TRUNCATED)?, depth + 1)?;
                if used == 0 {
                    break;
                }
                at += used;
                items.push(item);
            }
            Ok((single_or_list(items, field), at))
        }
        kind => {
            let size = basic_size(kind)?;
            let mut items = Vec::with_capacity(count);
            for _ in 0..count {
                let raw = bytes.get(at..at + size).ok_or(TRUNCATED)?;
                at += size;
                let word = |n: usize| u64::from_le_bytes(padded(&raw[..n]));
                items.push(match kind {
                    b'e' => {
                        let index = word(2) as usize;
                        field
                            .names
                            .get(index)
                            .map_or(Value::Number(index as f64), |n| Value::Name(n.clone()))
                    }
                    b'S' => Value::Number(f64::from(word(2) as u16 as i16)),
                    b'l' => Value::Number(f64::from(word(4) as u32 as i32)),
                    b'f' => Value::Number(f64::from(f32::from_bits(word(4) as u32))),
                    b'd' | b'm' | b'M' => Value::Number(f64::from_bits(word(8))),
                    _ => Value::Number(word(size.min(8)) as f64),
                });
            }
            Ok((single_or_list(items, field), at))
        }
    }
}

fn padded(bytes: &[u8]) -> [u8; 8] {
    let mut word = [0u8; 8];
    word[..bytes.len()].copy_from_slice(bytes);
    word
}

/// One item where the dictionary says one and the field is not a pointer, else a list.
fn single_or_list(mut items: Vec<Value>, field: &Field) -> Value {
    if field.count == 1 && !field.pointer && items.len() == 1 {
        items.remove(0)
    } else {
        Value::List(items)
    }
}

/// An `Egda_BaseData` (a table of numbers: rows, columns, type, object type, values),
/// and the bytes it takes.
fn base_data(bytes: &[u8]) -> std::result::Result<(Vec<Value>, usize), String> {
    let rows = u32_at(bytes, 0).ok_or(TRUNCATED)? as usize;
    let columns = u32_at(bytes, 4).ok_or(TRUNCATED)? as usize;
    let kind = u16_at(bytes, 8).ok_or(TRUNCATED)?;
    let pixel = PixelType::from_index(usize::from(kind))
        .filter(|p| p.bits() >= 8 && !matches!(p, PixelType::Complex))
        .ok_or_else(|| format!("a table holds values of unread type {kind}"))?;
    let size = pixel.bits() / 8;
    let n = rows.checked_mul(columns).ok_or(TRUNCATED)?;
    let end = n
        .checked_mul(size)
        .and_then(|b| b.checked_add(12))
        .ok_or(TRUNCATED)?;
    let data = bytes.get(12..end).ok_or(TRUNCATED)?;
    let values = data
        .chunks_exact(size)
        .map(|raw| Value::Number(f64::from(pixel.value(u64::from_le_bytes(padded(raw))))))
        .collect();
    Ok((values, end))
}

/// How a band's samples are stored (`Eimg_Layer.pixelType`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum PixelType {
    Unsigned(usize),
    Signed(usize),
    Float(usize),
    Complex,
}

impl PixelType {
    /// The type of index `i` of `u1, u2, u4, u8, s8, u16, s16, u32, s32, f32, f64, c64,
    /// c128`.
    pub(super) fn from_index(i: usize) -> Option<Self> {
        use PixelType::*;
        [
            Unsigned(1),
            Unsigned(2),
            Unsigned(4),
            Unsigned(8),
            Signed(8),
            Unsigned(16),
            Signed(16),
            Unsigned(32),
            Signed(32),
            Float(32),
            Float(64),
            Complex,
            Complex,
        ]
        .get(i)
        .copied()
    }

    pub(super) fn from_name(name: &str) -> Option<Self> {
        const NAMES: [&str; 13] = [
            "u1", "u2", "u4", "u8", "s8", "u16", "s16", "u32", "s32", "f32", "f64", "c64", "c128",
        ];
        NAMES
            .iter()
            .position(|n| *n == name)
            .and_then(Self::from_index)
    }

    pub(super) fn bits(self) -> usize {
        match self {
            PixelType::Unsigned(b) | PixelType::Signed(b) | PixelType::Float(b) => b,
            PixelType::Complex => 64,
        }
    }

    /// The value of a sample whose bits (little-endian, zero-extended) are `raw`.
    pub(super) fn value(self, raw: u64) -> f32 {
        match self {
            PixelType::Unsigned(_) | PixelType::Complex => raw as f32,
            PixelType::Signed(8) => f32::from(raw as u8 as i8),
            PixelType::Signed(16) => f32::from(raw as u16 as i16),
            PixelType::Signed(_) => raw as u32 as i32 as f32,
            PixelType::Float(32) => f32::from_bits(raw as u32),
            PixelType::Float(_) => f64::from_bits(raw) as f32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_types_enums_and_pointers_decode_by_the_dictionary() {
        let types = parse_dictionary(
            b"{1:x{0:pcstring,}Emif_String,title,1:e3:thematic,athematic,fft of real-valued \
              data,layerType,0:pdparams,1:Sshort,}Example,.",
        )
        .unwrap();
        assert!(types.contains_key("Emif_String"));
        let mut bytes = Vec::new();
        bytes.extend(3u32.to_le_bytes());
        bytes.extend(0u32.to_le_bytes());
        bytes.extend(b"ab\0");
        bytes.extend(2u16.to_le_bytes());
        bytes.extend(2u32.to_le_bytes());
        bytes.extend(0u32.to_le_bytes());
        bytes.extend(1.5f64.to_le_bytes());
        bytes.extend((-2.0f64).to_le_bytes());
        bytes.extend((-7i16).to_le_bytes());
        let (value, used) = decode_object(&types, "Example", &bytes, 0).unwrap();
        assert_eq!(used, bytes.len());
        assert_eq!(value.text("title.string").as_deref(), Some("ab"));
        assert_eq!(
            value.text("layerType").as_deref(),
            Some("fft of real-valued data")
        );
        assert_eq!(value.numbers("params"), [1.5, -2.0]);
        assert_eq!(value.number("short"), Some(-7.0));
        // A count past the data is refused, not read past.
        bytes[16] = 0xff;
        assert!(decode_object(&types, "Example", &bytes[..20], 0).is_err());
    }
}
