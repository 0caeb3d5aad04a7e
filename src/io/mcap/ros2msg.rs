//! Parser of ROS message schema text as stored in MCAP `ros2msg` and `ros1msg` schemas:
//! the main definition, then dependencies, each after a line of `=` signs and a
//! `MSG: pkg/Name` line.
//!
//! ROS 2 ([`parse`]) follows `rosidl_adapter` (the reference parser): comments start at
//! `#`, a field is `TYPE name [default]`, a constant `TYPE NAME=value`, types are
//! primitives, bounded strings `string<=N`, and messages `pkg/Name` or `Name` (same
//! package), each optionally an array `[]`, `[N]` or `[<=N]`.
//!
//! ROS 1 ([`parse_ros1`]) follows `genmsg`: no defaults, bounds or `wstring`; `byte` is
//! int8 and `char` uint8; `time` and `duration` are builtins (`secs`, `nsecs`); a bare
//! `Header` is `std_msgs/Header`; a string constant's value is the rest of its line,
//! `#` included.

use std::collections::HashMap;
use std::sync::Arc;

/// A primitive ROS type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    Bool,
    Byte,
    Char,
    Float32,
    Float64,
    Int8,
    Uint8,
    Int16,
    Uint16,
    Int32,
    Uint32,
    Int64,
    Uint64,
    String,
    WString,
}

/// The two schema languages: they differ in a few type names and in what a line may hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dialect {
    Ros2,
    Ros1,
}

impl Primitive {
    fn parse(name: &str, dialect: Dialect) -> Option<Primitive> {
        Some(match (name, dialect) {
            ("byte", Dialect::Ros1) => Primitive::Int8,
            ("char", Dialect::Ros1) => Primitive::Uint8,
            ("wstring", Dialect::Ros1) => return None,
            _ => return Primitive::parse_ros2(name),
        })
    }

    fn parse_ros2(name: &str) -> Option<Primitive> {
        Some(match name {
            "bool" => Primitive::Bool,
            "byte" => Primitive::Byte,
            "char" => Primitive::Char,
            "float32" => Primitive::Float32,
            "float64" => Primitive::Float64,
            "int8" => Primitive::Int8,
            "uint8" => Primitive::Uint8,
            "int16" => Primitive::Int16,
            "uint16" => Primitive::Uint16,
            "int32" => Primitive::Int32,
            "uint32" => Primitive::Uint32,
            "int64" => Primitive::Int64,
            "uint64" => Primitive::Uint64,
            "string" => Primitive::String,
            "wstring" => Primitive::WString,
            _ => return None,
        })
    }

    /// The fewest bytes a value takes (a string's or wstring's is its length).
    pub fn min_size(self) -> usize {
        match self {
            Primitive::Bool
            | Primitive::Byte
            | Primitive::Char
            | Primitive::Int8
            | Primitive::Uint8 => 1,
            Primitive::Int16 | Primitive::Uint16 => 2,
            Primitive::Float64 | Primitive::Int64 | Primitive::Uint64 => 8,
            Primitive::Float32
            | Primitive::Int32
            | Primitive::Uint32
            | Primitive::String
            | Primitive::WString => 4,
        }
    }

    /// The integer range of an integer type, `None` for the others.
    fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Primitive::Byte | Primitive::Uint8 => (0, 255),
            Primitive::Char | Primitive::Int8 => (-128, 127),
            Primitive::Int16 => (i16::MIN.into(), i16::MAX.into()),
            Primitive::Uint16 => (0, u16::MAX.into()),
            Primitive::Int32 => (i32::MIN.into(), i32::MAX.into()),
            Primitive::Uint32 => (0, u32::MAX.into()),
            Primitive::Int64 => (i64::MIN.into(), i64::MAX.into()),
            Primitive::Uint64 => (0, u64::MAX.into()),
            _ => return None,
        })
    }
}

/// What a field holds, before arrays.
#[derive(Debug, Clone, PartialEq)]
pub enum BaseType {
    Primitive(Primitive),
    /// A nested message: its index in [`Schema::messages`].
    Message(usize),
}

/// Whether and how a field is an array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    Single,
    Fixed(usize),
    Unbounded,
    Bounded(usize),
}

/// A literal of a default value or constant.
#[derive(Debug, Clone, PartialEq)]
pub enum Literal {
    Bool(bool),
    Int(i128),
    Float(f64),
    Str(String),
    Array(Vec<Literal>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    pub name: Arc<str>,
    pub base: BaseType,
    pub arity: Arity,
    /// `string<=N`: the most characters a string may hold.
    pub string_bound: Option<usize>,
    pub default: Option<Literal>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Constant {
    pub name: String,
    pub ty: Primitive,
    pub value: Literal,
}

/// One message definition, its field types resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageDef {
    /// `pkg/Name` (without the `msg/` part).
    pub name: String,
    pub fields: Vec<Field>,
    pub constants: Vec<Constant>,
    /// The field names, shared by every decoded value of this type.
    pub field_names: Arc<[Arc<str>]>,
    /// The fewest bytes a message of this type takes in either wire format (0 for one
    /// without fields), so that a corrupt array length fails before it allocates.
    pub min_size: usize,
}

/// A parsed schema: the root message and every message it uses.
#[derive(Debug, Clone, PartialEq)]
pub struct Schema {
    pub messages: Vec<MessageDef>,
    pub root: usize,
}

impl Schema {
    pub fn root(&self) -> &MessageDef {
        &self.messages[self.root]
    }
}

/// A field type as written, before message names are resolved.
pub(super) struct RawField {
    pub(super) name: String,
    pub(super) type_text: String,
    pub(super) base: RawBase,
    pub(super) arity: Arity,
    pub(super) string_bound: Option<usize>,
    pub(super) default_text: Option<String>,
    pub(super) line: usize,
}

pub(super) enum RawBase {
    Primitive(Primitive),
    Message(String),
}

pub(super) struct RawMessage {
    pub(super) name: String,
    pub(super) fields: Vec<RawField>,
    pub(super) constants: Vec<Constant>,
}

/// Parses `text`, the ROS 2 schema stored for message type `name` (e.g.
/// `nav_msgs/msg/Odometry`). Errors carry the line number (1-based) within `text`.
/// A service's event type, stored as rosbag2 stores it (the `.srv` text), is read as
/// the message it stands for.
pub fn parse(name: &str, text: &str) -> Result<Schema, String> {
    match service_event_as_messages(text) {
        Some(messages) => parse_dialect(name, &messages, Dialect::Ros2)
            .map_err(|e| format!("{e} (of the service event type made from the .srv text)")),
        None => parse_dialect(name, text, Dialect::Ros2),
    }
}

/// `service_msgs/msg/ServiceEventInfo`, the header of every service event; rosbag2 does
/// not store it with the `.srv` text.
const SERVICE_EVENT_INFO: &str = "\
uint8 REQUEST_SENT = 0
uint8 REQUEST_RECEIVED = 1
uint8 RESPONSE_SENT = 2
uint8 RESPONSE_RECEIVED = 3
uint8 event_type
builtin_interfaces/Time stamp
char[16] client_gid
int64 sequence_number
";

const DELIMITER: &str =
    "================================================================================";

/// rosbag2 (Jazzy on) records a service's events (`pkg/srv/Name_Event`) with the service
/// text in place of a message definition: a delimiter, `SRV: pkg/srv/Name`, the request
/// fields, `---`, the response fields, then the dependencies as usual. This writes out
/// the event message rosidl generates from it (`info`, then the request and response as
/// sequences of at most one), with the request, response and `ServiceEventInfo` as
/// dependencies. `None` for text that is not a service's.
fn service_event_as_messages(text: &str) -> Option<String> {
    let mut lines = text.lines().skip_while(|l| {
        let l = l.trim();
        l.is_empty() || (l.len() >= 3 && l.bytes().all(|b| b == b'='))
    });
    let service = lines.next()?.trim().strip_prefix("SRV:")?.trim();
    let (package, name) = match service.split('/').collect::<Vec<_>>().as_slice() {
        [package, _, name] | [package, name] => (package.to_string(), name.to_string()),
        _ => return None,
    };
    // The request, the response, and the dependencies after them.
    let mut parts = [String::new(), String::new(), String::new()];
    let mut part = 0;
    for line in lines {
        let trimmed = line.trim();
        if part < 2 && trimmed.len() >= 3 && trimmed.bytes().all(|b| b == b'=') {
            part = 2;
        } else if part == 0 && trimmed == "---" {
            part = 1;
            continue;
        }
        parts[part].push_str(line);
        parts[part].push('\n');
    }
    let [request, response, rest] = parts;
    let mut out = format!(
        "service_msgs/ServiceEventInfo info\n{name}_Request[<=1] request\n\
         {name}_Response[<=1] response\n\
         {DELIMITER}\nMSG: {package}/{name}_Request\n{request}\
         {DELIMITER}\nMSG: {package}/{name}_Response\n{response}{rest}"
    );
    if !rest.contains("MSG: service_msgs/ServiceEventInfo")
        && !rest.contains("MSG: service_msgs/msg/ServiceEventInfo")
    {
        out.push_str(&format!(
            "{DELIMITER}\nMSG: service_msgs/ServiceEventInfo\n{SERVICE_EVENT_INFO}"
        ));
    }
    Some(out)
}

/// Parses `text`, the ROS 1 schema (a `ros1msg` schema, the "message definition" of a
/// ROS 1 connection) stored for message type `name` (e.g. `nav_msgs/Odometry`).
pub fn parse_ros1(name: &str, text: &str) -> Result<Schema, String> {
    // Old bags call the header `roslib/Header`; genpy renames it the same way.
    let text = text.replace("roslib/Header", "std_msgs/Header");
    parse_dialect(name, &text, Dialect::Ros1)
}

fn parse_dialect(name: &str, text: &str, dialect: Dialect) -> Result<Schema, String> {
    let mut raw = Vec::new();
    let mut current_name = name.to_string();
    let mut section: Vec<(usize, &str)> = Vec::new();
    let mut flush = |name: &str, lines: &mut Vec<(usize, &str)>| -> Result<(), String> {
        raw.push(parse_message(name, lines, dialect)?);
        lines.clear();
        Ok(())
    };
    for (number, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.len() >= 3 && trimmed.bytes().all(|b| b == b'=') {
            flush(&current_name, &mut section)?;
            continue;
        }
        if let Some(rest) = trimmed.strip_prefix("MSG:") {
            current_name = rest.trim().to_string();
            continue;
        }
        section.push((number + 1, line));
    }
    flush(&current_name, &mut section)?;
    resolve(raw)
}

pub(super) fn short_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", msg] => format!("{pkg}/{msg}"),
        _ => name.to_string(),
    }
}

fn parse_message(
    name: &str,
    lines: &[(usize, &str)],
    dialect: Dialect,
) -> Result<RawMessage, String> {
    let name = short_name(name);
    let package = name.split('/').next().unwrap_or_default().to_string();
    let mut message = RawMessage {
        name,
        fields: Vec::new(),
        constants: Vec::new(),
    };
    for &(number, line) in lines {
        let at = |problem: String| format!("line {number}: {problem}");
        let line = line.replace('\t', " ");
        let content = match line.find('#') {
            Some(i) => &line[..i],
            None => &line[..],
        };
        let content = content.trim();
        if content.is_empty() {
            continue;
        }
        let (type_text, rest) = content
            .split_once(' ')
            .ok_or_else(|| at(format!("'{content}' has a type but no field name")))?;
        let rest = rest.trim_start();
        let (base, arity, string_bound) = parse_type(type_text, &package, dialect).map_err(at)?;
        if let Some((constant, value)) = rest.split_once('=') {
            let RawBase::Primitive(ty) = base else {
                return Err(at(format!("constant of message type '{type_text}'")));
            };
            if arity != Arity::Single {
                return Err(at("array constants are not allowed".into()));
            }
            let value = match (dialect, ty, line.split_once('=')) {
                // genmsg: a string constant is everything after the `=`, quotes and `#`
                // included.
                (Dialect::Ros1, Primitive::String, Some((_, raw))) => {
                    Literal::Str(raw.trim().to_string())
                }
                _ => parse_literal(ty, Arity::Single, value.trim()).map_err(at)?,
            };
            message.constants.push(Constant {
                name: constant.trim().to_string(),
                ty,
                value,
            });
            continue;
        }
        let (field_name, default_text) = match rest.split_once(' ') {
            Some((field, default)) => (field, Some(default.trim().to_string())),
            None => (rest, None),
        };
        if dialect == Dialect::Ros1 && default_text.is_some() {
            return Err(at(format!(
                "'{content}': a ROS 1 field is a type and a name, with no default value"
            )));
        }
        if !is_identifier(field_name) {
            return Err(at(format!("'{field_name}' is not a valid field name")));
        }
        message.fields.push(RawField {
            name: field_name.to_string(),
            type_text: type_text.to_string(),
            base,
            arity,
            string_bound,
            default_text: default_text.filter(|d| !d.is_empty()),
            line: number,
        });
    }
    Ok(message)
}

fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

type ParsedType = (RawBase, Arity, Option<usize>);

fn parse_type(text: &str, package: &str, dialect: Dialect) -> Result<ParsedType, String> {
    let (base_text, arity) = match text.find('[') {
        None => (text, Arity::Single),
        Some(open) => {
            let inside = text[open + 1..]
                .strip_suffix(']')
                .ok_or_else(|| format!("type '{text}' has an unclosed '['"))?;
            let arity = if inside.is_empty() {
                Arity::Unbounded
            } else if let Some(bound) = inside.strip_prefix("<=")
                && dialect == Dialect::Ros2
            {
                Arity::Bounded(parse_size(bound, text)?)
            } else {
                Arity::Fixed(parse_size(inside, text)?)
            };
            (&text[..open], arity)
        }
    };
    for string_type in ["string<=", "wstring<="] {
        if let Some(bound) = base_text.strip_prefix(string_type)
            && dialect == Dialect::Ros2
        {
            let primitive = if string_type.starts_with('w') {
                Primitive::WString
            } else {
                Primitive::String
            };
            let bound = parse_size(bound, text)?;
            return Ok((RawBase::Primitive(primitive), arity, Some(bound)));
        }
    }
    if let Some(primitive) = Primitive::parse(base_text, dialect) {
        return Ok((RawBase::Primitive(primitive), arity, None));
    }
    let full = match (base_text, dialect) {
        // ROS 1 compatibility names that rosidl still accepts.
        ("time", Dialect::Ros2) => "builtin_interfaces/Time".to_string(),
        ("duration", Dialect::Ros2) => "builtin_interfaces/Duration".to_string(),
        ("time" | "duration", Dialect::Ros1) => base_text.to_string(),
        ("Header", Dialect::Ros1) => "std_msgs/Header".to_string(),
        _ => match base_text.split('/').collect::<Vec<_>>().as_slice() {
            [name] => format!("{package}/{name}"),
            [pkg, name] | [pkg, "msg", name] => format!("{pkg}/{name}"),
            _ => return Err(format!("'{base_text}' is not a type name")),
        },
    };
    let message = full.rsplit('/').next().unwrap_or_default();
    // ROS 1 type names need not be capitalised (`tf/tfMessage`); ROS 2 ones must be.
    let capitalised =
        dialect == Dialect::Ros1 || message.starts_with(|c: char| c.is_ascii_uppercase());
    if !capitalised || !is_identifier(message) {
        return Err(format!(
            "'{base_text}' is neither a primitive nor a message type"
        ));
    }
    Ok((RawBase::Message(full), arity, None))
}

fn parse_size(text: &str, type_text: &str) -> Result<usize, String> {
    text.trim()
        .parse::<usize>()
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| format!("type '{type_text}' has an invalid size '{text}'"))
}

/// Parses a default value or constant. Arrays are `[a, b, ...]`; strings may be quoted
/// with `"` or `'` (a constant's unquoted string is the rest of the line).
pub(super) fn parse_literal(ty: Primitive, arity: Arity, text: &str) -> Result<Literal, String> {
    if arity != Arity::Single {
        let inner = text
            .strip_prefix('[')
            .and_then(|t| t.strip_suffix(']'))
            .ok_or_else(|| format!("array default '{text}' must be written [a, b, ...]"))?;
        let items = split_array_items(inner)?;
        let count = items.len();
        match arity {
            Arity::Fixed(n) if count != n => {
                return Err(format!("default has {count} values, the array holds {n}"));
            }
            Arity::Bounded(n) if count > n => {
                return Err(format!("default has {count} values, the bound is {n}"));
            }
            _ => {}
        }
        return items
            .into_iter()
            .map(|item| parse_literal(ty, Arity::Single, item.trim()))
            .collect::<Result<Vec<_>, _>>()
            .map(Literal::Array);
    }
    match ty {
        Primitive::Bool => match text.to_ascii_lowercase().as_str() {
            "true" | "1" => Ok(Literal::Bool(true)),
            "false" | "0" => Ok(Literal::Bool(false)),
            _ => Err(format!("'{text}' is not a bool")),
        },
        Primitive::Float32 | Primitive::Float64 => text
            .parse::<f64>()
            .map(Literal::Float)
            .map_err(|_| format!("'{text}' is not a number")),
        Primitive::String | Primitive::WString => Ok(Literal::Str(unquote(text))),
        integer => {
            let (low, high) = integer.int_range().unwrap_or((0, 0));
            let value = text
                .parse::<i128>()
                .map_err(|_| format!("'{text}' is not an integer"))?;
            if value < low || value > high {
                return Err(format!("{value} is out of range for {integer:?}"));
            }
            Ok(Literal::Int(value))
        }
    }
}

fn unquote(text: &str) -> String {
    for quote in ['"', '\''] {
        if text.len() >= 2 && text.starts_with(quote) && text.ends_with(quote) {
            let inner = &text[1..text.len() - 1];
            return inner.replace(&format!("\\{quote}"), &quote.to_string());
        }
    }
    text.to_string()
}

/// Splits `a, "b, c", d` on commas outside quotes.
fn split_array_items(inner: &str) -> Result<Vec<&str>, String> {
    if inner.trim().is_empty() {
        return Ok(Vec::new());
    }
    let mut items = Vec::new();
    let mut start = 0;
    let mut quote: Option<char> = None;
    let mut escaped = false;
    for (i, c) in inner.char_indices() {
        match quote {
            Some(q) if !escaped && c == q => quote = None,
            Some(_) => escaped = !escaped && c == '\\',
            None if c == '"' || c == '\'' => quote = Some(c),
            None if c == ',' => {
                items.push(&inner[start..i]);
                start = i + 1;
            }
            None => {}
        }
    }
    if quote.is_some() {
        return Err(format!("unterminated string in '[{inner}]'"));
    }
    items.push(&inner[start..]);
    Ok(items)
}

/// The definitions ROS 2 fills in when a schema refers to them without spelling them out.
fn builtin(name: &str) -> Option<RawMessage> {
    let field = |name: &str, ty: Primitive| RawField {
        name: name.into(),
        type_text: String::new(),
        base: RawBase::Primitive(ty),
        arity: Arity::Single,
        string_bound: None,
        default_text: None,
        line: 0,
    };
    let fields = match name {
        "builtin_interfaces/Time" | "builtin_interfaces/Duration" => vec![
            field("sec", Primitive::Int32),
            field("nanosec", Primitive::Uint32),
        ],
        // ROS 1's builtins, named as genpy names their fields.
        "time" => vec![
            field("secs", Primitive::Uint32),
            field("nsecs", Primitive::Uint32),
        ],
        "duration" => vec![
            field("secs", Primitive::Int32),
            field("nsecs", Primitive::Int32),
        ],
        _ => return None,
    };
    Some(RawMessage {
        name: name.to_string(),
        fields,
        constants: Vec::new(),
    })
}

/// Resolves message names to indices; `raw[0]` is the root.
pub(super) fn resolve(mut raw: Vec<RawMessage>) -> Result<Schema, String> {
    let mut index: HashMap<String, usize> = HashMap::new();
    for (i, message) in raw.iter().enumerate() {
        // The first definition of a name wins, as in the reference decoder's lookups.
        index.entry(message.name.clone()).or_insert(i);
    }
    // Builtins used but not defined.
    let mut missing = Vec::new();
    for message in &raw {
        for field in &message.fields {
            if let RawBase::Message(name) = &field.base
                && !index.contains_key(name)
                && !missing.contains(name)
            {
                missing.push(name.clone());
            }
        }
    }
    for name in missing {
        if let Some(message) = builtin(&name) {
            index.insert(name, raw.len());
            raw.push(message);
        }
    }
    let mut messages = Vec::with_capacity(raw.len());
    for message in raw {
        let mut fields = Vec::with_capacity(message.fields.len());
        for field in message.fields {
            let at = |problem: String| {
                format!(
                    "line {}: field '{}' of {}: {problem}",
                    field.line, field.name, message.name
                )
            };
            let base = match &field.base {
                RawBase::Primitive(p) => BaseType::Primitive(*p),
                RawBase::Message(name) => BaseType::Message(*index.get(name).ok_or_else(|| {
                    at(format!(
                        "type '{}' is not defined in the schema",
                        field.type_text
                    ))
                })?),
            };
            let default = match (&field.default_text, &base) {
                (None, _) => None,
                (Some(text), BaseType::Primitive(p)) => {
                    Some(parse_literal(*p, field.arity, text).map_err(at)?)
                }
                (Some(_), BaseType::Message(_)) => {
                    return Err(at("message fields cannot have default values".into()));
                }
            };
            fields.push(Field {
                name: field.name.into(),
                base,
                arity: field.arity,
                string_bound: field.string_bound,
                default,
            });
        }
        let field_names = fields.iter().map(|f| f.name.clone()).collect();
        messages.push(MessageDef {
            name: message.name,
            fields,
            constants: message.constants,
            field_names,
            min_size: 0,
        });
    }
    detect_recursion(&messages)?;
    fill_min_sizes(&mut messages);
    Ok(Schema { messages, root: 0 })
}

/// Sets every message's [`MessageDef::min_size`]: its fields' sizes, an unbounded or
/// bounded array counting only its 4-byte length.
fn fill_min_sizes(messages: &mut [MessageDef]) {
    fn size(messages: &[MessageDef], at: usize, memo: &mut [Option<usize>]) -> usize {
        if let Some(known) = memo[at] {
            return known;
        }
        let mut total = 0usize;
        for field in &messages[at].fields {
            let item = match field.base {
                BaseType::Primitive(p) => p.min_size(),
                BaseType::Message(inner) => size(messages, inner, memo),
            };
            let bytes = match field.arity {
                Arity::Single => item,
                Arity::Fixed(n) => item.saturating_mul(n),
                Arity::Unbounded | Arity::Bounded(_) => 4,
            };
            total = total.saturating_add(bytes);
        }
        memo[at] = Some(total);
        total
    }
    let mut memo = vec![None; messages.len()];
    for at in 0..messages.len() {
        messages[at].min_size = size(messages, at, &mut memo);
    }
}

/// A message that contains itself (other than through an unbounded array, which CDR can
/// end) would make the decoder recurse forever.
fn detect_recursion(messages: &[MessageDef]) -> Result<(), String> {
    fn visit(messages: &[MessageDef], at: usize, stack: &mut Vec<usize>) -> Result<(), String> {
        if stack.contains(&at) {
            return Err(format!("message {} contains itself", messages[at].name));
        }
        stack.push(at);
        for field in &messages[at].fields {
            if let (BaseType::Message(inner), Arity::Single | Arity::Fixed(_)) =
                (&field.base, field.arity)
            {
                visit(messages, *inner, stack)?;
            }
        }
        stack.pop();
        Ok(())
    }
    for i in 0..messages.len() {
        visit(messages, i, &mut Vec::new())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const POSE: &str = "\
# A pose
std_msgs/Header header
Pose pose  # nested, same package
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: geometry_msgs/Pose
Point position
float64[4] q [0, 0, 0, 1]
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
";

    #[test]
    fn parses_nested_messages_and_fills_in_builtins() {
        let schema = parse("geometry_msgs/msg/PoseStamped", POSE).unwrap();
        let root = schema.root();
        assert_eq!(root.name, "geometry_msgs/PoseStamped");
        assert_eq!(&*root.field_names, &["header".into(), "pose".into()]);
        let BaseType::Message(header) = root.fields[0].base else {
            panic!()
        };
        let header = &schema.messages[header];
        assert_eq!(header.name, "std_msgs/Header");
        let BaseType::Message(time) = header.fields[0].base else {
            panic!()
        };
        assert_eq!(schema.messages[time].name, "builtin_interfaces/Time");
        let BaseType::Message(pose) = root.fields[1].base else {
            panic!()
        };
        let q = &schema.messages[pose].fields[1];
        assert_eq!(q.arity, Arity::Fixed(4));
        assert_eq!(
            q.default,
            Some(Literal::Array(vec![
                Literal::Float(0.0),
                Literal::Float(0.0),
                Literal::Float(0.0),
                Literal::Float(1.0)
            ]))
        );
    }

    #[test]
    fn parses_constants_bounds_and_string_defaults() {
        let text = "int32 FOO=-3\nstring BAR = hello world\nstring<=5 s \"ab\"\n\
                    int16[<=3] v [1, -2]\nstring[2] names [\"a, b\", 'c']\nbool[] flags";
        let schema = parse("p/msg/M", text).unwrap();
        let m = schema.root();
        assert_eq!(m.constants[0].value, Literal::Int(-3));
        assert_eq!(m.constants[1].value, Literal::Str("hello world".into()));
        assert_eq!(m.fields[0].string_bound, Some(5));
        assert_eq!(m.fields[0].default, Some(Literal::Str("ab".into())));
        assert_eq!(m.fields[1].arity, Arity::Bounded(3));
        assert_eq!(
            m.fields[2].default,
            Some(Literal::Array(vec![
                Literal::Str("a, b".into()),
                Literal::Str("c".into())
            ]))
        );
        assert_eq!(m.fields[3].arity, Arity::Unbounded);
    }

    const ODOMETRY_ROS1: &str = "\
# comment
Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
================================================================================
MSG: geometry_msgs/PoseWithCovariance
Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/Pose
float64 x
";

    #[test]
    fn ros1_resolves_header_time_and_same_package_names() {
        let schema = parse_ros1("nav_msgs/Odometry", ODOMETRY_ROS1).unwrap();
        let root = schema.root();
        assert_eq!(root.name, "nav_msgs/Odometry");
        let BaseType::Message(header) = root.fields[0].base else {
            panic!()
        };
        let header = &schema.messages[header];
        assert_eq!(header.name, "std_msgs/Header");
        let BaseType::Message(time) = header.fields[1].base else {
            panic!()
        };
        assert_eq!(schema.messages[time].name, "time");
        assert_eq!(
            &*schema.messages[time].field_names,
            &["secs".into(), "nsecs".into()]
        );
        let BaseType::Message(with_covariance) = root.fields[2].base else {
            panic!()
        };
        let BaseType::Message(pose) = schema.messages[with_covariance].fields[0].base else {
            panic!()
        };
        assert_eq!(schema.messages[pose].name, "geometry_msgs/Pose");
        // seq 4 + stamp 8 + frame_id 4 | child_frame_id 4 | pose 8 + covariance 288.
        assert_eq!(root.min_size, 16 + 4 + 296);
        // Old bags' header name.
        let old = ODOMETRY_ROS1.replace("std_msgs/Header", "roslib/Header");
        assert_eq!(parse_ros1("nav_msgs/Odometry", &old).unwrap(), schema);
    }

    #[test]
    fn ros1_byte_and_char_constants_and_what_it_does_not_have() {
        let text = "byte b\nchar c\nduration d\ntf/tfMessage lower\n\
                    string GREETING = hi # all of this\nchar MAX=255\nbool YES=True\n\
                    ================\nMSG: tf/tfMessage\n";
        let schema = parse_ros1("p/M", text).unwrap();
        let m = schema.root();
        assert_eq!(m.fields[0].base, BaseType::Primitive(Primitive::Int8));
        assert_eq!(m.fields[1].base, BaseType::Primitive(Primitive::Uint8));
        let BaseType::Message(duration) = m.fields[2].base else {
            panic!()
        };
        assert_eq!(schema.messages[duration].name, "duration");
        assert_eq!(
            m.constants[0].value,
            Literal::Str("hi # all of this".into())
        );
        assert_eq!(m.constants[1].value, Literal::Int(255));
        assert_eq!(m.constants[2].value, Literal::Bool(true));
        for (bad, problem) in [
            ("int32 a 5", "no default value"),
            ("int32[<=3] a", "invalid size"),
            ("string<=3 a", "neither a primitive"),
            ("wstring w", "wstring"),
            ("byte B=200", "out of range"),
        ] {
            let err = parse_ros1("p/M", bad).unwrap_err();
            assert!(
                err.contains(problem) && err.contains("line 1"),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn service_events_are_read_from_the_srv_text_rosbag2_stores() {
        let text = format!(
            "{DELIMITER}\nSRV: nav_msgs/srv/SetMap\n# a comment\nOccupancyGrid map\n\
             geometry_msgs/Pose initial_pose\n---\nbool success\n\
             {DELIMITER}\nMSG: nav_msgs/OccupancyGrid\nint8[] data\n\
             {DELIMITER}\nMSG: geometry_msgs/Pose\nfloat64 x\n"
        );
        let schema = parse("nav_msgs/srv/SetMap_Event", &text).unwrap();
        let root = schema.root();
        assert_eq!(root.name, "nav_msgs/srv/SetMap_Event");
        assert_eq!(
            &*root.field_names,
            &["info".into(), "request".into(), "response".into()]
        );
        let message = |field: &Field| match field.base {
            BaseType::Message(i) => &schema.messages[i],
            _ => panic!("{field:?}"),
        };
        let info = message(&root.fields[0]);
        assert_eq!(info.name, "service_msgs/ServiceEventInfo");
        assert_eq!(info.constants.len(), 4);
        assert_eq!(info.fields[2].arity, Arity::Fixed(16));
        let request = message(&root.fields[1]);
        assert_eq!(root.fields[1].arity, Arity::Bounded(1));
        assert_eq!(request.name, "nav_msgs/SetMap_Request");
        assert_eq!(message(&request.fields[0]).name, "nav_msgs/OccupancyGrid");
        assert_eq!(message(&request.fields[1]).name, "geometry_msgs/Pose");
        let response = message(&root.fields[2]);
        assert_eq!(
            response.fields[0].base,
            BaseType::Primitive(Primitive::Bool)
        );
        // Plain messages are untouched by this.
        assert!(service_event_as_messages(POSE).is_none());
        let err = parse(
            "p/srv/S_Event",
            &format!("{DELIMITER}\nSRV: p/srv/S\nNope x\n---\n"),
        )
        .unwrap_err();
        assert!(err.contains("Nope") && err.contains(".srv"), "{err}");
    }

    #[test]
    fn reports_bad_definitions_with_their_line() {
        let err = parse("p/msg/M", "int32 a\nUnknown b").unwrap_err();
        assert!(err.contains("line 2") && err.contains("Unknown"), "{err}");
        let err = parse("p/msg/M", "uint8 a 300").unwrap_err();
        assert!(err.contains("out of range"), "{err}");
        let err = parse("p/msg/M", "int32[0] a").unwrap_err();
        assert!(err.contains("invalid size"), "{err}");
        let err = parse("p/msg/M", "M inner").unwrap_err();
        assert!(err.contains("contains itself"), "{err}");
        let err = parse("p/msg/M", "int32").unwrap_err();
        assert!(err.contains("no field name"), "{err}");
    }
}
