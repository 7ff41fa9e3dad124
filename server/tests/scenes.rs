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

/// One of every XPBD soft-body shape and a fluid with an emitter, in RON.
const SOFT_RON: &str = r#"(
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (10.0, 0.5, 10.0)), position: (0.0, -0.5, 0.0)),
        (name: "weight", shape: Sphere(radius: 0.1), position: (0.0, 2.0, 0.0), mass: 2.0),
        (name: "tank_floor", kind: Static, shape: Cuboid(half_extents: (0.5, 0.05, 0.5)), position: (5.0, 0.05, 5.0)),
    ],
    soft_bodies: [
        (name: "rope", shape: Rope(start: (0.0, 3.0, 0.0), end: (0.0, 2.0, 0.0), segments: 10, sag: 0.0),
         mass: 0.5, substeps: 20, attach: [(particles: End, body: "weight")], color: (200, 170, 110, 255)),
        (name: "bridge_rope", shape: Rope(start: (-2.0, 3.0, 2.0), end: (2.0, 3.0, 2.0), segments: 16,
         sag: 0.3, pin_end: true)),
        (name: "flag", shape: Cloth(origin: (2.0, 3.0, 0.0), u_axis: (1.0, 0.0, 0.0), v_axis: (0.0, -1.0, 0.0),
         width: 1.0, height: 0.6, nu: 8, nv: 5, pinned: [(0, 0), (0, 4)], tethers: true, bend_compliance: 10.0),
         damping: 0.5, self_collision: true, collision_radius: 0.01),
        (name: "jelly", shape: Box(center: (-3.0, 1.0, 0.0), half_extents: (0.25, 0.25, 0.25), cell: 0.1,
         rotation: Euler(0.0, 30.0, 0.0), edge_compliance: 1e-3), density: 800.0, collision_radius: 0.01),
        (name: "ball", shape: Sphere(center: (-3.0, 2.0, 3.0), radius: 0.3, cell: 0.1), mass: 5.0),
        (name: "tetra", shape: Mesh(position: (3.0, 1.0, -3.0), vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)],
         triangles: [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)], cell: 0.1)),
        (name: "bar", shape: Box(center: (0.0, 1.0, -3.0), half_extents: (0.5, 0.05, 0.05), cell: 0.05),
         pinned: [InBox(min: (-0.51, 0.9, -3.1), max: (-0.49, 1.1, -2.9))],
         plasticity: (yield_strain: 0.01, creep: 20.0, max_strain: 0.3), tear_strain: 0.5, gravity_scale: 0.0),
        (name: "balloon", shape: Balloon(center: (3.0, 2.0, 3.0), radius: 0.3, subdivisions: 2, pressure: 1.1),
         velocity: (0.0, 1.0, 0.0), friction: 0.5),
    ],
    fluids: [
        (name: "water", spacing: 0.1, blocks: [(min: (4.6, 0.1, 4.6), max: (5.0, 0.5, 5.0)), (min: (5.0, 0.1, 4.6), max: (5.4, 0.3, 5.0))],
         rest_density: 1000.0, viscosity: 0.02, substeps: 4, max_particles: 200,
         emitters: [(position: (5.0, 1.5, 5.0), velocity: (0.0, -1.0, 0.0), radius: 0.1, interval: 0.25,
                     start: 0.1, stop: 1.0, limit: 40)],
         color: (40, 110, 200, 200)),
    ],
)"#;

/// The same scene in JSON.
const SOFT_JSON: &str = r#"{
    "bodies": [
        {"name": "ground", "kind": "Static", "shape": {"Cuboid": {"half_extents": [10, 0.5, 10]}}, "position": [0, -0.5, 0]},
        {"name": "weight", "shape": {"Sphere": {"radius": 0.1}}, "position": [0, 2, 0], "mass": 2},
        {"name": "tank_floor", "kind": "Static", "shape": {"Cuboid": {"half_extents": [0.5, 0.05, 0.5]}}, "position": [5, 0.05, 5]}
    ],
    "soft_bodies": [
        {"name": "rope", "shape": {"Rope": {"start": [0, 3, 0], "end": [0, 2, 0], "segments": 10, "sag": 0}},
         "mass": 0.5, "substeps": 20, "attach": [{"particles": "End", "body": "weight"}], "color": [200, 170, 110, 255]},
        {"name": "bridge_rope", "shape": {"Rope": {"start": [-2, 3, 2], "end": [2, 3, 2], "segments": 16,
         "sag": 0.3, "pin_end": true}}},
        {"name": "flag", "shape": {"Cloth": {"origin": [2, 3, 0], "u_axis": [1, 0, 0], "v_axis": [0, -1, 0],
         "width": 1, "height": 0.6, "nu": 8, "nv": 5, "pinned": [[0, 0], [0, 4]], "tethers": true, "bend_compliance": 10}},
         "damping": 0.5, "self_collision": true, "collision_radius": 0.01},
        {"name": "jelly", "shape": {"Box": {"center": [-3, 1, 0], "half_extents": [0.25, 0.25, 0.25], "cell": 0.1,
         "rotation": {"Euler": [0, 30, 0]}, "edge_compliance": 0.001}}, "density": 800, "collision_radius": 0.01},
        {"name": "ball", "shape": {"Sphere": {"center": [-3, 2, 3], "radius": 0.3, "cell": 0.1}}, "mass": 5},
        {"name": "tetra", "shape": {"Mesh": {"position": [3, 1, -3], "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
         "triangles": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], "cell": 0.1}}},
        {"name": "bar", "shape": {"Box": {"center": [0, 1, -3], "half_extents": [0.5, 0.05, 0.05], "cell": 0.05}},
         "pinned": [{"InBox": {"min": [-0.51, 0.9, -3.1], "max": [-0.49, 1.1, -2.9]}}],
         "plasticity": {"yield_strain": 0.01, "creep": 20, "max_strain": 0.3}, "tear_strain": 0.5, "gravity_scale": 0},
        {"name": "balloon", "shape": {"Balloon": {"center": [3, 2, 3], "radius": 0.3, "subdivisions": 2, "pressure": 1.1}},
         "velocity": [0, 1, 0], "friction": 0.5}
    ],
    "fluids": [
        {"name": "water", "spacing": 0.1, "blocks": [{"min": [4.6, 0.1, 4.6], "max": [5, 0.5, 5]}, {"min": [5, 0.1, 4.6], "max": [5.4, 0.3, 5]}],
         "rest_density": 1000, "viscosity": 0.02, "substeps": 4, "max_particles": 200,
         "emitters": [{"position": [5, 1.5, 5], "velocity": [0, -1, 0], "radius": 0.1, "interval": 0.25,
                       "start": 0.1, "stop": 1, "limit": 40}],
         "color": [40, 110, 200, 200]}
    ]
}"#;

#[test]
fn soft_bodies_and_fluids_parse_from_ron_and_json_and_build() {
    let ron = Scene::parse(SOFT_RON, SceneFormat::Ron).unwrap();
    let json = Scene::parse(SOFT_JSON, SceneFormat::Json).unwrap();
    assert_eq!(ron, json, "the RON and JSON scenes say the same");
    let mut built = ron.build().unwrap();
    let names: Vec<&str> = built
        .soft_bodies_by_name
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        names,
        [
            "ball",
            "balloon",
            "bar",
            "bridge_rope",
            "flag",
            "jelly",
            "rope",
            "tetra"
        ]
    );
    // 3 bodies, and one entity for each soft body and fluid, described
    // as a point set of its particles.
    assert_eq!(
        built.entities.len(),
        3 + names.len() + built.fluids_by_name.len()
    );
    for (name, &h) in &built.soft_bodies_by_name {
        let id = built.entities.by_soft_body(h).expect("an entity");
        let desc = &built.entities.get(id).unwrap().desc;
        assert_eq!(&desc.name, name);
        let ShapeDesc::PointSet { points, .. } = desc.shape else {
            panic!("{name}: a point set");
        };
        assert_eq!(points as usize, built.world.soft_body(h).unwrap().len());
    }
    for &h in built.fluids_by_name.values() {
        assert!(built.entities.by_fluid(h).is_some());
    }
    let soft = |name: &str| {
        built
            .world
            .soft_body(built.soft_bodies_by_name[name])
            .unwrap()
    };
    assert_eq!(soft("rope").len(), 11);
    assert_eq!(soft("flag").len(), 40);
    assert_eq!(soft("balloon").len(), 162);
    // 5 × 5 × 5 cubes, 6 × 6 × 6 corners.
    assert_eq!(soft("jelly").len(), 216);
    // The flag's pins and the bar's clamped end (one layer of 3 × 3).
    let pinned = |name: &str| {
        soft(name)
            .inverse_masses()
            .iter()
            .filter(|w| **w == 0.0)
            .count()
    };
    assert_eq!(pinned("flag"), 2);
    assert_eq!(pinned("bar"), 9);
    assert_eq!(pinned("bridge_rope"), 2);
    // The sagging rope hangs 0.3 m low in the middle.
    let mid = soft("bridge_rope").positions()[8];
    assert!((mid.y - 2.7).abs() < 1e-5, "{mid}");
    // The ball weighs 5 kg; the jelly 800 kg/m³ of 0.125 m³.
    let mass = |name: &str| {
        soft(name)
            .inverse_masses()
            .iter()
            .filter(|w| **w > 0.0)
            .map(|w| 1.0 / f64::from(*w))
            .sum::<f64>()
    };
    assert!((mass("ball") - 5.0).abs() < 1e-3, "{}", mass("ball"));
    assert!((mass("jelly") - 100.0).abs() < 0.1, "{}", mass("jelly"));
    let water = built.fluids_by_name["water"];
    let f = built.world.fluid(water).unwrap();
    assert_eq!(f.len(), 64 + 32);
    assert_eq!(f.max_particles(), 200);
    assert_eq!(f.emitters().len(), 1);
    // Shots at 0.1, 0.35, 0.6 and 0.85 s of five particles each.
    for _ in 0..90 {
        let r = built.world.step(1.0 / 60.0).unwrap();
        assert!(r.quarantined.is_empty() && r.quarantined_bodies.is_empty());
    }
    let f = built.world.fluid(water).unwrap();
    assert_eq!(f.emitters()[0].emitted(), 20);
    assert_eq!(f.len(), 96 + 20);
    for (_, b) in built.world.soft_bodies() {
        assert!(b.positions().iter().all(|p| p.is_finite()));
    }
    // The weight hangs from the rope.
    let weight = built.bodies_by_name["weight"];
    let y = built.world.body(weight).unwrap().center_of_mass().y;
    assert!((1.9..2.1).contains(&y), "the weight hangs at {y}");
}

#[test]
fn bad_soft_bodies_and_fluids_name_the_entry() {
    let rope = |extra: &str| {
        format!(
            r#"(bodies: [(name: "b", shape: Sphere(radius: 0.1))],
                soft_bodies: [
                    (name: "ok", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4)),
                    {extra}
                ])"#
        )
    };
    let fluid = |extra: &str| {
        format!(
            r#"(fluids: [
                    (name: "ok", spacing: 0.1, blocks: [(min: (0.0, 0.0, 0.0), max: (0.2, 0.2, 0.2))]),
                    {extra}
                ])"#
        )
    };
    let cases: Vec<(String, &str)> = vec![
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 0))"#,
            ),
            "soft_bodies[1].shape.segments",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4, compliance: -1.0))"#,
            ),
            "soft_bodies[1].shape.compliance",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, NaN, 0.0), end: (1.0, 1.0, 0.0), segments: 4))"#,
            ),
            "soft_bodies[1].shape.start[1]",
        ),
        (
            rope(
                r#"(name: "ok", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4))"#,
            ),
            "soft_bodies[1].name",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), density: 10.0)"#,
            ),
            "soft_bodies[1].density",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), attach: [(particles: End, body: "nobody")])"#,
            ),
            "soft_bodies[1].attach[0].body",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), attach: [(particles: Index(5), body: "b")])"#,
            ),
            "soft_bodies[1].attach[0].particles",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), pinned: [Grid(0, 0)])"#,
            ),
            "soft_bodies[1].pinned[0]",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), substeps: 0)"#,
            ),
            "soft_bodies[1].substeps",
        ),
        (
            rope(
                r#"(name: "r", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4), plasticity: (yield_strain: 0.0, creep: 1.0, max_strain: 0.1))"#,
            ),
            "soft_bodies[1].plasticity.yield_strain",
        ),
        (
            rope(
                r#"(name: "c", shape: Cloth(origin: (0.0, 0.0, 0.0), width: 1.0, height: 1.0, nu: 4, nv: 4, pinned: [(4, 0)]))"#,
            ),
            "soft_bodies[1].shape.pinned[0]",
        ),
        (
            rope(
                r#"(name: "c", shape: Cloth(origin: (0.0, 0.0, 0.0), width: 0.0, height: 1.0, nu: 4, nv: 4))"#,
            ),
            "soft_bodies[1].shape.width",
        ),
        (
            rope(
                r#"(name: "c", shape: Cloth(origin: (0.0, 0.0, 0.0), u_axis: (1.0, 0.0, 0.0), v_axis: (2.0, 0.0, 0.0), width: 1.0, height: 1.0, nu: 4, nv: 4))"#,
            ),
            "soft_bodies[1].shape.v_axis",
        ),
        (
            rope(
                r#"(name: "j", shape: Box(center: (0.0, 1.0, 0.0), half_extents: (0.5, -0.5, 0.5), cell: 0.1))"#,
            ),
            "soft_bodies[1].shape.half_extents[1]",
        ),
        (
            rope(
                r#"(name: "j", shape: Box(center: (0.0, 1.0, 0.0), half_extents: (0.5, 0.5, 0.5), cell: 0.001))"#,
            ),
            "soft_bodies[1].shape.cell",
        ),
        (
            rope(
                r#"(name: "j", shape: Box(center: (0.0, 1.0, 0.0), half_extents: (0.5, 0.5, 0.5), cell: 0.1, volume_compliance: -1e-6))"#,
            ),
            "soft_bodies[1].shape.volume_compliance",
        ),
        (
            rope(
                r#"(name: "j", shape: Box(center: (0.0, 1.0, 0.0), half_extents: (0.5, 0.5, 0.5), cell: 0.1), pinned: [InBox(min: (5.0, 5.0, 5.0), max: (6.0, 6.0, 6.0))])"#,
            ),
            "soft_bodies[1].pinned[0]",
        ),
        (
            rope(
                r#"(name: "s", shape: Sphere(center: (0.0, 1.0, 0.0), radius: 0.5, cell: 0.1), mass: 1.0, density: 1.0)"#,
            ),
            "soft_bodies[1]",
        ),
        (
            // Four triangles, all in the plane z = 0: no volume.
            rope(
                r#"(name: "m", shape: Mesh(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0)],
                    triangles: [(0, 1, 2), (1, 3, 2), (0, 2, 1), (1, 2, 3)], cell: 0.1))"#,
            ),
            "soft_bodies[1].shape",
        ),
        (
            rope(
                r#"(name: "m", shape: Mesh(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)],
                    triangles: [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 4)], cell: 0.1))"#,
            ),
            "soft_bodies[1].shape.triangles[3]",
        ),
        (
            rope(
                r#"(name: "m", shape: Balloon(center: (0.0, 1.0, 0.0), radius: 0.5, subdivisions: 9))"#,
            ),
            "soft_bodies[1].shape.subdivisions",
        ),
        (
            fluid(
                r#"(name: "f", spacing: -0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.2, 0.2, 0.2))])"#,
            ),
            "fluids[1].spacing",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.05, 0.2, 0.2))])"#,
            ),
            "fluids[1].blocks[0].max",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.4, 0.4, 0.4)), (min: (1.2, 0.2, 0.2), max: (1.6, 0.6, 0.6))])"#,
            ),
            "fluids[1].blocks[1]",
        ),
        (
            fluid(
                r#"(name: "ok", spacing: 0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.2, 0.2, 0.2))])"#,
            ),
            "fluids[1].name",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.2, 0.2, 0.2))], viscosity: 2.0)"#,
            ),
            "fluids[1].viscosity",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, blocks: [(min: (1.0, 0.0, 0.0), max: (1.2, 0.2, 0.2))], kernel_radius: 0.05)"#,
            ),
            "fluids[1].kernel_radius",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, emitters: [(position: (0.0, 1.0, 0.0), velocity: (0.0, -1.0, 0.0))])"#,
            ),
            "fluids[1].max_particles",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, emitters: [(position: (0.0, 1.0, 0.0), velocity: (0.0, 0.0, 0.0), limit: 10)])"#,
            ),
            "fluids[1].emitters[0].velocity",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, emitters: [(position: (0.0, 1.0, 0.0), velocity: (0.0, -1.0, 0.0), interval: 0.01, limit: 10)])"#,
            ),
            "fluids[1].emitters[0]",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, emitters: [(position: (0.0, 1.0, 0.0), velocity: (0.0, -1.0, 0.0), start: 2.0, stop: 1.0, limit: 10)])"#,
            ),
            "fluids[1].emitters[0].stop",
        ),
        (
            fluid(
                r#"(name: "f", spacing: 0.1, emitters: [(position: (0.0, 1.0, 0.0), velocity: (0.0, -1.0, 0.0), limit: 0)])"#,
            ),
            "fluids[1].emitters[0].limit",
        ),
        (fluid(r#"(name: "f", spacing: 0.1)"#), "fluids[1]"),
    ];
    for (text, at) in &cases {
        let e = refused(text, SceneFormat::Ron);
        assert_eq!(e.at(), Some(*at), "{text}\n→ {e}");
    }
    // A soft body and a fluid may not share a name either.
    let e = refused(
        r#"(soft_bodies: [(name: "x", shape: Rope(start: (0.0, 1.0, 0.0), end: (1.0, 1.0, 0.0), segments: 4))],
            fluids: [(name: "x", spacing: 0.1, blocks: [(min: (0.0, 0.0, 0.0), max: (0.2, 0.2, 0.2))])])"#,
        SceneFormat::Ron,
    );
    assert_eq!(e.at(), Some("fluids[0].name"), "{e}");
    // Unknown fields and shapes are syntax errors with their path.
    let e = refused(
        r#"{"soft_bodies": [{"name": "r", "shape": {"Rope": {"start": [0, 1, 0], "end": [1, 1, 0], "segments": 4, "stiffness": 3}}}]}"#,
        SceneFormat::Json,
    );
    assert_eq!(e.at(), Some("soft_bodies[0].shape.stiffness"), "{e}");
    let e = refused(
        r#"{"fluids": [{"name": "f", "spacing": 0.1, "emitters": [{"position": [0, 1, 0], "velocity": [0, -1, 0], "rate": 3}]}]}"#,
        SceneFormat::Json,
    );
    assert_eq!(e.at(), Some("fluids[0].emitters[0].rate"), "{e}");
}

/// The height of a soft body (highest particle less lowest), m.
fn soft_height(b: &inertia_physics::SoftBody) -> f32 {
    let ys = b.positions().iter().map(|p| p.y);
    ys.clone().fold(f32::NEG_INFINITY, f32::max) - ys.fold(f32::INFINITY, f32::min)
}

/// The XPBD part of the demo: the rope bridge, the banner, the jelly, the
/// plastic bar and the pool stay finite and in place for twenty seconds;
/// the deck hangs from its ropes, the jelly squashes and recovers, the bar
/// keeps a bend, the crate floats.
#[test]
fn demo_soft_bodies_and_fluid_hold_together_for_twenty_seconds() {
    let mut built = demo_scene().unwrap().build().unwrap();
    let soft = |b: &inertia_server::scene::BuiltScene, name: &str| {
        b.world
            .soft_body(b.soft_bodies_by_name[name])
            .unwrap()
            .clone()
    };
    let body_y = |b: &inertia_server::scene::BuiltScene, name: &str| {
        b.world
            .body(b.bodies_by_name[name])
            .map_or(f64::NAN, |b| b.center_of_mass().y)
    };
    // The bar's free end: its particles at x = 4.
    let bar = soft(&built, "plastic_bar");
    let tip: Vec<usize> = (0..bar.len())
        .filter(|&i| bar.positions()[i].x > 3.99)
        .collect();
    let tip_y = |b: &inertia_physics::SoftBody| {
        tip.iter().map(|&i| b.positions()[i].y).sum::<f32>() / tip.len() as f32
    };
    let bar_start = tip_y(&bar);
    let jelly_rest = soft_height(&soft(&built, "jelly"));
    let mut jelly_lowest = jelly_rest;
    let dt = 1.0 / 60.0;
    let start = std::time::Instant::now();
    for tick in 0..1200 {
        let r = built.world.step(dt).unwrap();
        assert!(
            r.quarantined.is_empty() && r.quarantined_bodies.is_empty(),
            "tick {tick}: something went non-finite"
        );
        jelly_lowest = jelly_lowest.min(soft_height(&soft(&built, "jelly")));
    }
    let per_tick = start.elapsed().as_secs_f64() / 1200.0;
    eprintln!("demo: {:.2} ms per tick over 20 s", per_tick * 1e3);
    for (name, &h) in &built.soft_bodies_by_name {
        let b = built.world.soft_body(h).unwrap();
        assert!(
            b.positions()
                .iter()
                .all(|p| p.is_finite() && p.y > -0.1 && p.abs().max_element() < 60.0),
            "{name} left the scene"
        );
    }
    let pool = built.world.fluid(built.fluids_by_name["pool"]).unwrap();
    let in_tank = pool
        .positions()
        .iter()
        .filter(|p| {
            (19.95..21.05).contains(&p.x)
                && (-8.55..-7.45).contains(&p.z)
                && (-0.05..1.5).contains(&p.y)
        })
        .count();
    let level =
        2.0 * pool.positions().iter().map(|p| f64::from(p.y)).sum::<f64>() / pool.len() as f64;
    let crate_y = body_y(&built, "tank_crate");
    let jelly = soft(&built, "jelly");
    let bar = soft(&built, "plastic_bar");
    let weight_y = body_y(&built, "bar_weight");
    let deck: Vec<f64> = (0..10)
        .map(|i| body_y(&built, &format!("deck[{i}]")))
        .collect();
    eprintln!(
        "pool: {} particles, {in_tank} in the tank, level {level:.3} m, crate at {crate_y:.3} m; \
         jelly: rest {jelly_rest:.3} m, lowest {jelly_lowest:.3} m, now {:.3} m, volume {:.3}; \
         bar tip {bar_start:.3} → {:.3} m, weight at {weight_y:.3} m; deck {deck:.2?}; banner strain {:.4}",
        pool.len(),
        soft_height(&jelly),
        jelly.volume() / jelly.rest_volume(),
        tip_y(&bar),
        soft(&built, "banner").max_strain(),
    );
    assert_eq!(pool.len(), 800 + 80, "the spout added its 80 particles");
    assert!(pool.positions().iter().all(|p| p.is_finite()));
    assert!(
        in_tank * 100 >= pool.len() * 99,
        "{in_tank} of {} in the tank",
        pool.len()
    );
    // The crate floats: well off the floor, about half in the water.
    assert!(
        crate_y > level - 0.2 && crate_y < level + 0.15,
        "the crate at {crate_y} m, the water at {level} m"
    );
    assert!(
        jelly_lowest < 0.9 * jelly_rest,
        "the jelly squashed ({jelly_lowest} m)"
    );
    // Back to within 7 % of its height as built (it rests a little
    // squat under its own weight: 0.476 of 0.5 m when this was written).
    assert!(
        soft_height(&jelly) > 0.93 * jelly_rest,
        "the jelly recovered ({} of {jelly_rest} m)",
        soft_height(&jelly)
    );
    assert!(jelly.volume() / jelly.rest_volume() > 0.95);
    assert!(weight_y < 1.0, "the weight fell off the bar ({weight_y} m)");
    // Its own weight sags it 0.03 m; the weight bent it 0.26 m when this
    // was written, and it stays so.
    assert!(
        bar_start - tip_y(&bar) > 0.15,
        "the bar stays bent ({bar_start} → {} m)",
        tip_y(&bar)
    );
    assert!(
        deck.iter().all(|y| (2.0..3.0).contains(y)),
        "the deck hangs: {deck:?}"
    );
    assert!(soft(&built, "banner").max_strain() < 0.02);
}
