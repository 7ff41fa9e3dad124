//! What a game declares: its properties, each a name and a kind.

use serde::{Deserialize, Serialize};

use super::PropertyError;

/// The most properties a game declares per entity, and per match.
pub const MAX_PROPERTIES: usize = 32;

/// The longest property name, bytes of UTF-8.
pub const MAX_PROPERTY_NAME_BYTES: usize = 32;

/// A property's kind: what values it takes and how many bits one takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum PropertyKind {
    /// A flag (1 bit).
    Bool,
    /// An unsigned integer of `bits` bits, 1 to 64 (a team of four: 2).
    UInt {
        /// Its width.
        bits: u8,
    },
    /// A signed integer of `bits` bits, 2 to 64, two's complement.
    Int {
        /// Its width.
        bits: u8,
    },
    /// A 32-bit float (finite).
    F32,
}

impl PropertyKind {
    /// Bits one value takes on the wire.
    pub fn bits(self) -> u32 {
        match self {
            PropertyKind::Bool => 1,
            PropertyKind::UInt { bits } | PropertyKind::Int { bits } => u32::from(bits),
            PropertyKind::F32 => 32,
        }
    }

    fn check(self) -> Result<(), PropertyError> {
        let ok = match self {
            PropertyKind::Bool | PropertyKind::F32 => true,
            PropertyKind::UInt { bits } => (1..=64).contains(&bits),
            PropertyKind::Int { bits } => (2..=64).contains(&bits),
        };
        if ok {
            Ok(())
        } else {
            Err(PropertyError::Schema(format!(
                "a property of {} bits",
                self.bits()
            )))
        }
    }
}

/// One property a game declares.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PropertyDecl {
    /// Its name, for tools and clients (at most
    /// [`MAX_PROPERTY_NAME_BYTES`], unique among its kind's list).
    pub name: String,
    /// Its kind.
    pub kind: PropertyKind,
}

impl PropertyDecl {
    /// A property named `name` of `kind`.
    pub fn new(name: impl Into<String>, kind: PropertyKind) -> Self {
        Self {
            name: name.into(),
            kind,
        }
    }
}

/// The properties a game declares, per entity and per match, by index
/// (the order given is the wire's).
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PropertySchema {
    /// Each entity's (health, team, owner), at most [`MAX_PROPERTIES`].
    pub entity: Vec<PropertyDecl>,
    /// The match's (score, clock, phase), at most [`MAX_PROPERTIES`].
    pub match_state: Vec<PropertyDecl>,
}

impl PropertySchema {
    /// No properties: snapshots carry none, at no cost.
    pub fn is_empty(&self) -> bool {
        self.entity.is_empty() && self.match_state.is_empty()
    }

    /// Checks the counts, the names (length, unique within their list) and
    /// the kinds' widths.
    pub fn validate(&self) -> Result<(), PropertyError> {
        for (what, list) in [("entity", &self.entity), ("match", &self.match_state)] {
            if list.len() > MAX_PROPERTIES {
                return Err(PropertyError::Schema(format!(
                    "{} {what} properties, the most is {MAX_PROPERTIES}",
                    list.len()
                )));
            }
            for (i, d) in list.iter().enumerate() {
                if d.name.is_empty() || d.name.len() > MAX_PROPERTY_NAME_BYTES {
                    return Err(PropertyError::Schema(format!(
                        "{what} property {i}: a name of {} bytes (1 to {MAX_PROPERTY_NAME_BYTES})",
                        d.name.len()
                    )));
                }
                if list[..i].iter().any(|e| e.name == d.name) {
                    return Err(PropertyError::Schema(format!(
                        "two {what} properties named {:?}",
                        d.name
                    )));
                }
                d.kind.check()?;
            }
        }
        Ok(())
    }

    /// The index of the entity property `name`.
    pub fn entity_index(&self, name: &str) -> Option<usize> {
        self.entity.iter().position(|d| d.name == name)
    }

    /// The index of the match property `name`.
    pub fn match_index(&self, name: &str) -> Option<usize> {
        self.match_state.iter().position(|d| d.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_schema_is_checked() {
        let ok = PropertySchema {
            entity: vec![
                PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
                PropertyDecl::new("team", PropertyKind::UInt { bits: 2 }),
            ],
            match_state: vec![PropertyDecl::new("clock", PropertyKind::F32)],
        };
        assert_eq!(ok.validate(), Ok(()));
        assert_eq!(ok.entity_index("team"), Some(1));
        let mut twice = ok.clone();
        twice.entity[1].name = "health".into();
        assert!(twice.validate().is_err());
        let mut wide = ok.clone();
        wide.entity[0].kind = PropertyKind::UInt { bits: 65 };
        assert!(wide.validate().is_err());
        let mut many = ok.clone();
        many.match_state = (0..=MAX_PROPERTIES)
            .map(|i| PropertyDecl::new(format!("p{i}"), PropertyKind::Bool))
            .collect();
        assert!(many.validate().is_err());
        let mut long = ok;
        long.entity[0].name = "x".repeat(MAX_PROPERTY_NAME_BYTES + 1);
        assert!(long.validate().is_err());
    }
}
