//! Engine-neutral scene descriptions: bodies (shape, pose, kind, material)
//! and joints, built once and then turned into a world of either engine by
//! [`super::ours`] and [`super::rapier`].
//!
//! Conventions shared with both engines: SI units, +Y up, capsules and
//! cylinders along their local Y axis, shapes centred on the body origin,
//! heightfields centred on their origin with rows along Z and columns along
//! X. A joint's *frame* is its orientation in the world when the scene is
//! built; its local X axis is the twist axis (swing-twist joints) or the
//! hinge axis. Both engines count joint angles from that initial pose.

use std::sync::Arc;

use inertia_physics::glam::{DQuat, DVec3};

use crate::report::SplitMix64;

/// Friction coefficient of every surface (static and dynamic alike).
pub const FRICTION: f64 = 0.6;
/// Density of every dynamic body, kg/m³.
pub const DENSITY: f64 = 1000.0;
/// Restitution of the balls (everything else: 0).
pub const BALL_RESTITUTION: f64 = 0.2;
/// Angular damping of ragdoll parts, 1/s.
pub const RAGDOLL_ANGULAR_DAMPING: f64 = 0.5;

/// A collision shape in its own frame.
#[derive(Debug, Clone, PartialEq)]
pub enum NeutralShape {
    /// A ball of `radius` m.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// A box.
    Cuboid {
        /// Half the size along each axis, m.
        half_extents: DVec3,
    },
    /// A capsule along Y.
    Capsule {
        /// Half the length of the inner segment, m.
        half_height: f64,
        /// Radius, m.
        radius: f64,
    },
    /// A solid cylinder along Y.
    Cylinder {
        /// Half the height, m.
        half_height: f64,
        /// Radius, m.
        radius: f64,
    },
    /// The convex hull of these points, m.
    ConvexHull(Arc<Vec<DVec3>>),
    /// A terrain grid: `rows × cols` heights, row-major, rows along Z and
    /// columns along X, spanning `scale.x` by `scale.z` metres centred on the
    /// origin, each height multiplied by `scale.y`.
    HeightField {
        /// `heights[r * cols + c]`.
        heights: Arc<Vec<f64>>,
        /// Samples along Z.
        rows: usize,
        /// Samples along X.
        cols: usize,
        /// Size along X and Z (m) and the height factor.
        scale: DVec3,
    },
}

/// Whether a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NeutralKind {
    /// Moved by gravity, contacts and joints.
    Dynamic,
    /// Never moves.
    Static,
}

/// One body.
#[derive(Debug, Clone, PartialEq)]
pub struct NeutralBody {
    /// Its one collision shape.
    pub shape: NeutralShape,
    /// Origin of the body frame in the world, m.
    pub position: DVec3,
    /// Body frame → world.
    pub rotation: DQuat,
    /// Dynamic or static.
    pub kind: NeutralKind,
    /// Uniform density, kg/m³ (dynamic bodies).
    pub density: f64,
    /// Friction coefficient.
    pub friction: f64,
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Angular damping, 1/s.
    pub angular_damping: f64,
}

impl NeutralBody {
    /// A dynamic body of the default density and friction.
    pub fn dynamic(shape: NeutralShape, position: DVec3, rotation: DQuat) -> Self {
        Self {
            shape,
            position,
            rotation,
            kind: NeutralKind::Dynamic,
            density: DENSITY,
            friction: FRICTION,
            restitution: 0.0,
            angular_damping: 0.0,
        }
    }

    /// A static body.
    pub fn fixed(shape: NeutralShape, position: DVec3) -> Self {
        Self {
            kind: NeutralKind::Static,
            ..Self::dynamic(shape, position, DQuat::IDENTITY)
        }
    }
}

/// What a joint constrains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NeutralJointKind {
    /// The anchors coincide; rotation is free.
    Ball,
    /// A ball joint whose twist about the frame's X axis stays in `twist`
    /// (rad) and whose swing away from it stays within `swing` (rad).
    SwingTwist {
        /// Largest swing, rad.
        swing: f64,
        /// Lower and upper twist, rad.
        twist: (f64, f64),
    },
    /// Rotation only about the frame's X axis, between `limits` (rad).
    Hinge {
        /// Lower and upper angle, rad.
        limits: (f64, f64),
    },
}

/// A joint between two bodies of the scene (indices into
/// [`NeutralScene::bodies`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeutralJoint {
    /// First body.
    pub a: usize,
    /// Second body.
    pub b: usize,
    /// Anchor in A's body frame, m.
    pub anchor_a: DVec3,
    /// Anchor in B's body frame, m.
    pub anchor_b: DVec3,
    /// The joint frame in the world when the scene is built.
    pub frame: DQuat,
    /// What it constrains.
    pub kind: NeutralJointKind,
}

/// A scene: bodies, joints, and what the measurement needs to know about it.
#[derive(Debug, Clone, PartialEq)]
pub struct NeutralScene {
    /// Case name, e.g. `pyramid_20`.
    pub name: String,
    /// Every body, static ones included.
    pub bodies: Vec<NeutralBody>,
    /// Every joint.
    pub joints: Vec<NeutralJoint>,
    /// Whether every dynamic body starts at rest in a pose it should keep
    /// (then the drift is measured).
    pub starts_at_rest: bool,
    /// A dynamic body whose origin ends below this height (m) fell through
    /// the ground.
    pub floor_y: f64,
    /// Measured steps (after the warm-up).
    pub steps: usize,
}

impl NeutralScene {
    fn new(name: String, steps: usize, starts_at_rest: bool, floor_y: f64) -> Self {
        Self {
            name,
            bodies: Vec::new(),
            joints: Vec::new(),
            starts_at_rest,
            floor_y,
            steps,
        }
    }

    /// Number of dynamic bodies.
    pub fn dynamic_count(&self) -> usize {
        self.bodies
            .iter()
            .filter(|b| b.kind == NeutralKind::Dynamic)
            .count()
    }

    /// Number of static bodies.
    pub fn static_count(&self) -> usize {
        self.bodies.len() - self.dynamic_count()
    }

    fn add(&mut self, body: NeutralBody) -> usize {
        self.bodies.push(body);
        self.bodies.len() - 1
    }

    /// Joins `a` and `b` at the world point `at` with a joint whose frame is
    /// `frame` in the world, as the bodies are placed now.
    fn join(&mut self, a: usize, b: usize, at: DVec3, frame: DQuat, kind: NeutralJointKind) {
        let local = |i: usize| {
            let body = &self.bodies[i];
            body.rotation.inverse() * (at - body.position)
        };
        let joint = NeutralJoint {
            a,
            b,
            anchor_a: local(a),
            anchor_b: local(b),
            frame,
            kind,
        };
        self.joints.push(joint);
    }

    /// A static box whose top face is at `y = 0`, `half_x` by `half_z` m,
    /// centred on (`x`, `z`).
    fn ground(&mut self, x: f64, z: f64, half_x: f64, half_z: f64) {
        self.add(NeutralBody::fixed(
            NeutralShape::Cuboid {
                half_extents: DVec3::new(half_x, 0.5, half_z),
            },
            DVec3::new(x, -0.5, z),
        ));
    }

    /// Four static walls around the rectangle `|x| <= half`, `|z| <= half`
    /// from `y = 0` to `height`, 0.5 m thick.
    fn walls(&mut self, half: f64, height: f64) {
        let t = 0.25;
        let h = 0.5 * height;
        for s in [-1.0, 1.0] {
            self.add(NeutralBody::fixed(
                NeutralShape::Cuboid {
                    half_extents: DVec3::new(t, h, half + 2.0 * t),
                },
                DVec3::new(s * (half + t), h, 0.0),
            ));
            self.add(NeutralBody::fixed(
                NeutralShape::Cuboid {
                    half_extents: DVec3::new(half, h, t),
                },
                DVec3::new(0.0, h, s * (half + t)),
            ));
        }
    }

    /// A 2-D pyramid of unit boxes, `rows` at the base, in the plane
    /// `z = z0`, centred on `x0`, resting on `y = 0`.
    fn pyramid(&mut self, rows: usize, x0: f64, z0: f64) {
        for row in 0..rows {
            let n = rows - row;
            for i in 0..n {
                let x = x0 + (i as f64 - (n as f64 - 1.0) / 2.0) * BOX_SPACING;
                self.add(NeutralBody::dynamic(
                    NeutralShape::Cuboid {
                        half_extents: DVec3::splat(0.5),
                    },
                    DVec3::new(x, 0.5 + row as f64, z0),
                    DQuat::IDENTITY,
                ));
            }
        }
    }
}

/// Centre-to-centre distance of neighbouring boxes in a pyramid row, m (a
/// 5 cm gap, so that each box rests on the two below it only).
const BOX_SPACING: f64 = 1.05;

/// `pyramid_<rows>`: one pyramid of `rows` rows (`rows (rows + 1) / 2`
/// unit boxes) on a static ground box.
pub fn pyramid(rows: usize, steps: usize) -> NeutralScene {
    let mut s = NeutralScene::new(format!("pyramid_{rows}"), steps, true, -1.0);
    let half = 0.5 * rows as f64 * BOX_SPACING + 5.0;
    s.ground(0.0, 0.0, half, 5.0);
    s.pyramid(rows, 0.0, 0.0);
    s
}

/// `many_pyramids`: `count` pyramids of `rows` rows on one ground, on a
/// grid 6 wide along X (as many rows of pyramids along Z as needed).
pub fn many_pyramids(name: String, count: usize, rows: usize, steps: usize) -> NeutralScene {
    let mut s = NeutralScene::new(name, steps, true, -1.0);
    let across = count.min(6);
    let deep = count.div_ceil(across);
    let dx = rows as f64 * BOX_SPACING + 2.0;
    let dz = 3.0;
    let width = across as f64 * dx;
    let depth = deep as f64 * dz;
    s.ground(0.0, 0.0, 0.5 * width + 5.0, 0.5 * depth + 5.0);
    for k in 0..count {
        let (i, j) = (k % across, k / across);
        let x = (i as f64 - (across as f64 - 1.0) / 2.0) * dx;
        let z = (j as f64 - (deep as f64 - 1.0) / 2.0) * dz;
        s.pyramid(rows, x, z);
    }
    s
}

/// The smallest `side` with `side² · layers >= n` for a near-cubic grid.
fn grid_side(n: usize, layers_per_side: usize) -> usize {
    let mut side = 1;
    while side * side * side * layers_per_side < n {
        side += 1;
    }
    side
}

/// `balls`: `n` spheres of radius 0.25 m on a jittered grid (0.6 m pitch)
/// falling into a box container (static floor and four walls).
pub fn balls(name: String, n: usize, steps: usize) -> NeutralScene {
    let mut s = NeutralScene::new(name, steps, false, -1.0);
    let side = grid_side(n, 1);
    let layers = n.div_ceil(side * side);
    let pitch = 0.6;
    let radius = 0.25;
    let half = 0.5 * side as f64 * pitch + 0.3;
    s.ground(0.0, 0.0, half + 2.0, half + 2.0);
    s.walls(half, layers as f64 * pitch + 1.0);
    let mut rng = SplitMix64(0xBA11_5EED);
    for k in 0..n {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let jitter = |rng: &mut SplitMix64| rng.range(-0.05, 0.05);
        let x = (i as f64 - (side as f64 - 1.0) / 2.0) * pitch + jitter(&mut rng);
        let z = (j as f64 - (side as f64 - 1.0) / 2.0) * pitch + jitter(&mut rng);
        let y = 1.0 + l as f64 * pitch + jitter(&mut rng);
        let mut b = NeutralBody::dynamic(
            NeutralShape::Sphere { radius },
            DVec3::new(x, y, z),
            DQuat::IDENTITY,
        );
        b.restitution = BALL_RESTITUTION;
        s.add(b);
    }
    s
}

/// A uniformly random rotation (Shoemake's method).
fn random_rotation(rng: &mut SplitMix64) -> DQuat {
    let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    DQuat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize()
}

/// Number of points of each convex hull in `mixed_pile` and `convex_pile`.
pub const HULL_POINTS: usize = 32;

/// `HULL_POINTS` points on (and just inside) an ellipsoid with semi-axes
/// 0.3, 0.25 and 0.2 m: a rounded rock.
fn rock(rng: &mut SplitMix64) -> Vec<DVec3> {
    let axes = DVec3::new(0.3, 0.25, 0.2);
    (0..HULL_POINTS)
        .map(|_| {
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            let dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            dir * axes * rng.range(0.9, 1.0)
        })
        .collect()
}

/// `n` bodies dropped into a box container, randomly oriented, on a
/// `side` × `side` grid of layers `pitch` m apart (`side` fitted to `n`
/// for small piles), the lowest 1 m up; body `k` has shape `shape(k,
/// rocks)`, where `rocks` are 8 hulls of [`HULL_POINTS`] points drawn first
/// from the generator seeded with `seed`.
fn pile(
    mut s: NeutralScene,
    n: usize,
    (side, pitch): (usize, f64),
    seed: u64,
    shape: impl Fn(usize, &[Arc<Vec<DVec3>>]) -> NeutralShape,
) -> NeutralScene {
    let side = if n >= 1000 { side } else { grid_side(n, 3) };
    let layers = n.div_ceil(side * side);
    let half = 0.5 * side as f64 * pitch + 0.5;
    s.ground(0.0, 0.0, half + 2.0, half + 2.0);
    s.walls(half, layers as f64 * pitch + 1.5);
    let mut rng = SplitMix64(seed);
    let rocks: Vec<Arc<Vec<DVec3>>> = (0..8).map(|_| Arc::new(rock(&mut rng))).collect();
    for k in 0..n {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let x = (i as f64 - (side as f64 - 1.0) / 2.0) * pitch;
        let z = (j as f64 - (side as f64 - 1.0) / 2.0) * pitch;
        let y = 1.0 + l as f64 * pitch;
        let rotation = random_rotation(&mut rng);
        s.add(NeutralBody::dynamic(
            shape(k, &rocks),
            DVec3::new(x, y, z),
            rotation,
        ));
    }
    s
}

/// `mixed_pile`: `n` bodies — capsules, cylinders and 32-point convex hulls
/// in turn, randomly oriented — on a 15 × 15 grid (0.9 m pitch) of layers
/// (3000 bodies: 14 layers, the top one partly filled), dropped into a box
/// container.
pub fn mixed_pile(name: String, n: usize, steps: usize) -> NeutralScene {
    let s = NeutralScene::new(name, steps, false, -1.0);
    pile(s, n, (15, 0.9), 0x0051_1E5A, |k, rocks| match k % 3 {
        0 => NeutralShape::Capsule {
            half_height: 0.2,
            radius: 0.18,
        },
        1 => NeutralShape::Cylinder {
            half_height: 0.2,
            radius: 0.25,
        },
        _ => NeutralShape::ConvexHull(rocks[k % rocks.len()].clone()),
    })
}

/// `convex_pile`: `n` convex hulls of [`HULL_POINTS`] points (the rocks of
/// `mixed_pile`, 8 shapes), randomly oriented, on a 16 × 16 grid of layers
/// (0.8 m pitch; 5120 bodies: 20 layers), the lowest 1 m up, dropped into
/// a box container: Box3D's convex-pile benchmark, hull against hull
/// only.
pub fn convex_pile(name: String, n: usize, steps: usize) -> NeutralScene {
    let s = NeutralScene::new(name, steps, false, -1.0);
    pile(s, n, (16, 0.8), 0x0C0E_7E11, |k, rocks| {
        NeutralShape::ConvexHull(rocks[k % rocks.len()].clone())
    })
}

/// `joint_grid`: an `n × n` curtain of spheres (radius 0.1 m, 0.25 m
/// apart) in the XY plane, each joined by a ball joint at the midpoint to
/// its right and lower neighbour; the top row is static, so the curtain
/// hangs from it, starting at rest, its lowest row 5 m above a ground box
/// (out of reach even when the joints stretch).
pub fn joint_grid(name: String, n: usize, steps: usize) -> NeutralScene {
    let mut s = NeutralScene::new(name, steps, true, -1.0);
    let pitch = 0.25;
    let top = 5.0 + n as f64 * pitch;
    s.ground(0.0, 0.0, 0.5 * n as f64 * pitch + 2.0, 2.0);
    let first = s.bodies.len();
    let index = |i: usize, j: usize| first + j * n + i;
    for j in 0..n {
        for i in 0..n {
            let p = DVec3::new(
                (i as f64 - (n as f64 - 1.0) / 2.0) * pitch,
                top - j as f64 * pitch,
                0.0,
            );
            let shape = NeutralShape::Sphere { radius: 0.1 };
            let body = if j == 0 {
                NeutralBody::fixed(shape, p)
            } else {
                NeutralBody::dynamic(shape, p, DQuat::IDENTITY)
            };
            s.add(body);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let here = s.bodies[index(i, j)].position;
            if i + 1 < n && j > 0 {
                let at = 0.5 * (here + s.bodies[index(i + 1, j)].position);
                s.join(
                    index(i, j),
                    index(i + 1, j),
                    at,
                    DQuat::IDENTITY,
                    NeutralJointKind::Ball,
                );
            }
            if j + 1 < n {
                let at = 0.5 * (here + s.bodies[index(i, j + 1)].position);
                s.join(
                    index(i, j),
                    index(i, j + 1),
                    at,
                    DQuat::IDENTITY,
                    NeutralJointKind::Ball,
                );
            }
        }
    }
    s
}

/// The height of the `ragdolls` terrain at (`x`, `z`), m: gentle hills of
/// up to ±0.8 m.
fn terrain(x: f64, z: f64) -> f64 {
    0.5 * (0.35 * x).sin() * (0.3 * z).cos() + 0.3 * (0.11 * x + 0.17 * z).sin()
}

/// The rotation taking +X to `axis` (unit).
fn x_to(axis: DVec3) -> DQuat {
    DQuat::from_rotation_arc(DVec3::X, axis)
}

/// Adds one ragdoll standing with its feet at `feet`, turned by
/// `rotation`: eleven bodies (box pelvis and torso, sphere head, capsule
/// limbs) and ten joints (swing-twist spine, neck, shoulders and hips,
/// hinged elbows and knees), 1.8 m tall.
fn ragdoll(s: &mut NeutralScene, feet: DVec3, rotation: DQuat) {
    let place = |p: DVec3| feet + rotation * p;
    let along_x = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    let part = |s: &mut NeutralScene, shape: NeutralShape, at: DVec3, local: DQuat| {
        let mut b = NeutralBody::dynamic(shape, place(at), (rotation * local).normalize());
        b.angular_damping = RAGDOLL_ANGULAR_DAMPING;
        s.add(b)
    };
    let cuboid = |x: f64, y: f64, z: f64| NeutralShape::Cuboid {
        half_extents: DVec3::new(x, y, z),
    };
    let capsule = |half_height: f64, radius: f64| NeutralShape::Capsule {
        half_height,
        radius,
    };
    let pelvis = part(
        s,
        cuboid(0.15, 0.09, 0.1),
        DVec3::new(0.0, 1.0, 0.0),
        DQuat::IDENTITY,
    );
    let torso = part(
        s,
        cuboid(0.17, 0.19, 0.1),
        DVec3::new(0.0, 1.31, 0.0),
        DQuat::IDENTITY,
    );
    let head = part(
        s,
        NeutralShape::Sphere { radius: 0.11 },
        DVec3::new(0.0, 1.66, 0.0),
        DQuat::IDENTITY,
    );
    let frame = |axis: DVec3| (rotation * x_to(axis)).normalize();
    let st = |swing: f64, twist: f64| NeutralJointKind::SwingTwist {
        swing,
        twist: (-twist, twist),
    };
    s.join(
        pelvis,
        torso,
        place(DVec3::new(0.0, 1.1, 0.0)),
        frame(DVec3::Y),
        st(0.5, 0.4),
    );
    s.join(
        torso,
        head,
        place(DVec3::new(0.0, 1.53, 0.0)),
        frame(DVec3::Y),
        st(0.6, 0.9),
    );
    for side in [1.0, -1.0] {
        let upper_arm = part(
            s,
            capsule(0.12, 0.05),
            DVec3::new(side * 0.34, 1.44, 0.0),
            along_x,
        );
        let lower_arm = part(
            s,
            capsule(0.12, 0.045),
            DVec3::new(side * 0.62, 1.44, 0.0),
            along_x,
        );
        let upper_leg = part(
            s,
            capsule(0.17, 0.07),
            DVec3::new(side * 0.1, 0.7, 0.0),
            DQuat::IDENTITY,
        );
        let lower_leg = part(
            s,
            capsule(0.17, 0.055),
            DVec3::new(side * 0.1, 0.27, 0.0),
            DQuat::IDENTITY,
        );
        s.join(
            torso,
            upper_arm,
            place(DVec3::new(side * 0.2, 1.44, 0.0)),
            frame(DVec3::X * side),
            st(1.4, 0.8),
        );
        s.join(
            upper_arm,
            lower_arm,
            place(DVec3::new(side * 0.48, 1.44, 0.0)),
            frame(DVec3::Y * side),
            NeutralJointKind::Hinge { limits: (0.0, 2.5) },
        );
        s.join(
            pelvis,
            upper_leg,
            place(DVec3::new(side * 0.1, 0.89, 0.0)),
            frame(DVec3::NEG_Y),
            st(1.2, 0.5),
        );
        s.join(
            upper_leg,
            lower_leg,
            place(DVec3::new(side * 0.1, 0.5, 0.0)),
            frame(DVec3::X),
            NeutralJointKind::Hinge {
                limits: (-2.5, 0.0),
            },
        );
    }
}

/// Bodies per ragdoll.
pub const RAGDOLL_BODIES: usize = 11;

/// `ragdolls`: `n` ragdolls on a grid 2.5 m apart, each turned about Y at
/// random and tipped by up to 0.3 rad, feet 1 m above the highest point of
/// a static heightfield of gentle hills (`grid × grid` samples, 1 m apart).
pub fn ragdolls(name: String, n: usize, steps: usize) -> NeutralScene {
    let across = (1..).find(|k| k * k >= n).unwrap_or(1);
    let pitch = 2.5;
    let size = across as f64 * pitch + 8.0;
    let samples = size.ceil() as usize + 1;
    let mut heights = Vec::with_capacity(samples * samples);
    let mut max_h = f64::NEG_INFINITY;
    let mut min_h = f64::INFINITY;
    for r in 0..samples {
        for c in 0..samples {
            let x = (c as f64 / (samples - 1) as f64 - 0.5) * size;
            let z = (r as f64 / (samples - 1) as f64 - 0.5) * size;
            let h = terrain(x, z);
            max_h = max_h.max(h);
            min_h = min_h.min(h);
            heights.push(h);
        }
    }
    let mut s = NeutralScene::new(name, steps, false, min_h - 1.0);
    s.add(NeutralBody::fixed(
        NeutralShape::HeightField {
            heights: Arc::new(heights),
            rows: samples,
            cols: samples,
            scale: DVec3::new(size, 1.0, size),
        },
        DVec3::ZERO,
    ));
    let mut rng = SplitMix64(0x00DA_11ED);
    for k in 0..n {
        let (i, j) = (k % across, k / across);
        let x = (i as f64 - (across as f64 - 1.0) / 2.0) * pitch;
        let z = (j as f64 - (across as f64 - 1.0) / 2.0) * pitch;
        let yaw = DQuat::from_rotation_y(rng.range(0.0, std::f64::consts::TAU));
        let tip = DQuat::from_rotation_x(rng.range(-0.3, 0.3));
        ragdoll(
            &mut s,
            DVec3::new(x, max_h + 1.0, z),
            (yaw * tip).normalize(),
        );
    }
    s
}

/// Every scene of the suite, full size (`quick = false`) or the small
/// versions of `--quick`, named by their real sizes.
pub fn all(quick: bool) -> Vec<SceneSpec> {
    if quick {
        vec![
            SceneSpec::new("pyramid_4", 30, |_, st| pyramid(4, st)),
            SceneSpec::new("pyramid_8", 30, |_, st| pyramid(8, st)),
            SceneSpec::new("many_pyramids_4x4", 20, |n, st| many_pyramids(n, 4, 4, st)),
            SceneSpec::new("balls_64", 30, |n, st| balls(n, 64, st)),
            SceneSpec::new("mixed_pile_48", 30, |n, st| mixed_pile(n, 48, st)),
            SceneSpec::new("convex_pile_48", 30, |n, st| convex_pile(n, 48, st)),
            SceneSpec::new("joint_grid_6x6", 30, |n, st| joint_grid(n, 6, st)),
            SceneSpec::new("ragdolls_4", 30, |n, st| ragdolls(n, 4, st)),
        ]
    } else {
        vec![
            SceneSpec::new("pyramid_20", 300, |_, st| pyramid(20, st)),
            SceneSpec::new("pyramid_100", 120, |_, st| pyramid(100, st)),
            SceneSpec::new("many_pyramids", 90, |n, st| many_pyramids(n, 48, 20, st)),
            SceneSpec::new("balls", 120, |n, st| balls(n, 8000, st)),
            SceneSpec::new("mixed_pile", 90, |n, st| mixed_pile(n, 3000, st)),
            SceneSpec::new("convex_pile", 90, |n, st| convex_pile(n, 5120, st)),
            SceneSpec::new("joint_grid", 120, |n, st| joint_grid(n, 100, st)),
            SceneSpec::new("ragdolls", 200, |n, st| ragdolls(n, 200, st)),
        ]
    }
}

/// A scene by name, built on demand (so `--only` builds nothing it skips).
#[derive(Debug, Clone)]
pub struct SceneSpec {
    /// Case name.
    pub name: &'static str,
    /// Measured steps.
    pub steps: usize,
    build: fn(String, usize) -> NeutralScene,
}

impl SceneSpec {
    fn new(name: &'static str, steps: usize, build: fn(String, usize) -> NeutralScene) -> Self {
        Self { name, steps, build }
    }

    /// Builds the description.
    pub fn build(&self) -> NeutralScene {
        (self.build)(self.name.to_string(), self.steps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_scenes_have_the_sizes_the_readme_gives() {
        assert_eq!(pyramid(20, 1).dynamic_count(), 210);
        assert_eq!(pyramid(100, 1).dynamic_count(), 5050);
        assert_eq!(many_pyramids("m".into(), 48, 20, 1).dynamic_count(), 10_080);
        assert_eq!(balls("b".into(), 8000, 1).dynamic_count(), 8000);
        assert_eq!(mixed_pile("m".into(), 3000, 1).dynamic_count(), 3000);
        assert_eq!(convex_pile("c".into(), 5120, 1).dynamic_count(), 5120);
        let grid = joint_grid("j".into(), 100, 1);
        assert_eq!(grid.dynamic_count(), 9900);
        assert_eq!(grid.joints.len(), 99 * 99 + 100 * 99);
        let r = ragdolls("r".into(), 200, 1);
        assert_eq!(r.dynamic_count(), 200 * RAGDOLL_BODIES);
        assert_eq!(r.joints.len(), 200 * 10);
    }

    #[test]
    fn joint_anchors_meet_in_the_world() {
        let r = ragdolls("r".into(), 3, 1);
        for j in &r.joints {
            let (a, b) = (&r.bodies[j.a], &r.bodies[j.b]);
            let pa = a.position + a.rotation * j.anchor_a;
            let pb = b.position + b.rotation * j.anchor_b;
            assert!((pa - pb).length() < 1e-12, "{pa} vs {pb}");
        }
    }

    #[test]
    fn ragdolls_start_above_the_terrain() {
        let r = ragdolls("r".into(), 9, 1);
        let NeutralShape::HeightField { heights, .. } = &r.bodies[0].shape else {
            panic!("the first body is the terrain");
        };
        let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for b in r.bodies.iter().filter(|b| b.kind == NeutralKind::Dynamic) {
            assert!(b.position.y > top + 0.1, "{}", b.position);
        }
    }
}
