//! Rigid bodies: the state of one body and how it is described.
//!
//! A body is integrated at its **centre of mass**: `com` (world, m) and
//! `rotation` (body frame → world) are the state, with the linear velocity
//! of the centre of mass and the angular velocity, both in world
//! coordinates. The pose a game sees — the body frame's origin — is derived:
//! `origin = com - rotation · local_com`.
//!
//! The inertia tensor is stored diagonalised: `principal` rotates the
//! principal frame into the body frame and `inv_principal_inertia` holds
//! `1 / I_i` along those axes, so the world tensor is
//! `R diag(I) Rᵀ` with `R = rotation · principal`, rebuilt whenever it is
//! needed instead of being stored (no state that can go stale).
//!
//! Kinds: **dynamic** bodies respond to forces; **kinematic** bodies move
//! with the velocity the game sets and push but are never pushed; **static**
//! bodies never move. Kinematic and static bodies have infinite mass.

use glam::{DMat3, DQuat, DVec3};

use crate::error::{finite, finite3, non_negative, PhysicsError};
use crate::limits;
use crate::rigid::mass::MassProperties;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BodyKind {
    /// Moved by forces, contacts and joints.
    Dynamic,
    /// Moved only by the velocity the game sets; infinite mass.
    Kinematic,
    /// Never moves; infinite mass.
    Static,
}

impl BodyKind {
    pub(crate) fn code(self) -> u8 {
        match self {
            BodyKind::Dynamic => 0,
            BodyKind::Kinematic => 1,
            BodyKind::Static => 2,
        }
    }

    pub(crate) fn from_code(c: u8) -> Option<Self> {
        [BodyKind::Dynamic, BodyKind::Kinematic, BodyKind::Static]
            .get(c as usize)
            .copied()
    }
}

/// How the friction (or restitution) coefficients of two bodies in contact
/// combine into the contact's. When the two bodies ask for different rules,
/// the later one in this list wins (`Max` over `Multiply` over `Min` over
/// `GeometricMean` over `Average`), as in PhysX and Rapier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum CombineRule {
    /// `(a + b) / 2`.
    Average,
    /// `√(a b)`: the default for friction (Box2D's rule), so a frictionless
    /// body slides on anything.
    GeometricMean,
    /// `min(a, b)`.
    Min,
    /// `a b`.
    Multiply,
    /// `max(a, b)`: the default for restitution, so a bouncy ball bounces
    /// on anything.
    Max,
}

impl CombineRule {
    /// Every rule, in priority order (lowest first).
    pub const ALL: [CombineRule; 5] = [
        CombineRule::Average,
        CombineRule::GeometricMean,
        CombineRule::Min,
        CombineRule::Multiply,
        CombineRule::Max,
    ];

    /// The contact's coefficient from the two bodies' coefficients and
    /// rules.
    pub fn combine((a, rule_a): (f64, CombineRule), (b, rule_b): (f64, CombineRule)) -> f64 {
        match rule_a.max(rule_b) {
            CombineRule::Average => 0.5 * (a + b),
            CombineRule::GeometricMean => (a * b).sqrt(),
            CombineRule::Min => a.min(b),
            CombineRule::Multiply => a * b,
            CombineRule::Max => a.max(b),
        }
    }

    /// Its code in the saved state.
    pub(crate) fn code(self) -> u8 {
        self as u8
    }

    /// The rule with code `c`.
    pub(crate) fn from_code(c: u8) -> Option<Self> {
        Self::ALL.get(usize::from(c)).copied()
    }
}

/// Everything needed to create a rigid body. Units are SI.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBodyDesc {
    /// Dynamic, kinematic or static.
    pub kind: BodyKind,
    /// Pose of the body frame in the world.
    pub pose: Pose,
    /// Velocity of the centre of mass, m/s.
    pub linear_velocity: DVec3,
    /// Angular velocity, rad/s, world frame.
    pub angular_velocity: DVec3,
    /// Mass, centre of mass and inertia in the body frame (dynamic bodies;
    /// ignored for kinematic and static ones).
    pub mass_properties: MassProperties,
    /// The collision shape, in the body frame.
    pub shape: Option<Shape>,
    /// Linear damping, 1/s: velocity is scaled by `1 / (1 + c dt)` each step.
    pub linear_damping: f64,
    /// Angular damping, 1/s, applied like the linear one.
    pub angular_damping: f64,
    /// Multiplies the world's gravity (0 = floats, -1 = falls up).
    pub gravity_scale: f64,
    /// Linear drag coefficient `b`, kg/s, used by a [`Drag`](crate::Drag) body force.
    pub drag_linear: f64,
    /// Quadratic drag coefficient `c`, kg/m, used by a [`Drag`](crate::Drag) body force.
    pub drag_quadratic: f64,
    /// Coefficient of static friction (combined with the other body's by
    /// [`Self::friction_combine`]).
    pub friction_static: f64,
    /// Coefficient of dynamic (sliding) friction.
    pub friction_dynamic: f64,
    /// Coefficient of restitution, 0 (no bounce) to 1 (combined with the
    /// other body's by [`Self::restitution_combine`]).
    pub restitution: f64,
    /// How friction combines with the other body's (default
    /// [`CombineRule::GeometricMean`]).
    pub friction_combine: CombineRule,
    /// How restitution combines with the other body's (default
    /// [`CombineRule::Max`]).
    pub restitution_combine: CombineRule,
    /// A sensor (trigger): it reports contact begin and end events but
    /// never pushes or is pushed.
    pub sensor: bool,
    /// Report a contact force event when the total normal force between this
    /// body and another exceeds this, N (`f64::MAX` = never).
    pub contact_force_threshold: f64,
    /// Continuous collision detection: contacts are searched along the whole
    /// path the body can travel in a step, so a fast, small body is stopped
    /// by the first surface in its way (see `rigid::pipeline`).
    pub ccd: bool,
    /// Whether the body may fall asleep when it comes to rest.
    pub can_sleep: bool,
}

impl RigidBodyDesc {
    /// A dynamic body of `shape` with uniform `density` (kg/m³) at `pose`.
    pub fn dynamic(shape: Shape, density: f64, pose: Pose) -> Result<Self, PhysicsError> {
        crate::limits::density(density)?;
        let mass_properties =
            shape
                .mass_properties(density)
                .map_err(|e| PhysicsError::Invalid {
                    what: "rigid body shape",
                    why: e.to_string(),
                })?;
        Ok(Self {
            mass_properties,
            shape: Some(shape),
            ..Self::base(BodyKind::Dynamic, pose)
        })
    }

    /// A static body of `shape` at `pose`.
    pub fn fixed(shape: Shape, pose: Pose) -> Self {
        Self {
            shape: Some(shape),
            ..Self::base(BodyKind::Static, pose)
        }
    }

    /// A kinematic body of `shape` at `pose`.
    pub fn kinematic(shape: Shape, pose: Pose) -> Self {
        Self {
            shape: Some(shape),
            ..Self::base(BodyKind::Kinematic, pose)
        }
    }

    fn base(kind: BodyKind, pose: Pose) -> Self {
        Self {
            kind,
            pose,
            linear_velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            mass_properties: MassProperties {
                mass: 0.0,
                center_of_mass: DVec3::ZERO,
                inertia: DMat3::ZERO,
            },
            shape: None,
            linear_damping: 0.0,
            angular_damping: 0.0,
            gravity_scale: 1.0,
            drag_linear: 0.0,
            drag_quadratic: 0.0,
            friction_static: 0.6,
            friction_dynamic: 0.5,
            restitution: 0.0,
            friction_combine: CombineRule::GeometricMean,
            restitution_combine: CombineRule::Max,
            sensor: false,
            contact_force_threshold: f64::MAX,
            ccd: false,
            can_sleep: true,
        }
    }

    /// Sets the initial velocities, m/s and rad/s.
    pub fn with_velocity(mut self, linear: DVec3, angular: DVec3) -> Self {
        self.linear_velocity = linear;
        self.angular_velocity = angular;
        self
    }

    /// Gives the body a total mass of `mass` kg, its shape's distribution
    /// kept (centre of mass unchanged, inertia scaled with the mass): for
    /// a body whose weight matters more than its material. Refused for a
    /// body that is not dynamic or has no mass to scale, and for a mass
    /// outside the engine's limits; nothing is changed then.
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::rigid::body::RigidBodyDesc;
    /// use inertia_physics::rigid::pose::Pose;
    /// use inertia_physics::rigid::shape::Shape;
    /// use inertia_physics::{World, WorldConfig};
    ///
    /// // A 20 kg crate, grippy and a little bouncy, whatever it is made of.
    /// let crate_desc = RigidBodyDesc::dynamic(
    ///     Shape::cuboid(DVec3::splat(0.5))?,
    ///     1.0,
    ///     Pose::from_translation(DVec3::Y),
    /// )?
    /// .with_mass(20.0)?
    /// .with_friction(0.9)
    /// .with_restitution(0.2);
    /// let mut world = World::new(WorldConfig::default())?;
    /// let h = world.add_body(&crate_desc)?;
    /// assert!((world.body(h).unwrap().mass() - 20.0).abs() < 1e-9);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_mass(mut self, mass: f64) -> Result<Self, PhysicsError> {
        limits::mass(mass)?;
        let now = self.mass_properties.mass;
        if self.kind != BodyKind::Dynamic || !(now.is_finite() && now > 0.0) {
            return Err(PhysicsError::Invalid {
                what: "body mass",
                why: "only a dynamic body with a shape's mass can be given a mass".into(),
            });
        }
        let scale = mass / now;
        self.mass_properties.mass = mass;
        self.mass_properties.inertia *= scale;
        Ok(self)
    }

    /// Sets the mass, centre of mass (body frame, m) and inertia tensor
    /// about it (kg·m²) outright, for a body whose collision shape is not
    /// where its mass is (a hollow hull, a car with its engine low).
    /// Checked when the body is added.
    pub fn with_mass_properties(mut self, mass_properties: MassProperties) -> Self {
        self.mass_properties = mass_properties;
        self
    }

    /// Sets both friction coefficients, static and sliding, to `mu`.
    pub fn with_friction(self, mu: f64) -> Self {
        self.with_friction_coefficients(mu, mu)
    }

    /// Sets the static and the sliding (dynamic) friction coefficients.
    pub fn with_friction_coefficients(mut self, r#static: f64, dynamic: f64) -> Self {
        self.friction_static = r#static;
        self.friction_dynamic = dynamic;
        self
    }

    /// Sets the coefficient of restitution, 0 (no bounce) to 1.
    pub fn with_restitution(mut self, restitution: f64) -> Self {
        self.restitution = restitution;
        self
    }

    /// Sets the linear and angular damping, 1/s.
    pub fn with_damping(mut self, linear: f64, angular: f64) -> Self {
        self.linear_damping = linear;
        self.angular_damping = angular;
        self
    }

    /// Sets how strongly the world's gravity pulls the body (0 floats).
    pub fn with_gravity_scale(mut self, scale: f64) -> Self {
        self.gravity_scale = scale;
        self
    }

    /// Makes the body a sensor: it reports contacts but never pushes.
    pub fn as_sensor(mut self) -> Self {
        self.sensor = true;
        self
    }

    /// Turns continuous collision detection on or off.
    pub fn with_ccd(mut self, ccd: bool) -> Self {
        self.ccd = ccd;
        self
    }

    /// Whether the body may fall asleep when it rests.
    pub fn with_can_sleep(mut self, can_sleep: bool) -> Self {
        self.can_sleep = can_sleep;
        self
    }

    /// Checks every field and builds the body.
    pub(crate) fn build(&self) -> Result<RigidBody, PhysicsError> {
        finite3("body position", self.pose.translation)?;
        limits::position("body position (m)", self.pose.translation)?;
        let rotation = checked_rotation(self.pose.rotation)?;
        finite3("body linear velocity", self.linear_velocity)?;
        finite3("body angular velocity", self.angular_velocity)?;
        limits::velocity(self.linear_velocity)?;
        limits::angular_velocity(self.angular_velocity)?;
        non_negative("linear damping", self.linear_damping)?;
        non_negative("angular damping", self.angular_damping)?;
        finite("gravity scale", self.gravity_scale)?;
        non_negative("body linear drag", self.drag_linear)?;
        non_negative("body quadratic drag", self.drag_quadratic)?;
        non_negative("static friction", self.friction_static)?;
        non_negative("dynamic friction", self.friction_dynamic)?;
        non_negative("restitution", self.restitution)?;
        non_negative("contact force threshold", self.contact_force_threshold)?;
        if self.restitution > 1.0 {
            return Err(PhysicsError::Invalid {
                what: "restitution",
                why: format!("must be at most 1, got {}", self.restitution),
            });
        }
        let mut body = RigidBody {
            kind: self.kind,
            com: self.pose.translation,
            rotation,
            linvel: self.linear_velocity,
            angvel: self.angular_velocity,
            push_velocity: DVec3::ZERO,
            local_com: DVec3::ZERO,
            inv_mass: 0.0,
            principal: DQuat::IDENTITY,
            inv_principal_inertia: DVec3::ZERO,
            shape: self.shape.clone(),
            linear_damping: self.linear_damping,
            angular_damping: self.angular_damping,
            gravity_scale: self.gravity_scale,
            drag_linear: self.drag_linear,
            drag_quadratic: self.drag_quadratic,
            friction_static: self.friction_static,
            friction_dynamic: self.friction_dynamic,
            restitution: self.restitution,
            friction_combine: self.friction_combine,
            restitution_combine: self.restitution_combine,
            sensor: self.sensor,
            contact_force_threshold: self.contact_force_threshold,
            ccd: self.ccd,
            can_sleep: self.can_sleep,
            sleeping: false,
            sleep_time: 0.0,
            quarantined: false,
            control_force: DVec3::ZERO,
            control_torque: DVec3::ZERO,
            radius: 0.0,
        };
        match self.kind {
            BodyKind::Dynamic => {
                let mp = &self.mass_properties;
                if !(mp.mass.is_finite() && mp.mass > 0.0) {
                    return Err(PhysicsError::NonPositiveMass(mp.mass));
                }
                limits::mass(mp.mass)?;
                finite3("centre of mass", mp.center_of_mass)?;
                for c in mp.inertia.to_cols_array() {
                    finite("inertia tensor", c)?;
                }
                let (moments, principal) = mp.principal_axes();
                if moments.min_element() <= 0.0 || !moments.is_finite() {
                    return Err(PhysicsError::Invalid {
                        what: "inertia tensor",
                        why: format!("principal moments must be > 0 kg·m², got {moments}"),
                    });
                }
                for m in moments.to_array() {
                    limits::inertia(m)?;
                }
                body.inv_mass = 1.0 / mp.mass;
                body.local_com = mp.center_of_mass;
                body.principal = principal;
                body.inv_principal_inertia = moments.recip();
                body.com = self.pose.translation + rotation * mp.center_of_mass;
            }
            BodyKind::Static => {
                body.linvel = DVec3::ZERO;
                body.angvel = DVec3::ZERO;
            }
            BodyKind::Kinematic => {}
        }
        body.radius = bounding_radius(body.shape.as_ref(), body.local_com);
        Ok(body)
    }
}

/// Distance from the centre of mass (`local_com`, body frame, m) to the
/// farthest corner of the shape's box in the body frame, m; 0 without a shape.
pub(crate) fn bounding_radius(shape: Option<&Shape>, local_com: DVec3) -> f64 {
    shape.map_or(0.0, |s| {
        let b = s.local_aabb();
        let (lo, hi) = (b.min - local_com, b.max - local_com);
        lo.abs().max(hi.abs()).length()
    })
}

/// A finite, non-zero quaternion, normalised; refused otherwise.
pub(crate) fn checked_rotation(q: DQuat) -> Result<DQuat, PhysicsError> {
    for c in q.to_array() {
        finite("body rotation", c)?;
    }
    let len = q.length();
    if len <= 1e-9 || !len.is_finite() {
        return Err(PhysicsError::ZeroDirection("body rotation quaternion"));
    }
    Ok(q / len)
}

/// One rigid body.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBody {
    pub(crate) kind: BodyKind,
    /// Centre of mass, world, m.
    pub(crate) com: DVec3,
    /// Body frame → world, unit.
    pub(crate) rotation: DQuat,
    /// Velocity of the centre of mass, m/s.
    pub(crate) linvel: DVec3,
    /// Angular velocity, rad/s, world.
    pub(crate) angvel: DVec3,
    /// How fast the solver's position correction moved the centre of mass
    /// over the last step beyond its velocity, m/s (see
    /// [`RigidBody::push_velocity`]).
    pub(crate) push_velocity: DVec3,
    /// Centre of mass in the body frame, m.
    pub(crate) local_com: DVec3,
    /// 1/kg; 0 for kinematic and static bodies.
    pub(crate) inv_mass: f64,
    /// Principal frame → body frame.
    pub(crate) principal: DQuat,
    /// 1 / principal moments, 1/(kg·m²); 0 for kinematic and static bodies.
    pub(crate) inv_principal_inertia: DVec3,
    pub(crate) shape: Option<Shape>,
    pub(crate) linear_damping: f64,
    pub(crate) angular_damping: f64,
    pub(crate) gravity_scale: f64,
    /// Drag coefficients, kg/s and kg/m.
    pub(crate) drag_linear: f64,
    pub(crate) drag_quadratic: f64,
    /// Friction coefficients and restitution.
    pub(crate) friction_static: f64,
    pub(crate) friction_dynamic: f64,
    pub(crate) restitution: f64,
    /// How friction and restitution combine with another body's.
    pub(crate) friction_combine: CombineRule,
    pub(crate) restitution_combine: CombineRule,
    /// Sensors report overlaps and take no part in the contact solve.
    pub(crate) sensor: bool,
    /// Normal force above which contact force events are reported, N.
    pub(crate) contact_force_threshold: f64,
    pub(crate) ccd: bool,
    pub(crate) can_sleep: bool,
    pub(crate) sleeping: bool,
    /// How long the body has been resting, s (see [`crate::rigid::island`]).
    pub(crate) sleep_time: f64,
    /// Became non-finite during a step: frozen and excluded until released.
    pub(crate) quarantined: bool,
    /// Scripted force at the centre of mass, N, world; stays until changed.
    pub(crate) control_force: DVec3,
    /// Scripted torque, N·m, world; stays until changed.
    pub(crate) control_torque: DVec3,
    /// [`bounding_radius`] of the shape, m: derived, not saved.
    pub(crate) radius: f64,
}

impl RigidBody {
    /// Dynamic, kinematic or static.
    pub fn kind(&self) -> BodyKind {
        self.kind
    }

    /// Pose of the body frame (its origin and orientation) in the world.
    pub fn pose(&self) -> Pose {
        Pose {
            translation: self.com - self.rotation * self.local_com,
            rotation: self.rotation,
        }
    }

    /// Centre of mass in the world, m.
    pub fn center_of_mass(&self) -> DVec3 {
        self.com
    }

    /// Velocity of the centre of mass, m/s.
    pub fn linear_velocity(&self) -> DVec3 {
        self.linvel
    }

    /// How fast the solver's position correction moved the centre of mass
    /// over the last step, beyond what its velocity moved it, m/s (averaged
    /// over the step): push-out of overlaps, and joints pulled back
    /// together. The correction moves the body without giving it velocity
    /// (so an overlap does not launch it), so this is the one place to see
    /// it: a body dropped into the ground and pushed out reads about its
    /// overlap divided by the step. Zero for a body that overlaps nothing,
    /// and for bodies the solver did not move (asleep, fixed, quarantined).
    pub fn push_velocity(&self) -> DVec3 {
        self.push_velocity
    }

    /// Angular velocity, rad/s, world frame.
    pub fn angular_velocity(&self) -> DVec3 {
        self.angvel
    }

    /// Velocity of the material point at `point` (world), m/s.
    pub fn velocity_at(&self, point: DVec3) -> DVec3 {
        self.linvel + self.angvel.cross(point - self.com)
    }

    /// Mass, kg (infinite for kinematic and static bodies).
    pub fn mass(&self) -> f64 {
        if self.inv_mass > 0.0 {
            1.0 / self.inv_mass
        } else {
            f64::INFINITY
        }
    }

    /// Inverse mass, 1/kg.
    pub fn inverse_mass(&self) -> f64 {
        self.inv_mass
    }

    /// Principal moments of inertia, kg·m² (infinite for non-dynamic bodies).
    pub fn principal_inertia(&self) -> DVec3 {
        self.inv_principal_inertia
            .map(|i| if i > 0.0 { 1.0 / i } else { f64::INFINITY })
    }

    /// Principal frame → world.
    pub(crate) fn principal_rotation(&self) -> DQuat {
        self.rotation * self.principal
    }

    /// Inverse inertia tensor in world coordinates, 1/(kg·m²).
    pub fn inverse_inertia_world(&self) -> DMat3 {
        let r = DMat3::from_quat(self.principal_rotation());
        r * DMat3::from_diagonal(self.inv_principal_inertia) * r.transpose()
    }

    /// Inertia tensor in world coordinates, kg·m² (dynamic bodies; zero otherwise).
    pub fn inertia_world(&self) -> DMat3 {
        if self.inv_mass == 0.0 {
            return DMat3::ZERO;
        }
        let r = DMat3::from_quat(self.principal_rotation());
        r * DMat3::from_diagonal(self.inv_principal_inertia.recip()) * r.transpose()
    }

    /// Angular momentum about the centre of mass, kg·m²/s, world.
    pub fn angular_momentum(&self) -> DVec3 {
        self.inertia_world() * self.angvel
    }

    /// Linear momentum, kg·m/s.
    pub fn linear_momentum(&self) -> DVec3 {
        if self.inv_mass > 0.0 {
            self.linvel / self.inv_mass
        } else {
            DVec3::ZERO
        }
    }

    /// Translational plus rotational kinetic energy, J (0 for non-dynamic bodies).
    pub fn kinetic_energy(&self) -> f64 {
        // Still bodies (every sleeping one) skip the world inertia: the
        // answer is the same zero.
        if self.inv_mass == 0.0 || (self.linvel == DVec3::ZERO && self.angvel == DVec3::ZERO) {
            return 0.0;
        }
        let rot = self.angvel.dot(self.inertia_world() * self.angvel);
        0.5 * (self.linvel.length_squared() / self.inv_mass + rot)
    }

    /// The collision shape, in the body frame.
    pub fn shape(&self) -> Option<&Shape> {
        self.shape.as_ref()
    }

    /// Whether the body is asleep.
    pub fn is_sleeping(&self) -> bool {
        self.sleeping
    }

    /// Whether the body was quarantined after becoming non-finite.
    pub fn is_quarantined(&self) -> bool {
        self.quarantined
    }

    /// Linear damping, 1/s.
    pub fn linear_damping(&self) -> f64 {
        self.linear_damping
    }

    /// Angular damping, 1/s.
    pub fn angular_damping(&self) -> f64 {
        self.angular_damping
    }

    /// Gravity scale.
    pub fn gravity_scale(&self) -> f64 {
        self.gravity_scale
    }

    /// Radius of the sphere about the centre of mass that holds the shape, m
    /// (0 without a shape).
    pub fn shape_radius(&self) -> f64 {
        self.radius
    }

    /// How friction and restitution combine with another body's.
    pub fn combine_rules(&self) -> (CombineRule, CombineRule) {
        (self.friction_combine, self.restitution_combine)
    }

    /// Static and dynamic friction coefficients and restitution.
    pub fn material(&self) -> (f64, f64, f64) {
        (
            self.friction_static,
            self.friction_dynamic,
            self.restitution,
        )
    }

    /// Wakes the body and restarts its rest timer.
    pub(crate) fn wake(&mut self) {
        self.sleeping = false;
        self.sleep_time = 0.0;
    }

    /// Whether the solver must leave this body where it is this step: not
    /// dynamic, or asleep, or quarantined.
    pub(crate) fn is_fixed_now(&self) -> bool {
        self.kind != BodyKind::Dynamic || self.sleeping || self.quarantined
    }

    /// Whether the body is a sensor.
    pub fn is_sensor(&self) -> bool {
        self.sensor
    }

    /// Whether continuous collision detection is on.
    pub fn ccd(&self) -> bool {
        self.ccd
    }
}
