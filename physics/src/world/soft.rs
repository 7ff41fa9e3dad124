//! Soft bodies (XPBD) in the world: adding, reading, pinning, attaching,
//! and the **soft** stage of the step.

use glam::DVec3;

use super::World;
use crate::energy::Energy;
use crate::error::{finite3, non_negative, PhysicsError};
use crate::handle::{BodyHandle, SoftBodyHandle};
use crate::xpbd::coupling::{apply_changes, Coupling};
use crate::xpbd::soft::{self, SoftAttachment, SoftBody, SoftBodyDesc};

impl World {
    /// Adds a soft body; refused with a typed error (nothing added) when
    /// the description is inconsistent: indices out of range, degenerate
    /// edges or tetrahedra, negative compliance, a pressure shell that
    /// encloses nothing, ...
    pub fn add_soft_body(&mut self, desc: &SoftBodyDesc) -> Result<SoftBodyHandle, PhysicsError> {
        let body = SoftBody::new(desc)?;
        let (index, generation) = self.soft_bodies.insert(body);
        Ok(SoftBodyHandle { index, generation })
    }

    /// Removes a soft body.
    pub fn remove_soft_body(&mut self, h: SoftBodyHandle) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = self.gpu.as_mut() {
            on_gpu.soft_bodies.remove(&(h.index, h.generation));
        }
        self.soft_bodies
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownSoftBody(h))
    }

    /// A soft body, or `None` for a stale handle.
    pub fn soft_body(&self, h: SoftBodyHandle) -> Option<&SoftBody> {
        self.soft_bodies.get(h.index, h.generation)
    }

    /// Every soft body, in handle order.
    pub fn soft_bodies(&self) -> impl Iterator<Item = (SoftBodyHandle, &SoftBody)> {
        self.soft_bodies
            .iter()
            .map(|(index, generation, b)| (SoftBodyHandle { index, generation }, b))
    }

    fn soft_mut(&mut self, h: SoftBodyHandle) -> Result<&mut SoftBody, PhysicsError> {
        self.soft_bodies
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownSoftBody(h))
    }

    /// Moves pinned particle `particle` of soft body `h` to `position`
    /// (m): a scripted anchor, such as the top of a flag on a moving
    /// pole. Refused for a particle that is not pinned.
    pub fn set_soft_pin(
        &mut self,
        h: SoftBodyHandle,
        particle: u32,
        position: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("soft pin position", position)?;
        let body = self.soft_mut(h)?;
        let i = particle as usize;
        if i >= body.len() || body.w[i] != 0.0 {
            return Err(PhysicsError::Invalid {
                what: "soft pin",
                why: format!("particle {particle} is not a pinned particle of the body"),
            });
        }
        body.set_pin(i, position.as_vec3());
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = self.gpu.as_ref() {
            if let Some(buffers) = on_gpu.soft_bodies.get(&(h.index, h.generation)) {
                crate::gpu::soft::set_pin(&on_gpu.ctx, buffers, i, position.as_vec3());
            }
        }
        Ok(())
    }

    /// Moves soft body `h` to `backend`, carrying its state across. On
    /// the GPU (feature `gpu`) it takes the same small steps in `f32`,
    /// colour by colour (`gpu/soft.rs`), with contacts against the rigid
    /// bodies near it that push the dynamic ones back as on the CPU
    /// (`gpu/bodies.rs`), attachments, pressure, plastic flow and
    /// self-collision (its candidates on the GPU's neighbour grid); a
    /// tearing body is read back every step and tears on the CPU, then
    /// goes up again (a self-colliding one is read back every step too,
    /// for its candidates' reach). A body with contacts near a rigid body
    /// of a shape other than a cuboid, sphere or capsule is refused there
    /// ([`PhysicsError::Gpu`]; a step that finds one near later moves the
    /// body back to the CPU and says so in
    /// [`StepReport::soft_bodies_to_cpu`](crate::StepReport)).
    /// A saved state does not keep the backend: a restored body steps on
    /// the CPU until moved again. With
    /// [`WorldConfig::gpu_readback_every_step`](crate::WorldConfig) off,
    /// call [`World::sync_gpu`] before reading or saving it.
    pub fn set_soft_backend(
        &mut self,
        h: SoftBodyHandle,
        backend: crate::particle_system::Backend,
    ) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        use crate::particle_system::Backend;
        let current = self
            .soft_body(h)
            .ok_or(PhysicsError::UnknownSoftBody(h))?
            .backend;
        if current == backend {
            return Ok(());
        }
        #[cfg(feature = "gpu")]
        {
            match backend {
                Backend::Gpu => {
                    self.on_gpu()?;
                    let on_gpu = self.gpu.as_mut().expect("created above");
                    let body = self
                        .soft_bodies
                        .get_mut(h.index, h.generation)
                        .expect("checked above");
                    // Refused here, not at the next step: bodies near it
                    // (or held to it) the GPU cannot take.
                    let touch = body.material.collision_radius > 0.0;
                    let reach = body.material.collision_radius as f32 + 1e-3;
                    let near = crate::gpu::bodies::near_box(&body.x, reach);
                    let attached = body.attached_bodies();
                    crate::gpu::bodies::gather(
                        &self.bodies,
                        &self.step_start,
                        near.as_ref(),
                        &attached,
                        touch,
                    )?;
                    let buffers = crate::gpu::soft::upload(
                        &on_gpu.ctx,
                        on_gpu.soft_pipelines.as_ref(),
                        body,
                    )?;
                    on_gpu.soft_bodies.insert((h.index, h.generation), buffers);
                    body.backend = Backend::Gpu;
                }
                Backend::Cpu => {
                    let on_gpu = self
                        .gpu
                        .as_mut()
                        .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                    let body = self
                        .soft_bodies
                        .get_mut(h.index, h.generation)
                        .expect("checked above");
                    if let Some(buffers) = on_gpu.soft_bodies.remove(&(h.index, h.generation)) {
                        crate::gpu::soft::download(&on_gpu.ctx, body, &buffers)?;
                    }
                    body.backend = Backend::Cpu;
                }
            }
            Ok(())
        }
        #[cfg(not(feature = "gpu"))]
        {
            let _ = backend;
            Err(PhysicsError::Gpu("this build has no `gpu` feature".into()))
        }
    }

    /// Holds particle `particle` of soft body `h` to the point of rigid
    /// body `body` now at `at` (m, world), with compliance `compliance`
    /// (m/N; 0 = rigid). Both ways: the body is pulled by the particle.
    pub fn attach_soft_to_body(
        &mut self,
        h: SoftBodyHandle,
        particle: u32,
        body: BodyHandle,
        at: DVec3,
        compliance: f64,
    ) -> Result<(), PhysicsError> {
        finite3("soft attachment point", at)?;
        non_negative("soft attachment compliance", compliance)?;
        let local = self
            .bodies
            .get(body.index, body.generation)
            .ok_or(PhysicsError::UnknownBody(body))?
            .pose()
            .inverse_transform_point(at);
        let World {
            soft_bodies,
            #[cfg(feature = "gpu")]
            gpu,
            ..
        } = self;
        let soft = soft_bodies
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownSoftBody(h))?;
        if particle as usize >= soft.len() {
            return Err(PhysicsError::Invalid {
                what: "soft attachment",
                why: format!("particle {particle} of {}", soft.len()),
            });
        }
        let attachment = SoftAttachment {
            particle,
            body,
            local,
            compliance: compliance as f32,
        };
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = gpu.as_mut() {
            let slot = (h.index, h.generation);
            if let Some(buffers) = on_gpu.soft_bodies.get(&slot) {
                // On the GPU: it comes back, takes the attachment and goes
                // up again (its buffers are sized for its attachments).
                crate::gpu::soft::download(&on_gpu.ctx, soft, buffers)?;
                soft.attachments.push(attachment);
                return match crate::gpu::soft::upload(
                    &on_gpu.ctx,
                    on_gpu.soft_pipelines.as_ref(),
                    soft,
                ) {
                    Ok(buffers) => {
                        on_gpu.soft_bodies.insert(slot, buffers);
                        Ok(())
                    }
                    Err(e) => {
                        soft.attachments.pop();
                        Err(e)
                    }
                };
            }
        }
        soft.attachments.push(attachment);
        Ok(())
    }

    /// Stage 4: every soft body, then every fluid, in handle order, takes
    /// its small steps against the rigid bodies as they now stand, and the
    /// bodies then take what its particles gave them before the next one
    /// steps (a fluid's emitters then fire the shots due by the end of the
    /// step).
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
    pub(super) fn stage_soft(
        &mut self,
        dt: f64,
        energy: &mut Energy,
        report: &mut super::StepReport,
    ) -> Result<(), PhysicsError> {
        if self.soft_bodies.len() == 0 && self.fluids.len() == 0 {
            return Ok(());
        }
        let gravity = self.gravity.as_vec3();
        let dt32 = dt as f32;
        // The world's time at the end of this step, when emitters fire.
        let now = self.time + dt;
        let World {
            soft_bodies,
            fluids,
            bodies,
            config,
            step_start,
            #[cfg(feature = "gpu")]
            gpu,
            ..
        } = self;
        for (index, generation, body) in soft_bodies.iter_mut() {
            body.attachments
                .retain(|a| bodies.get(a.body.index, a.body.generation).is_some());
            #[cfg(feature = "gpu")]
            let slot = (index, generation);
            #[cfg(feature = "gpu")]
            if let Some((on_gpu, buffers)) = gpu
                .as_mut()
                .and_then(|g| g.soft_bodies.get(&slot).cloned().map(|b| (g, b)))
            {
                let ctx = &on_gpu.ctx;
                let pipelines = on_gpu.soft_pipelines.as_ref();
                // A tearing body tears on the CPU, from its positions; a
                // self-colliding one finds its candidates' reach from its
                // velocities.
                let tears = body.material.tear_strain;
                let readback = config.gpu_readback_every_step
                    || tears.is_some()
                    || body.material.self_collision;
                let touch = body.material.collision_radius > 0.0;
                // From the mirror, where it is fresh (read back the step
                // before): the bodies near the particles, and
                // self-collision's reach.
                let travel = (readback && touch).then(|| body.travel(dt32, gravity));
                let near = travel.and_then(|t| {
                    let reach = body.material.collision_radius as f32 + t + 1e-3;
                    crate::gpu::bodies::near_box(&body.x, reach)
                });
                let attached = body.attached_bodies();
                match crate::gpu::bodies::gather(
                    bodies,
                    step_start,
                    near.as_ref(),
                    &attached,
                    touch,
                ) {
                    Ok(near) => {
                        let changes = crate::gpu::soft::step(
                            ctx, pipelines, body, &buffers, dt32, gravity, &near, travel, readback,
                        )?;
                        apply_changes(bodies, &changes);
                        if tears.is_some_and(|t| soft::tear(body, t as f32)) {
                            // Its constraints changed: it goes up again.
                            match crate::gpu::soft::upload(ctx, pipelines, body) {
                                Ok(buffers) => {
                                    on_gpu.soft_bodies.insert(slot, buffers);
                                }
                                Err(why) => {
                                    let h = SoftBodyHandle { index, generation };
                                    to_cpu(on_gpu, body, h, why, report);
                                }
                            }
                        }
                        if readback && config.energy_accounting {
                            let g = gravity.as_dvec3() * body.material.gravity_scale;
                            add_energy(energy, &body.x, &body.v, &body.w, g);
                        }
                        continue;
                    }
                    Err(why) => {
                        // Bodies the GPU cannot take came near: the body
                        // goes back to the CPU and steps there, from now on.
                        crate::gpu::soft::download(ctx, body, &buffers)?;
                        let h = SoftBodyHandle { index, generation };
                        to_cpu(on_gpu, body, h, why, report);
                    }
                }
            }
            let travel = body.travel(dt32, gravity);
            let reach = body.material.collision_radius as f32 + travel + 1e-3;
            let always = body.attached_bodies();
            let wants_bodies = body.material.collision_radius > 0.0 || !always.is_empty();
            let mut coupling = if wants_bodies {
                Coupling::gather(bodies, &body.x, &body.w, reach, &always)
            } else {
                Coupling::default()
            };
            coupling.over_step(step_start);
            soft::step(body, dt32, gravity, travel, &mut coupling);
            // The bodies take what this soft body did before the next one
            // gathers them: a body held by two soft bodies (a plank between
            // two ropes) is moved by each in turn, not twice from the same
            // pose.
            apply_changes(bodies, &coupling.finish());
            if config.energy_accounting {
                let g = gravity.as_dvec3() * body.material.gravity_scale;
                add_energy(energy, &body.x, &body.v, &body.w, g);
            }
        }
        for (index, generation, fluid) in fluids.iter_mut() {
            #[cfg(feature = "gpu")]
            let slot = (index, generation);
            #[cfg(feature = "gpu")]
            if let Some((on_gpu, buffers)) = gpu
                .as_mut()
                .and_then(|g| g.fluids.get(&slot).cloned().map(|b| (g, b)))
            {
                let ctx = &on_gpu.ctx;
                let pipelines = on_gpu.fluid_pipelines.as_ref();
                let readback = config.gpu_readback_every_step;
                let reach = fluid.reach(dt32, gravity);
                let near = readback
                    .then(|| crate::gpu::bodies::near_box(&fluid.x, reach))
                    .flatten();
                match crate::gpu::bodies::gather(bodies, step_start, near.as_ref(), &[], true) {
                    Ok(near) => {
                        let changes = crate::gpu::fluid::step(
                            ctx, pipelines, fluid, &buffers, dt32, gravity, &near, readback,
                        )?;
                        apply_changes(bodies, &changes);
                        // Emitters fire on the host: the fluid comes back,
                        // takes the shot and goes up again.
                        if fluid.shot_due(now) {
                            if !readback {
                                crate::gpu::fluid::download(ctx, fluid, &buffers)?;
                            }
                            fluid.emit(now);
                            if fluid.len() != buffers.n as usize {
                                let buffers = crate::gpu::fluid::upload(ctx, pipelines, fluid)?;
                                on_gpu.fluids.insert(slot, buffers);
                            }
                        }
                        if readback && config.energy_accounting {
                            let g = gravity.as_dvec3() * fluid.params().gravity_scale;
                            add_energy(energy, &fluid.x, &fluid.v, fluid.inverse_masses(), g);
                        }
                        continue;
                    }
                    Err(why) => {
                        // Bodies the GPU cannot take came near: the fluid
                        // goes back to the CPU and steps there, from now on.
                        crate::gpu::fluid::download(ctx, fluid, &buffers)?;
                        on_gpu.fluids.remove(&slot);
                        fluid.backend = crate::particle_system::Backend::Cpu;
                        let h = crate::handle::FluidHandle { index, generation };
                        report.fluids_to_cpu.push((h, why));
                    }
                }
            }
            let reach = fluid.reach(dt32, gravity);
            let mut coupling =
                Coupling::gather(bodies, &fluid.x, fluid.inverse_masses(), reach, &[]);
            coupling.over_step(step_start);
            fluid.step(dt32, gravity, &mut coupling);
            apply_changes(bodies, &coupling.finish());
            fluid.emit(now);
            if config.energy_accounting {
                let g = gravity.as_dvec3() * fluid.params().gravity_scale;
                add_energy(energy, &fluid.x, &fluid.v, fluid.inverse_masses(), g);
            }
        }
        Ok(())
    }
}

/// Soft body `h`, its mirror up to date and its GPU buffers dropped, steps
/// on the CPU from now on because of `why`, which the step's report says.
#[cfg(feature = "gpu")]
fn to_cpu(
    on_gpu: &mut crate::gpu::OnGpu,
    body: &mut SoftBody,
    h: SoftBodyHandle,
    why: PhysicsError,
    report: &mut super::StepReport,
) {
    on_gpu.soft_bodies.remove(&(h.index, h.generation));
    body.backend = crate::particle_system::Backend::Cpu;
    report.soft_bodies_to_cpu.push((h, why));
}

/// Adds the kinetic and uniform-gravity energy of particles (J) to `energy`.
fn add_energy(energy: &mut Energy, x: &[glam::Vec3], v: &[glam::Vec3], w: &[f32], g: DVec3) {
    for ((x, v), w) in x.iter().zip(v).zip(w) {
        if *w > 0.0 {
            let m = 1.0 / f64::from(*w);
            energy.kinetic += 0.5 * m * f64::from(v.length_squared());
            energy.gravity_uniform -= m * g.dot(x.as_dvec3());
        }
    }
}
