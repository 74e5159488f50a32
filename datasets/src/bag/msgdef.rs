//! ROS message definitions, parsed from the text a bag carries: the `message_definition`
//! of a ROS 1 connection, or the `ros2msg` schema of an MCAP channel. Both are the
//! `.msg` text of the topic's type followed by the text of every type it uses, each
//! after a line of `=` and a line `MSG: package/Type`.
//!
//! The decoders ([`super::decode`]) read fields in the order and with the types these
//! definitions give, so a message's layout is never hard-coded: only the names of the
//! fields a reader needs (`ranges`, `header.stamp`, …) are.
//!
//! Grammar accepted (one field or constant per line, `#` starts a comment):
//! - `TYPE NAME` with TYPE a primitive (`bool`, `byte`, `char`, `int8` … `uint64`,
//!   `float32`, `float64`, `string`, `wstring`, ROS 1 `time` and `duration`), a message
//!   type (`Point`, `geometry_msgs/Point`, `geometry_msgs/msg/Point`; a name without a
//!   package is looked up in the package of the type that uses it, `Header` in ROS 1
//!   means `std_msgs/Header`), with an optional array suffix `[]`, `[N]` or `[<=N]`
//!   and, for strings, a bound `string<=N`;
//! - ROS 2 default values after the name (`float64 x 0.0`) are ignored;
//! - constants `TYPE NAME=VALUE` are skipped (they are not on the wire).
//!
//! Every type a field names must be defined in the text, and no type may contain
//! itself (directly or not): both are errors naming the type and the field.

use std::collections::BTreeMap;
use std::fmt;

/// Which serialisation the definitions describe (it decides what `time`, `byte` and
/// `char` are and how values are laid out).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    /// ROS 1: little-endian, packed, `time` and `duration` built in.
    Ros1,
    /// ROS 2: CDR (aligned, with an encapsulation header), time as a message.
    Ros2,
}

/// A primitive type of the message language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    /// `bool` (one byte).
    Bool,
    /// `int8` (ROS 1 `byte`).
    Int8,
    /// `uint8` (ROS 1 `char`, ROS 2 `byte` and `char`).
    UInt8,
    /// `int16`.
    Int16,
    /// `uint16`.
    UInt16,
    /// `int32`.
    Int32,
    /// `uint32`.
    UInt32,
    /// `int64`.
    Int64,
    /// `uint64`.
    UInt64,
    /// `float32`.
    Float32,
    /// `float64`.
    Float64,
    /// `string`.
    String,
    /// `wstring` (ROS 2; not decoded).
    WString,
    /// ROS 1 `time`: `uint32` seconds and `uint32` nanoseconds.
    Time,
    /// ROS 1 `duration`: `int32` seconds and `int32` nanoseconds.
    Duration,
}

impl Primitive {
    fn parse(name: &str, dialect: Dialect) -> Option<Self> {
        Some(match name {
            "bool" => Primitive::Bool,
            "int8" => Primitive::Int8,
            "uint8" => Primitive::UInt8,
            "byte" if dialect == Dialect::Ros1 => Primitive::Int8,
            "char" | "byte" | "octet" => Primitive::UInt8,
            "int16" => Primitive::Int16,
            "uint16" => Primitive::UInt16,
            "int32" => Primitive::Int32,
            "uint32" => Primitive::UInt32,
            "int64" => Primitive::Int64,
            "uint64" => Primitive::UInt64,
            "float32" => Primitive::Float32,
            "float64" => Primitive::Float64,
            "string" => Primitive::String,
            "wstring" if dialect == Dialect::Ros2 => Primitive::WString,
            "time" if dialect == Dialect::Ros1 => Primitive::Time,
            "duration" if dialect == Dialect::Ros1 => Primitive::Duration,
            _ => return None,
        })
    }

    /// Size on the wire of a fixed-size primitive (strings: their length prefix).
    pub fn size(self) -> usize {
        match self {
            Primitive::Bool | Primitive::Int8 | Primitive::UInt8 => 1,
            Primitive::Int16 | Primitive::UInt16 => 2,
            Primitive::Int32
            | Primitive::UInt32
            | Primitive::Float32
            | Primitive::String
            | Primitive::WString => 4,
            Primitive::Int64
            | Primitive::UInt64
            | Primitive::Float64
            | Primitive::Time
            | Primitive::Duration => 8,
        }
    }
}

/// The element type of a field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// A primitive.
    Primitive(Primitive),
    /// A message type, by its full name `package/Type`.
    Message(String),
}

/// Whether a field is one value or an array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    /// One value.
    Single,
    /// A fixed number of values (no length on the wire).
    Fixed(usize),
    /// A sequence: a length, then the values (a declared upper bound is not enforced).
    Sequence,
}

/// One field of a message type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// Its element type.
    pub ty: FieldType,
    /// One value or an array.
    pub arity: Arity,
}

/// One message type: its full name and fields in wire order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MessageType {
    /// Full name, `package/Type`.
    pub name: String,
    /// Fields in wire order.
    pub fields: Vec<Field>,
}

/// A problem in a message definition text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DefinitionError {
    /// The type whose definition has the problem.
    pub message_type: String,
    /// 1-based line within the definition text (0 when it concerns the whole text).
    pub line: usize,
    /// What is wrong.
    pub problem: String,
}

impl fmt::Display for DefinitionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(
                f,
                "message definition of {}, line {}: {}",
                self.message_type, self.line, self.problem
            )
        } else {
            write!(
                f,
                "message definition of {}: {}",
                self.message_type, self.problem
            )
        }
    }
}

/// The parsed definitions of one topic's type and every type it uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Definitions {
    /// The topic's type (full name).
    pub root: String,
    /// Every defined type by full name.
    pub types: BTreeMap<String, MessageType>,
    /// The serialisation.
    pub dialect: Dialect,
}

/// Largest nesting of message types accepted (the deepest standard ROS message nests
/// about six levels).
pub const MAX_NESTING: usize = 32;

/// `package/msg/Type` → `package/Type`; other names unchanged.
pub fn normalise_type_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    if parts.len() == 3 && parts[1] == "msg" {
        format!("{}/{}", parts[0], parts[2])
    } else {
        name.to_string()
    }
}

fn package_of(name: &str) -> &str {
    name.split_once('/').map_or("", |(p, _)| p)
}

fn is_separator(line: &str) -> bool {
    let t = line.trim();
    t.len() >= 3 && t.bytes().all(|b| b == b'=')
}

fn valid_identifier(name: &str) -> bool {
    !name.is_empty()
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
        && !name.as_bytes()[0].is_ascii_digit()
}

fn valid_type_name(name: &str) -> bool {
    !name.is_empty() && name.split('/').all(valid_identifier) && name.split('/').count() <= 3
}

impl Definitions {
    /// Parses the definition text of type `root` (a full name; `package/msg/Type` is
    /// accepted).
    ///
    /// # Errors
    /// A line that is neither a field, a constant nor a comment; a type used but not
    /// defined; a type that contains itself; nesting deeper than [`MAX_NESTING`].
    pub fn parse(root: &str, text: &str, dialect: Dialect) -> Result<Self, DefinitionError> {
        let root = normalise_type_name(root);
        let mut types = BTreeMap::new();
        let mut current_name = root.clone();
        let mut current: Vec<Field> = Vec::new();
        let mut expect_msg_line = false;
        for (number, raw) in text.lines().enumerate() {
            let line = number + 1;
            let err = |problem: String, name: &str| DefinitionError {
                message_type: name.to_string(),
                line,
                problem,
            };
            if is_separator(raw) {
                let finished = std::mem::take(&mut current);
                insert_type(&mut types, &current_name, finished, line)?;
                expect_msg_line = true;
                continue;
            }
            let content = raw.split('#').next().unwrap_or("").trim();
            if expect_msg_line {
                if raw.trim().is_empty() {
                    continue;
                }
                let Some(name) = raw.trim().strip_prefix("MSG:") else {
                    return Err(err(
                        format!("expected `MSG: package/Type` after a separator, found {raw:?}"),
                        &current_name,
                    ));
                };
                let name = normalise_type_name(name.trim());
                if !valid_type_name(&name) {
                    return Err(err(format!("invalid type name {name:?}"), &current_name));
                }
                current_name = name;
                expect_msg_line = false;
                continue;
            }
            if content.is_empty() {
                continue;
            }
            let (type_token, rest) = content
                .split_once(char::is_whitespace)
                .map_or((content, ""), |(a, b)| (a, b.trim_start()));
            if rest.is_empty() {
                return Err(err(
                    format!("{content:?}: a field needs a type and a name"),
                    &current_name,
                ));
            }
            let name_end = rest
                .find(|c: char| c.is_whitespace() || c == '=')
                .unwrap_or(rest.len());
            let name = &rest[..name_end];
            let after = rest[name_end..].trim_start();
            if after.starts_with('=') {
                // A constant: not part of the wire format. A string constant's value may
                // hold `#`, so the raw line is not needed beyond this point.
                if !valid_identifier(name) {
                    return Err(err(
                        format!("invalid constant name {name:?}"),
                        &current_name,
                    ));
                }
                continue;
            }
            if !valid_identifier(name) {
                return Err(err(format!("invalid field name {name:?}"), &current_name));
            }
            let (ty, arity) = parse_type(type_token, &current_name, dialect)
                .map_err(|problem| err(problem, &current_name))?;
            current.push(Field {
                name: name.to_string(),
                ty,
                arity,
            });
        }
        if expect_msg_line {
            return Err(DefinitionError {
                message_type: current_name,
                line: 0,
                problem: "the text ends after a separator, without `MSG: package/Type`".into(),
            });
        }
        insert_type(&mut types, &current_name, current, 0)?;
        let mut definitions = Definitions {
            root,
            types,
            dialect,
        };
        definitions.resolve()?;
        Ok(definitions)
    }

    /// The root type.
    pub fn root_type(&self) -> &MessageType {
        &self.types[&self.root]
    }

    /// Resolves message field types to defined full names and checks for cycles.
    fn resolve(&mut self) -> Result<(), DefinitionError> {
        let names: Vec<String> = self.types.keys().cloned().collect();
        let mut by_short: BTreeMap<&str, Vec<&String>> = BTreeMap::new();
        for n in &names {
            let short = n.rsplit('/').next().unwrap_or(n);
            by_short.entry(short).or_default().push(n);
        }
        let mut resolved: BTreeMap<(String, usize), String> = BTreeMap::new();
        for (type_name, t) in &self.types {
            for (k, f) in t.fields.iter().enumerate() {
                let FieldType::Message(wanted) = &f.ty else {
                    continue;
                };
                let candidates = if wanted.contains('/') {
                    vec![wanted.clone()]
                } else {
                    let in_package = format!("{}/{wanted}", package_of(type_name));
                    let mut c = vec![in_package];
                    if let Some(others) = by_short.get(wanted.as_str()) {
                        if others.len() == 1 {
                            c.push(others[0].clone());
                        }
                    }
                    c
                };
                let Some(found) = candidates.into_iter().find(|c| self.types.contains_key(c))
                else {
                    return Err(DefinitionError {
                        message_type: type_name.clone(),
                        line: 0,
                        problem: format!(
                            "field `{}` has type {wanted}, which the definition text does not define",
                            f.name
                        ),
                    });
                };
                resolved.insert((type_name.clone(), k), found);
            }
        }
        for ((type_name, k), full) in resolved {
            if let Some(t) = self.types.get_mut(&type_name) {
                t.fields[k].ty = FieldType::Message(full);
            }
        }
        // Cycles and depth: depth-first from every type (a type the root does not use
        // is still walked by the decoder's size table, found by fuzzing).
        let names: Vec<String> = self.types.keys().cloned().collect();
        for name in std::iter::once(self.root.clone()).chain(names) {
            let mut stack = Vec::new();
            self.check_depth(&name, &mut stack)?;
        }
        Ok(())
    }

    fn check_depth(&self, name: &str, stack: &mut Vec<String>) -> Result<(), DefinitionError> {
        if stack.iter().any(|s| s == name) {
            return Err(DefinitionError {
                message_type: name.to_string(),
                line: 0,
                problem: format!("the type contains itself ({} → {name})", stack.join(" → ")),
            });
        }
        if stack.len() >= MAX_NESTING {
            return Err(DefinitionError {
                message_type: name.to_string(),
                line: 0,
                problem: format!("message types nested more than {MAX_NESTING} deep"),
            });
        }
        let Some(t) = self.types.get(name) else {
            return Err(DefinitionError {
                message_type: name.to_string(),
                line: 0,
                problem: "type not defined".into(),
            });
        };
        stack.push(name.to_string());
        for f in &t.fields {
            if let FieldType::Message(m) = &f.ty {
                self.check_depth(m, stack)?;
            }
        }
        stack.pop();
        Ok(())
    }
}

fn insert_type(
    types: &mut BTreeMap<String, MessageType>,
    name: &str,
    fields: Vec<Field>,
    line: usize,
) -> Result<(), DefinitionError> {
    if types.contains_key(name) {
        return Err(DefinitionError {
            message_type: name.to_string(),
            line,
            problem: "type defined twice in the text".into(),
        });
    }
    types.insert(
        name.to_string(),
        MessageType {
            name: name.to_string(),
            fields,
        },
    );
    Ok(())
}

/// Largest fixed array length accepted in a definition.
const MAX_FIXED_LENGTH: usize = 1 << 24;

fn parse_type(token: &str, owner: &str, dialect: Dialect) -> Result<(FieldType, Arity), String> {
    let (base, arity) = match token.find('[') {
        None => (token, Arity::Single),
        Some(open) => {
            let Some(inner) = token[open + 1..].strip_suffix(']') else {
                return Err(format!("type {token:?}: unclosed array bracket"));
            };
            let arity = if inner.is_empty() || inner.starts_with("<=") {
                if let Some(bound) = inner.strip_prefix("<=") {
                    bound
                        .parse::<usize>()
                        .map_err(|_| format!("type {token:?}: bound {bound:?} is not a number"))?;
                }
                Arity::Sequence
            } else {
                let n: usize = inner
                    .parse()
                    .map_err(|_| format!("type {token:?}: length {inner:?} is not a number"))?;
                if n > MAX_FIXED_LENGTH {
                    return Err(format!(
                        "type {token:?}: a fixed array of {n} elements (at most {MAX_FIXED_LENGTH})"
                    ));
                }
                Arity::Fixed(n)
            };
            (&token[..open], arity)
        }
    };
    // A bounded string `string<=N`.
    let base = match base.split_once("<=") {
        Some((b, bound)) if b == "string" || b == "wstring" => {
            bound
                .parse::<usize>()
                .map_err(|_| format!("type {token:?}: string bound {bound:?} is not a number"))?;
            b
        }
        Some(_) => return Err(format!("type {token:?}: only strings take a `<=` bound")),
        None => base,
    };
    if let Some(p) = Primitive::parse(base, dialect) {
        return Ok((FieldType::Primitive(p), arity));
    }
    if base == "Header" && dialect == Dialect::Ros1 {
        return Ok((FieldType::Message("std_msgs/Header".into()), arity));
    }
    let name = normalise_type_name(base);
    if !valid_type_name(&name) {
        return Err(format!("invalid type {token:?} (in {owner})"));
    }
    Ok((FieldType::Message(name), arity))
}

#[cfg(test)]
mod tests {
    use super::*;

    const POSE: &str = "geometry_msgs/Pose pose\nuint32 id\n\n\
        ================================================================================\n\
        MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n\
        ================================================================================\n\
        MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n\
        ================================================================================\n\
        MSG: geometry_msgs/Quaternion\n# comment\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w 1.0\n";

    #[test]
    fn parses_nested_types_with_relative_names() {
        let d = Definitions::parse("leg_tracker/Person", POSE, Dialect::Ros1).unwrap();
        assert_eq!(d.root, "leg_tracker/Person");
        let pose = &d.types["geometry_msgs/Pose"];
        assert_eq!(
            pose.fields[0].ty,
            FieldType::Message("geometry_msgs/Point".into())
        );
        assert_eq!(d.types["geometry_msgs/Quaternion"].fields.len(), 4);
        assert_eq!(
            d.root_type().fields[1].ty,
            FieldType::Primitive(Primitive::UInt32)
        );
    }

    #[test]
    fn arrays_constants_and_bounds() {
        let text =
            "uint8 A=1\nstring S=a # b\nfloat32[] r\nint8[3] f\nstring<=5[<=2] s\nHeader h\n\
                    ===\nMSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";
        let d = Definitions::parse("x/Y", text, Dialect::Ros1).unwrap();
        let f = &d.root_type().fields;
        assert_eq!(f.len(), 4);
        assert_eq!(f[0].arity, Arity::Sequence);
        assert_eq!(f[1].arity, Arity::Fixed(3));
        assert_eq!(f[2].arity, Arity::Sequence);
        assert_eq!(f[3].ty, FieldType::Message("std_msgs/Header".into()));
    }

    #[test]
    fn refuses_undefined_recursive_and_malformed() {
        let e = Definitions::parse("a/B", "Missing m\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("does not define"), "{e}");
        let e = Definitions::parse("a/B", "B inner\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("contains itself"), "{e}");
        // A recursive type the root does not use (found by fuzzing: the decoder's size
        // table recursed on it without end).
        let text = "float32 x\n===\nMSG: std_msgs/Header\nHeader seq\n";
        let e = Definitions::parse("a/B", text, Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("contains itself"), "{e}");
        let e = Definitions::parse("a/B", "float64\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("type and a name"), "{e}");
        let e = Definitions::parse("a/B", "float64[x] v\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("not a number"), "{e}");
        let e = Definitions::parse("a/B", "float64 v\n===\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("MSG:"), "{e}");
        let e = Definitions::parse("a/B", "float64[99999999999] v\n", Dialect::Ros1).unwrap_err();
        assert!(e.problem.contains("fixed array"), "{e}");
    }

    #[test]
    fn ros2_names() {
        let text = "builtin_interfaces/Time stamp\n===\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
        let d = Definitions::parse("std_msgs/msg/Header", text, Dialect::Ros2).unwrap();
        assert_eq!(d.root, "std_msgs/Header");
        assert!(Definitions::parse("a/B", "time t\n", Dialect::Ros2).is_err());
    }
}
