//! The rigid-body broad phase: the dynamic AABB tree and sweep and prune
//! against brute force, pair-order determinism, tree invariants and
//! balance, scene queries, and refusal of bad input.
//! (The timing behind the tree's choice is an example, not a test:
//! `cargo run --release -p inertia-physics --example broad_phase_bench`.)

use crate::common;

use common::Rng;
use std::collections::BTreeMap;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::aabb::Aabb;
use inertia_physics::rigid::broad_phase::{
    brute_force_pairs, BroadPhase, BroadPhaseError, DynamicTree, Pair, ProxyId, SweepAndPrune,
};

// ---------------------------------------------------------------- helpers

/// A random box of size 0.2–2 m with its centre in a cube of side `side` m.
fn random_box(rng: &mut Rng, side: f64) -> Aabb {
    Aabb::from_center_half_extents(rng.in_box(0.0, side), rng.in_box(0.1, 1.0))
}

fn translated(b: &Aabb, d: DVec3) -> Aabb {
    Aabb::new(b.min + d, b.max + d)
}

/// Holds the broad phase's pairs to the brute-force reference over its fat
/// boxes, and checks they cover every overlap of the tight boxes.
fn check_against_brute_force(bp: &BroadPhase, tight: &BTreeMap<u32, (Aabb, bool)>) {
    bp.validate().expect("broad phase invariants");
    assert_eq!(bp.pairs(), brute_force_pairs(&bp.proxies()).as_slice());
    let tight: Vec<(u32, Aabb, bool)> = tight.iter().map(|(&k, &(b, s))| (k, b, s)).collect();
    for p in brute_force_pairs(&tight) {
        assert!(
            bp.pairs().binary_search(&p).is_ok(),
            "tight overlap {p:?} missing"
        );
    }
}

// ---------------------------------------------------------------- pairs

#[test]
fn pairs_match_brute_force_through_inserts_removals_and_moves() {
    let mut rng = Rng(1);
    let mut bp = BroadPhase::default();
    let mut sap = SweepAndPrune::new(bp.tree().margin()).unwrap();
    let mut tight: BTreeMap<u32, (Aabb, bool)> = BTreeMap::new();
    let mut next_key = 0u32;
    let side = 30.0;
    for round in 0..60 {
        // Inserts (more early on), removals, then moves of most survivors.
        let inserts = if round < 5 { 120 } else { 8 };
        for _ in 0..inserts {
            let b = random_box(&mut rng, side);
            let is_static = rng.f64() < 0.2;
            let key = next_key * 7 % 10_007; // keys not in insertion order
            next_key += 1;
            bp.insert(key, b, is_static).unwrap();
            sap.insert(key, b, is_static).unwrap();
            tight.insert(key, (b, is_static));
        }
        let keys: Vec<u32> = tight.keys().copied().collect();
        for _ in 0..6 {
            let k = keys[rng.below(keys.len())];
            if tight.remove(&k).is_some() {
                bp.remove(k).unwrap();
                sap.remove(k).unwrap();
            }
        }
        let before = bp.pairs().to_vec();
        for (&k, (b, is_static)) in tight.iter_mut() {
            if *is_static || rng.f64() < 0.3 {
                continue;
            }
            // Mostly small steps, sometimes a jump across the scene.
            let d = if rng.f64() < 0.05 {
                rng.in_box(-10.0, 10.0)
            } else {
                rng.in_box(-0.08, 0.08)
            };
            *b = translated(b, d);
            let m1 = bp.update(k, *b, d).unwrap();
            let m2 = sap.update(k, *b, d).unwrap();
            assert_eq!(m1, m2, "tree and SAP disagree on reinsertion of {k}");
        }
        bp.update_pairs();
        sap.update_pairs();
        check_against_brute_force(&bp, &tight);
        assert_eq!(
            bp.pairs(),
            sap.pairs(),
            "round {round}: SAP differs from the tree"
        );
        // The reported changes turn the old pair set into the new one.
        let mut rebuilt: Vec<Pair> = before
            .iter()
            .filter(|p| bp.removed_pairs().binary_search(p).is_err())
            .copied()
            .chain(bp.added_pairs().iter().copied())
            .collect();
        rebuilt.sort_unstable();
        assert_eq!(
            rebuilt,
            bp.pairs(),
            "round {round}: added/removed inconsistent"
        );
        if round == 30 {
            bp.rebuild();
            bp.validate().unwrap();
        }
    }
    assert!(!bp.pairs().is_empty());
}

#[test]
fn pair_order_independent_of_insertion_order_rebuilds_and_threads() {
    let mut rng = Rng(2);
    let boxes: Vec<(u32, Aabb, bool)> = (0..3000)
        .map(|k| (k, random_box(&mut rng, 60.0), rng.f64() < 0.1))
        .collect();
    let build = |order: &[usize]| {
        let mut bp = BroadPhase::default();
        for &i in order {
            let (k, b, s) = boxes[i];
            bp.insert(k, b, s).unwrap();
        }
        bp
    };
    let forward: Vec<usize> = (0..boxes.len()).collect();
    let mut shuffled = forward.clone();
    rng.shuffle(&mut shuffled);
    let reversed: Vec<usize> = forward.iter().rev().copied().collect();

    let mut a = build(&forward);
    let mut b = build(&shuffled);
    let mut c = build(&reversed);
    c.rebuild();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    one.install(|| a.update_pairs());
    two.install(|| b.update_pairs());
    c.update_pairs();
    assert!(a.pairs().len() > 100);
    assert_eq!(a.pairs(), b.pairs());
    assert_eq!(a.pairs(), c.pairs());
    assert!(a.pairs().windows(2).all(|w| w[0] < w[1]));
    assert!(a.pairs().iter().all(|p| p.a < p.b));
    // Tree shapes do differ: the order is the sort's, not the tree's.
    assert_eq!(a.pairs(), brute_force_pairs(&a.proxies()).as_slice());
}

#[test]
fn static_pairs_are_skipped_and_resting_proxies_cost_nothing() {
    let unit = |x: f64| Aabb::from_center_half_extents(DVec3::new(x, 0.0, 0.0), DVec3::splat(0.5));
    let mut bp = BroadPhase::default();
    bp.insert(1, unit(0.0), true).unwrap();
    bp.insert(2, unit(0.5), true).unwrap();
    bp.insert(3, unit(1.0), false).unwrap();
    bp.update_pairs();
    assert_eq!(bp.pairs(), &[Pair::new(1, 3), Pair::new(2, 3)]);
    assert_eq!(bp.added_pairs(), bp.pairs());
    // Jitter well inside the margin: no reinsertion, no change.
    for step in 0..10 {
        let d = DVec3::splat(if step % 2 == 0 { 1e-4 } else { -1e-4 });
        assert!(!bp.update(3, translated(&unit(1.0), d), d).unwrap());
        bp.update_pairs();
        assert!(bp.added_pairs().is_empty() && bp.removed_pairs().is_empty());
    }
    // Leave: the pairs end.
    assert!(bp.update(3, unit(10.0), DVec3::X * 9.0).unwrap());
    bp.update_pairs();
    assert!(bp.pairs().is_empty());
    assert_eq!(bp.removed_pairs(), &[Pair::new(1, 3), Pair::new(2, 3)]);
    bp.validate().unwrap();
}

#[test]
fn fat_box_stretches_along_motion_and_shrinks_back_when_it_stops() {
    let mut bp = BroadPhase::new(0.1).unwrap();
    let b0 = Aabb::new(DVec3::ZERO, DVec3::ONE);
    bp.insert(1, b0, false).unwrap();
    let d = DVec3::new(2.0, 0.0, 0.0);
    let b1 = translated(&b0, d);
    assert!(bp.update(1, b1, d).unwrap());
    let fat = bp.fat_aabb(1).unwrap();
    // Margin on every side, plus four steps of the motion ahead of it.
    assert!((fat.max.x - (b1.max.x + 0.1 + 4.0 * d.x)).abs() < 1e-12);
    assert!((fat.min.x - (b1.min.x - 0.1)).abs() < 1e-12);
    // Still inside, but the box is now far too long: it is refitted.
    assert!(bp.update(1, b1, DVec3::ZERO).unwrap());
    assert_eq!(bp.fat_aabb(1), Some(b1.expanded(0.1)));
    // And then left alone.
    assert!(!bp.update(1, b1, DVec3::ZERO).unwrap());
    bp.validate().unwrap();
}

// ---------------------------------------------------------------- the tree

#[test]
fn tree_invariants_hold_through_churn() {
    let mut rng = Rng(3);
    let mut tree = DynamicTree::new(0.1).unwrap();
    let mut live: Vec<(ProxyId, Aabb)> = Vec::new();
    for step in 0..4000 {
        let r = rng.f64();
        if r < 0.5 || live.is_empty() {
            let b = random_box(&mut rng, 50.0);
            live.push((tree.create_proxy(b, step).unwrap(), b));
        } else if r < 0.7 {
            let i = rng.below(live.len());
            let (id, _) = live.swap_remove(i);
            tree.destroy_proxy(id).unwrap();
        } else {
            let i = rng.below(live.len());
            let d = rng.in_box(-0.5, 0.5);
            let b = translated(&live[i].1, d);
            tree.move_proxy(live[i].0, b, d).unwrap();
            live[i].1 = b;
        }
        if step % 97 == 0 {
            tree.validate().unwrap();
            for (id, tight) in &live {
                assert!(tree.fat_aabb(*id).unwrap().contains(tight));
            }
        }
    }
    assert_eq!(tree.len(), live.len());
    tree.rebuild();
    tree.validate().unwrap();
    for (id, tight) in &live {
        assert!(tree.fat_aabb(*id).unwrap().contains(tight));
    }
}

#[test]
fn height_stays_logarithmic_for_sorted_insertion() {
    let n = 10_000u32;
    let bound = 3.0 * (n as f64).log2() + 5.0;
    // Sorted along a line, and sorted along a grid's rows: the classic
    // degenerate inputs for an unbalanced tree.
    let line = |i: u32| DVec3::new(i as f64 * 1.5, 0.0, 0.0);
    let grid = |i: u32| DVec3::new((i % 100) as f64 * 1.5, 0.0, (i / 100) as f64 * 1.5);
    for place in [line, grid] {
        let mut tree = DynamicTree::default();
        for i in 0..n {
            let b = Aabb::from_center_half_extents(place(i), DVec3::splat(0.5));
            tree.create_proxy(b, i).unwrap();
        }
        tree.validate().unwrap();
        let h = tree.height() as f64;
        println!("sorted insertion of {n}: height {h}, bound {bound:.1}");
        assert!(h < bound, "height {h} >= {bound}");
        tree.rebuild();
        tree.validate().unwrap();
        assert!(
            (tree.height() as f64) < bound,
            "rebuilt height {}",
            tree.height()
        );
    }
}

#[test]
fn ray_casts_match_brute_force() {
    let mut rng = Rng(4);
    let mut bp = BroadPhase::default();
    for k in 0..800 {
        bp.insert(k, random_box(&mut rng, 40.0), false).unwrap();
    }
    bp.rebuild();
    let proxies = bp.proxies();
    for ray in 0..200 {
        let origin = rng.in_box(-5.0, 45.0);
        let mut dir = rng.in_box(-1.0, 1.0);
        if ray % 10 == 0 {
            dir = DVec3::new(dir.x, 0.0, 0.0); // axis-parallel rays too
        }
        let max_t = rng.range(1.0, 60.0);
        let mut expected: Vec<(u32, f64)> = proxies
            .iter()
            .filter_map(|&(k, b, _)| slab(origin, dir, max_t, &b).map(|t| (k, t)))
            .collect();
        expected.sort_by_key(|h| h.0);
        let mut got = Vec::new();
        bp.ray_cast(origin, dir, max_t, |k, t| {
            got.push((k, t));
            max_t
        })
        .unwrap();
        got.sort_by_key(|h| h.0);
        assert_eq!(got, expected, "ray {ray}");
        // Clipping to each hit finds the nearest.
        let mut nearest = f64::INFINITY;
        bp.ray_cast(origin, dir, max_t, |_, t| {
            nearest = nearest.min(t);
            t
        })
        .unwrap();
        let want = expected.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
        assert_eq!(nearest, want, "ray {ray} nearest");
    }
    // A negative return stops at the first hit.
    let mut calls = 0;
    bp.ray_cast(DVec3::splat(-5.0), DVec3::ONE, f64::INFINITY, |_, _| {
        calls += 1;
        -1.0
    })
    .unwrap();
    assert_eq!(calls, 1);
}

/// Brute-force slab test, written independently of the tree's.
fn slab(o: DVec3, d: DVec3, max_t: f64, b: &Aabb) -> Option<f64> {
    let mut lo = 0.0f64;
    let mut hi = max_t;
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < b.min[a] || o[a] > b.max[a] {
                return None;
            }
        } else {
            let t1 = (b.min[a] - o[a]) / d[a];
            let t2 = (b.max[a] - o[a]) / d[a];
            lo = lo.max(t1.min(t2));
            hi = hi.min(t1.max(t2));
        }
    }
    (lo <= hi).then_some(lo)
}

#[test]
fn queries_without_hits() {
    let empty = BroadPhase::default();
    let mut hits = 0;
    empty.query(&Aabb::new(DVec3::splat(-1e9), DVec3::splat(1e9)), |_| {
        hits += 1;
        true
    });
    empty
        .ray_cast(DVec3::ZERO, DVec3::X, f64::INFINITY, |_, _| {
            hits += 1;
            0.0
        })
        .unwrap();
    let mut rng = Rng(5);
    let mut bp = BroadPhase::default();
    for k in 0..500 {
        bp.insert(k, random_box(&mut rng, 20.0), false).unwrap();
    }
    bp.query(&Aabb::new(DVec3::splat(100.0), DVec3::splat(101.0)), |_| {
        hits += 1;
        true
    });
    bp.query(
        &Aabb::new(DVec3::splat(f64::NAN), DVec3::splat(f64::NAN)),
        |_| {
            hits += 1;
            true
        },
    );
    bp.ray_cast(DVec3::splat(100.0), DVec3::ONE, f64::INFINITY, |_, _| {
        hits += 1;
        0.0
    })
    .unwrap();
    assert_eq!(hits, 0);
    // And a box query that does hit agrees with brute force.
    let q = Aabb::new(DVec3::splat(5.0), DVec3::splat(8.0));
    let mut got = Vec::new();
    bp.query(&q, |k| {
        got.push(k);
        true
    });
    got.sort_unstable();
    let want: Vec<u32> = bp
        .proxies()
        .iter()
        .filter(|p| p.1.intersects(&q))
        .map(|p| p.0)
        .collect();
    let mut want = want;
    want.sort_unstable();
    assert!(!want.is_empty());
    assert_eq!(got, want);
}

#[test]
fn removing_everything_leaves_an_empty_tree() {
    let mut rng = Rng(6);
    let mut bp = BroadPhase::default();
    for k in 0..1000 {
        bp.insert(k, random_box(&mut rng, 20.0), k % 5 == 0)
            .unwrap();
    }
    bp.update_pairs();
    assert!(!bp.pairs().is_empty());
    let capacity = bp.tree().node_capacity();
    let mut keys: Vec<u32> = (0..1000).collect();
    rng.shuffle(&mut keys);
    for k in keys {
        bp.remove(k).unwrap();
    }
    bp.update_pairs();
    assert!(bp.is_empty() && bp.tree().is_empty());
    assert_eq!(bp.tree().height(), 0);
    assert!(bp.pairs().is_empty());
    bp.validate().unwrap();
    assert_eq!(bp.remove(3), Err(BroadPhaseError::UnknownKey(3)));
    // Freed nodes are reused.
    for k in 0..1000 {
        bp.insert(k, random_box(&mut rng, 20.0), false).unwrap();
    }
    assert_eq!(bp.tree().node_capacity(), capacity);
    bp.validate().unwrap();
}

#[test]
fn bad_input_is_refused_without_corrupting_the_tree() {
    let mut rng = Rng(7);
    let mut bp = BroadPhase::default();
    let mut tight = BTreeMap::new();
    for k in 0..200 {
        let b = random_box(&mut rng, 10.0);
        bp.insert(k, b, false).unwrap();
        tight.insert(k, (b, false));
    }
    bp.update_pairs();
    let pairs = bp.pairs().to_vec();
    let good = Aabb::new(DVec3::ZERO, DVec3::ONE);
    let nan = Aabb::new(DVec3::new(0.0, f64::NAN, 0.0), DVec3::ONE);
    let inf = Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, f64::INFINITY));
    let inverted = Aabb::new(DVec3::ONE, DVec3::ZERO);
    let huge = Aabb::new(DVec3::ZERO, DVec3::splat(f64::MAX));

    assert!(matches!(
        bp.insert(500, nan, false),
        Err(BroadPhaseError::NonFinite { .. })
    ));
    assert!(matches!(
        bp.insert(500, inf, false),
        Err(BroadPhaseError::NonFinite { .. })
    ));
    assert!(matches!(
        bp.insert(500, inverted, false),
        Err(BroadPhaseError::Inverted { .. })
    ));
    assert!(matches!(
        bp.insert(500, huge, false),
        Err(BroadPhaseError::OutOfRange { .. })
    ));
    assert_eq!(
        bp.insert(3, good, false),
        Err(BroadPhaseError::DuplicateKey(3))
    );
    assert!(matches!(
        bp.update(3, nan, DVec3::ZERO),
        Err(BroadPhaseError::NonFinite { .. })
    ));
    assert!(matches!(
        bp.update(3, inverted, DVec3::ZERO),
        Err(BroadPhaseError::Inverted { .. })
    ));
    assert!(matches!(
        bp.update(3, good, DVec3::new(f64::NEG_INFINITY, 0.0, 0.0)),
        Err(BroadPhaseError::NonFinite { .. })
    ));
    assert!(matches!(
        bp.update(3, good, DVec3::splat(f64::MAX)),
        Err(BroadPhaseError::OutOfRange { .. })
    ));
    assert_eq!(
        bp.update(999, good, DVec3::ZERO),
        Err(BroadPhaseError::UnknownKey(999))
    );
    assert!(matches!(
        bp.ray_cast(DVec3::splat(f64::NAN), DVec3::X, 1.0, |_, t| t),
        Err(BroadPhaseError::NonFinite { .. })
    ));
    assert_eq!(
        bp.ray_cast(DVec3::ZERO, DVec3::X, -1.0, |_, t| t),
        Err(BroadPhaseError::BadRayLength(-1.0))
    );
    assert!(matches!(
        BroadPhase::new(f64::NAN),
        Err(BroadPhaseError::BadMargin(_))
    ));
    assert!(matches!(
        BroadPhase::new(-0.1),
        Err(BroadPhaseError::BadMargin(_))
    ));

    assert!(!bp.contains(500));
    assert_eq!(bp.len(), 200);
    bp.update_pairs();
    assert_eq!(bp.pairs(), pairs.as_slice());
    assert!(bp.added_pairs().is_empty());
    check_against_brute_force(&bp, &tight);

    let mut tree = DynamicTree::default();
    let gone = tree.create_proxy(good, 9).unwrap();
    assert_eq!(tree.destroy_proxy(gone), Ok(9));
    assert_eq!(
        tree.destroy_proxy(gone),
        Err(BroadPhaseError::UnknownProxy(0))
    );
    assert!(tree.move_proxy(gone, good, DVec3::ZERO).is_err());
    let id = tree.create_proxy(good, 0).unwrap();
    assert!(tree.create_proxy(nan, 1).is_err());
    assert!(tree.move_proxy(id, inf, DVec3::ZERO).is_err());
    tree.validate().unwrap();
    assert_eq!(tree.len(), 1);
}
