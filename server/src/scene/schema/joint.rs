//! Joints between named bodies.

use serde::Deserialize;

use super::*;

/// A joint between two named bodies.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// First body's name.
    pub a: String,
    /// Second body's name.
    pub b: String,
    /// Where the bodies are joined, world, m (default: midway between
    /// their origins).
    #[serde(default)]
    pub anchor: Option<Vec3>,
    /// What it constrains.
    pub kind: JointKindSpec,
    /// Force above which it breaks, N (default: never).
    #[serde(default)]
    pub break_force: Option<f64>,
}

/// What a joint constrains. Axes are in world coordinates at build time.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum JointKindSpec {
    /// The anchors stay together; rotation is free.
    Ball,
    /// The bodies move as one.
    Fixed,
    /// A hinge about `axis`, with optional angle limits and motor.
    Hinge {
        /// Hinge axis, world.
        axis: Vec3,
        /// Lower and upper angle, degrees.
        #[serde(default)]
        limits_deg: Option<(f64, f64)>,
        /// Target speed (deg/s) and largest torque (N·m).
        #[serde(default)]
        motor: Option<(f64, f64)>,
    },
    /// A ball joint whose swing is limited to a cone about `axis` and whose
    /// twist about it is limited.
    SwingTwist {
        /// Twist axis, world.
        axis: Vec3,
        /// Largest swing, degrees.
        swing_deg: f64,
        /// Largest twist either way, degrees.
        twist_deg: f64,
    },
    /// A slider along `axis` with optional limits (m) and motor.
    Prismatic {
        /// Slide axis, world.
        axis: Vec3,
        /// Lower and upper travel from the anchor, m.
        #[serde(default)]
        limits: Option<(f64, f64)>,
        /// Target speed (m/s) and largest force (N).
        #[serde(default)]
        motor: Option<(f64, f64)>,
    },
    /// The anchors stay between `min` and `max` apart, m.
    Distance {
        /// Smallest distance, m.
        min: f64,
        /// Largest distance, m.
        max: f64,
    },
}
