//! Moving a system to and from the GPU, and stepping it there.

use glam::DVec3;

use crate::energy::Energy;
use crate::error::PhysicsError;
use crate::particle_system::step::FLAG_NEW_QUARANTINE;
use crate::particle_system::{ParticleSystem, FLAG_PINNED, FLAG_QUARANTINED};

use super::buffers::{Contents, GpuSystem};
use super::context::GpuContext;
use super::layout::{self, GpuBody};
use super::params;

/// Uploads `sys` to GPU buffers. Refuses, leaving `sys` unchanged, what
/// the GPU path cannot step (see [`params::check_supported`]) and values
/// outside the f32 range.
pub(crate) fn upload(
    ctx: &GpuContext,
    sys: &mut ParticleSystem,
) -> Result<GpuSystem, PhysicsError> {
    params::check_supported(sys)?;
    sys.refresh_topology();
    let mut bodies = layout::bodies(sys)?;
    for b in &mut bodies {
        b.flags &= FLAG_PINNED | FLAG_QUARANTINED;
    }
    let gpu = GpuSystem::create(
        ctx,
        &Contents {
            bodies: &bodies,
            props: &layout::props(sys)?,
            springs: &layout::springs(sys)?,
            csr: &layout::csr(sys),
            control: &layout::control(sys)?,
        },
    )?;
    Ok(gpu)
}

/// Brings `sys`'s CPU arrays up to date with its GPU state `gpu` (a no-op
/// when they already are: right after upload, where the mirror keeps the
/// exact f64 values, and after a step with readback).
pub(crate) fn download(
    ctx: &GpuContext,
    sys: &mut ParticleSystem,
    gpu: &mut GpuSystem,
) -> Result<(), PhysicsError> {
    if !gpu.mirror_fresh {
        let bodies = ctx
            .scoped("reading back a particle system", || {
                let mut encoder =
                    ctx.device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("particle download"),
                        });
                gpu.record_readback(&mut encoder);
                ctx.queue.submit([encoder.finish()]);
                Ok(())
            })
            .and_then(|()| gpu.read_bodies(ctx))?;
        write_mirror(sys, &bodies)?;
    }
    // Quarantines from steps without readback were never reported; the
    // transient flag is not part of the state.
    for f in &mut sys.flags {
        *f &= !FLAG_NEW_QUARANTINE;
    }
    gpu.mirror_fresh = true;
    Ok(())
}

/// Copies GPU bodies (f32) into the CPU arrays (f64).
fn write_mirror(sys: &mut ParticleSystem, bodies: &[GpuBody]) -> Result<(), PhysicsError> {
    if bodies.len() != sys.len() {
        return Err(PhysicsError::Gpu(format!(
            "read back {} particles, the system has {}",
            bodies.len(),
            sys.len()
        )));
    }
    let v3 = |a: [f32; 3]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
    for (i, b) in bodies.iter().enumerate() {
        sys.position[i] = v3(b.pos);
        sys.velocity[i] = v3(b.vel);
        sys.flags[i] = b.flags;
    }
    Ok(())
}

/// Steps one GPU system by `dt` s from time `t` s, cut into the same
/// substeps as the CPU path (`ParticleSystem::substeps_for`: stiff springs
/// are stepped at `h = dt / n`, and softened by the same factors when the
/// substep budget runs out). Each substep is one submission of the
/// springs, interactions and integration passes. With `readback`, waits,
/// copies positions, velocities and flags into the CPU arrays and returns
/// kinetic and uniform-gravity energy summed on the CPU in index order;
/// without it, returns zero energy and leaves the CPU arrays stale.
/// `gravity` is the world's, m/s².
pub(crate) fn step_system(
    ctx: &GpuContext,
    sys: &mut ParticleSystem,
    gpu: &mut GpuSystem,
    gravity: DVec3,
    t: f64,
    dt: f64,
    readback: bool,
) -> Result<Energy, PhysicsError> {
    let substeps = sys.substeps_for(dt);
    let h = dt / f64::from(substeps);

    // Compile every substep's uniform block first: anything unsupported is
    // refused before any work is submitted.
    let blocks = (0..substeps)
        .map(|k| {
            let mut p = params::compile(sys, gravity, t + f64::from(k) * h, h)?;
            p.first_substep = u32::from(k == 0);
            Ok(p)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let first = &blocks[0];
    if gpu.n != first.n || gpu.n_springs != first.n_springs {
        return Err(PhysicsError::Gpu(
            "the system changed shape since its upload; move it to the CPU and back".into(),
        ));
    }
    let springs_grid = ctx.workgroups(first.n_springs)?;
    let particles_grid = ctx.workgroups(first.n)?;
    ctx.scoped("a GPU particle step", || {
        for (k, params) in blocks.iter().enumerate() {
            // Written before this submission runs, after the previous one.
            ctx.queue
                .write_buffer(&gpu.params, 0, bytemuck::bytes_of(params));
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("particle step"),
                });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("particle step"),
                    timestamp_writes: None,
                });
                // Each dispatch is its own usage scope: wgpu orders them with
                // barriers, so pass 2 sees pass 1's writes and pass 3 sees
                // pass 2's.
                if params.n_springs > 0 {
                    pass.set_pipeline(&ctx.springs);
                    pass.set_bind_group(0, &gpu.springs_group, &[]);
                    pass.dispatch_workgroups(springs_grid.0, springs_grid.1, 1);
                }
                if params.n > 0 && params.has_interaction != 0 {
                    pass.set_pipeline(&ctx.interactions);
                    pass.set_bind_group(0, &gpu.interactions_group, &[]);
                    pass.dispatch_workgroups(particles_grid.0, particles_grid.1, 1);
                }
                if params.n > 0 {
                    pass.set_pipeline(&ctx.integrate);
                    pass.set_bind_group(0, &gpu.integrate_group, &[]);
                    pass.dispatch_workgroups(particles_grid.0, particles_grid.1, 1);
                }
            }
            if readback && k + 1 == blocks.len() {
                gpu.record_readback(&mut encoder);
            }
            ctx.queue.submit([encoder.finish()]);
        }
        Ok(())
    })?;
    if !readback {
        // Reclaim finished submissions without waiting.
        let _ = ctx.device.poll(wgpu::PollType::Poll);
        gpu.mirror_fresh = false;
        return Ok(Energy::default());
    }
    let bodies = gpu.read_bodies(ctx)?;
    write_mirror(sys, &bodies)?;
    gpu.mirror_fresh = true;
    let g = sys.field_forces(gravity, t, dt);
    let mut e = Energy::default();
    for i in 0..sys.len() {
        e.kinetic += 0.5 * sys.velocity[i].length_squared() / sys.inv_mass[i];
        e.gravity_uniform += g.gravity_potential(sys.position[i], sys.inv_mass[i]);
    }
    Ok(e)
}
