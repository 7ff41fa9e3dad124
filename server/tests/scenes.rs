//! Scene files: every example loads and builds, the demo holds together for
//! ten seconds, and bad files are refused with the path of the bad entry.

use std::path::{Path, PathBuf};

use inertia_physics::rigid::body::BodyKind;
use inertia_protocol::{EntityKind, ShapeDesc};
use inertia_server::scene::demo::demo_scene;
use inertia_server::scene::{EntitySource, Scene, SceneError, SceneFormat};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

#[test]
fn every_example_scene_loads_and_builds() {
    let mut seen = 0;
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if SceneFormat::from_path(&path).is_none() {
            continue;
        }
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let built = scene
            .build()
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(!built.entities.is_empty(), "{}", path.display());
        seen += 1;
    }
    assert!(
        seen >= 3,
        "expected demo.ron, pyramid.json, fiedler_cubes.ron"
    );
}

#[test]
fn fiedler_cubes_has_901_cubes() {
    let built = Scene::load(scenes_dir().join("fiedler_cubes.ron"))
        .unwrap()
        .build()
        .unwrap();
    let cubes = built
        .entities
        .iter()
        .filter(|(_, e)| {
            e.desc.kind == EntityKind::Dynamic && matches!(e.desc.shape, ShapeDesc::Cuboid { .. })
        })
        .count();
    assert_eq!(cubes, 901);
    assert!(built.bodies_by_name.contains_key("player_cube"));
    assert!(built.bodies_by_name.contains_key("cube[899]"));
}

#[test]
fn pyramid_json_stacks_21_boxes() {
    let built = Scene::load(scenes_dir().join("pyramid.json"))
        .unwrap()
        .build()
        .unwrap();
    assert_eq!(built.entities.len(), 1 + 21);
    // Ids run from 1 in file order: the ground first.
    let first = built.entities.get(1).unwrap();
    assert_eq!(first.desc.name, "ground");
    assert_eq!(first.desc.kind, EntityKind::Static);
}

#[test]
fn the_builtin_demo_is_the_demo_file() {
    let file = Scene::load(scenes_dir().join("demo.ron")).unwrap();
    assert_eq!(demo_scene().unwrap(), file);
}

#[test]
fn demo_holds_together_for_ten_seconds() {
    let mut built = demo_scene().unwrap().build().unwrap();
    let bodies = built.world.bodies().count();
    assert!(
        (100..=500).contains(&bodies),
        "{bodies} bodies: keep the demo modest"
    );
    let particles = built
        .entities
        .iter()
        .filter(|(_, e)| matches!(e.source, EntitySource::Particle(_)))
        .count();
    assert!(particles > 50, "the flag and the rope are streamed");
    let dt = 1.0 / 60.0;
    let start = std::time::Instant::now();
    for tick in 0..600 {
        let r = built.world.step(dt).unwrap();
        assert!(
            r.quarantined.is_empty() && r.quarantined_bodies.is_empty(),
            "tick {tick}: something went non-finite"
        );
        let gone: Vec<&String> = built
            .bodies_by_name
            .iter()
            .filter(|(_, h)| r.removed_bodies.contains(h))
            .map(|(n, _)| n)
            .collect();
        assert!(gone.is_empty(), "tick {tick}: {gone:?} left the world");
    }
    let per_tick = start.elapsed().as_secs_f64() / 600.0;
    eprintln!(
        "demo: {bodies} bodies, {particles} particles, {:.2} ms per tick",
        per_tick * 1e3
    );
    let pool = |x: f64, z: f64| (10.0..=16.0).contains(&x) && (-3.0..=3.0).contains(&z);
    for (h, b) in built.world.bodies() {
        let p = b.center_of_mass();
        assert!(p.is_finite(), "{h:?} non-finite");
        if b.kind() != BodyKind::Dynamic {
            continue;
        }
        let floor = if pool(p.x, p.z) { -2.0 } else { 0.0 };
        assert!(p.y > floor - 0.05, "{h:?} at {p} sank through the floor");
    }
    for s in built.world.systems() {
        assert_eq!(s.quarantined_count(), 0);
        assert!(s.positions().iter().all(|p| p.is_finite() && p.y > -0.5));
    }
    // The crates float: their centres sit near the water surface (−0.4 m).
    for name in ["crate_a", "crate_b", "crate_c", "crate_d", "crate_e"] {
        let h = built.bodies_by_name[name];
        let y = built.world.body(h).unwrap().center_of_mass().y;
        assert!((-0.9..0.1).contains(&y), "{name} at y = {y}: not floating");
    }
}

fn refused(text: &str, format: SceneFormat) -> SceneError {
    match Scene::parse(text, format) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    }
}

#[test]
fn syntax_errors_name_the_entry() {
    let e = refused(
        r#"(bodies: [
            (shape: Sphere(radius: 1.0)),
            (shape: Sphere(radius: 1.0)),
            (shape: Sphere(radius: 1.0)),
            (shape: Sphere(radius: "big")),
        ])"#,
        SceneFormat::Ron,
    );
    assert_eq!(e.at(), Some("bodies[3].shape.radius"), "{e}");

    let e = refused(
        r#"{"bodies": [{"shape": {"Sphere": {"radius": 1}}, "colour": [1,2,3,4]}]}"#,
        SceneFormat::Json,
    );
    assert!(e.to_string().contains("colour"), "{e}");
    assert_eq!(e.at(), Some("bodies[0].colour"), "{e}");

    let e = refused(
        r#"{"bodies": [{"shape": {"Blob": {"radius": 1}}}]}"#,
        SceneFormat::Json,
    );
    assert_eq!(e.at(), Some("bodies[0].shape"), "{e}");
}

#[test]
fn meaning_errors_name_the_entry() {
    let cases: &[(&str, &str)] = &[
        (
            "(bodies: [(shape: Sphere(radius: 1.0)), (shape: Sphere(radius: -2.0))])",
            "bodies[1].shape.radius",
        ),
        (
            "(bodies: [(shape: Cuboid(half_extents: (1.0, NaN, 1.0)))])",
            "bodies[0].shape.half_extents[1]",
        ),
        (
            "(bodies: [(shape: Sphere(radius: 1.0), position: (0.0, inf, 0.0))])",
            "bodies[0].position[1]",
        ),
        (
            r#"(bodies: [(name: "a", shape: Sphere(radius: 1.0)), (name: "a", shape: Sphere(radius: 1.0))])"#,
            "bodies[1]",
        ),
        (
            r#"(bodies: [(name: "a", shape: Sphere(radius: 1.0)), (name: "b", shape: Sphere(radius: 1.0))],
                joints: [(a: "a", b: "b", kind: Ball), (a: "a", b: "c", kind: Ball)])"#,
            "joints[1].b",
        ),
        (
            r#"(bodies: [(name: "a", shape: Sphere(radius: 1.0)), (name: "b", shape: Sphere(radius: 1.0))],
                joints: [(a: "a", b: "b", kind: Hinge(axis: (0.0, 0.0, 0.0)))])"#,
            "joints[0].kind.axis",
        ),
        (
            "(bodies: [(shape: Sphere(radius: 1.0), density: 5.0, mass: 3.0)])",
            "bodies[0]",
        ),
        (
            "(bodies: [(shape: Sphere(radius: 1.0), restitution: 1.5)])",
            "bodies[0].restitution",
        ),
        (
            "(generators: [Pyramid(name: \"p\", rows: 0, body: (shape: Sphere(radius: 1.0)))])",
            "generators[0].rows",
        ),
        (
            "(generators: [Grid(name: \"g\", counts: (2, 1, 2), spacing: (1.0, 1.0, 1.0), body: (shape: Capsule(half_height: 0.0, radius: 1.0)))])",
            "generators[0].body.shape.half_height",
        ),
        (
            "(cloths: [(name: \"c\", origin: (0.0, 0.0, 0.0), width: 1.0, height: 1.0, nu: 4, nv: 4, pinned: [(0, 0), (4, 0)])])",
            "cloths[0].pinned[1]",
        ),
        (
            "(ropes: [(name: \"r\", start: (0.0, 0.0, 0.0), end: (1.0, 0.0, 0.0), segments: 4, attach_end: \"nobody\")])",
            "ropes[0].attach_end",
        ),
        (
            "(bodies: [(kind: Static, shape: TriMesh(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], triangles: [(0, 1, 2)]))])",
            "bodies[0].shape",
        ),
        (
            "(forces: [Water(surface_height: 0.0, density: -1.0)])",
            "forces[0].density",
        ),
        (
            "(world: (solver_substeps: 0))",
            "world.solver_substeps",
        ),
    ];
    for (text, at) in cases {
        let e = refused(text, SceneFormat::Ron);
        assert_eq!(e.at(), Some(*at), "{text}\n→ {e}");
    }
}

#[test]
fn load_names_the_file() {
    let dir = std::env::temp_dir().join(format!("inertia-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.json");
    std::fs::write(
        &path,
        r#"{"bodies": [{"shape": {"Sphere": {"radius": -1}}}]}"#,
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err();
    assert!(e.to_string().contains("bad.json"), "{e}");
    assert_eq!(e.at(), Some("bodies[0].shape.radius"));
    assert!(matches!(
        Scene::load(dir.join("scene.yaml")),
        Err(SceneError::UnknownFormat(_))
    ));
}

#[test]
fn every_shape_joint_and_field_builds() {
    let text = r#"(
        name: "kitchen sink",
        bodies: [
            (name: "ground", kind: Static, shape: Cuboid(half_extents: (10.0, 0.5, 10.0)), position: (0.0, -0.5, 0.0)),
            (name: "hull", shape: ConvexHull(points: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]), position: (0.0, 2.0, 0.0)),
            (name: "comp", shape: Compound(parts: [
                (position: (-0.5, 0.0, 0.0), shape: Sphere(radius: 0.3)),
                (position: (0.5, 0.0, 0.0), rotation: AxisAngle(axis: (0.0, 0.0, 1.0), deg: 90.0), shape: Capsule(half_height: 0.2, radius: 0.1)),
            ]), position: (3.0, 2.0, 0.0), mass: 4.0),
            (name: "cyl", shape: Cylinder(half_height: 0.3, radius: 0.2), position: (-3.0, 2.0, 0.0), rotation: Quat(0.0, 0.0, 0.0, 1.0)),
            (name: "kin", kind: Kinematic, shape: Sphere(radius: 0.5), position: (5.0, 1.0, 5.0), velocity: (1.0, 0.0, 0.0)),
            (name: "ramp", kind: Static, shape: TriMesh(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)], triangles: [(0, 2, 1)]), position: (6.0, 0.0, -6.0)),
            (name: "s1", shape: Sphere(radius: 0.2), position: (0.0, 4.0, 3.0)),
            (name: "s2", shape: Sphere(radius: 0.2), position: (0.5, 4.0, 3.0)),
            (name: "s3", shape: Sphere(radius: 0.2), position: (1.0, 4.0, 3.0)),
            (name: "s4", shape: Sphere(radius: 0.2), position: (1.5, 4.0, 3.0)),
        ],
        joints: [
            (a: "s1", b: "s2", kind: Ball),
            (a: "s2", b: "s3", kind: Hinge(axis: (0.0, 0.0, 1.0), limits_deg: (-45.0, 45.0), motor: (90.0, 5.0))),
            (a: "s3", b: "s4", kind: Prismatic(axis: (1.0, 0.0, 0.0), limits: (0.3, 0.7))),
            (a: "hull", b: "cyl", kind: Distance(min: 0.0, max: 4.0), anchor: (0.0, 2.0, 0.0)),
            (a: "comp", b: "s4", kind: SwingTwist(axis: (1.0, 0.0, 0.0), swing_deg: 30.0, twist_deg: 10.0), break_force: 1000.0),
            (a: "ground", b: "s1", kind: Fixed),
        ],
        ragdolls: [(name: "bob", position: (0.0, 0.0, -4.0))],
        ropes: [(name: "rope", start: (4.0, 5.0, 0.0), end: (4.0, 3.0, 0.0), segments: 5, attach_end: "comp")],
        cloths: [(name: "sheet", origin: (-4.0, 4.0, 0.0), width: 1.0, height: 1.0, nu: 5, nv: 5, pinned: [(0, 0), (4, 0)])],
        forces: [
            Wind(velocity: (3.0, 0.0, 0.0)),
            Drag(linear_scale: 1.0, applies_to: Bodies),
            Explosion(center: (0.0, 0.0, 0.0), at: 0.5, applies_to: Particles),
            Water(surface_height: -3.0),
        ],
    )"#;
    let mut built = Scene::parse(text, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    assert_eq!(built.name, "kitchen sink");
    assert!(built.bodies_by_name.contains_key("bob.head"));
    for _ in 0..120 {
        let r = built.world.step(1.0 / 60.0).unwrap();
        assert!(r.quarantined_bodies.is_empty() && r.quarantined.is_empty());
    }
    let states = built.entities.states(&built.world);
    assert!(states.windows(2).all(|w| w[0].id < w[1].id));
    assert!(states.iter().all(|s| s.position.is_finite()));
}
