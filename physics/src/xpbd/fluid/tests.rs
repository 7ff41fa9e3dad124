//! Fluids in tanks of static boxes, stepped without a world: the tests
//! gather the coupling, step the fluid and hand the loads to the bodies
//! themselves.

use glam::{DVec3, Vec3};

use super::*;
use crate::arena::Arena;
use crate::rigid::body::{RigidBody, RigidBodyDesc};
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;
use crate::xpbd::coupling::{apply_changes, Coupling, StepStart};

const DT: f32 = 1.0 / 60.0;
const G: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// A tank open at the top: a floor and four walls of static boxes around
/// the inside `min` to `max` (m), 0.2 m thick.
fn tank(bodies: &mut Arena<RigidBody>, min: DVec3, max: DVec3) {
    let t = 0.2;
    let size = max - min;
    let centre = (min + max) * 0.5;
    let mut add = |centre: DVec3, half: DVec3| {
        let desc =
            RigidBodyDesc::fixed(Shape::cuboid(half).unwrap(), Pose::from_translation(centre));
        bodies.insert(desc.build().unwrap());
    };
    // The floor runs under the walls.
    add(
        DVec3::new(centre.x, min.y - t / 2.0, centre.z),
        DVec3::new(size.x / 2.0 + t, t / 2.0, size.z / 2.0 + t),
    );
    for side in [-1.0, 1.0] {
        add(
            DVec3::new(centre.x + side * (size.x + t) / 2.0, centre.y, centre.z),
            DVec3::new(t / 2.0, size.y / 2.0, size.z / 2.0 + t),
        );
        add(
            DVec3::new(centre.x, centre.y, centre.z + side * (size.z + t) / 2.0),
            DVec3::new(size.x / 2.0, size.y / 2.0, t / 2.0),
        );
    }
}

/// One step of the fluid against the bodies, which then take what the
/// particles did to them.
fn step(fluid: &mut Fluid, bodies: &mut Arena<RigidBody>) {
    step_after(fluid, bodies, &StepStart::default());
}

/// [`step`] after a rigid stage that moved the bodies from where `start`
/// saw them (as the world's soft stage runs).
fn step_after(fluid: &mut Fluid, bodies: &mut Arena<RigidBody>, start: &StepStart) {
    let reach = fluid.reach(DT, G);
    let changes = {
        let mut coupling = Coupling::gather(
            bodies,
            fluid.positions(),
            fluid.inverse_masses(),
            reach,
            &[],
        );
        coupling.over_step(start);
        fluid.step(DT, G, &mut coupling);
        coupling.finish()
    };
    apply_changes(bodies, &changes);
}

/// `nx × ny × nz` particles `s` m apart filling the floor of a tank
/// `nx s` by `nz s` wide and twice as deep as the fluid.
fn resting_tank(nx: usize, ny: usize, nz: usize, s: f64) -> (Fluid, Arena<RigidBody>) {
    let size = DVec3::new(nx as f64, ny as f64, nz as f64) * s;
    let desc = FluidDesc::block(DVec3::ZERO, size, s).unwrap();
    let fluid = Fluid::new(desc).unwrap();
    let mut bodies = Arena::default();
    tank(
        &mut bodies,
        DVec3::ZERO,
        DVec3::new(size.x, 2.0 * size.y, size.z),
    );
    (fluid, bodies)
}

fn max_speed(fluid: &Fluid) -> f32 {
    fluid
        .velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max)
}

#[test]
fn a_resting_tank_holds_its_density_and_level() {
    let s = 0.1;
    let (nx, ny, nz) = (12, 12, 12);
    let (mut fluid, mut bodies) = resting_tank(nx, ny, nz, s);
    let n = fluid.len();
    for _ in 0..240 {
        step(&mut fluid, &mut bodies);
    }
    let rest = f64::from(fluid.rest_density());
    let h = f64::from(fluid.kernel_radius());
    // The level from the particles' mean height (a column of even density
    // from the floor up to L has its mean at L / 2), against the level
    // their volume fills over the floor.
    let mean_y = fluid
        .positions()
        .iter()
        .map(|p| f64::from(p.y))
        .sum::<f64>()
        / n as f64;
    let level = 2.0 * mean_y;
    let want = n as f64 * s * s * s / (nx as f64 * s * nz as f64 * s);
    // The density more than a kernel radius below the free surface (the
    // particles above lack neighbours overhead), and over all particles.
    let (mut sum, mut count, mut all) = (0.0f64, 0usize, 0.0f64);
    for (p, &rho) in fluid.positions().iter().zip(fluid.densities()) {
        all += f64::from(rho);
        if f64::from(p.y) < level - h {
            sum += f64::from(rho);
            count += 1;
        }
    }
    let interior = sum / count as f64 / rest - 1.0;
    let overall = all / n as f64 / rest - 1.0;
    let level_error = level / want - 1.0;
    let speed = max_speed(&fluid);
    eprintln!(
        "resting tank, {n} particles after 4 s: density {:+.2} % below the surface layer \
         ({count} particles), {:+.2} % over all; level {level:.4} m for {want:.4} m \
         ({:+.2} %); fastest particle {speed:.3} m/s",
        100.0 * interior,
        100.0 * overall,
        100.0 * level_error,
    );
    let tol = 1e-3;
    let (wx, wz) = ((nx as f64 * s) as f32, (nz as f64 * s) as f32);
    for p in fluid.positions() {
        assert!(p.is_finite());
        assert!(p.x > -tol && p.x < wx + tol, "left the tank: {p}");
        assert!(p.z > -tol && p.z < wz + tol, "left the tank: {p}");
        assert!(p.y > -tol, "through the floor: {p}");
    }
    assert!(interior.abs() < 0.01, "density error {interior}");
    assert!(level_error.abs() < 0.02, "level error {level_error}");
    assert!(speed < 0.25, "fastest particle {speed} m/s");
}

/// A box of `density` kg/m³ put on the fluid's surface in a tank, moving
/// only up and down (the test integrates it: gravity, then the fluid's
/// impulses). Returns the mean submerged fraction over the last 2 s of
/// `seconds`.
fn float_box(density: f64, seconds: f32) -> f64 {
    let s = 0.1;
    let (nx, ny, nz) = (16, 8, 16);
    let size = DVec3::new(nx as f64, ny as f64, nz as f64) * s;
    let fluid_desc = FluidDesc::block(DVec3::ZERO, size, s).unwrap();
    let mut fluid = Fluid::new(fluid_desc).unwrap();
    let mut bodies = Arena::default();
    tank(
        &mut bodies,
        DVec3::ZERO,
        DVec3::new(size.x, 2.5 * size.y, size.z),
    );
    let half = DVec3::new(0.3, 0.15, 0.3);
    let centre = DVec3::new(size.x / 2.0, size.y + half.y, size.z / 2.0);
    let desc = RigidBodyDesc::dynamic(
        Shape::cuboid(half).unwrap(),
        density,
        Pose::from_translation(centre),
    )
    .unwrap();
    let (bi, bg) = bodies.insert(desc.build().unwrap());
    let steps = (seconds / DT) as usize;
    let average_from = steps - (2.0 / DT) as usize;
    let (mut sum, mut count) = (0.0, 0);
    let mut start = StepStart::default();
    for k in 0..steps {
        start.record(&bodies, f64::from(DT));
        {
            let b = bodies.get_mut(bi, bg).unwrap();
            b.linvel = DVec3::new(0.0, b.linvel.y + f64::from(G.y * DT), 0.0);
            b.angvel = DVec3::ZERO;
            b.com += b.linvel * f64::from(DT);
        }
        step_after(&mut fluid, &mut bodies, &start);
        if k >= average_from {
            let b = bodies.get(bi, bg).unwrap();
            let bottom = b.com.y - half.y;
            // The level of the fluid away from the box, from the mean
            // height of the particles more than a kernel radius off its
            // sides (as in the resting tank: the column there is even from
            // the floor up to the level).
            let clear = half.x + f64::from(fluid.kernel_radius());
            let (mut heights, mut n) = (0.0f64, 0usize);
            for p in fluid.positions() {
                if (f64::from(p.x) - centre.x).abs() > clear
                    || (f64::from(p.z) - centre.z).abs() > clear
                {
                    heights += f64::from(p.y);
                    n += 1;
                }
            }
            let surface = 2.0 * heights / n as f64;
            sum += (surface - bottom) / (2.0 * half.y);
            count += 1;
        }
    }
    sum / count as f64
}

#[test]
fn a_box_of_half_the_fluids_density_floats_half_submerged() {
    let fraction = float_box(500.0, 6.0);
    eprintln!(
        "a box of 500 kg/m³ on water floats {:.3} submerged",
        fraction
    );
    assert!(
        (fraction - 0.5).abs() < 0.05,
        "submerged fraction {fraction}"
    );
}

/// The positions and velocities of a tank with a floating box after a
/// second, bit for bit, and the box's velocity.
fn tank_bits() -> (Vec<[u32; 3]>, Vec<[u32; 3]>, [u64; 3]) {
    let s = 0.1;
    let size = DVec3::new(1.6, 1.0, 1.6);
    let desc = FluidDesc::block(DVec3::ZERO, size, s).unwrap();
    let mut fluid = Fluid::new(desc).unwrap();
    assert!(fluid.len() > 2 * CHUNK, "several chunks");
    let mut bodies = Arena::default();
    tank(&mut bodies, DVec3::ZERO, DVec3::new(1.6, 2.0, 1.6));
    let desc = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::new(0.3, 0.15, 0.3)).unwrap(),
        500.0,
        Pose::from_translation(DVec3::new(0.7, 1.1, 0.8)),
    )
    .unwrap();
    let (bi, bg) = bodies.insert(desc.build().unwrap());
    for _ in 0..60 {
        {
            let b = bodies.get_mut(bi, bg).unwrap();
            b.linvel.y += f64::from(G.y * DT);
            b.com += b.linvel * f64::from(DT);
        }
        step(&mut fluid, &mut bodies);
    }
    let bits = |v: &[Vec3]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
    let b = bodies.get(bi, bg).unwrap();
    (
        bits(fluid.positions()),
        bits(fluid.velocities()),
        b.linvel.to_array().map(f64::to_bits),
    )
}

#[test]
fn one_thread_and_two_threads_give_the_same_bits() {
    let one = crate::parallel::sequential(tank_bits);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let two = pool.install(tank_bits);
    assert!(one.0 == two.0, "positions differ");
    assert!(one.1 == two.1, "velocities differ");
    assert_eq!(one.2, two.2, "the box's velocity differs");
}

#[test]
fn bad_descriptions_are_refused() {
    let good = || FluidDesc::block(DVec3::ZERO, DVec3::splat(0.4), 0.1).unwrap();
    assert!(Fluid::new(good()).is_ok());
    let refused = |change: &dyn Fn(&mut FluidDesc)| {
        let mut d = good();
        change(&mut d);
        Fluid::new(d).unwrap_err()
    };
    assert!(matches!(
        refused(&|d| d.spacing = 0.0),
        PhysicsError::NotPositive { .. }
    ));
    assert!(matches!(
        refused(&|d| d.spacing = f64::NAN),
        PhysicsError::NonFinite { .. }
    ));
    assert!(matches!(
        refused(&|d| d.rest_density = -1.0),
        PhysicsError::NotPositive { .. }
    ));
    assert!(matches!(
        refused(&|d| d.viscosity = -0.1),
        PhysicsError::Negative { .. }
    ));
    assert!(matches!(
        refused(&|d| d.viscosity = 2.0),
        PhysicsError::OutOfRange { .. }
    ));
    assert!(matches!(
        refused(&|d| d.positions[3].y = f64::INFINITY),
        PhysicsError::NonFinite { .. }
    ));
    assert!(matches!(
        refused(&|d| d.velocities = vec![DVec3::ZERO; 2]),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&|d| d.max_particles = 10),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&|d| d.substeps = 0),
        PhysicsError::NotPositive { .. }
    ));
    assert!(matches!(
        refused(&|d| d.substeps = 65),
        PhysicsError::OutOfRange { .. }
    ));
    assert!(matches!(
        refused(&|d| d.kernel_radius = Some(0.05)),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&|d| d.collision_radius = Some(1.0)),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&|d| d.relaxation = -1.0),
        PhysicsError::Negative { .. }
    ));
    assert!(matches!(
        refused(&|d| d.tensile_dq = 1.0),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&|d| d.friction = f64::NAN),
        PhysicsError::NonFinite { .. }
    ));
    assert!(matches!(
        refused(&|d| d.gravity_scale = f64::INFINITY),
        PhysicsError::NonFinite { .. }
    ));
    assert!(FluidDesc::block(DVec3::ZERO, DVec3::splat(1e3), 1e-3).is_err());
    assert!(FluidDesc::block(DVec3::ZERO, DVec3::splat(0.05), 0.1).is_err());
}

#[test]
fn emitters_are_all_or_nothing_and_capped() {
    let mut desc = FluidDesc::block(DVec3::ZERO, DVec3::splat(0.2), 0.1).unwrap();
    desc.max_particles = 10;
    let mut fluid = Fluid::new(desc).unwrap();
    assert_eq!(fluid.len(), 8);
    let at = [DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.1, 0.0, 0.0)];
    let bad = [DVec3::new(1.0, 0.0, 0.0), DVec3::new(f64::NAN, 0.0, 0.0)];
    assert!(fluid.add_particles(&bad, &[]).is_err());
    assert!(
        fluid.add_particles(&at, &[DVec3::X]).is_err(),
        "one velocity for two"
    );
    assert_eq!(fluid.len(), 8);
    fluid.add_particles(&at, &[DVec3::X, DVec3::Y]).unwrap();
    assert_eq!(fluid.len(), 10);
    assert_eq!(fluid.velocities()[9], Vec3::Y);
    assert_eq!(fluid.densities().len(), 10);
    assert!(matches!(
        fluid.add_particles(&at[..1], &[]),
        Err(PhysicsError::Invalid { .. })
    ));
    assert_eq!(fluid.len(), 10);
    // Removing keeps the survivors' order.
    let gone = fluid.remove_particles_outside(Aabb {
        min: DVec3::splat(-1.0),
        max: DVec3::new(1.05, 1.0, 1.0),
    });
    assert_eq!(gone, 1);
    assert_eq!(fluid.len(), 9);
    assert_eq!(fluid.positions()[8], Vec3::new(1.0, 0.0, 0.0));
    let mut bodies = Arena::default();
    step(&mut fluid, &mut bodies);
    assert!(fluid.positions().iter().all(|p| p.is_finite()));
}

#[test]
fn a_block_fills_its_box_on_a_lattice() {
    let d = FluidDesc::block(DVec3::ZERO, DVec3::new(0.3, 0.2, 0.1), 0.1).unwrap();
    assert_eq!(d.positions.len(), 6);
    assert_eq!(d.positions[0], DVec3::splat(0.05));
    assert!(d.validate().is_ok());
    let f = Fluid::new(d).unwrap();
    assert!((f.particle_mass() - 1.0).abs() < 1e-5);
    assert!((f.kernel_radius() - 0.2).abs() < 1e-7);
    assert_eq!(f.rest_density(), 1000.0);
    assert!((f.spacing() - 0.1).abs() < 1e-7);
}

#[test]
fn bad_steps_change_nothing_and_violence_stays_finite() {
    let (mut fluid, mut bodies) = resting_tank(6, 6, 6, 0.1);
    let before = fluid.positions().to_vec();
    let mut empty = Coupling::default();
    fluid.step(f32::NAN, G, &mut empty);
    fluid.step(-1.0, G, &mut empty);
    fluid.step(0.0, G, &mut empty);
    assert_eq!(fluid.positions(), &before[..]);
    // Particles thrown hard at the floor and each other.
    for (k, v) in fluid.v.iter_mut().enumerate() {
        *v = Vec3::new((k % 7) as f32 - 3.0, -200.0, (k % 5) as f32 - 2.0);
    }
    for _ in 0..30 {
        step(&mut fluid, &mut bodies);
    }
    assert!(fluid.positions().iter().all(|p| p.is_finite()));
    assert!(fluid.velocities().iter().all(|v| v.is_finite()));
    assert!(fluid.densities().iter().all(|d| d.is_finite()));
}

#[test]
fn vorticity_confinement_keeps_a_swirl_going() {
    // A column of fluid turning about the vertical at 2 rad/s in a tank,
    // without gravity: viscosity and the solver slow it down, confinement
    // feeds the swirl back.
    let energy = |vorticity: f64| {
        let mut desc = FluidDesc::block(DVec3::ZERO, DVec3::new(1.2, 0.6, 1.2), 0.1).unwrap();
        desc.vorticity = vorticity;
        desc.viscosity = 0.1;
        let centre = DVec3::new(0.6, 0.0, 0.6);
        desc.velocities = desc
            .positions
            .iter()
            .map(|p| DVec3::new(0.0, 2.0, 0.0).cross(*p - centre))
            .collect();
        let mut fluid = Fluid::new(desc).unwrap();
        let mut bodies = Arena::default();
        tank(&mut bodies, DVec3::ZERO, DVec3::new(1.2, 1.2, 1.2));
        for _ in 0..60 {
            let loads = {
                let mut coupling = Coupling::gather(
                    &bodies,
                    fluid.positions(),
                    fluid.inverse_masses(),
                    fluid.reach(DT, Vec3::ZERO),
                    &[],
                );
                fluid.step(DT, Vec3::ZERO, &mut coupling);
                coupling.finish()
            };
            apply_changes(&mut bodies, &loads);
        }
        assert!(fluid.velocities().iter().all(|v| v.is_finite()));
        fluid
            .velocities()
            .iter()
            .map(|v| 0.5 * f64::from(v.length_squared()))
            .sum::<f64>()
    };
    let (without, with) = (energy(0.0), energy(0.5));
    eprintln!(
        "swirl after 1 s: kinetic energy {without:.2} J without confinement, {with:.2} J with"
    );
    assert!(with > without, "{with} <= {without}");
}
