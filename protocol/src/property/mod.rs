//! Replicated game state: the properties a game declares per entity
//! (health, team, owner, a small enum) and per match (score, clock,
//! phase), changed only by its rules and carried to clients in the
//! snapshot datagram, delta-coded against the view the client
//! acknowledged like the entities' states.
//!
//! # Design
//!
//! A game declares its properties once ([`PropertySchema`]: a name and a
//! kind each, at most [`MAX_PROPERTIES`] per entity and per match); the
//! welcome tells every client the schema. A value travels in its kind's
//! width ([`PropertyKind::bits`]: one bit for a flag, the declared width
//! for an integer, 32 for a float), so a team of four costs two bits.
//!
//! Values live in the views both ends keep per snapshot sequence
//! ([`PropertyView`]: a row of raw values per entity that has any set,
//! and one for the match). A snapshot lists only what differs from its
//! baseline's view (the view the client acknowledged), so an unchanged
//! property costs nothing and a change lost with its datagram is sent
//! again in every snapshot until one carrying it is acknowledged:
//! eventually consistent, whatever the loss. An entity's properties
//! travel only while the entity is in the client's view (the snapshot's
//! interest), and a new entity's come with it. A row missing is all
//! zeros (every kind's default: false, 0, 0.0).
//!
//! # Layout (after the snapshot's entities; bits, least significant first)
//!
//! ```text
//! match:    changed 1 [mask m | each changed value]      (when m > 0)
//! entities: count varuint, then for each, ascending by id:
//!           id gap varuint | mask n (not 0) | each changed value   (when n > 0)
//! ```
//!
//! `m` and `n` are the schema's counts of match and entity properties;
//! mask bit `i` says property `i` changed. Id gaps and counts are coded as
//! the snapshot's; the snapshot codec writes and reads the section
//! (`snapshot/property_section.rs`).

mod schema;
mod value;
mod view;

pub use schema::{
    PropertyDecl, PropertyKind, PropertySchema, MAX_PROPERTIES, MAX_PROPERTY_NAME_BYTES,
};
pub use value::{PropertyError, PropertyValue};
pub(crate) use view::{changed_mask, raw_at};
pub use view::{FrameProperties, PropertyRow, PropertyView};
