//! Rigid bodies: poses, shapes and their mass properties, convex hulls,
//! bounding boxes, the body state and its free motion.

pub mod aabb;
pub mod attachment;
pub mod ballistic;
pub mod body;
pub(crate) mod body_index;
pub mod broad_phase;
pub mod contact;
pub(crate) mod forces;
pub(crate) mod immersion;
pub mod island;
pub mod joint;
pub mod mass;
pub(crate) mod motion;
pub mod narrow;
pub(crate) mod pipeline;
pub mod pose;
pub mod query;
pub mod shape;
pub mod solver;

pub use pipeline::{
    ContactEvent, ContactEventKind, ContactForceEvent, PairContact, SPECULATIVE_DISTANCE,
};
