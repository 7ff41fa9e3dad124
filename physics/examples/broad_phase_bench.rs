//! Measures the broad phase's dynamic AABB tree against sweep-and-prune on
//! 10 000 boxes (a resting pyramid, a cloud that all moves, a cloud where a
//! tenth moves): build time and per-step update time, one thread. Both must
//! report the same pairs; the numbers back the choice of the tree
//! (see `rigid/broad_phase.rs`).
//!
//! Run: `cargo run --release -p inertia-physics --example broad_phase_bench`

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::aabb::Aabb;
use inertia_physics::rigid::broad_phase::{BroadPhase, SweepAndPrune};

/// SplitMix64: a tiny deterministic generator, enough for test clouds.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// `b` moved by `d`.
fn translated(b: &Aabb, d: DVec3) -> Aabb {
    Aabb::new(b.min + d, b.max + d)
}

struct Scene {
    name: &'static str,
    boxes: Vec<Aabb>,
    /// Per-step displacement of each box (zero = does not move).
    velocity: Vec<DVec3>,
    /// Jitter amplitude, m, for resting boxes that wobble in place.
    jitter: f64,
}

fn pyramid(n: usize) -> Scene {
    // Layers of a square-based pyramid of unit cubes 1 cm apart.
    let mut boxes = Vec::with_capacity(n);
    let mut base = 1;
    while base * (base + 1) * (2 * base + 1) / 6 < n {
        base += 1;
    }
    'outer: for layer in 0..base {
        let w = base - layer;
        for i in 0..w {
            for j in 0..w {
                if boxes.len() == n {
                    break 'outer;
                }
                let c = DVec3::new(
                    i as f64 * 1.01 + layer as f64 * 0.505,
                    layer as f64 * 1.01 + 0.5,
                    j as f64 * 1.01 + layer as f64 * 0.505,
                );
                boxes.push(Aabb::from_center_half_extents(c, DVec3::splat(0.5)));
            }
        }
    }
    Scene {
        name: "pyramid, resting (1e-4 m jitter)",
        velocity: vec![DVec3::ZERO; boxes.len()],
        boxes,
        jitter: 1e-4,
    }
}

fn cloud(n: usize, moving_fraction: f64, seed: u64) -> Scene {
    let mut rng = Rng(seed);
    // About 2 neighbours each: n unit-ish boxes in a cube of volume ~4n.
    let side = (4.0 * n as f64).cbrt() * 1.2;
    let boxes: Vec<Aabb> = (0..n)
        .map(|_| Aabb::from_center_half_extents(rng.vec(0.0, side), rng.vec(0.2, 0.6)))
        .collect();
    let velocity = (0..n)
        .map(|_| {
            if rng.f64() < moving_fraction {
                let v = rng.vec(-1.0, 1.0);
                v.normalize_or_zero() * 0.02
            } else {
                DVec3::ZERO
            }
        })
        .collect();
    Scene {
        name: if moving_fraction >= 1.0 {
            "random cloud, every box moving 0.02 m"
        } else {
            "random cloud, 10 % of boxes moving"
        },
        boxes,
        velocity,
        jitter: 0.0,
    }
}

/// Runs a scene through both broad phases; returns ms (build, per update).
fn run_scene(scene: &Scene, steps: usize) -> [(f64, f64); 2] {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    one.install(|| {
        let mut tree = BroadPhase::default();
        let mut sap = SweepAndPrune::new(tree.tree().margin()).unwrap();
        let t = Instant::now();
        for (k, b) in scene.boxes.iter().enumerate() {
            tree.insert(k as u32, *b, false).unwrap();
        }
        tree.update_pairs();
        let tree_build = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        for (k, b) in scene.boxes.iter().enumerate() {
            sap.insert(k as u32, *b, false).unwrap();
        }
        sap.update_pairs();
        let sap_build = t.elapsed().as_secs_f64() * 1e3;

        let mut boxes = scene.boxes.clone();
        let (mut tree_ms, mut sap_ms) = (0.0, 0.0);
        for step in 0..steps {
            let mut moves = Vec::new();
            for (k, b) in boxes.iter_mut().enumerate() {
                let d = if scene.jitter > 0.0 {
                    DVec3::splat(if (step + k) % 2 == 0 {
                        scene.jitter
                    } else {
                        -scene.jitter
                    })
                } else {
                    scene.velocity[k]
                };
                if d != DVec3::ZERO {
                    *b = translated(b, d);
                    moves.push((k as u32, *b, d));
                }
            }
            let t = Instant::now();
            for &(k, b, d) in &moves {
                tree.update(k, b, d).unwrap();
            }
            tree.update_pairs();
            tree_ms += t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            for &(k, b, d) in &moves {
                sap.update(k, b, d).unwrap();
            }
            sap.update_pairs();
            sap_ms += t.elapsed().as_secs_f64() * 1e3;
            assert_eq!(tree.pairs(), sap.pairs());
        }
        let mut rebuilt = tree.clone();
        let t = Instant::now();
        rebuilt.rebuild();
        let rebuild_ms = t.elapsed().as_secs_f64() * 1e3;
        println!(
            "{:40} pairs {:6} height {:3} area ratio {:5.1}; rebuilt in {rebuild_ms:.1} ms: height {:3} area ratio {:5.1}",
            scene.name,
            tree.pairs().len(),
            tree.tree().height(),
            tree.tree().area_ratio(),
            rebuilt.tree().height(),
            rebuilt.tree().area_ratio()
        );
        [
            (tree_build, tree_ms / steps as f64),
            (sap_build, sap_ms / steps as f64),
        ]
    })
}

fn main() {
    let n = 10_000;
    let steps = 60;
    println!("{n} boxes, {steps} updates, one thread; ms");
    println!("| scene | tree build | tree update | SAP build | SAP update |");
    for scene in [pyramid(n), cloud(n, 1.0, 11), cloud(n, 0.1, 12)] {
        let [(tb, tu), (sb, su)] = run_scene(&scene, steps);
        println!("| {} | {tb:.2} | {tu:.3} | {sb:.2} | {su:.3} |", scene.name);
    }
}
