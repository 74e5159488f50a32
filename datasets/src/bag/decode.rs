//! Decoding one serialised message into a [`Value`] tree, driven by its
//! [`Definitions`]: ROS 1 serialisation (little-endian, packed) and ROS 2 CDR (a
//! 4-byte encapsulation header, then values aligned to their size relative to the end
//! of that header, little- or big-endian).
//!
//! Every length read from the message is checked against the bytes really left before
//! anything is allocated for it: a sequence of `n` elements needs at least `n` times
//! the smallest size an element can have. A message that ends early, a string that is
//! not UTF-8 or a length beyond the bytes left is a [`DecodeError`] naming the field
//! path (`ranges[17]`, `header.frame_id`).

use super::msgdef::{Arity, Definitions, Dialect, FieldType, MessageType, Primitive};
use std::collections::BTreeMap;
use std::fmt;

/// A decoded value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `bool`.
    Bool(bool),
    /// A signed integer.
    Int(i64),
    /// An unsigned integer.
    UInt(u64),
    /// A floating-point number (`float32` values are widened, see [`widen_f32`]).
    Float(f64),
    /// A string.
    String(String),
    /// ROS 1 `time` or `duration`: seconds and nanoseconds.
    Time {
        /// Seconds.
        sec: i64,
        /// Nanoseconds.
        nanosec: i64,
    },
    /// An array of numbers (any numeric primitive), kept flat.
    Numbers(Vec<f64>),
    /// An array of other values.
    Array(Vec<Value>),
    /// A message: its fields in wire order.
    Message(Vec<(String, Value)>),
}

/// A message that cannot be decoded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DecodeError {
    /// Path of the field being read (`header.stamp`, `ranges[3]`).
    pub field: String,
    /// Byte offset in the message where it failed.
    pub offset: usize,
    /// What is wrong.
    pub problem: String,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "field `{}` at byte {}: {}",
            self.field, self.offset, self.problem
        )
    }
}

/// `float32` values are widened to `f64` through their shortest decimal representation
/// (`2.123f32` becomes `2.123`, not `2.1229999065…`): sensors write decimal values
/// (millimetres, degrees) into `float32`, and a text export of the same bag prints
/// them that way, so both give the same numbers.
pub fn widen_f32(x: f32) -> f64 {
    if !x.is_finite() {
        return f64::from(x);
    }
    let text = x.to_string();
    text.parse::<f64>().unwrap_or(f64::from(x))
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    /// Start of the aligned region (after the CDR encapsulation header).
    origin: usize,
    dialect: Dialect,
    big_endian: bool,
}

type Path = Vec<String>;

fn path_text(path: &Path) -> String {
    let mut s = String::new();
    for p in path {
        if p.starts_with('[') || s.is_empty() {
            s.push_str(p);
        } else {
            s.push('.');
            s.push_str(p);
        }
    }
    s
}

impl<'a> Reader<'a> {
    fn error(&self, path: &Path, problem: impl Into<String>) -> DecodeError {
        DecodeError {
            field: path_text(path),
            offset: self.pos,
            problem: problem.into(),
        }
    }

    fn left(&self) -> usize {
        self.data.len() - self.pos
    }

    fn align(&mut self, size: usize, path: &Path) -> Result<(), DecodeError> {
        if self.dialect == Dialect::Ros1 || size <= 1 {
            return Ok(());
        }
        let size = size.min(8);
        let rel = self.pos - self.origin;
        let pad = (size - rel % size) % size;
        if pad > self.left() {
            return Err(self.error(path, "message ends inside alignment padding"));
        }
        self.pos += pad;
        Ok(())
    }

    fn take(&mut self, n: usize, path: &Path) -> Result<&'a [u8], DecodeError> {
        if n > self.left() {
            return Err(self.error(
                path,
                format!("needs {n} bytes, {} left in the message", self.left()),
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn fixed<const N: usize>(&mut self, path: &Path) -> Result<[u8; N], DecodeError> {
        self.align(N, path)?;
        let s = self.take(N, path)?;
        let mut b = [0u8; N];
        b.copy_from_slice(s);
        if self.big_endian {
            b.reverse();
        }
        Ok(b)
    }

    fn u32(&mut self, path: &Path) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(self.fixed::<4>(path)?))
    }

    fn i32(&mut self, path: &Path) -> Result<i32, DecodeError> {
        Ok(i32::from_le_bytes(self.fixed::<4>(path)?))
    }

    fn length(&mut self, path: &Path, min_element: usize) -> Result<usize, DecodeError> {
        let n = self.u32(path)? as usize;
        let needed = n.saturating_mul(min_element.max(1));
        self.need(path, needed, |left| {
            format!("length {n} needs at least {needed} more bytes, {left} left in the message")
        })?;
        Ok(n)
    }

    /// Fails unless `needed` more bytes are left; `problem(left)` says what needs them.
    fn need(
        &self,
        path: &Path,
        needed: usize,
        problem: impl FnOnce(usize) -> String,
    ) -> Result<(), DecodeError> {
        if needed > self.left() {
            return Err(self.error(path, problem(self.left())));
        }
        Ok(())
    }

    fn string(&mut self, path: &Path) -> Result<String, DecodeError> {
        let n = self.length(path, 1)?;
        let bytes = self.take(n, path)?;
        let bytes = match self.dialect {
            // CDR strings count and carry their terminating NUL.
            Dialect::Ros2 => match bytes.split_last() {
                Some((0, rest)) => rest,
                Some(_) => return Err(self.error(path, "CDR string without its terminating NUL")),
                None => {
                    return Err(self.error(path, "CDR string of length 0 (needs at least its NUL)"))
                }
            },
            Dialect::Ros1 => bytes,
        };
        String::from_utf8(bytes.to_vec()).map_err(|_| self.error(path, "string is not UTF-8"))
    }

    fn number(&mut self, p: Primitive, path: &Path) -> Result<f64, DecodeError> {
        Ok(match self.primitive(p, path)? {
            Value::Bool(b) => f64::from(u8::from(b)),
            Value::Int(i) => i as f64,
            Value::UInt(u) => u as f64,
            Value::Float(x) => x,
            _ => return Err(self.error(path, "not a number")),
        })
    }

    fn primitive(&mut self, p: Primitive, path: &Path) -> Result<Value, DecodeError> {
        Ok(match p {
            Primitive::Bool => Value::Bool(self.fixed::<1>(path)?[0] != 0),
            Primitive::Int8 => Value::Int(i64::from(i8::from_le_bytes(self.fixed::<1>(path)?))),
            Primitive::UInt8 => Value::UInt(u64::from(self.fixed::<1>(path)?[0])),
            Primitive::Int16 => Value::Int(i64::from(i16::from_le_bytes(self.fixed::<2>(path)?))),
            Primitive::UInt16 => Value::UInt(u64::from(u16::from_le_bytes(self.fixed::<2>(path)?))),
            Primitive::Int32 => Value::Int(i64::from(i32::from_le_bytes(self.fixed::<4>(path)?))),
            Primitive::UInt32 => Value::UInt(u64::from(u32::from_le_bytes(self.fixed::<4>(path)?))),
            Primitive::Int64 => Value::Int(i64::from_le_bytes(self.fixed::<8>(path)?)),
            Primitive::UInt64 => Value::UInt(u64::from_le_bytes(self.fixed::<8>(path)?)),
            Primitive::Float32 => {
                Value::Float(widen_f32(f32::from_le_bytes(self.fixed::<4>(path)?)))
            }
            Primitive::Float64 => Value::Float(f64::from_le_bytes(self.fixed::<8>(path)?)),
            Primitive::String => Value::String(self.string(path)?),
            Primitive::WString => {
                return Err(self.error(path, "wstring fields are not supported"));
            }
            // Seconds, then nanoseconds (fields are read in the order written).
            Primitive::Time => Value::Time {
                sec: i64::from(self.u32(path)?),
                nanosec: i64::from(self.u32(path)?),
            },
            Primitive::Duration => Value::Time {
                sec: i64::from(self.i32(path)?),
                nanosec: i64::from(self.i32(path)?),
            },
        })
    }
}

fn is_numeric(p: Primitive) -> bool {
    !matches!(
        p,
        Primitive::String | Primitive::WString | Primitive::Time | Primitive::Duration
    )
}

/// Smallest number of bytes a value of each type takes on the wire (alignment
/// ignored), for checking lengths against the bytes left before allocating.
struct MinSizes(BTreeMap<String, usize>);

impl MinSizes {
    fn new(defs: &Definitions) -> Self {
        let mut sizes = BTreeMap::new();
        // Definitions are acyclic (checked when parsed), so a memoised walk ends.
        fn size_of(name: &str, defs: &Definitions, sizes: &mut BTreeMap<String, usize>) -> usize {
            if let Some(&s) = sizes.get(name) {
                return s;
            }
            let Some(t) = defs.types.get(name) else {
                return 0;
            };
            let mut total: usize = 0;
            for f in &t.fields {
                let element = match &f.ty {
                    FieldType::Primitive(p) => p.size(),
                    FieldType::Message(m) => size_of(m, defs, sizes),
                };
                let s = match f.arity {
                    Arity::Single => element,
                    Arity::Fixed(n) => element.saturating_mul(n),
                    Arity::Sequence => 4,
                };
                total = total.saturating_add(s);
            }
            sizes.insert(name.to_string(), total);
            total
        }
        for name in defs.types.keys() {
            size_of(name, defs, &mut sizes);
        }
        MinSizes(sizes)
    }
}

/// A decoder for the messages of one topic.
#[derive(Clone, Debug)]
pub struct Decoder {
    definitions: Definitions,
    min_sizes: BTreeMap<String, usize>,
}

impl Decoder {
    /// A decoder for messages of the root type of `definitions`.
    pub fn new(definitions: Definitions) -> Self {
        let min_sizes = MinSizes::new(&definitions).0;
        Self {
            definitions,
            min_sizes,
        }
    }

    /// The definitions this decoder reads.
    pub fn definitions(&self) -> &Definitions {
        &self.definitions
    }

    /// Decodes one message. ROS 2 messages start with the CDR encapsulation header
    /// (`00 01` little-endian or `00 00` big-endian, then two option bytes).
    ///
    /// # Errors
    /// A [`DecodeError`] naming the field where the message stops making sense; bytes
    /// left over after the last field are not an error (CDR pads messages).
    pub fn decode(&self, data: &[u8]) -> Result<Value, DecodeError> {
        let mut reader = Reader {
            data,
            pos: 0,
            origin: 0,
            dialect: self.definitions.dialect,
            big_endian: false,
        };
        if self.definitions.dialect == Dialect::Ros2 {
            let header = reader.take(4, &vec!["(CDR header)".into()])?;
            reader.big_endian = match (header[0], header[1]) {
                (0, 1) => false,
                (0, 0) => true,
                (a, b) => {
                    return Err(DecodeError {
                        field: "(CDR header)".into(),
                        offset: 0,
                        problem: format!(
                            "encapsulation {a:02x} {b:02x} is not plain CDR (00 00 or 00 01)"
                        ),
                    })
                }
            };
            reader.origin = 4;
        }
        let root = &self.definitions.types[&self.definitions.root];
        let mut walk = Walk {
            decoder: self,
            reader,
            path: Vec::new(),
        };
        walk.message(root)
    }

    fn min_size(&self, ty: &FieldType) -> usize {
        match ty {
            FieldType::Primitive(p) => p.size(),
            FieldType::Message(m) => self.min_sizes.get(m).copied().unwrap_or(0),
        }
    }
}

/// One message being decoded: the decoder, the reader over its bytes and the path of
/// the field being read (for errors).
struct Walk<'d, 'r> {
    decoder: &'d Decoder,
    reader: Reader<'r>,
    path: Path,
}

impl<'d> Walk<'d, '_> {
    fn message(&mut self, t: &'d MessageType) -> Result<Value, DecodeError> {
        let decoder = self.decoder;
        let mut fields = Vec::with_capacity(t.fields.len());
        for f in &t.fields {
            self.path.push(f.name.clone());
            let v = match f.arity {
                Arity::Single => self.element(&f.ty)?,
                Arity::Fixed(n) => {
                    let needed = n.saturating_mul(decoder.min_size(&f.ty));
                    self.reader.need(&self.path, needed, |left| {
                        format!("fixed array of {n} needs at least {needed} bytes, {left} left")
                    })?;
                    self.array(&f.ty, n)?
                }
                Arity::Sequence => {
                    let n = self.reader.length(&self.path, decoder.min_size(&f.ty))?;
                    self.array(&f.ty, n)?
                }
            };
            self.path.pop();
            fields.push((f.name.clone(), v));
        }
        Ok(Value::Message(fields))
    }

    fn element(&mut self, ty: &'d FieldType) -> Result<Value, DecodeError> {
        match ty {
            FieldType::Primitive(p) => self.reader.primitive(*p, &self.path),
            FieldType::Message(m) => {
                let decoder = self.decoder;
                let Some(t) = decoder.definitions.types.get(m) else {
                    return Err(self
                        .reader
                        .error(&self.path, format!("type {m} is not defined")));
                };
                self.message(t)
            }
        }
    }

    fn array(&mut self, ty: &'d FieldType, n: usize) -> Result<Value, DecodeError> {
        if let FieldType::Primitive(p) = ty {
            if is_numeric(*p) {
                let numbers = self.elements(n, |w| w.reader.number(*p, &w.path))?;
                return Ok(Value::Numbers(numbers));
            }
        }
        // Elements of size 0 (empty messages) take no bytes: bound their number by the
        // bytes left anyway, so a length from the file never sizes an allocation alone.
        if self.decoder.min_size(ty) == 0 {
            self.reader.need(&self.path, n, |left| {
                format!("{n} empty elements: more than the {left} bytes left")
            })?;
        }
        Ok(Value::Array(self.elements(n, |w| w.element(ty))?))
    }

    /// `n` elements, each read by `read` with its index `[k]` on the path.
    fn elements<T>(
        &mut self,
        n: usize,
        mut read: impl FnMut(&mut Self) -> Result<T, DecodeError>,
    ) -> Result<Vec<T>, DecodeError> {
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            self.path.push(format!("[{k}]"));
            out.push(read(self)?);
            self.path.pop();
        }
        Ok(out)
    }
}

impl Value {
    /// The field `name` of a message value.
    pub fn get(&self, name: &str) -> Option<&Value> {
        match self {
            Value::Message(fields) => fields.iter().find(|(n, _)| n == name).map(|(_, v)| v),
            _ => None,
        }
    }

    /// The value at a dotted path (`pose.pose.position.x`).
    pub fn at(&self, path: &str) -> Option<&Value> {
        path.split('.').try_fold(self, |v, name| v.get(name))
    }

    /// The value as a number (integers, floats and booleans).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Float(x) => Some(*x),
            Value::Int(i) => Some(*i as f64),
            Value::UInt(u) => Some(*u as f64),
            Value::Bool(b) => Some(f64::from(u8::from(*b))),
            _ => None,
        }
    }

    /// The value as an unsigned integer.
    pub fn as_u64(&self) -> Option<u64> {
        match self {
            Value::UInt(u) => Some(*u),
            Value::Int(i) => u64::try_from(*i).ok(),
            _ => None,
        }
    }

    /// The value as a string.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// A time stamp in seconds: ROS 1 `time` or a ROS 2 `builtin_interfaces/Time`
    /// message (`sec`, `nanosec`).
    pub fn as_seconds(&self) -> Option<f64> {
        match self {
            Value::Time { sec, nanosec } => Some(*sec as f64 + *nanosec as f64 * 1e-9),
            Value::Message(_) => {
                let sec = self.get("sec")?.as_f64()?;
                let nanosec = self.get("nanosec")?.as_f64()?;
                Some(sec + nanosec * 1e-9)
            }
            _ => None,
        }
    }

    /// The value as a flat array of numbers.
    pub fn as_numbers(&self) -> Option<&[f64]> {
        match self {
            Value::Numbers(v) => Some(v),
            Value::Array(v) if v.is_empty() => Some(&[]),
            _ => None,
        }
    }

    /// The value as an array of values.
    pub fn as_array(&self) -> Option<&[Value]> {
        match self {
            Value::Array(v) => Some(v),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ros1(text: &str) -> Decoder {
        Decoder::new(Definitions::parse("t/T", text, Dialect::Ros1).unwrap())
    }

    #[test]
    fn ros1_packed_values() {
        let d = ros1("uint32 a\nstring s\nfloat32[] r\ntime t\nint8[2] f\n");
        let mut bytes = Vec::new();
        bytes.extend(7u32.to_le_bytes());
        bytes.extend(2u32.to_le_bytes());
        bytes.extend(b"hi");
        bytes.extend(2u32.to_le_bytes());
        bytes.extend(2.123f32.to_le_bytes());
        bytes.extend(f32::INFINITY.to_le_bytes());
        bytes.extend(5u32.to_le_bytes());
        bytes.extend(6u32.to_le_bytes());
        bytes.extend([0xffu8, 1]);
        let v = d.decode(&bytes).unwrap();
        assert_eq!(v.get("a").unwrap().as_u64(), Some(7));
        assert_eq!(v.get("s").unwrap().as_str(), Some("hi"));
        let r = v.get("r").unwrap().as_numbers().unwrap();
        assert_eq!(r[0], 2.123);
        assert!(r[1].is_infinite());
        assert_eq!(v.get("t").unwrap().as_seconds(), Some(5.000000006));
        assert_eq!(v.get("f").unwrap().as_numbers().unwrap(), &[-1.0, 1.0]);
    }

    #[test]
    fn lengths_beyond_the_message_are_refused_before_allocating() {
        let d = ros1("float64[] r\n");
        let mut bytes = Vec::new();
        bytes.extend(u32::MAX.to_le_bytes());
        bytes.extend([0u8; 16]);
        let e = d.decode(&bytes).unwrap_err();
        assert_eq!(e.field, "r");
        assert!(e.problem.contains("length 4294967295"), "{e}");
        let d = ros1("string s\n");
        let e = d.decode(&[3, 0, 0, 0, b'a']).unwrap_err();
        assert!(e.problem.contains("left"), "{e}");
        let d = ros1("float64 x\n");
        assert!(d.decode(&[0; 7]).is_err());
    }

    #[test]
    fn cdr_alignment_and_endianness() {
        let text = "uint8 a\nfloat64 b\nstring s\nfloat32[] r\n";
        let d = Decoder::new(Definitions::parse("t/T", text, Dialect::Ros2).unwrap());
        // The same message little-endian (encapsulation 00 01) or big-endian (00 00).
        let message = |big_endian: bool| {
            // A number's little-endian bytes, in the message's byte order.
            let put = |m: &mut Vec<u8>, le: &[u8]| {
                if big_endian {
                    m.extend(le.iter().rev());
                } else {
                    m.extend(le);
                }
            };
            let mut m = vec![0u8, u8::from(!big_endian), 0, 0];
            m.push(9);
            m.extend([0u8; 7]);
            put(&mut m, &1.5f64.to_le_bytes());
            put(&mut m, &3u32.to_le_bytes());
            m.extend(b"ab\0");
            m.push(0); // pad to 4
            put(&mut m, &1u32.to_le_bytes());
            put(&mut m, &0.25f32.to_le_bytes());
            m
        };
        let v = d.decode(&message(false)).unwrap();
        assert_eq!(v.get("a").unwrap().as_u64(), Some(9));
        assert_eq!(v.get("b").unwrap().as_f64(), Some(1.5));
        assert_eq!(v.get("s").unwrap().as_str(), Some("ab"));
        assert_eq!(v.get("r").unwrap().as_numbers().unwrap(), &[0.25]);
        assert_eq!(d.decode(&message(true)).unwrap(), v);
        let e = d.decode(&[0, 7, 0, 0]).unwrap_err();
        assert!(e.problem.contains("encapsulation"), "{e}");
    }

    #[test]
    fn widening_keeps_decimal_values() {
        assert_eq!(widen_f32(2.123), 2.123);
        assert_eq!(widen_f32(0.1), 0.1);
        assert!(widen_f32(f32::NAN).is_nan());
    }
}
