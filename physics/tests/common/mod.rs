//! Scenes shared by the physics tests.
#![allow(dead_code)]

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    BodyHandle, GravityMethod, Integrator, MutualGravity, ParticleDesc, ParticleHandle,
    SpringParams, SystemDesc, SystemHandle, World, WorldConfig,
};

pub fn world() -> World {
    World::new(WorldConfig {
        threads: 1,
        ..WorldConfig::default()
    })
    .unwrap()
}

/// A mass `m` on a spring of stiffness `k` to a pinned anchor at the origin,
/// along x, displaced by `amplitude` from rest length 1 m.
pub struct Oscillator {
    pub world: World,
    pub sys: SystemHandle,
    pub mass: ParticleHandle,
    pub omega: f64,
    pub amplitude: f64,
}

pub const REST: f64 = 1.0;

pub fn oscillator(integrator: Integrator, m: f64, k: f64, c: f64, amplitude: f64) -> Oscillator {
    let mut world = world();
    let sys = world.add_system(SystemDesc::with_integrator(integrator));
    let anchor = world
        .add_particle(
            sys,
            ParticleDesc {
                pinned: true,
                ..ParticleDesc::at(DVec3::ZERO, 1.0)
            },
        )
        .unwrap();
    let mass = world
        .add_particle(
            sys,
            ParticleDesc::at(DVec3::new(REST + amplitude, 0.0, 0.0), m),
        )
        .unwrap();
    world
        .add_spring(
            anchor,
            mass,
            SpringParams {
                rest_length: REST,
                stiffness: k,
                damping: c,
            },
        )
        .unwrap();
    Oscillator {
        world,
        sys,
        mass,
        omega: (k / m).sqrt(),
        amplitude,
    }
}

impl Oscillator {
    /// Displacement from rest, m.
    pub fn x(&self) -> f64 {
        self.world.particle(self.mass).unwrap().position.x - REST
    }
}

/// A light body orbiting a pinned central mass with `G M = 1`, starting at
/// periapsis on +x with semi-major axis `a` and eccentricity `e`.
pub struct Kepler {
    pub world: World,
    pub body: ParticleHandle,
    pub a: f64,
    pub e: f64,
}

pub fn kepler(integrator: Integrator, a: f64, e: f64) -> Kepler {
    let mut world = world();
    let sys = world.add_system(SystemDesc::with_integrator(integrator));
    world
        .add_force(
            sys,
            MutualGravity {
                g_constant: 1.0,
                softening: 0.0,
                method: GravityMethod::Exact,
            },
        )
        .unwrap();
    world
        .add_particle(
            sys,
            ParticleDesc {
                pinned: true,
                ..ParticleDesc::at(DVec3::ZERO, 1.0)
            },
        )
        .unwrap();
    let rp = a * (1.0 - e);
    let vp = ((1.0 + e) / rp).sqrt();
    let body = world
        .add_particle(
            sys,
            ParticleDesc::at(DVec3::new(rp, 0.0, 0.0), 1e-6)
                .with_velocity(DVec3::new(0.0, vp, 0.0)),
        )
        .unwrap();
    Kepler { world, body, a, e }
}

/// Analytic position on the Kepler orbit above at time `t` (μ = 1).
pub fn kepler_position(a: f64, e: f64, t: f64) -> DVec3 {
    let n = (1.0 / (a * a * a)).sqrt();
    let m = n * t;
    let mut ecc = if e > 0.8 { std::f64::consts::PI } else { m };
    for _ in 0..100 {
        let d = (ecc - e * ecc.sin() - m) / (1.0 - e * ecc.cos());
        ecc -= d;
        if d.abs() < 1e-15 {
            break;
        }
    }
    DVec3::new(
        a * (ecc.cos() - e),
        a * (1.0 - e * e).sqrt() * ecc.sin(),
        0.0,
    )
}

/// Steps `world` `n` times by `dt`.
pub fn run(world: &mut World, dt: f64, n: usize) {
    for _ in 0..n {
        world.step(dt).unwrap();
    }
}

/// The state hash after each of `n` steps of `dt`.
pub fn state_hashes(world: &mut World, dt: f64, n: usize) -> Vec<u64> {
    (0..n)
        .map(|_| {
            world.step(dt).unwrap();
            world.state_hash()
        })
        .collect()
}

/// A tiny deterministic PRNG (splitmix64) for test scenes.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    /// Uniform in the cube [-h, h]³.
    pub fn in_cube(&mut self, h: f64) -> DVec3 {
        DVec3::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
    }
    /// Uniform in the box [lo, hi)³.
    pub fn in_box(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    /// A random unit vector.
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = self.in_cube(1.0);
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return v / l;
            }
        }
    }
    /// A random rotation (uniform over the unit quaternions).
    pub fn rotation(&mut self) -> DQuat {
        loop {
            let q = DQuat::from_xyzw(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = q.length();
            if l > 1e-3 && l <= 1.0 {
                return q / l;
            }
        }
    }
    /// A random pose within 5 m of the origin.
    pub fn pose(&mut self) -> Pose {
        Pose::new(self.in_cube(5.0), self.rotation())
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Fisher–Yates shuffle.
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            v.swap(i, self.below(i + 1));
        }
    }
    /// Uniform in the ball of radius `r`.
    pub fn in_ball(&mut self, r: f64) -> DVec3 {
        loop {
            let p = DVec3::new(
                self.f64() * 2.0 - 1.0,
                self.f64() * 2.0 - 1.0,
                self.f64() * 2.0 - 1.0,
            );
            if p.length_squared() <= 1.0 {
                return p * r;
            }
        }
    }
}

/// The apex of a ball's first bounce over `e² h`, dropped from `h` m at
/// `hz` steps a second onto ground of restitution `e`.
pub fn bounce_ratio(e: f64, h: f64, hz: f64) -> f64 {
    let mut w = world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let mut ground = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    );
    ground.restitution = e;
    w.add_body(&ground).unwrap();
    let r = 0.25;
    let mut ball = RigidBodyDesc::dynamic(
        Shape::sphere(r).unwrap(),
        1000.0,
        Pose::from_translation(DVec3::Y * (h + r)),
    )
    .unwrap();
    ball.restitution = e;
    let b = w.add_body(&ball).unwrap();
    let (mut bounced, mut apex) = (false, 0.0f64);
    for _ in 0..(10.0 * hz) as usize {
        w.step(1.0 / hz).unwrap();
        let body = w.body(b).unwrap();
        let v = body.linear_velocity().y;
        bounced |= v > 0.0;
        if bounced {
            apex = apex.max(body.center_of_mass().y - r);
            if v < 0.0 {
                break;
            }
        }
    }
    apex / (e * e * h)
}

// ----- soft bodies and fluids (issue 16) -----

/// A world of `threads` workers under Earth's gravity.
pub fn earth_world(threads: usize) -> World {
    let mut w = World::new(WorldConfig {
        threads,
        ..WorldConfig::default()
    })
    .unwrap();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    w
}

/// A pose at `p` (m), unturned.
pub fn at(p: DVec3) -> Pose {
    Pose {
        translation: p,
        rotation: DQuat::IDENTITY,
    }
}

/// A static slab 40 m wide whose top is the plane y = 0.
pub fn ground(w: &mut World) -> BodyHandle {
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        at(DVec3::new(0.0, -0.5, 0.0)),
    ))
    .unwrap()
}

/// A tank open at the top, inside from `min` to `max` (m): a floor and
/// four walls of static boxes 0.2 m thick.
pub fn tank(w: &mut World, min: DVec3, max: DVec3) {
    let t = 0.2;
    let size = max - min;
    let c = (min + max) * 0.5;
    let mut add = |centre: DVec3, half: DVec3| {
        w.add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(half).unwrap(),
            at(centre),
        ))
        .unwrap();
    };
    add(
        DVec3::new(c.x, min.y - t / 2.0, c.z),
        DVec3::new(size.x / 2.0 + t, t / 2.0, size.z / 2.0 + t),
    );
    for side in [-1.0, 1.0] {
        add(
            DVec3::new(c.x + side * (size.x + t) / 2.0, c.y, c.z),
            DVec3::new(t / 2.0, size.y / 2.0, size.z / 2.0 + t),
        );
        add(
            DVec3::new(c.x, c.y, c.z + side * (size.z + t) / 2.0),
            DVec3::new(size.x / 2.0, size.y / 2.0, t / 2.0),
        );
    }
}

/// A hammock in `w`: a 2 m cloth of 1 kg and 24 × 24 particles, 2 cm
/// thick, pinned at its corners 1 m up, stepped on `substeps` substeps;
/// and a 6.4 kg crate 0.2 m above it. Returns the cloth and the crate.
pub fn hammock(w: &mut World, substeps: u32) -> (inertia_physics::SoftBodyHandle, BodyHandle) {
    let cloth = inertia_physics::SoftCloth {
        corner: DVec3::new(-1.0, 1.0, -1.0),
        across: DVec3::new(2.0, 0.0, 0.0),
        down: DVec3::new(0.0, 0.0, 2.0),
        rows: 24,
        cols: 24,
        pinned: vec![[0, 0], [0, 23], [23, 0], [23, 23]],
        material: inertia_physics::SoftMaterial {
            collision_radius: 0.02,
            friction: 0.5,
            substeps,
            ..inertia_physics::SoftMaterial::default()
        },
        ..inertia_physics::SoftCloth::default()
    };
    let h = w.add_soft_body(&cloth.build().unwrap()).unwrap();
    let crate_ = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(0.2)).unwrap(),
        100.0,
        at(DVec3::new(0.0, 1.4, 0.0)),
    )
    .unwrap();
    (h, w.add_body(&crate_).unwrap())
}

/// A plastic bar 1 m long (along x from `x0`, m), 10 cm square, at y =
/// 1 m: a `SoftSolid` of 5 cm cells (yield at 1 % strain, creep 20/s, at
/// most 30 % permanent strain, 20 substeps) that feels no gravity, its
/// end at `x0` pinned and its tip's particles held rigidly to a kinematic
/// hand of shape `hand` at the tip's centre. Returns the bar, the tip's
/// particles and the hand.
pub fn plastic_bar(
    w: &mut World,
    x0: f64,
    hand: Shape,
) -> (inertia_physics::SoftBodyHandle, Vec<u32>, BodyHandle) {
    let solid = inertia_physics::SoftSolid {
        shape: inertia_physics::SolidShape::Box {
            half_extents: DVec3::new(0.5, 0.05, 0.05),
        },
        position: DVec3::new(x0 + 0.5, 1.0, 0.0),
        cell: 0.05,
        density: 500.0,
        edge_compliance: 1e-8,
        volume_compliance: 0.0,
        material: inertia_physics::SoftMaterial {
            damping: 2.0,
            substeps: 20,
            gravity_scale: 0.0,
            plasticity: Some(inertia_physics::Plasticity {
                yield_strain: 0.01,
                creep: 20.0,
                max_strain: 0.3,
            }),
            ..inertia_physics::SoftMaterial::default()
        },
        ..inertia_physics::SoftSolid::default()
    };
    let mut desc = solid.build().unwrap();
    let mut tip = Vec::new();
    for (k, p) in desc.positions.iter().enumerate() {
        if p.x < x0 + 1e-6 {
            desc.masses[k] = 0.0;
        }
        if p.x > x0 + 1.0 - 1e-6 {
            tip.push(k as u32);
        }
    }
    let bar = w.add_soft_body(&desc).unwrap();
    let hand = w
        .add_body(&RigidBodyDesc::kinematic(
            hand,
            at(DVec3::new(x0 + 1.0, 1.0, 0.0)),
        ))
        .unwrap();
    for &k in &tip {
        let p = w.soft_body(bar).unwrap().positions()[k as usize].as_dvec3();
        w.attach_soft_to_body(bar, k, hand, p, 0.0).unwrap();
    }
    (bar, tip, hand)
}

/// A 0.5 × 0.95 m sheet (11 × 20 particles, 12 mm collision radius)
/// folded in two on the ground: rows 10..20 laid back over rows 0..10,
/// 3 cm above them. With `self_collision` its upper half can rest on the
/// lower; without, it falls through.
pub fn folded_sheet(self_collision: bool) -> inertia_physics::SoftBodyDesc {
    let cloth = inertia_physics::SoftCloth {
        corner: DVec3::new(-0.25, 0.02, 0.0),
        across: DVec3::new(0.5, 0.0, 0.0),
        down: DVec3::new(0.0, 0.0, 0.95),
        rows: 20,
        cols: 11,
        mass: 0.3,
        stretch_compliance: 0.0,
        shear_compliance: 1e-5,
        bend_compliance: 10.0,
        pinned: Vec::new(),
        tethers: false,
        material: inertia_physics::SoftMaterial {
            collision_radius: 0.012,
            self_collision,
            friction: 0.5,
            ..inertia_physics::SoftMaterial::default()
        },
    };
    let mut desc = cloth.build().unwrap();
    for row in 10..20 {
        for col in 0..11 {
            let i = row * 11 + col;
            let under = (19 - row) * 11 + col;
            desc.positions[i] = desc.positions[under] + DVec3::new(0.0, 0.03, 0.0);
        }
    }
    desc
}

/// The mean height (m) of a [`folded_sheet`]'s upper half, away from the
/// fold.
pub fn upper_half_height(b: &inertia_physics::SoftBody) -> f32 {
    let x = b.positions();
    let upper: Vec<f32> = (12..20)
        .flat_map(|row| (0..11).map(move |col| row * 11 + col))
        .map(|i| x[i].y)
        .collect();
    upper.iter().sum::<f32>() / upper.len() as f32
}

/// A 2 m square sheet of `n` × `n` particles hung by its top corners in
/// the plane z = 0 (2 kg, soft stretch and shear, no tethers) that tears
/// past 8 % strain.
pub fn tearing_sheet(n: u32) -> inertia_physics::SoftBodyDesc {
    inertia_physics::SoftCloth {
        corner: DVec3::new(-1.0, 3.0, 0.0),
        across: DVec3::new(2.0, 0.0, 0.0),
        down: DVec3::new(0.0, -2.0, 0.0),
        rows: n,
        cols: n,
        mass: 2.0,
        stretch_compliance: 1e-3,
        shear_compliance: 1e-3,
        bend_compliance: 100.0,
        pinned: vec![[0, 0], [0, n - 1]],
        tethers: false,
        material: inertia_physics::SoftMaterial {
            tear_strain: Some(0.08),
            ..inertia_physics::SoftMaterial::default()
        },
    }
    .build()
    .unwrap()
}
