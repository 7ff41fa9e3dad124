//! A property's value, as the rules set it and clients read it, and as it
//! is held and travels: raw bits of its kind's width.

use thiserror::Error;

use super::PropertyKind;

/// One property's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PropertyValue {
    /// Of a [`PropertyKind::Bool`].
    Bool(bool),
    /// Of a [`PropertyKind::UInt`].
    UInt(u64),
    /// Of a [`PropertyKind::Int`].
    Int(i64),
    /// Of a [`PropertyKind::F32`].
    F32(f32),
}

/// Why a schema or a value was refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum PropertyError {
    /// The schema breaks a bound.
    #[error("property schema: {0}")]
    Schema(String),
    /// No property has this index.
    #[error("no property {index} (the schema declares {count})")]
    NoSuchProperty {
        /// The index asked for.
        index: usize,
        /// Properties declared.
        count: usize,
    },
    /// A value of another kind than the property's.
    #[error("a value of another kind than {0:?}")]
    WrongKind(PropertyKind),
    /// A value outside its kind's range (an integer too wide, a float not
    /// finite).
    #[error("a value out of the range of {0:?}")]
    OutOfRange(PropertyKind),
    /// No entity has this id (any more).
    #[error("no entity {0}")]
    UnknownEntity(u32),
}

fn mask(bits: u32) -> u64 {
    if bits >= 64 {
        u64::MAX
    } else {
        (1 << bits) - 1
    }
}

impl PropertyValue {
    /// The default of `kind` (false, 0, 0.0): what a property holds until
    /// the rules set it, raw 0.
    pub fn default_of(kind: PropertyKind) -> Self {
        Self::from_raw(kind, 0)
    }

    /// The raw bits of this value as a property of `kind` holds them,
    /// refused when it is of another kind or out of the kind's range.
    pub fn to_raw(self, kind: PropertyKind) -> Result<u64, PropertyError> {
        let bits = kind.bits();
        match (kind, self) {
            (PropertyKind::Bool, PropertyValue::Bool(b)) => Ok(u64::from(b)),
            (PropertyKind::UInt { .. }, PropertyValue::UInt(v)) if v <= mask(bits) => Ok(v),
            (PropertyKind::Int { .. }, PropertyValue::Int(v)) => {
                let (lo, hi) = if bits >= 64 {
                    (i64::MIN, i64::MAX)
                } else {
                    (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
                };
                if (lo..=hi).contains(&v) {
                    Ok(v as u64 & mask(bits))
                } else {
                    Err(PropertyError::OutOfRange(kind))
                }
            }
            (PropertyKind::F32, PropertyValue::F32(f)) if f.is_finite() => {
                Ok(u64::from(f.to_bits()))
            }
            (PropertyKind::UInt { .. }, PropertyValue::UInt(_))
            | (PropertyKind::F32, PropertyValue::F32(_)) => Err(PropertyError::OutOfRange(kind)),
            _ => Err(PropertyError::WrongKind(kind)),
        }
    }

    /// The value raw bits of `kind` stand for (bits past the kind's width
    /// are ignored).
    pub fn from_raw(kind: PropertyKind, raw: u64) -> Self {
        let bits = kind.bits();
        let raw = raw & mask(bits);
        match kind {
            PropertyKind::Bool => PropertyValue::Bool(raw != 0),
            PropertyKind::UInt { .. } => PropertyValue::UInt(raw),
            PropertyKind::Int { .. } => {
                let shift = 64 - bits;
                PropertyValue::Int(((raw << shift) as i64) >> shift)
            }
            PropertyKind::F32 => PropertyValue::F32(f32::from_bits(raw as u32)),
        }
    }

    /// Whether raw bits read off the wire are a value of `kind` (a float
    /// must be finite; the rest hold any bits of their width).
    pub(crate) fn raw_is_valid(kind: PropertyKind, raw: u64) -> bool {
        match kind {
            PropertyKind::F32 => f32::from_bits(raw as u32).is_finite(),
            _ => true,
        }
    }

    /// The value as a JSON-friendly number (a flag as 0 or 1).
    pub fn as_f64(self) -> f64 {
        match self {
            PropertyValue::Bool(b) => f64::from(u8::from(b)),
            PropertyValue::UInt(v) => v as f64,
            PropertyValue::Int(v) => v as f64,
            PropertyValue::F32(f) => f64::from(f),
        }
    }
}

impl From<bool> for PropertyValue {
    fn from(v: bool) -> Self {
        PropertyValue::Bool(v)
    }
}

impl From<f32> for PropertyValue {
    fn from(v: f32) -> Self {
        PropertyValue::F32(v)
    }
}

macro_rules! from_ints {
    ($variant:ident, $wide:ty: $($t:ty),*) => {
        $(impl From<$t> for PropertyValue {
            fn from(v: $t) -> Self {
                PropertyValue::$variant(<$wide>::from(v))
            }
        })*
    };
}
from_ints!(UInt, u64: u8, u16, u32, u64);
from_ints!(Int, i64: i8, i16, i32, i64);

impl std::fmt::Display for PropertyValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PropertyValue::Bool(b) => write!(f, "{b}"),
            PropertyValue::UInt(v) => write!(f, "{v}"),
            PropertyValue::Int(v) => write!(f, "{v}"),
            PropertyValue::F32(v) => write!(f, "{v}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_go_to_raw_bits_and_back_within_their_kinds() {
        let cases = [
            (PropertyKind::Bool, PropertyValue::Bool(true)),
            (PropertyKind::UInt { bits: 7 }, PropertyValue::UInt(100)),
            (
                PropertyKind::UInt { bits: 64 },
                PropertyValue::UInt(u64::MAX),
            ),
            (PropertyKind::Int { bits: 8 }, PropertyValue::Int(-128)),
            (PropertyKind::Int { bits: 8 }, PropertyValue::Int(127)),
            (PropertyKind::Int { bits: 64 }, PropertyValue::Int(i64::MIN)),
            (PropertyKind::F32, PropertyValue::F32(-2.5)),
        ];
        for (kind, v) in cases {
            let raw = v.to_raw(kind).unwrap();
            assert!(raw <= mask(kind.bits()), "{kind:?}");
            assert_eq!(PropertyValue::from_raw(kind, raw), v);
        }
        let refused = [
            (PropertyKind::UInt { bits: 7 }, PropertyValue::UInt(128)),
            (PropertyKind::Int { bits: 8 }, PropertyValue::Int(128)),
            (PropertyKind::Int { bits: 8 }, PropertyValue::Int(-129)),
            (PropertyKind::F32, PropertyValue::F32(f32::NAN)),
            (PropertyKind::Bool, PropertyValue::UInt(1)),
        ];
        for (kind, v) in refused {
            assert!(v.to_raw(kind).is_err(), "{kind:?} {v:?}");
        }
        assert_eq!(
            PropertyValue::default_of(PropertyKind::F32),
            PropertyValue::F32(0.0)
        );
    }
}
