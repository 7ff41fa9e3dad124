//! What a world at rest costs while something else moves: a grid of boxes
//! asleep on the ground, and one ball bouncing far from them. Prints the
//! median step with and without the sleeping boxes, ms:
//! `cargo run --release -p inertia-physics --example sleeping_world -- [boxes] [steps] [threads]`.

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{World, WorldConfig};

fn world(boxes: usize, threads: usize) -> Result<World, Box<dyn std::error::Error>> {
    let mut w = World::new(WorldConfig {
        threads,
        ..WorldConfig::default()
    })?;
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = true;
    w.set_solver_config(cfg)?;
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(500.0, 0.5, 500.0))?,
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))?;
    let side = (boxes as f64).sqrt().ceil() as usize;
    for k in 0..boxes {
        let (i, j) = ((k % side) as f64, (k / side) as f64);
        w.add_body(&RigidBodyDesc::dynamic(
            Shape::cuboid(DVec3::splat(0.5))?,
            300.0,
            Pose::from_translation(DVec3::new(i * 2.0, 0.5, j * 2.0)),
        )?)?;
    }
    // Let them fall asleep, then drop a bouncing ball far away.
    for _ in 0..120 {
        w.step(1.0 / 60.0)?;
    }
    w.add_body(
        &RigidBodyDesc::dynamic(
            Shape::sphere(0.5)?,
            300.0,
            Pose::from_translation(DVec3::new(-200.0, 5.0, -200.0)),
        )?
        .with_restitution(0.9)
        .with_can_sleep(false),
    )?;
    Ok(w)
}

fn median_step_ms(w: &mut World, steps: usize) -> Result<f64, Box<dyn std::error::Error>> {
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps {
        let t = Instant::now();
        w.step(1.0 / 60.0)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    Ok(times[steps / 2])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>());
    let boxes = args.next().transpose()?.unwrap_or(5000);
    let steps = args.next().transpose()?.unwrap_or(300);
    let threads = args.next().transpose()?.unwrap_or(1);
    let mut crowd = world(boxes, threads)?;
    let asleep = crowd.bodies().filter(|(_, b)| b.is_sleeping()).count();
    let mut alone = world(0, threads)?;
    let before = crowd.profile_totals().sum.rigid;
    let (with, without) = (
        median_step_ms(&mut crowd, steps)?,
        median_step_ms(&mut alone, steps)?,
    );
    let r = crowd.profile_totals().sum.rigid;
    let per = |d: std::time::Duration| d.as_secs_f64() * 1e3 / steps as f64;
    println!(
        "rigid stages with them, ms a step: forces {:.3}, broad {:.3}, narrow {:.3}, colouring {:.3}, solve {:.3}, finish {:.3}, islands {:.3}",
        per(r.forces - before.forces), per(r.broad_phase - before.broad_phase), per(r.narrow_phase - before.narrow_phase), per(r.colouring - before.colouring),
        per(r.solve - before.solve), per(r.finish - before.finish), per(r.islands - before.islands)
    );
    println!(
        "{asleep} of {boxes} boxes asleep; one ball bouncing: {with:.4} ms a step with them, {without:.4} ms without ({:.0} ns per sleeping body)",
        (with - without) * 1e6 / asleep.max(1) as f64
    );
    Ok(())
}
