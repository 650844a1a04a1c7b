//! The message types the CLI can decode and encode, found by the type hash an ADVERTISE
//! carries: the generated types of `r2p-msgs` (`firmware/msgs/*.msg`) and the primitive
//! topics the node runtime's `Wire` implements (`uint32`, `float32[4]`, `bool`, …).
//!
//! A generated type's layout is read from its canonical text (`R2pMessage::CANONICAL`,
//! `Name:type name;type[N] name;…`), the text its hash is taken over, so the CLI needs no
//! second copy of the schemas; every payload is also decoded by the generated Rust type itself
//! (`R2pMessage::decode`), which refuses what the type refuses (a `bool` other than 0 or 1).
//! Primitive hashes are the node runtime's own `Wire::TYPE_HASH` constants.

use std::fmt::{self, Write as _};

use r2p_msgs::R2pMessage;
use r2p_node::wire::fnv1a_extend;
use r2p_node::Wire;

/// A field's element type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prim {
    /// `bool`: one byte, 0 or 1.
    Bool,
    /// `uint8`.
    U8,
    /// `uint16`.
    U16,
    /// `uint32`.
    U32,
    /// `uint64`.
    U64,
    /// `int8`.
    I8,
    /// `int16`.
    I16,
    /// `int32`.
    I32,
    /// `int64`.
    I64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
}

impl Prim {
    /// Every element type.
    pub const ALL: [Prim; 11] = [
        Prim::Bool,
        Prim::U8,
        Prim::U16,
        Prim::U32,
        Prim::U64,
        Prim::I8,
        Prim::I16,
        Prim::I32,
        Prim::I64,
        Prim::F32,
        Prim::F64,
    ];

    /// The `.msg` name.
    pub fn name(self) -> &'static str {
        match self {
            Prim::Bool => "bool",
            Prim::U8 => "uint8",
            Prim::U16 => "uint16",
            Prim::U32 => "uint32",
            Prim::U64 => "uint64",
            Prim::I8 => "int8",
            Prim::I16 => "int16",
            Prim::I32 => "int32",
            Prim::I64 => "int64",
            Prim::F32 => "float32",
            Prim::F64 => "float64",
        }
    }

    /// The type named `name` in `.msg` files.
    pub fn from_name(name: &str) -> Option<Prim> {
        Prim::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Bytes on the bus.
    pub fn size(self) -> usize {
        match self {
            Prim::Bool | Prim::U8 | Prim::I8 => 1,
            Prim::U16 | Prim::I16 => 2,
            Prim::U32 | Prim::I32 | Prim::F32 => 4,
            Prim::U64 | Prim::I64 | Prim::F64 => 8,
        }
    }

    /// The node runtime's type hash of a topic of this type.
    pub fn wire_hash(self) -> u32 {
        match self {
            Prim::Bool => bool::TYPE_HASH,
            Prim::U8 => u8::TYPE_HASH,
            Prim::U16 => u16::TYPE_HASH,
            Prim::U32 => u32::TYPE_HASH,
            Prim::U64 => u64::TYPE_HASH,
            Prim::I8 => i8::TYPE_HASH,
            Prim::I16 => i16::TYPE_HASH,
            Prim::I32 => i32::TYPE_HASH,
            Prim::I64 => i64::TYPE_HASH,
            Prim::F32 => f32::TYPE_HASH,
            Prim::F64 => f64::TYPE_HASH,
        }
    }

    /// The node runtime's type hash of a topic of `[self; n]` (`Wire` for arrays).
    pub fn array_hash(self, n: usize) -> u32 {
        let h = fnv1a_extend(self.wire_hash(), b"[");
        fnv1a_extend(fnv1a_extend(h, &(n as u32).to_le_bytes()), b"]")
    }

    fn read(self, b: &[u8]) -> Scalar {
        let le8 = |b: &[u8]| {
            let mut w = [0u8; 8];
            w[..b.len()].copy_from_slice(b);
            u64::from_le_bytes(w)
        };
        let raw = le8(b);
        let signed = |bits: u32| ((raw << (64 - bits)) as i64) >> (64 - bits);
        match self {
            Prim::Bool => Scalar::Bool(raw != 0),
            Prim::U8 | Prim::U16 | Prim::U32 | Prim::U64 => Scalar::U(raw),
            Prim::I8 => Scalar::I(signed(8)),
            Prim::I16 => Scalar::I(signed(16)),
            Prim::I32 => Scalar::I(signed(32)),
            Prim::I64 => Scalar::I(signed(64)),
            Prim::F32 => Scalar::F32(f32::from_bits(raw as u32)),
            Prim::F64 => Scalar::F64(f64::from_bits(raw)),
        }
    }

    fn write(self, v: Scalar, out: &mut Vec<u8>) {
        let bytes = match v {
            Scalar::Bool(b) => u64::from(b),
            Scalar::U(x) => x,
            Scalar::I(x) => x as u64,
            Scalar::F32(x) => u64::from(x.to_bits()),
            Scalar::F64(x) => x.to_bits(),
        };
        out.extend_from_slice(&bytes.to_le_bytes()[..self.size()]);
    }

    /// Parses a command-line value of this type (decimal, `0x` hex for integers, `true`/`false`
    /// for bools, `nan`/`inf` for floats), checking the range.
    pub fn parse(self, text: &str) -> Result<Scalar, String> {
        let t = text.trim();
        let bad = |what: &str| format!("{text:?} is not {what}");
        let int = |t: &str| -> Option<i128> {
            let (neg, digits) = match t.strip_prefix('-') {
                Some(d) => (true, d),
                None => (false, t.strip_prefix('+').unwrap_or(t)),
            };
            let v = match digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
                Some(hex) => i128::from_str_radix(hex, 16).ok()?,
                None => digits.parse::<i128>().ok()?,
            };
            Some(if neg { -v } else { v })
        };
        let range = |lo: i128, hi: i128| -> Result<i128, String> {
            let v = int(t).ok_or_else(|| bad(&format!("an integer ({})", self.name())))?;
            if v < lo || v > hi {
                return Err(format!("{text} does not fit {} ({lo} to {hi})", self.name()));
            }
            Ok(v)
        };
        Ok(match self {
            Prim::Bool => match t {
                "true" | "1" => Scalar::Bool(true),
                "false" | "0" => Scalar::Bool(false),
                _ => return Err(bad("a bool (true, false, 1 or 0)")),
            },
            Prim::U8 => Scalar::U(range(0, u8::MAX.into())? as u64),
            Prim::U16 => Scalar::U(range(0, u16::MAX.into())? as u64),
            Prim::U32 => Scalar::U(range(0, u32::MAX.into())? as u64),
            Prim::U64 => Scalar::U(range(0, u64::MAX.into())? as u64),
            Prim::I8 => Scalar::I(range(i8::MIN.into(), i8::MAX.into())? as i64),
            Prim::I16 => Scalar::I(range(i16::MIN.into(), i16::MAX.into())? as i64),
            Prim::I32 => Scalar::I(range(i32::MIN.into(), i32::MAX.into())? as i64),
            Prim::I64 => Scalar::I(range(i64::MIN.into(), i64::MAX.into())? as i64),
            Prim::F32 | Prim::F64 => {
                let v: f64 = t.parse().map_err(|_| bad("a number"))?;
                if self == Prim::F64 {
                    Scalar::F64(v)
                } else if v.is_finite() && (v as f32).is_infinite() {
                    return Err(format!("{text} does not fit float32"));
                } else {
                    Scalar::F32(v as f32)
                }
            }
        })
    }
}

/// One element's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scalar {
    /// A bool.
    Bool(bool),
    /// Any unsigned integer.
    U(u64),
    /// Any signed integer.
    I(i64),
    /// A float32.
    F32(f32),
    /// A float64.
    F64(f64),
}

impl Scalar {
    /// As JSON: numbers, with the float's shortest decimal; NaN and infinities as the strings
    /// `"nan"`, `"inf"`, `"-inf"` (as `scripts/msggen decode` prints them).
    pub fn to_json(self) -> serde_json::Value {
        let float = |v: f64, text: String| {
            if v.is_nan() {
                serde_json::Value::from("nan")
            } else if v.is_infinite() {
                serde_json::Value::from(if v > 0.0 { "inf" } else { "-inf" })
            } else {
                // The shortest decimal of a float32, not of its float64 widening (0.1, not
                // 0.10000000149011612).
                serde_json::Value::from(text.parse::<f64>().unwrap_or(v))
            }
        };
        match self {
            Scalar::Bool(b) => b.into(),
            Scalar::U(x) => x.into(),
            Scalar::I(x) => x.into(),
            Scalar::F32(x) => float(f64::from(x), x.to_string()),
            Scalar::F64(x) => float(x, x.to_string()),
        }
    }
}

/// As Rust's `Debug` prints it (what the generated types' `Debug` shows).
impl fmt::Display for Scalar {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Scalar::Bool(b) => write!(f, "{b}"),
            Scalar::U(x) => write!(f, "{x}"),
            Scalar::I(x) => write!(f, "{x}"),
            Scalar::F32(x) => write!(f, "{x:?}"),
            Scalar::F64(x) => write!(f, "{x:?}"),
        }
    }
}

/// A field of a message type: `prim name` or `prim[len] name`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// Its element type.
    pub prim: Prim,
    /// Its array length, if it is an array.
    pub len: Option<usize>,
}

impl Field {
    fn size(&self) -> usize {
        self.prim.size() * self.len.unwrap_or(1)
    }

    fn type_name(&self) -> String {
        match self.len {
            Some(n) => format!("{}[{n}]", self.prim.name()),
            None => self.prim.name().to_string(),
        }
    }
}

/// A field's (or a whole primitive message's) value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A single element.
    One(Scalar),
    /// An array.
    Many(Vec<Scalar>),
}

impl Value {
    /// As JSON.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Value::One(s) => s.to_json(),
            Value::Many(v) => v.iter().map(|s| s.to_json()).collect(),
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::One(s) => write!(f, "{s}"),
            Value::Many(v) => {
                f.write_char('[')?;
                for (i, s) in v.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{s}")?;
                }
                f.write_char(']')
            }
        }
    }
}

/// How a message is laid out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Shape {
    /// The empty message (`()`): no bytes.
    Empty,
    /// One primitive (`uint32`), or an array of them (`uint32[4]`).
    Plain(Field),
    /// A generated type's fields, in order.
    Struct(Vec<Field>),
}

/// A decoded message.
#[derive(Clone, Debug, PartialEq)]
pub enum Decoded {
    /// The empty message.
    Empty,
    /// A primitive topic's value.
    Plain(Value),
    /// A generated type's fields, in order.
    Struct(Vec<(String, Value)>),
}

impl Decoded {
    /// As JSON: the value, or an object of the fields.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Decoded::Empty => serde_json::Value::Null,
            Decoded::Plain(v) => v.to_json(),
            Decoded::Struct(fields) => {
                fields.iter().map(|(n, v)| (n.clone(), v.to_json())).collect()
            }
        }
    }
}

/// `field=value …`, a bare value or `(empty)`.
impl fmt::Display for Decoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decoded::Empty => f.write_str("(empty)"),
            Decoded::Plain(v) => write!(f, "{v}"),
            Decoded::Struct(fields) => {
                for (i, (n, v)) in fields.iter().enumerate() {
                    if i > 0 {
                        f.write_char(' ')?;
                    }
                    write!(f, "{n}={v}")?;
                }
                Ok(())
            }
        }
    }
}

/// The generated type's own decoder, giving its `Debug` text or its error.
type Check = fn(&[u8]) -> Result<String, String>;

/// A message type the CLI knows.
#[derive(Clone, Debug)]
pub struct MsgType {
    /// Its name: a generated type's (`Obstacle`) or a primitive's (`uint32`, `float32[4]`).
    pub name: String,
    /// The type hash ADVERTISE and SUBSCRIBE_REQUEST carry.
    pub hash: u32,
    /// Bytes on the bus.
    pub size: usize,
    /// Its layout.
    pub shape: Shape,
    check: Option<Check>,
}

struct Generated {
    canonical: &'static str,
    hash: u32,
    size: usize,
    check: Check,
}

macro_rules! generated {
    ($($t:ident),* $(,)?) => {
        &[$(Generated {
            canonical: <r2p_msgs::$t as R2pMessage>::CANONICAL,
            hash: <r2p_msgs::$t as R2pMessage>::TYPE_HASH,
            size: <r2p_msgs::$t as R2pMessage>::SIZE,
            check: |b| {
                <r2p_msgs::$t as R2pMessage>::decode(b)
                    .map(|v| format!("{v:?}"))
                    .map_err(|e| format!("{e:?}"))
            },
        }),*]
    };
}

/// Every generated type (a test checks this against `r2p_msgs::ALL`).
const GENERATED: &[Generated] = generated!(
    Barometer,
    Battery,
    BusPower,
    FaultClear,
    GatewayStatus,
    GnssFix,
    Imu,
    MagneticField,
    MotorFault,
    Obstacle,
    Odometry,
    Proximity,
    PsuEvent,
    PsuState,
    Twist2D,
    WheelSetpoint,
    WheelState
);

/// Largest message (one RTCAN message).
pub const MAX_SIZE: usize = r2p_msgs::MAX_SIZE;

/// Parses `prim` or `prim[N]`.
fn parse_field_type(t: &str) -> Option<(Prim, Option<usize>)> {
    match t.split_once('[') {
        None => Some((Prim::from_name(t)?, None)),
        Some((p, rest)) => {
            let n: usize = rest.strip_suffix(']')?.parse().ok()?;
            (n >= 1).then_some((Prim::from_name(p)?, Some(n)))
        }
    }
}

/// Reads a canonical text `Name:type name;type[N] name;…` into a name and fields.
fn parse_canonical(text: &str) -> Option<(String, Vec<Field>)> {
    let (name, body) = text.split_once(':')?;
    let fields = body
        .split(';')
        .map(|f| {
            let (t, n) = f.split_once(' ')?;
            let (prim, len) = parse_field_type(t)?;
            Some(Field { name: n.to_string(), prim, len })
        })
        .collect::<Option<Vec<_>>>()?;
    Some((name.to_string(), fields))
}

impl MsgType {
    fn generated(g: &Generated) -> MsgType {
        let (name, fields) = parse_canonical(g.canonical).expect("generated canonical text");
        MsgType {
            name,
            hash: g.hash,
            size: g.size,
            shape: Shape::Struct(fields),
            check: Some(g.check),
        }
    }

    fn plain(prim: Prim, len: Option<usize>) -> MsgType {
        let field = Field { name: String::new(), prim, len };
        let hash = len.map_or(prim.wire_hash(), |n| prim.array_hash(n));
        MsgType {
            name: field.type_name(),
            hash,
            size: field.size(),
            shape: Shape::Plain(field),
            check: None,
        }
    }

    fn empty() -> MsgType {
        MsgType {
            name: "empty".into(),
            hash: <() as Wire>::TYPE_HASH,
            size: 0,
            shape: Shape::Empty,
            check: None,
        }
    }

    /// The type a topic advertised with `hash` and `size` has, if the CLI knows it.
    pub fn by_hash(hash: u32, size: usize) -> Option<MsgType> {
        if let Some(g) = GENERATED.iter().find(|g| g.hash == hash && g.size == size) {
            return Some(MsgType::generated(g));
        }
        if size == 0 {
            return (hash == <() as Wire>::TYPE_HASH).then(MsgType::empty);
        }
        Prim::ALL.into_iter().find_map(|p| {
            if !size.is_multiple_of(p.size()) {
                return None;
            }
            let n = size / p.size();
            if n == 1 && p.wire_hash() == hash {
                Some(MsgType::plain(p, None))
            } else {
                (p.array_hash(n) == hash).then(|| MsgType::plain(p, Some(n)))
            }
        })
    }

    /// The type called `name`: a generated type (`Obstacle`), a primitive (`uint32`), an array
    /// of one (`float32[4]`) or `empty`.
    pub fn by_name(name: &str) -> Result<MsgType, String> {
        if name == "empty" {
            return Ok(MsgType::empty());
        }
        if let Some(g) = GENERATED.iter().find(|g| g.canonical.split(':').next() == Some(name)) {
            return Ok(MsgType::generated(g));
        }
        match parse_field_type(name) {
            Some((p, len)) if p.size() * len.unwrap_or(1) <= MAX_SIZE => Ok(MsgType::plain(p, len)),
            _ => Err(format!("unknown type {name:?}: known types are {}", known_types())),
        }
    }

    /// A JSON Schema (draft 2020-12) of [`Self::record_json`]'s objects, for recordings
    /// (`crate::mcap_log`): a generated type's fields, or `data` for a primitive topic. Floats
    /// may be the strings "nan", "inf", "-inf" ([`Scalar::to_json`]).
    pub fn json_schema(&self) -> serde_json::Value {
        use serde_json::json;
        let field = |f: &Field| {
            let one = match f.prim {
                Prim::Bool => json!({"type": "boolean"}),
                Prim::F32 | Prim::F64 => json!({"type": ["number", "string"]}),
                _ => json!({"type": "integer"}),
            };
            match f.len {
                None => one,
                Some(n) => json!({"type": "array", "items": one, "minItems": n, "maxItems": n}),
            }
        };
        let (properties, required): (serde_json::Map<String, serde_json::Value>, Vec<String>) =
            match &self.shape {
                Shape::Empty => (serde_json::Map::new(), vec![]),
                Shape::Plain(f) => (
                    [("data".to_string(), field(f))].into_iter().collect(),
                    vec!["data".to_string()],
                ),
                Shape::Struct(fields) => (
                    fields.iter().map(|f| (f.name.clone(), field(f))).collect(),
                    fields.iter().map(|f| f.name.clone()).collect(),
                ),
            };
        json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": self.name,
            "type": "object",
            "properties": properties,
            "required": required,
            "additionalProperties": false,
        })
    }

    /// `decoded` as a JSON object (what recordings hold: readers such as Foxglove want one):
    /// a generated type's fields, `{"data": value}` for a primitive topic, `{}` when empty.
    pub fn record_json(&self, decoded: &Decoded) -> serde_json::Value {
        match decoded {
            Decoded::Empty => serde_json::json!({}),
            Decoded::Plain(v) => serde_json::json!({ "data": v.to_json() }),
            Decoded::Struct(_) => decoded.to_json(),
        }
    }

    /// Decodes a payload of this type; errors say what is wrong with the bytes.
    pub fn decode(&self, bytes: &[u8]) -> Result<Decoded, String> {
        if bytes.len() != self.size {
            return Err(format!("{} bytes, {} has {}", bytes.len(), self.name, self.size));
        }
        if let Some(check) = self.check {
            check(bytes).map_err(|e| format!("not a valid {}: {e}", self.name))?;
        }
        let mut at = 0;
        let mut read = |f: &Field| {
            let one = |at: &mut usize| {
                let s = f.prim.read(&bytes[*at..*at + f.prim.size()]);
                *at += f.prim.size();
                s
            };
            match f.len {
                None => Ok(Value::One(one(&mut at))),
                Some(n) => Ok(Value::Many((0..n).map(|_| one(&mut at)).collect())),
            }
        };
        match &self.shape {
            Shape::Empty => Ok(Decoded::Empty),
            Shape::Plain(f) => {
                if f.prim == Prim::Bool && bytes.iter().any(|&b| b > 1) {
                    return Err(format!(
                        "not a valid {}: a bool byte is neither 0 nor 1",
                        self.name
                    ));
                }
                read(f).map(Decoded::Plain)
            }
            Shape::Struct(fields) => fields
                .iter()
                .map(|f| read(f).map(|v| (f.name.clone(), v)))
                .collect::<Result<_, String>>()
                .map(Decoded::Struct),
        }
    }

    /// The fields, for messages (`name type` pairs, for error messages and `--help`).
    pub fn describe_fields(&self) -> String {
        match &self.shape {
            Shape::Empty => "no fields".into(),
            Shape::Plain(f) => format!("one value of type {}", f.type_name()),
            Shape::Struct(fields) => fields
                .iter()
                .map(|f| format!("{}={}", f.name, f.type_name()))
                .collect::<Vec<_>>()
                .join(" "),
        }
    }

    /// Encodes a message from command-line words: `field=value …` for a generated type (arrays
    /// as `v1,v2,…`; fields not given are 0 or false), one value for a primitive (an array as
    /// `v1,v2,…` or as separate words), nothing for `empty`.
    pub fn encode_args(&self, args: &[String]) -> Result<Vec<u8>, String> {
        let mut out = Vec::with_capacity(self.size);
        match &self.shape {
            Shape::Empty => {
                if let Some(a) = args.first() {
                    return Err(format!("{} carries no data, but {a:?} was given", self.name));
                }
            }
            Shape::Plain(f) => {
                if let Some(a) = args.iter().find(|a| a.contains('=')) {
                    return Err(format!(
                        "{a:?}: type {} has no named fields: give {}",
                        self.name,
                        self.describe_fields()
                    ));
                }
                let words: Vec<&str> = args.iter().flat_map(|a| a.split(',')).collect();
                if words.is_empty() {
                    return Err(format!("no value given: give {}", self.describe_fields()));
                }
                encode_field(f, &words, &mut out)?;
            }
            Shape::Struct(fields) => {
                let mut given: Vec<Option<Vec<&str>>> = vec![None; fields.len()];
                for a in args {
                    let (name, value) = a.split_once('=').ok_or_else(|| {
                        format!(
                            "{a:?} is not field=value ({} fields: {})",
                            self.name,
                            self.describe_fields()
                        )
                    })?;
                    let i = fields.iter().position(|f| f.name == name).ok_or_else(|| {
                        format!(
                            "{} has no field {name:?}; its fields: {}",
                            self.name,
                            self.describe_fields()
                        )
                    })?;
                    if given[i].is_some() {
                        return Err(format!("field {name} given twice"));
                    }
                    given[i] = Some(value.split(',').collect());
                }
                for (f, g) in fields.iter().zip(given) {
                    let zero = vec!["0"; f.len.unwrap_or(1)];
                    encode_field(f, g.as_deref().unwrap_or(&zero), &mut out)
                        .map_err(|e| format!("field {}: {e}", f.name))?;
                }
            }
        }
        debug_assert_eq!(out.len(), self.size);
        if let Some(check) = self.check {
            check(&out).map_err(|e| format!("the generated type refuses these values: {e}"))?;
        }
        Ok(out)
    }
}

fn encode_field(f: &Field, words: &[&str], out: &mut Vec<u8>) -> Result<(), String> {
    let n = f.len.unwrap_or(1);
    if words.len() != n {
        return Err(format!("{} needs {n} value(s), got {}", f.type_name(), words.len()));
    }
    for w in words {
        f.prim.write(f.prim.parse(w)?, out);
    }
    Ok(())
}

/// The names of the known types, for error messages.
pub fn known_types() -> String {
    let mut names: Vec<String> =
        GENERATED.iter().map(|g| g.canonical.split(':').next().unwrap_or("").to_string()).collect();
    names.push("a primitive (bool, uint8…uint64, int8…int64, float32, float64) or an array of one (float32[4])".into());
    names.push("empty".into());
    names.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic byte pattern (xorshift), with bools kept valid where `valid_bools`.
    fn bytes(n: usize, seed: u64) -> Vec<u8> {
        let mut s = seed | 1;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s as u8
            })
            .collect()
    }

    /// The schema-driven decoding printed like the generated type's `Debug`.
    fn as_debug(t: &MsgType, d: &Decoded) -> String {
        let Decoded::Struct(fields) = d else { panic!("a struct") };
        let body: Vec<String> = fields.iter().map(|(n, v)| format!("{n}: {v}")).collect();
        format!("{} {{ {} }}", t.name, body.join(", "))
    }

    #[test]
    fn every_generated_type_is_registered() {
        let names: Vec<&str> =
            GENERATED.iter().map(|g| g.canonical.split(':').next().unwrap()).collect();
        let all: Vec<&str> = r2p_msgs::ALL.iter().map(|(n, _, _)| *n).collect();
        assert_eq!(names, all, "add new r2p-msgs types to GENERATED in types.rs");
        for (name, hash, size) in r2p_msgs::ALL {
            let t = MsgType::by_hash(*hash, *size).unwrap();
            assert_eq!((t.name.as_str(), t.size), (*name, *size));
            assert_eq!(MsgType::by_name(name).unwrap().hash, *hash);
        }
    }

    #[test]
    fn the_schema_decoder_agrees_with_the_generated_types() {
        for g in GENERATED {
            let t = MsgType::generated(g);
            for seed in 1..200 {
                let mut b = bytes(t.size, seed);
                // Keep bool fields valid so that both decoders accept the bytes.
                let Shape::Struct(fields) = &t.shape else { panic!() };
                let mut at = 0;
                for f in fields {
                    for _ in 0..f.len.unwrap_or(1) {
                        if f.prim == Prim::Bool {
                            b[at] &= 1;
                        }
                        at += f.prim.size();
                    }
                }
                let d = t.decode(&b).unwrap();
                assert_eq!(as_debug(&t, &d), (g.check)(&b).unwrap(), "{}", t.name);
                // Encoding the decoded values gives the same bytes back (NaN payloads aside).
                let args: Vec<String> = match &d {
                    Decoded::Struct(f) => f
                        .iter()
                        .map(|(n, v)| match v {
                            Value::One(s) => format!("{n}={}", arg(*s)),
                            Value::Many(v) => format!(
                                "{n}={}",
                                v.iter().map(|s| arg(*s)).collect::<Vec<_>>().join(",")
                            ),
                        })
                        .collect(),
                    _ => unreachable!(),
                };
                if !args.iter().any(|a| a.contains("NaN")) {
                    assert_eq!(t.encode_args(&args).unwrap(), b, "{}", t.name);
                }
            }
        }
    }

    fn arg(s: Scalar) -> String {
        match s {
            Scalar::F32(x) if x.is_infinite() => if x > 0.0 { "inf" } else { "-inf" }.into(),
            Scalar::F64(x) if x.is_infinite() => if x > 0.0 { "inf" } else { "-inf" }.into(),
            s => s.to_string(),
        }
    }

    #[test]
    fn primitive_topics_have_the_node_runtimes_hashes() {
        assert_eq!(MsgType::by_name("uint32").unwrap().hash, u32::TYPE_HASH);
        assert_eq!(MsgType::by_name("uint32[4]").unwrap().hash, <[u32; 4]>::TYPE_HASH);
        assert_eq!(MsgType::by_name("float32[3]").unwrap().hash, <[f32; 3]>::TYPE_HASH);
        assert_eq!(MsgType::by_name("bool[2]").unwrap().hash, <[bool; 2]>::TYPE_HASH);
        assert_eq!(MsgType::by_name("empty").unwrap().hash, <()>::TYPE_HASH);
        let scan = MsgType::by_hash(<[u32; 4]>::TYPE_HASH, 16).unwrap();
        assert_eq!(scan.name, "uint32[4]");
        let d = scan.decode(&[1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]).unwrap();
        assert_eq!(d.to_string(), "[1, 2, 3, 4294967295]");
        assert_eq!(d.to_json().to_string(), "[1,2,3,4294967295]");
        let i16t = MsgType::by_hash(i16::TYPE_HASH, 2).unwrap();
        assert_eq!(i16t.decode(&[0xFE, 0xFF]).unwrap().to_string(), "-2");
        assert!(MsgType::by_hash(u32::TYPE_HASH, 8).is_none(), "size must match");
        assert!(MsgType::by_hash(0x1234_5678, 4).is_none());
    }

    #[test]
    fn values_print_and_serialise_like_msggen() {
        let t = MsgType::by_name("Obstacle").unwrap();
        let d = t.decode(&[3, 0, 0, 0, 0x3F]).unwrap();
        assert_eq!(d.to_string(), "channel=3 distance=0.5");
        assert_eq!(d.to_json().to_string(), r#"{"channel":3,"distance":0.5}"#);
        let f = MsgType::by_name("float32").unwrap();
        let tenth = f.encode_args(&["0.1".into()]).unwrap();
        assert_eq!(f.decode(&tenth).unwrap().to_json().to_string(), "0.1");
        let nan = f.decode(&f32::NAN.to_le_bytes()).unwrap();
        assert_eq!((nan.to_string(), nan.to_json().to_string()), ("NaN".into(), r#""nan""#.into()));
    }

    #[test]
    fn malformed_fields_are_refused_with_the_reason() {
        let t = MsgType::by_name("WheelSetpoint").unwrap();
        assert_eq!(
            t.encode_args(&["mode=1".into(), "value=2.5".into()]).unwrap(),
            [1, 0, 0, 0x20, 0x40]
        );
        assert_eq!(
            t.encode_args(&["value=1".into()]).unwrap(),
            [0, 0, 0, 0x80, 0x3F],
            "mode defaults to 0"
        );
        let err = |t: &MsgType, a: &[&str]| {
            t.encode_args(&a.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap_err()
        };
        assert!(err(&t, &["speed=1"])
            .contains("no field \"speed\"; its fields: mode=uint8 value=float32"));
        assert!(err(&t, &["mode=256"]).contains("field mode: 256 does not fit uint8 (0 to 255)"));
        assert!(err(&t, &["mode=-1"]).contains("does not fit uint8"));
        assert!(err(&t, &["mode=x"]).contains("\"x\" is not an integer"));
        assert!(err(&t, &["mode=1", "mode=2"]).contains("given twice"));
        assert!(err(&t, &["1"]).contains("is not field=value"));
        assert!(err(&t, &["value=1e39"]).contains("does not fit float32"));
        let p = MsgType::by_name("Proximity").unwrap();
        assert!(err(&p, &["distance=1,2"]).contains("float32[4] needs 4 value(s), got 2"));
        let scan = MsgType::by_name("uint32[4]").unwrap();
        assert_eq!(scan.encode_args(&["1,2,3,4".into()]).unwrap().len(), 16);
        assert_eq!(
            scan.encode_args(&["1".into(), "2".into(), "3".into(), "4".into()]).unwrap(),
            scan.encode_args(&["1,2,3,4".into()]).unwrap()
        );
        assert!(err(&scan, &["a=1"]).contains("has no named fields"));
        assert!(err(&scan, &[]).contains("no value given"));
        assert!(err(&MsgType::by_name("empty").unwrap(), &["1"]).contains("carries no data"));
        let b = MsgType::by_name("bool").unwrap();
        assert!(err(&b, &["yes"]).contains("not a bool"));
        assert!(b.decode(&[2]).unwrap_err().contains("neither 0 nor 1"));
        let state = MsgType::by_name("WheelState").unwrap();
        assert!(state.decode(&[0; 12]).unwrap_err().contains("12 bytes, WheelState has 13"));
        assert!(MsgType::by_name("Nope")
            .unwrap_err()
            .contains("known types are Barometer, Battery"));
        assert!(MsgType::by_name("uint32[0]").is_err() && MsgType::by_name("uint32[257]").is_err());
    }
}
