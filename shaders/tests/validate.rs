//! Every shader parses and validates with naga, declares the workgroup size
//! the engine dispatches with, and lays out its shared structs at the byte
//! sizes in `inertia_shaders::layout` (which the engine's `#[repr(C)]`
//! mirrors assert at compile time).

use inertia_shaders::{layout, ALL, DRAWING};
use naga::valid::{Capabilities, ValidationFlags, Validator};

fn parse(name: &str, src: &str) -> naga::Module {
    naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{name} does not parse:\n{}", e.emit_to_string(src)))
}

/// `src` parsed and validated (panicking with naga's report otherwise).
fn validated(name: &str, src: &str) -> naga::Module {
    let module = parse(name, src);
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name} does not validate:\n{}", e.emit_to_string(src)));
    module
}

#[test]
fn every_shader_parses_and_validates() {
    assert!(!ALL.is_empty());
    for (name, src) in ALL {
        validated(name, src);
    }
}

#[test]
fn every_drawing_shader_validates_with_its_vertex_and_fragment_entry_points() {
    assert!(!DRAWING.is_empty());
    for (name, src) in DRAWING {
        let module = validated(name, src);
        let stages: Vec<_> = module.entry_points.iter().map(|e| e.stage).collect();
        assert!(stages.contains(&naga::ShaderStage::Vertex), "{name}");
        assert!(stages.contains(&naga::ShaderStage::Fragment), "{name}");
    }
}

/// The particle step's shaders (one `main` each, one shared layout).
fn particle_shaders() -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    ALL.iter().filter(|(name, _)| name.starts_with("particle_"))
}

#[test]
fn every_particle_shader_has_one_compute_main_of_the_engine_workgroup_size() {
    for (name, src) in particle_shaders() {
        let module = parse(name, src);
        assert_eq!(module.entry_points.len(), 1, "{name}");
        let ep = &module.entry_points[0];
        assert_eq!(ep.name, "main", "{name}");
        assert_eq!(ep.stage, naga::ShaderStage::Compute, "{name}");
        assert_eq!(ep.workgroup_size, [layout::WORKGROUP_SIZE, 1, 1], "{name}");
    }
}

/// Byte size naga computes for the struct called `wanted`, if declared.
fn struct_size(module: &naga::Module, wanted: &str) -> Option<usize> {
    module
        .types
        .iter()
        .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
            (Some(n), naga::TypeInner::Struct { span, .. }) if n == wanted => Some(*span as usize),
            _ => None,
        })
}

#[test]
fn shared_structs_match_the_engine_layout() {
    let expected = [
        ("Params", layout::PARAMS_BYTES),
        ("Body", layout::BODY_BYTES),
        ("FieldForce", layout::FIELD_FORCE_BYTES),
        ("Props", layout::PROPS_BYTES),
        ("Spring", layout::SPRING_BYTES),
    ];
    let mut seen = vec![0; expected.len()];
    for (name, src) in particle_shaders() {
        let module = parse(name, src);
        for (k, (ty, bytes)) in expected.iter().enumerate() {
            if let Some(size) = struct_size(&module, ty) {
                assert_eq!(size, *bytes, "{name}: struct {ty}");
                seen[k] += 1;
            }
        }
    }
    for (k, (ty, _)) in expected.iter().enumerate() {
        assert!(seen[k] > 0, "no shader declares struct {ty}");
    }
}

/// The block between the shared-layout markers, if any.
fn shared_block(src: &str) -> Option<&str> {
    let start = src.find("// ---- shared layout")?;
    let end = src.find("// ---- end of shared layout ----")?;
    Some(&src[start..end])
}

#[test]
fn shared_layout_block_is_identical_in_every_particle_shader() {
    let blocks: Vec<(&str, &str)> = ALL
        .iter()
        .filter(|(name, _)| name.starts_with("particle_"))
        .map(|(name, src)| {
            let block =
                shared_block(src).unwrap_or_else(|| panic!("{name} lacks the shared layout block"));
            (*name, block)
        })
        .collect();
    assert!(blocks.len() >= 2);
    for (name, block) in &blocks[1..] {
        assert_eq!(*block, blocks[0].1, "{name} differs from {}", blocks[0].0);
    }
}

#[test]
fn the_soft_body_shader_has_its_entry_points_and_the_engine_layout() {
    let module = validated("xpbd_soft.wgsl", inertia_shaders::XPBD_SOFT);
    let mut names: Vec<&str> = module
        .entry_points
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "advance_bodies",
            "attach",
            "collide",
            "find_contacts",
            "finish",
            "flow",
            "predict",
            "project",
            "reduce_bodies",
            "reduce_chunks",
            "shell_apply",
            "shell_gradient",
            "shell_sums",
            "shell_total",
            "take_pushes"
        ]
    );
    for ep in &module.entry_points {
        assert_eq!(ep.stage, naga::ShaderStage::Compute);
        assert_eq!(
            ep.workgroup_size,
            [layout::WORKGROUP_SIZE, 1, 1],
            "{}",
            ep.name
        );
    }
    for (ty, bytes) in [
        ("SoftParams", layout::SOFT_PARAMS_BYTES),
        ("Distance", layout::SOFT_DISTANCE_BYTES),
        ("Quad", layout::SOFT_QUAD_BYTES),
        ("Tether", layout::SOFT_TETHER_BYTES),
        ("Attachment", layout::SOFT_ATTACHMENT_BYTES),
        ("Shape", layout::SHAPE_BYTES),
        ("Push", layout::PUSH_BYTES),
        ("Motion", layout::MOTION_BYTES),
    ] {
        assert_eq!(struct_size(&module, ty), Some(bytes), "struct {ty}");
    }
    for (constant, value) in [
        ("WORKGROUP_SIZE", layout::WORKGROUP_SIZE as usize),
        ("BODY_SLOTS", layout::BODY_SLOTS),
        ("PUSH_CHUNK", layout::PUSH_CHUNK),
        ("SHELL_CHUNK", layout::SHELL_CHUNK),
    ] {
        let decl = format!("const {constant}: u32 = {value}u;");
        assert!(
            inertia_shaders::XPBD_SOFT.contains(&decl),
            "xpbd_soft.wgsl must declare `{decl}`"
        );
    }
}

#[test]
fn the_self_collision_shader_has_its_entry_points_and_the_engine_layout() {
    let module = validated(
        "xpbd_self_collision.wgsl",
        inertia_shaders::XPBD_SELF_COLLISION,
    );
    let mut names: Vec<&str> = module
        .entry_points
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "count",
            "keep",
            "scan",
            "scatter",
            "self_collide",
            "sort_cells"
        ]
    );
    assert_eq!(
        struct_size(&module, "SelfParams"),
        Some(layout::SELF_PARAMS_BYTES)
    );
    assert_eq!(struct_size(&module, "Slot"), Some(layout::FLUID_SLOT_BYTES));
    for (constant, value) in [
        ("WORKGROUP_SIZE", layout::WORKGROUP_SIZE as usize),
        ("SCAN_SIZE", layout::FLUID_SCAN_SIZE as usize),
    ] {
        let decl = format!("const {constant}: u32 = {value}u;");
        assert!(
            inertia_shaders::XPBD_SELF_COLLISION.contains(&decl),
            "xpbd_self_collision.wgsl must declare `{decl}`"
        );
    }
}

#[test]
fn shader_constants_match_the_engine_limits() {
    for (name, src) in particle_shaders() {
        for (constant, value) in [
            ("WORKGROUP_SIZE", layout::WORKGROUP_SIZE as usize),
            ("MAX_FIELD_FORCES", layout::MAX_FIELD_FORCES),
            ("MAX_MUTUAL_GRAVITY", layout::MAX_MUTUAL_GRAVITY),
        ] {
            let decl = format!("const {constant}: u32 = {value}u;");
            assert!(src.contains(&decl), "{name} must declare `{decl}`");
        }
    }
}

#[test]
fn the_fluid_shader_has_its_entry_points_and_the_engine_layout() {
    let src = inertia_shaders::PBF;
    let module = validated("pbf.wgsl", src);
    let mut names: Vec<&str> = module
        .entry_points
        .iter()
        .map(|e| e.name.as_str())
        .collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "advance_bodies",
            "collide",
            "confine",
            "corrections",
            "count",
            "densities",
            "find_walls",
            "predict",
            "reduce_bodies",
            "reduce_chunks",
            "scan",
            "scatter",
            "sort_cells",
            "take_pushes",
            "take_velocities",
            "vorticity",
            "xsph"
        ]
    );
    for ep in &module.entry_points {
        assert_eq!(ep.stage, naga::ShaderStage::Compute);
        let size = if ep.name == "scan" {
            layout::FLUID_SCAN_SIZE
        } else {
            layout::WORKGROUP_SIZE
        };
        assert_eq!(ep.workgroup_size, [size, 1, 1], "{}", ep.name);
    }
    for (ty, bytes) in [
        ("FluidParams", layout::FLUID_PARAMS_BYTES),
        ("Shape", layout::SHAPE_BYTES),
        ("Plane", layout::FLUID_PLANE_BYTES),
        ("Slot", layout::FLUID_SLOT_BYTES),
        ("Push", layout::PUSH_BYTES),
        ("Motion", layout::MOTION_BYTES),
    ] {
        assert_eq!(struct_size(&module, ty), Some(bytes), "struct {ty}");
    }
    for (constant, value) in [
        ("WORKGROUP_SIZE", layout::WORKGROUP_SIZE as usize),
        ("SCAN_SIZE", layout::FLUID_SCAN_SIZE as usize),
        ("BODY_SLOTS", layout::BODY_SLOTS),
        ("PUSH_CHUNK", layout::PUSH_CHUNK),
    ] {
        let decl = format!("const {constant}: u32 = {value}u;");
        assert!(src.contains(&decl), "pbf.wgsl must declare `{decl}`");
    }
}
