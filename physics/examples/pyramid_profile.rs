//! Times the rigid pipeline on a box pyramid with sleeping off:
//! `cargo run --release -p inertia-physics --example pyramid_profile -- [rows] [steps] [threads] [sleep: 0|1]`.

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{World, WorldConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>());
    let rows = args.next().transpose()?.unwrap_or(100);
    let steps = args.next().transpose()?.unwrap_or(60);
    let threads = args.next().transpose()?.unwrap_or(1);
    let sleep = args.next().transpose()?.unwrap_or(0) != 0;
    let mut w = World::new(WorldConfig {
        threads,
        ..WorldConfig::default()
    })?;
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = sleep;
    w.set_solver_config(cfg)?;
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(200.0, 0.5, 200.0))?,
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))?;
    for row in 0..rows {
        for i in 0..(rows - row) {
            let x = (i as f64 - (rows - row) as f64 / 2.0) * 1.05;
            let p = Pose::from_translation(DVec3::new(x, 0.5 + row as f64, 0.0));
            w.add_body(&RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.5))?,
                300.0,
                p,
            )?)?;
        }
    }
    if sleep {
        // Let it settle and fall asleep first.
        for _ in 0..200 {
            w.step(1.0 / 60.0)?;
        }
    }
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps {
        let t = Instant::now();
        w.step(1.0 / 60.0)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{} bodies, {} contacts: median {:.2} ms/step, max {:.2}",
        w.bodies().count(),
        w.contact_count(),
        times[times.len() / 2],
        times[times.len() - 1]
    );
    let p = w.profile();
    eprintln!("{p:?}");
    Ok(())
}
