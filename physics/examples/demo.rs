//! The built-in demo: steps particle worlds and prints what they show.
//!
//! 1. The lecture projectile (v0 = (2, 3), a = (0, -1), dt = 1 s) under each
//!    integrator, next to the closed form.
//! 2. An eccentric orbit, ten periods at a coarse step: how far each
//!    integrator drifts in energy and position. Also drawn to
//!    `target/demo/orbits.svg`.
//! 3. A cloth in wind hit by an explosion, with the step's stage timings.
//! 4. A brick spun about its intermediate axis tumbles (drawn to
//!    `target/demo/tumble.svg`).
//! 5. A heap of boxes, balls and capsules falls onto the ground.
//!
//! Run: `cargo run --release -p inertia-physics --example demo`

use std::f64::consts::PI;
use std::fmt::Write as _;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    build_cloth, ClothDesc, Explosion, GravityMethod, Integrator, MutualGravity, ParticleDesc,
    SpringStiffness, SystemDesc, UniformGravity, Wind, World, WorldConfig,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("Inertia physics engine demo\n");
    projectile()?;
    let paths = orbits()?;
    cloth()?;
    let spin = tumbling_brick()?;
    pile()?;
    std::fs::create_dir_all("target/demo")?;
    std::fs::write("target/demo/orbits.svg", orbit_svg(&paths))?;
    std::fs::write("target/demo/tumble.svg", tumble_svg(&spin))?;
    println!("\nPictures written to target/demo/orbits.svg and target/demo/tumble.svg");
    Ok(())
}

/// The tennis-racket theorem: a brick spun about its intermediate axis
/// flips over and back, while its angular momentum stays fixed.
fn tumbling_brick() -> Result<Vec<(f64, DVec3)>, Box<dyn std::error::Error>> {
    println!("\n4. A 1×2×3 m brick spun at 3 rad/s about its intermediate axis (the tennis-racket theorem)");
    let mut world = World::new(WorldConfig::default())?;
    let shape = Shape::cuboid(DVec3::new(0.5, 1.0, 1.5))?;
    let desc = RigidBodyDesc::dynamic(shape, 1000.0, Pose::IDENTITY)?
        .with_velocity(DVec3::ZERO, DVec3::new(1e-3, 3.0, 1e-3));
    let brick = world.add_body(&desc)?;
    let l0 = world.body(brick).ok_or("body vanished")?.angular_momentum();
    println!(
        "{:>8} {:>34} {:>22}",
        "t (s)", "body Y axis in the world", "|ΔL| / |L|"
    );
    let mut samples = Vec::new();
    for tick in 1..=1800 {
        world.step(1.0 / 60.0)?;
        let b = world.body(brick).ok_or("body vanished")?;
        let axis = b.pose().rotation * DVec3::Y;
        samples.push((tick as f64 / 60.0, axis));
        if tick % 150 == 0 {
            let dl = (b.angular_momentum() - l0).length() / l0.length();
            println!(
                "{:>8.1} {:>34} {:>22.2e}",
                tick as f64 / 60.0,
                format!("({:+.3}, {:+.3}, {:+.3})", axis.x, axis.y, axis.z),
                dl
            );
        }
    }
    println!("   the axis swings to -Y and back again and again; angular momentum is conserved to rounding.");
    Ok(samples)
}

/// Bodies of three shapes dropped in a heap on the ground.
fn pile() -> Result<(), Box<dyn std::error::Error>> {
    println!("\n5. 60 boxes, balls and capsules dropped on the ground (60 Hz, 4 substeps)");
    let mut world = World::new(WorldConfig::default())?;
    world.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    world.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(10.0, 0.5, 10.0))?,
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))?;
    for i in 0..60 {
        let (x, z) = ((i % 4) as f64 * 0.7 - 1.0, ((i / 4) % 4) as f64 * 0.7 - 1.0);
        let p = DVec3::new(x, 0.5 + (i / 16) as f64 * 0.8, z);
        let shape = match i % 3 {
            0 => Shape::cuboid(DVec3::new(0.3, 0.2, 0.25))?,
            1 => Shape::sphere(0.25)?,
            _ => Shape::capsule(0.2, 0.15)?,
        };
        let mut d = RigidBodyDesc::dynamic(
            shape,
            500.0,
            Pose::new(p, inertia_physics::glam::DQuat::from_rotation_y(i as f64)),
        )?;
        d.restitution = 0.2;
        world.add_body(&d)?;
    }
    println!(
        "{:>8} {:>12} {:>16} {:>12}",
        "t (s)", "manifolds", "kinetic (J)", "step (ms)"
    );
    for tick in 1..=240 {
        let r = world.step(1.0 / 60.0)?;
        if tick % 40 == 0 {
            println!(
                "{:>8.2} {:>12} {:>16.3} {:>12.3}",
                r.time,
                world.contact_count(),
                r.energy.kinetic,
                world.profile().bodies.as_secs_f64() * 1e3
            );
        }
    }
    let lowest = world
        .bodies()
        .filter(|(_, b)| b.kind() == BodyKind::Dynamic)
        .map(|(_, b)| b.center_of_mass().y)
        .fold(f64::INFINITY, f64::min);
    println!("   the heap settles (balls roll on: there is no rolling resistance yet); lowest body centre {lowest:.3} m above the ground.");
    Ok(())
}

/// The Y component of the brick's intermediate axis over time.
fn tumble_svg(samples: &[(f64, DVec3)]) -> String {
    let (w, h) = (640.0, 260.0);
    let t_max = samples.last().map_or(1.0, |s| s.0);
    let pts: Vec<String> = samples
        .iter()
        .map(|(t, a)| {
            format!(
                "{:.1},{:.1}",
                40.0 + t / t_max * (w - 60.0),
                h / 2.0 - a.y * (h / 2.0 - 30.0)
            )
        })
        .collect();
    format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' viewBox='0 0 {w} {h}'>\n\
         <rect width='100%' height='100%' fill='white'/>\n\
         <text x='10' y='20' font-family='sans-serif' font-size='14'>Intermediate axis · world Y, over {t_max:.0} s</text>\n\
         <line x1='40' y1='{mid}' x2='{x2}' y2='{mid}' stroke='#bbb'/>\n\
         <text x='8' y='{top}' font-family='sans-serif' font-size='12'>+1</text>\n\
         <text x='8' y='{bottom}' font-family='sans-serif' font-size='12'>-1</text>\n\
         <polyline fill='none' stroke='#1f77b4' stroke-width='1.5' points='{}'/>\n</svg>\n",
        pts.join(" "),
        mid = h / 2.0,
        x2 = w - 20.0,
        top = 34.0,
        bottom = h - 26.0,
    )
}

fn projectile() -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "1. Projectile, v0 = (2, 3) m/s, a = (0, -1) m/s², dt = 1 s (height y at each second)"
    );
    let mut header = format!("{:>18}", "t =");
    for t in 0..=7 {
        write!(header, "{t:>7}")?;
    }
    println!("{header}");
    let mut row = format!("{:>18}", "closed form");
    for t in 0..=7 {
        let t = t as f64;
        write!(row, "{:>7.2}", 3.0 * t - 0.5 * t * t)?;
    }
    println!("{row}");
    for integrator in Integrator::ALL {
        let mut world = World::new(WorldConfig::default())?;
        let sys = world.add_system(SystemDesc::with_integrator(integrator));
        world.add_force(
            sys,
            UniformGravity {
                g: 1.0,
                direction: DVec3::NEG_Y,
            },
        )?;
        let p = world.add_particle(
            sys,
            ParticleDesc::at(DVec3::ZERO, 1.0).with_velocity(DVec3::new(2.0, 3.0, 0.0)),
        )?;
        let mut row = format!("{:>18}", integrator.name());
        for _ in 0..=7 {
            write!(
                row,
                "{:>7.2}",
                world.particle(p).ok_or("particle vanished")?.position.y
            )?;
            world.step(1.0)?;
        }
        println!("{row}");
    }
    println!("   forward Euler reproduces the lecture table (0,0) (2,3) (4,5) (6,6) (8,6) (10,5) (12,3) (14,0);");
    println!("   symplectic Euler overshoots by the same ½·a·t·dt; the higher-order methods are exact here.\n");
    Ok(())
}

/// Each integrator's orbit path.
type Paths = Vec<(Integrator, Vec<DVec3>)>;

fn orbits() -> Result<Paths, Box<dyn std::error::Error>> {
    let (a, e) = (1.0, 0.6);
    let period = 2.0 * PI;
    let dt = period / 200.0;
    println!("2. Orbit around a fixed star, GM = 1, a = 1, e = {e}, ten periods at dt = T/200");
    println!(
        "{:>18} {:>16} {:>18} {:>12}",
        "integrator", "energy drift", "return miss (m)", "µs/step"
    );
    let mut paths = Vec::new();
    for integrator in Integrator::ALL {
        let mut world = World::new(WorldConfig {
            threads: 1,
            ..WorldConfig::default()
        })?;
        let sys = world.add_system(SystemDesc::with_integrator(integrator));
        world.add_force(
            sys,
            MutualGravity {
                g_constant: 1.0,
                softening: 0.0,
                method: GravityMethod::Exact,
            },
        )?;
        world.add_particle(
            sys,
            ParticleDesc {
                pinned: true,
                ..ParticleDesc::at(DVec3::ZERO, 1.0)
            },
        )?;
        let rp = a * (1.0 - e);
        let start = DVec3::new(rp, 0.0, 0.0);
        let body = world.add_particle(
            sys,
            ParticleDesc::at(start, 1e-6).with_velocity(DVec3::new(
                0.0,
                ((1.0 + e) / rp).sqrt(),
                0.0,
            )),
        )?;
        let e0 = world.compute_energy().total();
        let mut path = vec![start];
        let t0 = std::time::Instant::now();
        for _ in 0..2000 {
            world.step(dt)?;
            path.push(world.particle(body).ok_or("particle vanished")?.position);
        }
        let us = t0.elapsed().as_secs_f64() * 1e6 / 2000.0;
        let drift = (world.energy().total() - e0) / e0.abs();
        let miss = (path[path.len() - 1] - start).length();
        println!(
            "{:>18} {:>+16.3e} {:>18.4} {:>12.2}",
            integrator.name(),
            drift,
            miss,
            us
        );
        paths.push((integrator, path));
    }
    println!("   symplectic methods keep the energy bounded; forward Euler spirals outwards, RK4 slowly inwards.\n");
    Ok(paths)
}

fn cloth() -> Result<(), Box<dyn std::error::Error>> {
    println!("3. A 32×32 cloth pinned at two corners, in wind, hit by a blast at t = 1 s (60 Hz)");
    let mut world = World::new(WorldConfig::default())?;
    let sys = world.add_system(SystemDesc::default());
    world.add_force(sys, UniformGravity::earth())?;
    world.add_force(
        sys,
        Wind {
            velocity: DVec3::new(0.0, 0.0, 3.0),
            ..Wind::default()
        },
    )?;
    world.add_force(
        sys,
        Explosion {
            center: DVec3::new(1.0, -1.5, -1.0),
            start_time: 1.0,
            front_speed: 30.0,
            peak_pressure: 400.0,
            max_radius: 6.0,
            ..Explosion::default()
        },
    )?;
    let n = 32;
    let cloth = build_cloth(
        &mut world,
        sys,
        &ClothDesc {
            nu: n,
            nv: n,
            width: 2.0,
            height: 2.0,
            mass: 2.0,
            v_axis: DVec3::NEG_Y,
            drag_linear: 0.002,
            structural: SpringStiffness {
                stiffness: 150.0,
                damping: 0.02,
            },
            shear: SpringStiffness {
                stiffness: 40.0,
                damping: 0.01,
            },
            bend: SpringStiffness {
                stiffness: 8.0,
                damping: 0.002,
            },
            pinned: vec![(0, 0), (n - 1, 0)],
            ..ClothDesc::default()
        },
    )?;
    let corner = cloth.particles[n * n - 1];
    println!(
        "   {} particles, {} springs, {} substeps per tick, spring stiffness scale {}",
        cloth.particles.len(),
        cloth.spring_counts.iter().sum::<usize>(),
        world.substeps_for(sys, 1.0 / 60.0),
        world
            .system(sys)
            .map_or(1.0, |s| s.spring_stiffness_scale())
    );
    println!(
        "{:>8} {:>28} {:>14} {:>12}",
        "t (s)", "free corner position (m)", "energy (J)", "step (ms)"
    );
    for tick in 1..=180 {
        let r = world.step(1.0 / 60.0)?;
        if tick % 20 == 0 {
            let p = world.particle(corner).ok_or("particle vanished")?.position;
            println!(
                "{:>8.2} {:>28} {:>14.4} {:>12.3}",
                r.time,
                format!("({:+.3}, {:+.3}, {:+.3})", p.x, p.y, p.z),
                r.energy.total(),
                world.profile().total.as_secs_f64() * 1e3
            );
        }
    }
    let t = world.profile_totals();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3 / t.steps as f64;
    println!(
        "   mean stage times per tick: prepare {:.3} ms, forces {:.3} ms, integrate {:.3} ms, energy {:.3} ms, total {:.3} ms",
        ms(t.sum.prepare),
        ms(t.sum.forces),
        ms(t.sum.integrate),
        ms(t.sum.energy),
        ms(t.sum.total)
    );
    println!(
        "   state hash after {} ticks: {:#018x}",
        world.tick(),
        world.state_hash()
    );
    Ok(())
}

/// A small SVG of the orbit paths, one colour per integrator.
fn orbit_svg(paths: &[(Integrator, Vec<DVec3>)]) -> String {
    let colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e"];
    let (w, h, scale) = (640.0, 520.0, 150.0);
    let (cx, cy) = (w * 0.62, h * 0.5);
    let mut s = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' viewBox='0 0 {w} {h}'>\n\
         <rect width='100%' height='100%' fill='white'/>\n\
         <text x='10' y='20' font-family='sans-serif' font-size='14'>Ten orbits, e = 0.6, dt = T/200</text>\n\
         <circle cx='{cx}' cy='{cy}' r='4' fill='black'/>\n"
    );
    for (k, (integrator, path)) in paths.iter().enumerate() {
        let pts: Vec<String> = path
            .iter()
            .map(|p| {
                format!(
                    "{:.1},{:.1}",
                    cx + p.x.clamp(-3.0, 3.0) * scale,
                    cy - p.y.clamp(-3.0, 3.0) * scale
                )
            })
            .collect();
        let c = colours[k % colours.len()];
        let _ = writeln!(
            s,
            "<polyline fill='none' stroke='{c}' stroke-width='1' points='{}'/>",
            pts.join(" ")
        );
        let _ = writeln!(
            s,
            "<text x='10' y='{}' font-family='sans-serif' font-size='13' fill='{c}'>{}</text>",
            45 + 18 * k,
            integrator.name()
        );
    }
    s.push_str("</svg>\n");
    s
}
