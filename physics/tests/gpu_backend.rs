//! Moving systems between the CPU and GPU backends, what the GPU backend
//! refuses, pinning, quarantine, readback and save/restore on the GPU.
//!
//! Run: `cargo test -p inertia-physics --features gpu --test integration gpu_backend::`.
//! Without a GPU these run on Mesa lavapipe / llvmpipe; with no adapter at
//! all they fail unless `INERTIA_SKIP_GPU_TESTS=1`.
#![cfg(feature = "gpu")]

use crate::gpu_support;

use gpu_support::{cpu_config, default_gpu_world, gpu_world, max_diff, Lcg};
use inertia_physics::glam::DVec3;
use inertia_physics::gpu::GPU_TOLERANCE;
use inertia_physics::{
    build_rope, Backend, Drag, GravityMethod, Integrator, MutualGravity, ParticleDesc,
    PhysicsError, RopeDesc, SystemDesc, SystemHandle, UniformGravity, World, WorldConfig,
};

/// A hanging rope with drag plus a few free particles under gravity.
fn scene(w: &mut World) -> SystemHandle {
    let sys = w.add_system(SystemDesc::with_integrator(Integrator::SymplecticEuler));
    build_rope(
        w,
        sys,
        &RopeDesc {
            start: DVec3::new(0.0, 3.0, 0.0),
            end: DVec3::new(2.0, 3.0, 0.0),
            segments: 12,
            mass: 0.5,
            stiffness: 400.0,
            damping: 0.5,
            drag_linear: 0.02,
            ..RopeDesc::default()
        },
    )
    .unwrap();
    let mut rng = Lcg(11);
    for _ in 0..20 {
        w.add_particle(
            sys,
            ParticleDesc {
                position: rng.vec(5.0),
                velocity: rng.vec(2.0),
                mass: rng.range(0.2, 2.0),
                drag_quadratic: 0.01,
                ..ParticleDesc::default()
            },
        )
        .unwrap();
    }
    w.add_force(sys, UniformGravity::earth()).unwrap();
    w.add_force(sys, Drag::default()).unwrap();
    sys
}

fn is_gpu_error(e: &PhysicsError) -> bool {
    matches!(e, PhysicsError::Gpu(_))
}

#[test]
fn round_trip_without_steps_is_lossless() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    for _ in 0..3 {
        w.step(1.0 / 60.0).unwrap();
    }
    let before = w.state_hash();
    w.set_backend(sys, Backend::Gpu).unwrap();
    assert_eq!(w.system(sys).unwrap().backend(), Backend::Gpu);
    w.sync_gpu().unwrap();
    w.set_backend(sys, Backend::Cpu).unwrap();
    assert_eq!(w.system(sys).unwrap().backend(), Backend::Cpu);
    // The f64 mirror is kept until the GPU steps, so nothing was rounded.
    assert_eq!(w.state_hash(), before);
}

#[test]
fn state_moves_cpu_to_gpu_to_cpu() {
    let mut moved = gpu_or_skip!(default_gpu_world());
    let mut reference = World::new(cpu_config()).unwrap();
    let a = scene(&mut moved);
    let b = scene(&mut reference);
    let dt = 1.0 / 120.0;
    let mut x_scale: f64 = 0.0;
    let mut v_scale: f64 = 0.0;
    for k in 0..90 {
        if k == 30 {
            moved.set_backend(a, Backend::Gpu).unwrap();
        }
        if k == 60 {
            moved.set_backend(a, Backend::Cpu).unwrap();
            assert!(moved.system(a).unwrap().backend() == Backend::Cpu);
        }
        moved.step(dt).unwrap();
        reference.step(dt).unwrap();
        let s = reference.system(b).unwrap();
        x_scale = x_scale.max(max_diff(s.positions(), s.positions()).1);
        v_scale = v_scale.max(max_diff(s.velocities(), s.velocities()).1);
    }
    let (m, r) = (moved.system(a).unwrap(), reference.system(b).unwrap());
    let (dx, _) = max_diff(m.positions(), r.positions());
    let (dv, _) = max_diff(m.velocities(), r.velocities());
    // 30 steps ran in f32; the rest in f64 from the downloaded state.
    eprintln!("CPU->GPU->CPU: |dx| = {dx:.3e} m, |dv| = {dv:.3e} m/s after 90 steps");
    assert!(dx <= GPU_TOLERANCE.bound(90, x_scale), "dx = {dx:e}");
    assert!(dv <= GPU_TOLERANCE.bound(90, v_scale), "dv = {dv:e}");
    // Back on the CPU the system is editable again.
    moved
        .add_particle(a, ParticleDesc::at(DVec3::ZERO, 1.0))
        .unwrap();
    moved.step(dt).unwrap();
}

#[test]
fn unsupported_integrators_are_refused_at_upload() {
    let mut w = gpu_or_skip!(default_gpu_world());
    for integrator in [Integrator::Leapfrog, Integrator::Verlet, Integrator::Rk4] {
        let sys = w.add_system(SystemDesc::with_integrator(integrator));
        w.add_particle(sys, ParticleDesc::at(DVec3::ONE, 1.0))
            .unwrap();
        let e = w.set_backend(sys, Backend::Gpu).unwrap_err();
        assert!(is_gpu_error(&e), "{e}");
        assert!(e.to_string().contains(integrator.name()), "{e}");
        assert_eq!(w.system(sys).unwrap().backend(), Backend::Cpu);
    }
    // Refusal changed nothing: the world still steps on the CPU.
    w.step(0.01).unwrap();
}

#[test]
fn integrator_changed_on_the_gpu_is_refused_at_step() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    w.set_backend(sys, Backend::Gpu).unwrap();
    w.step(0.01).unwrap();
    let before = w.state_hash();
    w.set_integrator(sys, Integrator::Rk4).unwrap();
    let e = w.step(0.01).unwrap_err();
    assert!(is_gpu_error(&e), "{e}");
    w.set_integrator(sys, Integrator::SymplecticEuler).unwrap();
    assert_eq!(w.state_hash(), before, "a refused step must change nothing");
    w.step(0.01).unwrap();
}

#[test]
fn barnes_hut_is_refused_at_upload_and_at_step() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    let bh = MutualGravity {
        g_constant: 1.0,
        softening: 0.1,
        method: GravityMethod::BarnesHut { theta: 0.5 },
    };
    let f = w.add_force(sys, bh).unwrap();
    let e = w.set_backend(sys, Backend::Gpu).unwrap_err();
    assert!(is_gpu_error(&e) && e.to_string().contains("Barnes"), "{e}");
    w.remove_force(f).unwrap();
    w.set_backend(sys, Backend::Gpu).unwrap();
    // Forces may change while on the GPU: an unsupported one added later
    // is refused by the step, before anything is dispatched.
    let f = w.add_force(sys, bh).unwrap();
    assert!(is_gpu_error(&w.step(0.01).unwrap_err()));
    w.set_force(
        f,
        MutualGravity {
            method: GravityMethod::Exact,
            ..bh
        },
    )
    .unwrap();
    w.step(0.01).unwrap();
}

#[test]
fn values_outside_f32_are_refused_at_upload() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = w.add_system(SystemDesc::default());
    w.add_particle(sys, ParticleDesc::at(DVec3::new(1e39, 0.0, 0.0), 1.0))
        .unwrap();
    let e = w.set_backend(sys, Backend::Gpu).unwrap_err();
    assert!(is_gpu_error(&e) && e.to_string().contains("f32"), "{e}");
    assert_eq!(w.system(sys).unwrap().backend(), Backend::Cpu);
}

#[test]
fn structural_edits_wait_for_the_cpu() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    w.set_backend(sys, Backend::Gpu).unwrap();
    let e = w
        .add_particle(sys, ParticleDesc::at(DVec3::ZERO, 1.0))
        .unwrap_err();
    assert!(is_gpu_error(&e));
}

#[test]
fn pinned_particles_do_not_move_on_the_gpu() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    let pinned: Vec<_> = w
        .system(sys)
        .unwrap()
        .particle_handles()
        .filter(|h| w.particle(*h).unwrap().pinned)
        .collect();
    assert!(!pinned.is_empty());
    let at: Vec<_> = pinned.iter().map(|h| w.particle(*h).unwrap()).collect();
    w.set_backend(sys, Backend::Gpu).unwrap();
    for _ in 0..50 {
        w.step(1.0 / 60.0).unwrap();
    }
    for (h, before) in pinned.iter().zip(&at) {
        let now = w.particle(*h).unwrap();
        // Exactly where it was, up to the f32 rounding of the upload.
        assert_eq!(now.position, before.position.as_vec3().as_dvec3());
        assert_eq!(now.velocity, DVec3::ZERO);
        assert!(now.pinned);
    }
}

#[test]
fn non_finite_particles_are_quarantined_on_the_gpu() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = w.add_system(SystemDesc::with_integrator(Integrator::ForwardEuler));
    let hs = w
        .add_particles(
            sys,
            &[
                ParticleDesc::at(DVec3::new(1.0, 2.0, 3.0), 1e-3).with_velocity(DVec3::X),
                ParticleDesc::at(DVec3::new(-1.0, 0.0, 0.0), 1.0).with_velocity(DVec3::Y),
            ],
        )
        .unwrap();
    w.add_force(sys, UniformGravity::earth()).unwrap();
    // 1e38 N on 1 g is 1e41 m/s²: finite in f64, infinite in f32.
    w.set_control_force(hs[0], DVec3::new(0.0, 1e38, 0.0))
        .unwrap();
    w.set_backend(sys, Backend::Gpu).unwrap();
    let report = w.step(0.01).unwrap();
    assert_eq!(report.quarantined, vec![hs[0]]);
    let q = w.particle(hs[0]).unwrap();
    assert!(q.quarantined);
    assert_eq!(
        q.position,
        DVec3::new(1.0, 2.0, 3.0),
        "keeps its last finite position"
    );
    assert_eq!(q.velocity, DVec3::ZERO);
    let other = w.particle(hs[1]).unwrap();
    assert!(!other.quarantined && other.position != DVec3::new(-1.0, 0.0, 0.0));
    // Frozen afterwards and reported only once.
    let report = w.step(0.01).unwrap();
    assert!(report.quarantined.is_empty());
    assert_eq!(w.particle(hs[0]).unwrap().position, q.position);
    // The transient flag is not left in the state.
    assert!(w.system(sys).unwrap().flags().iter().all(|f| f & 4 == 0));
    w.set_backend(sys, Backend::Cpu).unwrap();
    assert!(w.particle(hs[0]).unwrap().quarantined);
}

#[test]
fn without_readback_the_mirror_waits_for_sync() {
    let mut w = gpu_or_skip!(gpu_world(WorldConfig {
        threads: 1,
        gpu_readback_every_step: false,
        ..WorldConfig::default()
    }));
    let sys = scene(&mut w);
    let start: Vec<DVec3> = w.system(sys).unwrap().positions().to_vec();
    w.set_backend(sys, Backend::Gpu).unwrap();
    for _ in 0..10 {
        let r = w.step(1.0 / 60.0).unwrap();
        assert_eq!(r.energy.kinetic, 0.0, "no readback, no kinetic energy");
    }
    w.gpu_context().unwrap().finish().unwrap();
    assert_eq!(
        w.system(sys).unwrap().positions(),
        &start[..],
        "stale until sync"
    );
    w.sync_gpu().unwrap();
    assert_ne!(w.system(sys).unwrap().positions(), &start[..]);
    let e = w.compute_energy();
    assert!(e.kinetic > 0.0);
}

#[test]
fn readback_energy_matches_the_cpu() {
    let mut g = gpu_or_skip!(default_gpu_world());
    let mut c = World::new(cpu_config()).unwrap();
    let (a, _) = (scene(&mut g), scene(&mut c));
    g.set_backend(a, Backend::Gpu).unwrap();
    let (mut eg, mut ec) = Default::default();
    for _ in 0..30 {
        eg = g.step(1.0 / 120.0).unwrap().energy;
        ec = c.step(1.0 / 120.0).unwrap().energy;
    }
    let (eg, ec): (inertia_physics::Energy, inertia_physics::Energy) = (eg, ec);
    for (name, x, y) in [
        ("kinetic", eg.kinetic, ec.kinetic),
        ("uniform gravity", eg.gravity_uniform, ec.gravity_uniform),
        ("spring", eg.spring, ec.spring),
    ] {
        assert!(
            (x - y).abs() <= 1e-4 * y.abs().max(1.0),
            "{name}: GPU {x} vs CPU {y}"
        );
    }
}

#[test]
fn save_and_restore_a_gpu_world() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = scene(&mut w);
    w.set_backend(sys, Backend::Gpu).unwrap();
    for _ in 0..10 {
        w.step(1.0 / 60.0).unwrap();
    }
    let saved = w.save();
    let mut restored = World::from_saved(cpu_config(), &saved).unwrap();
    assert_eq!(restored.system(sys).unwrap().backend(), Backend::Gpu);
    for _ in 0..10 {
        w.step(1.0 / 60.0).unwrap();
        restored.step(1.0 / 60.0).unwrap();
    }
    // The mirror holds exact f32 values, so the re-upload is exact too.
    assert_eq!(restored.state_hash(), w.state_hash());
}

#[test]
fn an_empty_system_steps_on_the_gpu() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let sys = w.add_system(SystemDesc::default());
    w.set_backend(sys, Backend::Gpu).unwrap();
    let r = w.step(0.01).unwrap();
    assert_eq!(r.energy.kinetic, 0.0);
    w.set_backend(sys, Backend::Cpu).unwrap();
}

#[test]
fn the_context_describes_its_adapter() {
    let mut w = gpu_or_skip!(default_gpu_world());
    let ctx = w.gpu_context().unwrap();
    assert!(!ctx.adapter_name().is_empty());
    assert!(
        ["vulkan", "gl"].contains(&ctx.backend_name()),
        "{}",
        ctx.backend_name()
    );
    assert!(ctx.description().contains(ctx.adapter_name()));
}
