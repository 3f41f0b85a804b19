//! FMI 3.0 variable types and typed value buffers, with their text form in CSV files and start
//! attributes.
//!
//! Text form (as FMPy's `read_csv`/`write_csv` and the Reference-FMUs' `*_out.csv` write it):
//! numbers in Rust's shortest round-trip form, Booleans `true`/`false` (also `1`/`0` when read),
//! Binary as hexadecimal digits, an array as its elements in row-major order separated by
//! spaces.

use crate::csv::format_number;

/// The type element of an FMI 3.0 variable (FMI 3.0.2 section 2.4.7: `<Float64>`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[allow(missing_docs)]
pub enum Type3 {
    Float32,
    Float64,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Boolean,
    String,
    Binary,
    Enumeration,
    Clock,
}

impl Type3 {
    /// Every type, in the standard's order.
    pub const ALL: [Type3; 15] = [
        Type3::Float32,
        Type3::Float64,
        Type3::Int8,
        Type3::UInt8,
        Type3::Int16,
        Type3::UInt16,
        Type3::Int32,
        Type3::UInt32,
        Type3::Int64,
        Type3::UInt64,
        Type3::Boolean,
        Type3::String,
        Type3::Binary,
        Type3::Enumeration,
        Type3::Clock,
    ];

    /// The element name in `<ModelVariables>` (`Float64`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Type3::Float32 => "Float32",
            Type3::Float64 => "Float64",
            Type3::Int8 => "Int8",
            Type3::UInt8 => "UInt8",
            Type3::Int16 => "Int16",
            Type3::UInt16 => "UInt16",
            Type3::Int32 => "Int32",
            Type3::UInt32 => "UInt32",
            Type3::Int64 => "Int64",
            Type3::UInt64 => "UInt64",
            Type3::Boolean => "Boolean",
            Type3::String => "String",
            Type3::Binary => "Binary",
            Type3::Enumeration => "Enumeration",
            Type3::Clock => "Clock",
        }
    }

    /// Parses a variable element name.
    pub fn parse(s: &str) -> Option<Type3> {
        Type3::ALL.into_iter().find(|t| t.as_str() == s)
    }

    /// Parses a type definition element name (`Float64Type`, ...).
    pub fn parse_definition(s: &str) -> Option<Type3> {
        Type3::parse(s.strip_suffix("Type")?)
    }

    /// Float32 or Float64.
    pub fn is_float(self) -> bool {
        matches!(self, Type3::Float32 | Type3::Float64)
    }

    /// A type whose values are exact numbers (the integers and Enumeration).
    pub fn is_integer(self) -> bool {
        matches!(
            self,
            Type3::Int8
                | Type3::UInt8
                | Type3::Int16
                | Type3::UInt16
                | Type3::Int32
                | Type3::UInt32
                | Type3::Int64
                | Type3::UInt64
                | Type3::Enumeration
        )
    }

    /// Inclusive range of an integer type (Enumeration: Int64, as fmi3GetInt64 reads it).
    fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Type3::Int8 => (i8::MIN.into(), i8::MAX.into()),
            Type3::UInt8 => (0, u8::MAX.into()),
            Type3::Int16 => (i16::MIN.into(), i16::MAX.into()),
            Type3::UInt16 => (0, u16::MAX.into()),
            Type3::Int32 => (i32::MIN.into(), i32::MAX.into()),
            Type3::UInt32 => (0, u32::MAX.into()),
            Type3::Int64 | Type3::Enumeration => (i64::MIN.into(), i64::MAX.into()),
            Type3::UInt64 => (0, u64::MAX.into()),
            _ => return None,
        })
    }
}

impl std::fmt::Display for Type3 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Values of one type, as the typed fmi3Get/fmi3Set functions exchange them.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[allow(missing_docs)]
pub enum Values {
    Float32(Vec<f32>),
    Float64(Vec<f64>),
    Int8(Vec<i8>),
    UInt8(Vec<u8>),
    Int16(Vec<i16>),
    UInt16(Vec<u16>),
    Int32(Vec<i32>),
    UInt32(Vec<u32>),
    /// Int64 and Enumeration.
    Int64(Vec<i64>),
    UInt64(Vec<u64>),
    /// Boolean and Clock.
    Boolean(Vec<bool>),
    String(Vec<String>),
    Binary(Vec<Vec<u8>>),
}

/// Applies `$body` to the vector inside any [`Values`].
macro_rules! each {
    ($v:expr, $x:ident => $body:expr) => {
        each!(@ $v, $x => $body; Float32 Float64 Int8 UInt8 Int16 UInt16 Int32 UInt32 Int64
            UInt64 Boolean String Binary)
    };
    (@ $v:expr, $x:ident => $body:expr; $($variant:ident)*) => {
        match $v {
            $(Values::$variant($x) => $body,)*
        }
    };
}

/// An element of a [`Values`] buffer: its number (Booleans 0/1; None for String and Binary)
/// and its text (see the module documentation).
trait Element {
    fn number(&self) -> Option<f64>;
    fn text(&self) -> String;
}

/// [`Element`] for types whose `f64::from` is exact and whose text is their `Display`.
macro_rules! exact_element {
    ($($t:ty),*) => {$(
        impl Element for $t {
            fn number(&self) -> Option<f64> {
                Some(f64::from(*self))
            }
            fn text(&self) -> String {
                self.to_string()
            }
        }
    )*};
}
exact_element!(i8, u8, i16, u16, i32, u32);

impl Element for f32 {
    fn number(&self) -> Option<f64> {
        Some(f64::from(*self))
    }
    fn text(&self) -> String {
        format_f32(*self)
    }
}

impl Element for f64 {
    fn number(&self) -> Option<f64> {
        Some(*self)
    }
    fn text(&self) -> String {
        format_number(*self)
    }
}

/// 64-bit integers: the nearest f64 (exact up to 2^53).
macro_rules! wide_element {
    ($($t:ty),*) => {$(
        impl Element for $t {
            fn number(&self) -> Option<f64> {
                Some(*self as f64)
            }
            fn text(&self) -> String {
                self.to_string()
            }
        }
    )*};
}
wide_element!(i64, u64);

impl Element for bool {
    fn number(&self) -> Option<f64> {
        Some(f64::from(u8::from(*self)))
    }
    fn text(&self) -> String {
        self.to_string()
    }
}

impl Element for String {
    fn number(&self) -> Option<f64> {
        None
    }
    fn text(&self) -> String {
        self.clone()
    }
}

impl Element for Vec<u8> {
    fn number(&self) -> Option<f64> {
        None
    }
    fn text(&self) -> String {
        hex(self)
    }
}

impl Values {
    /// `n` zero values (false, empty strings) of the buffer type of `ty`.
    pub fn zeros(ty: Type3, n: usize) -> Values {
        match ty {
            Type3::Float32 => Values::Float32(vec![0.0; n]),
            Type3::Float64 => Values::Float64(vec![0.0; n]),
            Type3::Int8 => Values::Int8(vec![0; n]),
            Type3::UInt8 => Values::UInt8(vec![0; n]),
            Type3::Int16 => Values::Int16(vec![0; n]),
            Type3::UInt16 => Values::UInt16(vec![0; n]),
            Type3::Int32 => Values::Int32(vec![0; n]),
            Type3::UInt32 => Values::UInt32(vec![0; n]),
            Type3::Int64 | Type3::Enumeration => Values::Int64(vec![0; n]),
            Type3::UInt64 => Values::UInt64(vec![0; n]),
            Type3::Boolean | Type3::Clock => Values::Boolean(vec![false; n]),
            Type3::String => Values::String(vec![String::new(); n]),
            Type3::Binary => Values::Binary(vec![Vec::new(); n]),
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        each!(self, x => x.len())
    }

    /// True when there is no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` as a number (Booleans 0/1); None for String and Binary or out of range.
    pub fn number(&self, i: usize) -> Option<f64> {
        each!(self, x => x.get(i)?.number())
    }

    /// Text of value `i` (see the module documentation); empty when out of range.
    pub fn text(&self, i: usize) -> String {
        each!(self, x => x.get(i).map(Element::text).unwrap_or_default())
    }

    /// Values `range` joined by spaces (an array's cell).
    pub fn joined(&self, range: std::ops::Range<usize>) -> String {
        range.map(|i| self.text(i)).collect::<Vec<_>>().join(" ")
    }

    /// Appends the values of `other` (same variant; otherwise nothing happens).
    pub fn extend_from(&mut self, other: &Values) {
        macro_rules! ext {
            ($($v:ident),*) => {
                match (self, other) {
                    $((Values::$v(a), Values::$v(b)) => a.extend_from_slice(b),)*
                    _ => {}
                }
            };
        }
        ext!(
            Float32, Float64, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Boolean,
            String, Binary
        );
    }

    /// Parses whitespace-separated tokens (a numeric or Boolean start attribute, an array cell)
    /// as values of `ty`. String and Binary take one token: the whole text.
    pub fn parse(ty: Type3, text: &str) -> Result<Values, ValueError> {
        let tokens: Vec<&str> = text.split_whitespace().collect();
        match ty {
            Type3::String => return Ok(Values::String(vec![text.to_string()])),
            Type3::Binary => return Ok(Values::Binary(vec![unhex(text.trim())?])),
            _ => {}
        }
        let mut out = Values::zeros(ty, 0);
        for tok in tokens {
            let one = parse_token(ty, tok)?;
            out.extend_from(&one);
        }
        Ok(out)
    }
}

/// A value that does not parse as its type, in the words of the message it gives.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ValueError {
    /// A token that is not of the expected kind (`expected`: "an integer", "a number", ...).
    #[error("'{}' is not {expected}", crate::error::shown(.token, 40))]
    NotA {
        /// The token as written.
        token: String,
        /// What it should have been.
        expected: &'static str,
    },
    /// An integer outside its type's range.
    #[error("{value} is outside the range of {ty} [{lo}, {hi}]")]
    OutOfRange {
        /// The integer.
        value: i128,
        /// Its type.
        ty: Type3,
        /// Least value of the type.
        lo: i128,
        /// Greatest value of the type.
        hi: i128,
    },
    /// Hexadecimal text with an odd number of digits.
    #[error("'{}' is not hexadecimal bytes (odd number of digits)", crate::error::shown(.text, 40))]
    OddHexDigits {
        /// The text.
        text: String,
    },
    /// Text with a character that is no hexadecimal digit.
    #[error("'{}' is not hexadecimal bytes", crate::error::shown(.text, 40))]
    NotHex {
        /// The text.
        text: String,
    },
    /// A Float value that is not finite or beyond the largest magnitude a run takes.
    #[error("{text} is not a finite number within +-{limit:e}")]
    NotFinite {
        /// The value as text.
        text: String,
        /// The largest magnitude.
        limit: f64,
    },
}

fn parse_token(ty: Type3, tok: &str) -> Result<Values, ValueError> {
    let bad = |expected: &'static str| ValueError::NotA {
        token: tok.to_string(),
        expected,
    };
    if let Some((lo, hi)) = ty.int_range() {
        let x: i128 = tok
            .parse::<i128>()
            .ok()
            .or_else(|| {
                // An integral number written as a float (1.0, 2e3), as spreadsheets write them.
                let f: f64 = tok.parse().ok()?;
                (f.fract() == 0.0 && f.abs() < 1.7e38).then_some(f as i128)
            })
            .ok_or_else(|| bad("an integer"))?;
        if x < lo || x > hi {
            return Err(ValueError::OutOfRange {
                value: x,
                ty,
                lo,
                hi,
            });
        }
        return Ok(match ty {
            Type3::Int8 => Values::Int8(vec![x as i8]),
            Type3::UInt8 => Values::UInt8(vec![x as u8]),
            Type3::Int16 => Values::Int16(vec![x as i16]),
            Type3::UInt16 => Values::UInt16(vec![x as u16]),
            Type3::Int32 => Values::Int32(vec![x as i32]),
            Type3::UInt32 => Values::UInt32(vec![x as u32]),
            Type3::UInt64 => Values::UInt64(vec![x as u64]),
            _ => Values::Int64(vec![x as i64]),
        });
    }
    Ok(match ty {
        Type3::Float32 => Values::Float32(vec![crate::xml::parse_real(tok)
            .ok_or_else(|| bad("a number"))?
            as f32]),
        Type3::Float64 => Values::Float64(vec![
            crate::xml::parse_real(tok).ok_or_else(|| bad("a number"))?
        ]),
        _ => Values::Boolean(vec![
            crate::xml::parse_bool(tok).ok_or_else(|| bad("a Boolean (true, false, 1, 0)"))?
        ]),
    })
}

/// A Float32 in its shortest round-trip form as f32 (`0.1`, not `0.10000000149011612`).
fn format_f32(x: f32) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Bytes as lowercase hexadecimal digits.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Hexadecimal digits (either case, even count, an optional `0x`) as bytes.
pub fn unhex(text: &str) -> Result<Vec<u8>, ValueError> {
    let t = text.strip_prefix("0x").unwrap_or(text);
    if t.len() % 2 != 0 {
        return Err(ValueError::OddHexDigits {
            text: text.to_string(),
        });
    }
    (0..t.len())
        .step_by(2)
        .map(|i| {
            t.get(i..i + 2)
                .and_then(|d| u8::from_str_radix(d, 16).ok())
                .ok_or_else(|| ValueError::NotHex {
                    text: text.to_string(),
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{Type3, ValueError, Values};

    #[test]
    fn tokens_parse_to_their_type_and_refuse_values_out_of_range() {
        assert_eq!(
            Values::parse(Type3::Float64, "1 0 2.5").unwrap(),
            Values::Float64(vec![1.0, 0.0, 2.5])
        );
        assert_eq!(
            Values::parse(Type3::UInt64, "18446744073709551615").unwrap(),
            Values::UInt64(vec![u64::MAX])
        );
        assert_eq!(
            Values::parse(Type3::Int8, "-128 127 3.0").unwrap(),
            Values::Int8(vec![-128, 127, 3])
        );
        assert!(matches!(
            Values::parse(Type3::Int8, "128"),
            Err(ValueError::OutOfRange { value: 128, .. })
        ));
        assert!(Values::parse(Type3::UInt16, "-1").is_err());
        assert!(Values::parse(Type3::Int32, "1.5").is_err());
        assert_eq!(
            Values::parse(Type3::Boolean, "true 0").unwrap(),
            Values::Boolean(vec![true, false])
        );
        assert!(Values::parse(Type3::Boolean, "yes").is_err());
        assert_eq!(
            Values::parse(Type3::Binary, "0aFF").unwrap(),
            Values::Binary(vec![vec![10, 255]])
        );
        assert!(Values::parse(Type3::Binary, "abc").is_err());
        assert!(Values::parse(Type3::Binary, "zz").is_err());
    }

    #[test]
    fn text_reads_back_to_the_same_values() {
        let v = Values::Float32(vec![0.1, -3.0e-7, 1.0e20]);
        let text = v.joined(0..3);
        assert_eq!(text, "0.1 -3e-7 1e20");
        assert_eq!(Values::parse(Type3::Float32, &text).unwrap(), v);
        let v = Values::Float64(vec![0.1, 1.0 / 3.0]);
        assert_eq!(Values::parse(Type3::Float64, &v.joined(0..2)).unwrap(), v);
        assert_eq!(Values::Binary(vec![vec![0, 1, 171]]).text(0), "0001ab");
        assert_eq!(Values::Boolean(vec![true]).text(0), "true");
        assert_eq!(Values::Int64(vec![i64::MIN]).text(0), i64::MIN.to_string());
    }
}
