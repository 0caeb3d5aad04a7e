//! Parser of `ros2idl` schemas, rosbag2's form for types that have an `.idl` file and no
//! `.msg`: the IDL of the type and of every type it uses, in any order, each after a line
//! of `=` signs and an `IDL: pkg/msg/Name` line (rosbag2's `message_definition_encoding`).
//!
//! The language is the OMG IDL 4.2 subset `rosidl` generates and reads: nested `module`s,
//! `struct`s, `typedef`s (rosidl writes one for each fixed array: `typedef double
//! double__36[36];`), `const`s (in the `Name_Constants` module rosidl writes beside struct
//! `Name`), `sequence<T>` and `sequence<T, N>`, `string<N>`, one-dimensional arrays, the
//! IDL primitive names and rosidl's `int8` … `uint64`. Annotations (`@default`,
//! `@verbatim`, `@range`, ...) do not change the wire format and are skipped; so are
//! comments and `#include` lines. What rosidl cannot express (unions, enums, `long
//! double`, `wchar`, nested sequences, arrays of more than one dimension) is an error
//! naming its line. The result is the [`Schema`] the same type's `.msg` text gives, so
//! the CDR decoder is the same.

use std::collections::HashMap;

use super::ros2msg::{
    Arity, Constant, Literal, Primitive, RawBase, RawField, RawMessage, Schema, parse_literal,
    resolve, short_name,
};

/// Parses `text`, the `ros2idl` schema stored for type `name` (e.g.
/// `nav_msgs/msg/Odometry`). Errors carry the line number (1-based) within `text`.
pub fn parse(name: &str, text: &str) -> Result<Schema, String> {
    let tokens = lex(text)?;
    let mut parser = Parser {
        tokens,
        at: 0,
        scope: Vec::new(),
        found: Found::default(),
    };
    parser.definitions(true)?;
    messages(parser.found, &short_name(name))
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Ident(String),
    Number(String),
    Str(String),
    Punct(&'static str),
}

#[derive(Debug)]
struct Lexed {
    token: Token,
    line: usize,
}

const PUNCTUATION: [&str; 20] = [
    "::", "{", "}", ";", "<", ">", ",", "[", "]", "(", ")", "@", "=", "-", "+", "*", "/", "|", "&",
    ":",
];

/// Splits the text into tokens, dropping comments, `#` lines (the preprocessor's) and the
/// delimiter and `IDL:` lines between definitions.
fn lex(text: &str) -> Result<Vec<Lexed>, String> {
    let mut tokens = Vec::new();
    let mut in_block_comment = false;
    for (number, line) in text.lines().enumerate() {
        let number = number + 1;
        let trimmed = line.trim();
        if !in_block_comment
            && ((trimmed.len() >= 3 && trimmed.bytes().all(|b| b == b'='))
                || trimmed.starts_with("IDL:")
                || trimmed.starts_with('#'))
        {
            continue;
        }
        let chars: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            if in_block_comment {
                if c == '*' && chars.get(i + 1) == Some(&'/') {
                    in_block_comment = false;
                    i += 2;
                } else {
                    i += 1;
                }
                continue;
            }
            let next = chars.get(i + 1).copied();
            if c.is_whitespace() {
                i += 1;
            } else if c == '/' && next == Some('/') {
                break;
            } else if c == '/' && next == Some('*') {
                in_block_comment = true;
                i += 2;
            } else if c == '"' || c == '\'' || (c == 'L' && matches!(next, Some('"' | '\''))) {
                let open = if c == 'L' { i + 1 } else { i };
                let (value, end) = string_literal(&chars, open)
                    .map_err(|problem| format!("line {number}: {problem}"))?;
                tokens.push(Lexed {
                    token: Token::Str(value),
                    line: number,
                });
                i = end;
            } else if c.is_ascii_alphabetic() || c == '_' {
                let start = i;
                while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
                tokens.push(Lexed {
                    token: Token::Ident(chars[start..i].iter().collect()),
                    line: number,
                });
            } else if c.is_ascii_digit() || (c == '.' && next.is_some_and(|n| n.is_ascii_digit())) {
                let start = i;
                let hex = c == '0' && matches!(next, Some('x' | 'X'));
                while i < chars.len() {
                    let d = chars[i];
                    let exponent_sign =
                        !hex && matches!(d, '+' | '-') && matches!(chars[i - 1], 'e' | 'E');
                    if d.is_ascii_alphanumeric() || d == '.' || exponent_sign {
                        i += 1;
                    } else {
                        break;
                    }
                }
                tokens.push(Lexed {
                    token: Token::Number(chars[start..i].iter().collect()),
                    line: number,
                });
            } else {
                let rest: String = chars[i..(i + 2).min(chars.len())].iter().collect();
                let punct = PUNCTUATION
                    .iter()
                    .find(|p| rest.starts_with(**p))
                    .ok_or_else(|| format!("line {number}: unexpected character '{c}'"))?;
                tokens.push(Lexed {
                    token: Token::Punct(punct),
                    line: number,
                });
                i += punct.len();
            }
        }
    }
    if in_block_comment {
        return Err("a /* comment is never closed".into());
    }
    Ok(tokens)
}

/// The string or character literal opening at `chars[open]`, unescaped, and the index
/// after its closing quote. A literal ends on its own line, as in IDL.
fn string_literal(chars: &[char], open: usize) -> Result<(String, usize), String> {
    let quote = chars[open];
    let mut value = String::new();
    let mut i = open + 1;
    while i < chars.len() {
        match chars[i] {
            c if c == quote => return Ok((value, i + 1)),
            '\\' => {
                let escaped = chars.get(i + 1).ok_or("a string ends in '\\'")?;
                value.push(match escaped {
                    'n' => '\n',
                    't' => '\t',
                    'r' => '\r',
                    '0' => '\0',
                    other => *other,
                });
                i += 2;
            }
            c => {
                value.push(c);
                i += 1;
            }
        }
    }
    Err("a string literal is not closed on its line".into())
}

/// A type as written, before names are looked up.
#[derive(Debug, Clone)]
enum TypeSpec {
    Primitive(Primitive),
    String {
        wide: bool,
        bound: Option<usize>,
    },
    Sequence(Box<TypeSpec>, Option<usize>),
    /// A scoped name (`pkg::msg::Name`, `Name`); `absolute` for a leading `::`.
    Named {
        parts: Vec<String>,
        absolute: bool,
    },
}

/// A struct member or typedef: a type and, for an array, its length.
#[derive(Debug, Clone)]
struct Declared {
    ty: TypeSpec,
    array: Option<usize>,
    /// The module path it was declared in, where its names are looked up first.
    scope: Vec<String>,
    line: usize,
}

struct Member {
    name: String,
    declared: Declared,
}

/// What the text defines, by full scoped name (`pkg::msg::Name`).
#[derive(Default)]
struct Found {
    /// Structs in the order they are defined.
    structs: Vec<(String, Vec<Member>)>,
    typedefs: HashMap<String, Declared>,
    /// Constants by the full name of the module they are in.
    constants: HashMap<String, Vec<Constant>>,
}

/// rosidl nests two modules (`pkg::msg`); a bound keeps hostile text off the stack.
const MAX_MODULE_DEPTH: usize = 32;

struct Parser {
    tokens: Vec<Lexed>,
    at: usize,
    scope: Vec<String>,
    found: Found,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at).map(|t| &t.token)
    }

    fn line(&self) -> usize {
        self.tokens
            .get(self.at)
            .or(self.tokens.last())
            .map_or(1, |t| t.line)
    }

    fn fail<T>(&self, problem: impl std::fmt::Display) -> Result<T, String> {
        Err(format!("line {}: {problem}", self.line()))
    }

    fn next(&mut self) -> Option<Token> {
        let token = self.tokens.get(self.at).map(|t| t.token.clone());
        self.at += 1;
        token
    }

    fn is_punct(&self, punct: &str) -> bool {
        matches!(self.peek(), Some(Token::Punct(p)) if *p == punct)
    }

    fn is_word(&self, word: &str) -> bool {
        matches!(self.peek(), Some(Token::Ident(w)) if w == word)
    }

    fn expect(&mut self, punct: &str) -> Result<(), String> {
        if self.is_punct(punct) {
            self.at += 1;
            Ok(())
        } else {
            self.fail(format!("expected '{punct}', found {}", self.describe()))
        }
    }

    fn ident(&mut self) -> Result<String, String> {
        match self.peek() {
            Some(Token::Ident(name)) => {
                let name = name.clone();
                self.at += 1;
                Ok(name)
            }
            _ => self.fail(format!("expected a name, found {}", self.describe())),
        }
    }

    fn describe(&self) -> String {
        match self.peek() {
            None => "the end of the schema".into(),
            Some(Token::Ident(w) | Token::Number(w)) => format!("'{w}'"),
            Some(Token::Str(s)) => format!("the string \"{s}\""),
            Some(Token::Punct(p)) => format!("'{p}'"),
        }
    }

    fn full_name(&self, name: &str) -> String {
        let mut parts = self.scope.clone();
        parts.push(name.to_string());
        parts.join("::")
    }

    /// Definitions up to the end of the text (`top`) or of the enclosing module's braces.
    fn definitions(&mut self, top: bool) -> Result<(), String> {
        loop {
            self.annotations()?;
            match self.peek() {
                None if top => return Ok(()),
                None => return self.fail("a module is not closed with '}'"),
                Some(Token::Punct("}")) if !top => return Ok(()),
                Some(Token::Punct(";")) => self.at += 1,
                Some(Token::Ident(word)) => match word.as_str() {
                    "module" => self.module()?,
                    "struct" => self.structure()?,
                    "typedef" => self.typedef()?,
                    "const" => self.constant()?,
                    "enum" | "union" | "bitmask" | "bitset" | "interface" | "exception"
                    | "valuetype" | "native" => {
                        return self
                            .fail(format!("IDL '{word}' is not supported (rosidl has none)"));
                    }
                    _ => return self.fail(format!("unexpected {}", self.describe())),
                },
                Some(_) => return self.fail(format!("unexpected {}", self.describe())),
            }
        }
    }

    /// Skips `@name` and `@name (...)`, parentheses balanced.
    fn annotations(&mut self) -> Result<(), String> {
        while self.is_punct("@") {
            self.at += 1;
            self.scoped_name()?;
            if self.is_punct("(") {
                let mut depth = 0usize;
                loop {
                    match self.next() {
                        Some(Token::Punct("(")) => depth += 1,
                        Some(Token::Punct(")")) => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        Some(_) => {}
                        None => return self.fail("an annotation's '(' is not closed"),
                    }
                }
            }
        }
        Ok(())
    }

    fn module(&mut self) -> Result<(), String> {
        self.at += 1;
        let name = self.ident()?;
        self.expect("{")?;
        if self.scope.len() >= MAX_MODULE_DEPTH {
            return self.fail(format!("modules nested more than {MAX_MODULE_DEPTH} deep"));
        }
        self.scope.push(name);
        self.definitions(false)?;
        self.scope.pop();
        self.expect("}")?;
        self.expect(";")
    }

    fn structure(&mut self) -> Result<(), String> {
        self.at += 1;
        let name = self.ident()?;
        if self.is_punct(";") {
            // A forward declaration.
            self.at += 1;
            return Ok(());
        }
        if self.is_punct(":") {
            return self.fail(format!(
                "struct {name} inherits from another: not supported"
            ));
        }
        self.expect("{")?;
        let mut members = Vec::new();
        loop {
            self.annotations()?;
            if self.is_punct("}") {
                break;
            }
            let ty = self.type_spec()?;
            loop {
                let line = self.line();
                let member = self.ident()?;
                let array = self.array()?;
                members.push(Member {
                    name: member,
                    declared: Declared {
                        ty: ty.clone(),
                        array,
                        scope: self.scope.clone(),
                        line,
                    },
                });
                if self.is_punct(",") {
                    self.at += 1;
                } else {
                    break;
                }
            }
            self.expect(";")?;
        }
        self.expect("}")?;
        self.expect(";")?;
        let full = self.full_name(&name);
        self.found.structs.push((full, members));
        Ok(())
    }

    fn typedef(&mut self) -> Result<(), String> {
        self.at += 1;
        let line = self.line();
        let ty = self.type_spec()?;
        let name = self.ident()?;
        let array = self.array()?;
        self.expect(";")?;
        let declared = Declared {
            ty,
            array,
            scope: self.scope.clone(),
            line,
        };
        self.found.typedefs.insert(self.full_name(&name), declared);
        Ok(())
    }

    fn constant(&mut self) -> Result<(), String> {
        self.at += 1;
        let line = self.line();
        let ty = match self.type_spec()? {
            TypeSpec::Primitive(p) => p,
            TypeSpec::String { wide: false, .. } => Primitive::String,
            TypeSpec::String { wide: true, .. } => Primitive::WString,
            _ => return self.fail("a constant's type must be a primitive or a string"),
        };
        let name = self.ident()?;
        self.expect("=")?;
        let mut text = String::new();
        let mut string: Option<String> = None;
        while !self.is_punct(";") {
            match self.next() {
                // Adjacent string literals concatenate.
                Some(Token::Str(s)) => string.get_or_insert_with(String::new).push_str(&s),
                Some(Token::Number(n) | Token::Ident(n)) => text.push_str(&n),
                Some(Token::Punct(p)) => text.push_str(p),
                None => return self.fail(format!("constant {name} has no ';'")),
            }
        }
        self.at += 1;
        let value = match (ty, string) {
            (Primitive::String | Primitive::WString, Some(s)) if text.is_empty() => Literal::Str(s),
            (_, None) => parse_literal(ty, Arity::Single, &text)
                .or_else(|e| hex_literal(ty, &text).ok_or(e))
                .map_err(|e| format!("line {line}: constant {name}: {e}"))?,
            _ => {
                return Err(format!(
                    "line {line}: constant {name} has a value of the wrong kind"
                ));
            }
        };
        self.found
            .constants
            .entry(self.scope.join("::"))
            .or_default()
            .push(Constant { name, ty, value });
        Ok(())
    }

    /// `[N]` after a declarator, if there.
    fn array(&mut self) -> Result<Option<usize>, String> {
        if !self.is_punct("[") {
            return Ok(None);
        }
        self.at += 1;
        let size = self.size()?;
        self.expect("]")?;
        if self.is_punct("[") {
            return self.fail("arrays of more than one dimension are not supported");
        }
        Ok(Some(size))
    }

    fn size(&mut self) -> Result<usize, String> {
        match self.next() {
            Some(Token::Number(n)) => match n.parse::<usize>() {
                Ok(size) if size > 0 => Ok(size),
                _ => {
                    self.at -= 1;
                    self.fail(format!("'{n}' is not a size"))
                }
            },
            _ => {
                self.at -= 1;
                self.fail(format!("expected a size, found {}", self.describe()))
            }
        }
    }

    fn scoped_name(&mut self) -> Result<(Vec<String>, bool), String> {
        let absolute = self.is_punct("::");
        if absolute {
            self.at += 1;
        }
        let mut parts = vec![self.ident()?];
        while self.is_punct("::") {
            self.at += 1;
            parts.push(self.ident()?);
        }
        Ok((parts, absolute))
    }

    fn type_spec(&mut self) -> Result<TypeSpec, String> {
        let word = match self.peek() {
            Some(Token::Ident(word)) => word.clone(),
            Some(Token::Punct("::")) => String::new(),
            _ => return self.fail(format!("expected a type, found {}", self.describe())),
        };
        let primitive = |p| Ok(TypeSpec::Primitive(p));
        let simple = match word.as_str() {
            "boolean" => Some(Primitive::Bool),
            "octet" => Some(Primitive::Byte),
            "char" => Some(Primitive::Char),
            "float" => Some(Primitive::Float32),
            "double" => Some(Primitive::Float64),
            "short" => Some(Primitive::Int16),
            "int8" => Some(Primitive::Int8),
            "uint8" => Some(Primitive::Uint8),
            "int16" => Some(Primitive::Int16),
            "uint16" => Some(Primitive::Uint16),
            "int32" => Some(Primitive::Int32),
            "uint32" => Some(Primitive::Uint32),
            "int64" => Some(Primitive::Int64),
            "uint64" => Some(Primitive::Uint64),
            _ => None,
        };
        if let Some(p) = simple {
            self.at += 1;
            return primitive(p);
        }
        match word.as_str() {
            "long" => {
                self.at += 1;
                if self.is_word("double") {
                    return self.fail("'long double' is not supported");
                }
                if self.is_word("long") {
                    self.at += 1;
                    return primitive(Primitive::Int64);
                }
                primitive(Primitive::Int32)
            }
            "unsigned" => {
                self.at += 1;
                if self.is_word("short") {
                    self.at += 1;
                    return primitive(Primitive::Uint16);
                }
                if !self.is_word("long") {
                    return self.fail(format!("'unsigned {}' is not a type", self.describe()));
                }
                self.at += 1;
                if self.is_word("long") {
                    self.at += 1;
                    return primitive(Primitive::Uint64);
                }
                primitive(Primitive::Uint32)
            }
            "wchar" => self.fail("'wchar' is not supported"),
            "string" | "wstring" => {
                self.at += 1;
                let bound = if self.is_punct("<") {
                    self.at += 1;
                    let bound = self.size()?;
                    self.expect(">")?;
                    Some(bound)
                } else {
                    None
                };
                Ok(TypeSpec::String {
                    wide: word == "wstring",
                    bound,
                })
            }
            "sequence" => {
                self.at += 1;
                self.expect("<")?;
                if self.is_word("sequence") {
                    return self.fail("sequences of sequences are not supported");
                }
                let item = self.type_spec()?;
                let bound = if self.is_punct(",") {
                    self.at += 1;
                    Some(self.size()?)
                } else {
                    None
                };
                self.expect(">")?;
                Ok(TypeSpec::Sequence(Box::new(item), bound))
            }
            _ => {
                let (parts, absolute) = self.scoped_name()?;
                Ok(TypeSpec::Named { parts, absolute })
            }
        }
    }
}

/// `0x..` integer constants, which `.msg` literals do not have.
fn hex_literal(ty: Primitive, text: &str) -> Option<Literal> {
    let digits = text
        .strip_prefix("0x")
        .or_else(|| text.strip_prefix("0X"))?;
    let value = i128::from_str_radix(digits, 16).ok()?;
    parse_literal(ty, Arity::Single, &value.to_string()).ok()
}

/// A struct's ROS name: `pkg::msg::Name` is `pkg/Name` as the `.msg` parser names it,
/// `pkg::srv::Name_Request` is `pkg/srv/Name_Request`.
fn ros_name(full: &str) -> String {
    short_name(&full.replace("::", "/"))
}

/// The full names a name used in `scope` may stand for, innermost scope first.
fn candidates(parts: &[String], absolute: bool, scope: &[String]) -> Vec<String> {
    let name = parts.join("::");
    if absolute {
        return vec![name];
    }
    (0..=scope.len())
        .rev()
        .map(|depth| {
            let mut full = scope[..depth].to_vec();
            full.push(name.clone());
            full.join("::")
        })
        .collect()
}

/// What a declared type comes to: its base, its arity and a string's bound.
type Resolved = (RawBase, Arity, Option<usize>);

fn resolve_type(declared: &Declared, found: &Found, depth: usize) -> Result<Resolved, String> {
    let at = |problem: String| format!("line {}: {problem}", declared.line);
    if depth > 32 {
        return Err(at("typedefs refer to each other in a loop".into()));
    }
    let (base, item_arity, bound) = match &declared.ty {
        TypeSpec::Primitive(p) => (RawBase::Primitive(*p), Arity::Single, None),
        TypeSpec::String { wide, bound } => {
            let p = if *wide {
                Primitive::WString
            } else {
                Primitive::String
            };
            (RawBase::Primitive(p), Arity::Single, *bound)
        }
        TypeSpec::Sequence(item, limit) => {
            let inner = Declared {
                ty: (**item).clone(),
                array: None,
                ..declared.clone()
            };
            let (base, arity, bound) = resolve_type(&inner, found, depth + 1)?;
            if arity != Arity::Single {
                return Err(at(
                    "a sequence of arrays or sequences is not supported".into()
                ));
            }
            let arity = limit.map_or(Arity::Unbounded, Arity::Bounded);
            (base, arity, bound)
        }
        TypeSpec::Named { parts, absolute } => {
            let names = candidates(parts, *absolute, &declared.scope);
            if let Some(typedef) = names.iter().find_map(|n| found.typedefs.get(n)) {
                resolve_type(typedef, found, depth + 1)?
            } else if let Some(full) = names
                .iter()
                .find(|n| found.structs.iter().any(|(s, _)| s == *n))
            {
                (RawBase::Message(ros_name(full)), Arity::Single, None)
            } else {
                // Not defined here: a builtin (`builtin_interfaces::msg::Time`) or an
                // error `resolve` names.
                (
                    RawBase::Message(ros_name(&parts.join("::"))),
                    Arity::Single,
                    None,
                )
            }
        }
    };
    match (item_arity, declared.array) {
        (arity, None) => Ok((base, arity, bound)),
        (Arity::Single, Some(n)) => Ok((base, Arity::Fixed(n), bound)),
        _ => Err(at("an array of arrays or sequences is not supported".into())),
    }
}

/// The structs as messages, the one named `root` first.
fn messages(found: Found, root: &str) -> Result<Schema, String> {
    let mut raw = Vec::with_capacity(found.structs.len());
    for (full, members) in &found.structs {
        let mut fields = Vec::with_capacity(members.len());
        for member in members.iter().filter(|m| !is_placeholder(m, members.len())) {
            let (base, arity, string_bound) = resolve_type(&member.declared, &found, 0)
                .map_err(|e| format!("{e} (member '{}' of {full})", member.name))?;
            fields.push(RawField {
                name: member.name.clone(),
                type_text: type_text(&member.declared.ty),
                base,
                arity,
                string_bound,
                default_text: None,
                line: member.declared.line,
            });
        }
        let constants = found
            .constants
            .get(&format!("{full}_Constants"))
            .cloned()
            .unwrap_or_default();
        raw.push(RawMessage {
            name: ros_name(full),
            fields,
            constants,
        });
    }
    let root_at = raw
        .iter()
        .position(|m| m.name == root)
        .ok_or_else(|| format!("the schema defines no struct {root}"))?;
    raw.swap(0, root_at);
    resolve(raw)
}

/// rosidl gives a message without fields the member `uint8
/// structure_needs_at_least_one_member`, since an IDL struct cannot be empty; the `.msg`
/// parser leaves it out and the CDR decoder reads its byte, so it is left out here too.
fn is_placeholder(member: &Member, members: usize) -> bool {
    members == 1
        && member.name == "structure_needs_at_least_one_member"
        && matches!(member.declared.ty, TypeSpec::Primitive(Primitive::Uint8))
        && member.declared.array.is_none()
}

fn type_text(ty: &TypeSpec) -> String {
    match ty {
        TypeSpec::Primitive(p) => format!("{p:?}").to_lowercase(),
        TypeSpec::String { wide, .. } => if *wide { "wstring" } else { "string" }.into(),
        TypeSpec::Sequence(item, _) => format!("sequence<{}>", type_text(item)),
        TypeSpec::Named { parts, .. } => parts.join("::"),
    }
}

#[cfg(test)]
mod tests {
    use super::super::ros2msg::{self, BaseType, MessageDef};
    use super::*;
    use proptest::prelude::*;

    const DELIMITER: &str =
        "================================================================================";

    /// `geometry_msgs/msg/PoseWithCovarianceStamped` as rosbag2 stores it, in the form
    /// `rosidl_adapter` generates: comments, includes, annotations, a typedef for the
    /// fixed array, a constants module.
    fn pose_idl() -> String {
        format!(
            r#"{DELIMITER}
IDL: geometry_msgs/msg/PoseWithCovarianceStamped
// generated from rosidl_adapter/resource/msg.idl.em
// with input from geometry_msgs/msg/PoseWithCovarianceStamped.msg
// generated code does not contain a copyright notice

#include "geometry_msgs/msg/PoseWithCovariance.idl"
#include "std_msgs/msg/Header.idl"

module geometry_msgs {{
  module msg {{
    @verbatim (language="comment", text=
      "This expresses an estimated pose with a reference coordinate frame and timestamp")
    struct PoseWithCovarianceStamped {{
      std_msgs::msg::Header header;

      PoseWithCovariance pose;
    }};
  }};
}};
{DELIMITER}
IDL: geometry_msgs/msg/PoseWithCovariance
#include "geometry_msgs/msg/Pose.idl"

module geometry_msgs {{
  module msg {{
    typedef double double__36[36];
    module PoseWithCovariance_Constants {{
      /**
       * How the covariance was estimated.
       */
      const uint8 ESTIMATED=1;
      const string SOURCE = "odometry" " and imu";
      const int32 NEGATIVE = -7;
      const uint16 MASK = 0xff;
    }};
    struct PoseWithCovariance {{
      geometry_msgs::msg::Pose pose;

      @verbatim (language="comment", text=
        "Row-major representation of the 6x6 covariance matrix" "\n"
        "(x, y, z, rotation about X axis, rotation about Y axis, rotation about Z axis)")
      double__36 covariance;
    }};
  }};
}};
{DELIMITER}
IDL: geometry_msgs/msg/Pose
module geometry_msgs {{
  module msg {{
    struct Pose {{
      geometry_msgs::msg::Point position;
      geometry_msgs::msg::Quaternion orientation;
    }};
  }};
}};
{DELIMITER}
IDL: geometry_msgs/msg/Point
module geometry_msgs {{ module msg {{ struct Point {{ double x; double y; double z; }}; }}; }};
{DELIMITER}
IDL: geometry_msgs/msg/Quaternion
module geometry_msgs {{
  module msg {{
    struct Quaternion {{
      @default (value=0.0)
      double x;
      @default (value=0.0)
      double y, z;
      @default (value=1.0)
      double w;
    }};
  }};
}};
{DELIMITER}
IDL: std_msgs/msg/Header
#include "builtin_interfaces/msg/Time.idl"
module std_msgs {{
  module msg {{
    struct Header {{
      builtin_interfaces::msg::Time stamp;
      string frame_id;
    }};
  }};
}};
"#
        )
    }

    const POSE_MSG: &str = "\
std_msgs/Header header
PoseWithCovariance pose
================================================================================
MSG: geometry_msgs/PoseWithCovariance
uint8 ESTIMATED=1
string SOURCE=\"odometry and imu\"
int32 NEGATIVE=-7
uint16 MASK=255
Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/Pose
Point position
Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
";

    /// The message named `name`, with its fields' types spelled out by name so that two
    /// schemas that order their messages differently compare equal.
    fn shape(schema: &Schema, name: &str) -> Vec<(String, String, Arity, Option<usize>)> {
        let message: &MessageDef = schema.messages.iter().find(|m| m.name == name).unwrap();
        message
            .fields
            .iter()
            .map(|f| {
                let base = match &f.base {
                    BaseType::Primitive(p) => format!("{p:?}"),
                    BaseType::Message(i) => schema.messages[*i].name.clone(),
                };
                (f.name.to_string(), base, f.arity, f.string_bound)
            })
            .collect()
    }

    #[test]
    fn rosidl_generated_idl_gives_the_schema_of_the_msg_text() {
        let name = "geometry_msgs/msg/PoseWithCovarianceStamped";
        let idl = parse(name, &pose_idl()).unwrap();
        let msg = ros2msg::parse(name, POSE_MSG).unwrap();
        assert_eq!(idl.root().name, "geometry_msgs/PoseWithCovarianceStamped");
        let mut names: Vec<&str> = msg.messages.iter().map(|m| m.name.as_str()).collect();
        names.sort();
        let mut idl_names: Vec<&str> = idl.messages.iter().map(|m| m.name.as_str()).collect();
        idl_names.sort();
        assert_eq!(idl_names, names);
        for name in names {
            assert_eq!(shape(&idl, name), shape(&msg, name), "{name}");
            let message = |s: &Schema| s.messages.iter().find(|m| m.name == name).cloned();
            let (a, b) = (message(&idl).unwrap(), message(&msg).unwrap());
            assert_eq!(a.constants, b.constants, "{name}");
            assert_eq!(a.min_size, b.min_size, "{name}");
        }
    }

    #[test]
    fn sequences_strings_and_every_primitive_name() {
        let text = "\
module test_msgs { module msg {
  typedef sequence<int32, 10> Bounded;
  struct Everything {
    boolean b; octet o; char c; int8 i8; uint8 u8;
    short s; unsigned short us; long l; unsigned long ul;
    long long ll; unsigned long long ull; float f; double d;
    string text; string<5> short_text; wstring wide; wstring<3> short_wide;
    sequence<double> doubles; sequence<string<4>, 2> words;
    Bounded bounded; ::test_msgs::msg::Inner inner; Inner inners[2];
    sequence<Inner> more;
  };
  struct Inner { uint16 x; };
}; };
";
        let schema = parse("test_msgs/msg/Everything", text).unwrap();
        let fields = shape(&schema, "test_msgs/Everything");
        let spelled: Vec<String> = fields
            .iter()
            .map(|(name, base, arity, bound)| format!("{name} {base} {arity:?} {bound:?}"))
            .collect();
        assert_eq!(
            spelled,
            [
                "b Bool Single None",
                "o Byte Single None",
                "c Char Single None",
                "i8 Int8 Single None",
                "u8 Uint8 Single None",
                "s Int16 Single None",
                "us Uint16 Single None",
                "l Int32 Single None",
                "ul Uint32 Single None",
                "ll Int64 Single None",
                "ull Uint64 Single None",
                "f Float32 Single None",
                "d Float64 Single None",
                "text String Single None",
                "short_text String Single Some(5)",
                "wide WString Single None",
                "short_wide WString Single Some(3)",
                "doubles Float64 Unbounded None",
                "words String Bounded(2) Some(4)",
                "bounded Int32 Bounded(10) None",
                "inner test_msgs/Inner Single None",
                "inners test_msgs/Inner Fixed(2) None",
                "more test_msgs/Inner Unbounded None",
            ]
        );
    }

    #[test]
    fn the_member_rosidl_gives_an_empty_message_is_left_out_as_the_msg_parser_does() {
        let text = "\
module std_msgs { module msg {
  module Empty_Constants { const int32 ONLY = 7; };
  struct Empty { uint8 structure_needs_at_least_one_member; };
  struct One { uint8 structure_needs_at_least_one_member; uint8 other; };
}; };
";
        let schema = parse("std_msgs/msg/Empty", text).unwrap();
        let msg = ros2msg::parse("std_msgs/msg/Empty", "int32 ONLY=7\n").unwrap();
        assert!(schema.root().fields.is_empty());
        assert_eq!(schema.root().constants, msg.root().constants);
        assert_eq!(schema.root().min_size, msg.root().min_size);
        assert_eq!(shape(&schema, "std_msgs/One").len(), 2);
    }

    #[test]
    fn service_and_action_types_keep_their_kind_in_the_name() {
        let text = "\
module example_interfaces { module srv {
  struct AddTwoInts_Request { int64 a; int64 b; };
  struct AddTwoInts_Response { int64 sum; };
  struct AddTwoInts_Event {
    sequence<AddTwoInts_Request, 1> request;
    sequence<AddTwoInts_Response, 1> response;
  };
}; };
";
        let schema = parse("example_interfaces/srv/AddTwoInts_Event", text).unwrap();
        assert_eq!(
            schema.root().name,
            "example_interfaces/srv/AddTwoInts_Event"
        );
        assert_eq!(
            shape(&schema, "example_interfaces/srv/AddTwoInts_Event")[0].1,
            "example_interfaces/srv/AddTwoInts_Request"
        );
    }

    /// A field of a generated message: a primitive (index into `PRIMITIVES`) or a later
    /// message, an arity (0 single, 1 fixed, 2 unbounded, 3 bounded) and a size.
    type GeneratedField = (usize, Option<usize>, u8, usize);

    /// `.msg` and IDL names of the primitives (msg `char` written as IDL `char`, so that
    /// both give the same primitive).
    const PRIMITIVES: [(&str, &str); 15] = [
        ("bool", "boolean"),
        ("byte", "octet"),
        ("char", "char"),
        ("float32", "float"),
        ("float64", "double"),
        ("int8", "int8"),
        ("uint8", "uint8"),
        ("int16", "short"),
        ("uint16", "unsigned short"),
        ("int32", "long"),
        ("uint32", "unsigned long"),
        ("int64", "long long"),
        ("uint64", "uint64"),
        ("string", "string"),
        ("string<=7", "string<7>"),
    ];

    /// The `.msg` text (root first, then `MSG:` sections) and the IDL text (sections in
    /// the reverse order, with a typedef for each fixed array) of the same messages.
    fn render(messages: &[Vec<GeneratedField>]) -> (String, String) {
        let (mut msg, mut idl_sections) = (String::new(), Vec::new());
        for (i, fields) in messages.iter().enumerate() {
            if i > 0 {
                msg.push_str(&format!("{DELIMITER}\nMSG: p/M{i}\n"));
            }
            let (mut typedefs, mut members) = (String::new(), String::new());
            for (k, &(primitive, nested, arity, size)) in fields.iter().enumerate() {
                let (msg_base, idl_base) = match nested {
                    Some(j) => (format!("M{j}"), format!("p::msg::M{j}")),
                    None => (
                        PRIMITIVES[primitive].0.into(),
                        PRIMITIVES[primitive].1.into(),
                    ),
                };
                let (msg_array, idl_type) = match arity {
                    0 => (String::new(), idl_base),
                    1 => {
                        typedefs.push_str(&format!("typedef {idl_base} t{i}_{k}[{size}];\n"));
                        (format!("[{size}]"), format!("t{i}_{k}"))
                    }
                    2 => ("[]".into(), format!("sequence<{idl_base}>")),
                    _ => (
                        format!("[<={size}]"),
                        format!("sequence<{idl_base}, {size}>"),
                    ),
                };
                msg.push_str(&format!("{msg_base}{msg_array} f{k}\n"));
                members.push_str(&format!("  @default (value=0)\n  {idl_type} f{k};\n"));
            }
            idl_sections.push(format!(
                "{DELIMITER}\nIDL: p/msg/M{i}\nmodule p {{ module msg {{\n{typedefs}\
                 struct M{i} {{\n{members}}};\n}}; }};\n"
            ));
        }
        idl_sections.reverse();
        (msg, idl_sections.concat())
    }

    fn generated_messages() -> impl Strategy<Value = Vec<Vec<GeneratedField>>> {
        (1usize..4).prop_flat_map(|count| {
            (0..count)
                .map(|i| {
                    let field = (0..PRIMITIVES.len(), 0..count + 1, 0u8..4, 1usize..6).prop_map(
                        move |(primitive, nested, arity, size)| {
                            // A message uses only later ones, so none contains itself.
                            let nested = (nested > i && nested < count).then_some(nested);
                            (primitive, nested, arity, size)
                        },
                    );
                    prop::collection::vec(field, 1..6)
                })
                .collect::<Vec<_>>()
        })
    }

    proptest! {
        #[test]
        fn idl_and_msg_texts_of_the_same_messages_give_the_same_schema(
            messages in generated_messages()
        ) {
            let (msg, idl) = render(&messages);
            let from_msg = ros2msg::parse("p/msg/M0", &msg).unwrap();
            let from_idl = parse("p/msg/M0", &idl).unwrap();
            prop_assert_eq!(&from_idl.root().name, "p/M0");
            for i in 0..messages.len() {
                let name = format!("p/M{i}");
                prop_assert_eq!(shape(&from_idl, &name), shape(&from_msg, &name));
            }
            prop_assert_eq!(from_idl.root().min_size, from_msg.root().min_size);
        }

        #[test]
        fn arbitrary_idl_like_text_never_panics(
            text in "(module|struct|typedef|const|sequence|string|long|unsigned|@a|[(){};:<>,=\\[\\]]|[a-z0-9\"/*#\n ]){0,60}"
        ) {
            let _ = parse("p/msg/M", &text);
        }
    }

    #[test]
    fn what_rosidl_cannot_express_is_an_error_naming_its_line() {
        let cases = [
            (
                "module a { module msg {\n union U switch (long) { case 1: long x; };\n}; };",
                "line 2: IDL 'union' is not supported",
            ),
            (
                "module a { module msg { struct M {\n long double x;\n}; }; };",
                "line 2: 'long double' is not supported",
            ),
            (
                "module a { module msg { struct M {\n sequence<sequence<long>> x;\n}; }; };",
                "line 2: sequences of sequences",
            ),
            (
                "module a { module msg { struct M {\n double x[2][3];\n}; }; };",
                "line 2: arrays of more than one dimension",
            ),
            (
                "module a { module msg { struct M {\n a::msg::Missing x;\n}; }; };",
                "line 2: field 'x' of a/M: type 'a::msg::Missing' is not defined",
            ),
            (
                "module a { module msg { struct N { long x; }; }; };",
                "the schema defines no struct a/M",
            ),
            (
                "module a { module msg {\n module M_Constants { const uint8 C = 300; };\n}; };",
                "line 2: constant C: 300 is out of range",
            ),
            (
                "module a { module msg { struct M {\n long x\n}; }; };",
                "line 3: expected ';', found '}'",
            ),
            (
                "module a { module msg { struct M { long x; };",
                "a module is not closed",
            ),
            (
                "/* never closed\nmodule a {};",
                "a /* comment is never closed",
            ),
        ];
        for (text, expected) in cases {
            let error = parse("a/msg/M", text).unwrap_err();
            assert!(error.contains(expected), "{text:?}: {error}");
        }
    }
}
