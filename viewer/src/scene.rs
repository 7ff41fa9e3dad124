//! What to draw: the entities the server described ([`Catalogue`]) placed
//! where the interpolated frame has them ([`DrawList`]). No GPU here, so
//! the tests check it directly.

use std::collections::{BTreeMap, HashMap};
use std::hash::{Hash, Hasher};

use glam::{DQuat, DVec3, Mat4, Quat, Vec3};
use inertia_client::interp::Sample;
use inertia_client::point_sets::PointSetSample;
use inertia_protocol::{EntityDesc, EntityId, EntityKind, ShapeDesc};

use crate::mesh::Mesh;
use crate::point_sets::surface_of;

/// Names a shape by its content, so entities of one shape share a mesh.
pub type ShapeKey = u64;

/// The key of `shape`: equal shapes, equal keys.
pub fn shape_key(shape: &ShapeDesc) -> ShapeKey {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    hash_shape(shape, &mut h);
    h.finish()
}

fn hash_floats(values: impl IntoIterator<Item = f32>, h: &mut impl Hasher) {
    for v in values {
        v.to_bits().hash(h);
    }
}

fn hash_shape(shape: &ShapeDesc, h: &mut impl Hasher) {
    std::mem::discriminant(shape).hash(h);
    match shape {
        ShapeDesc::Sphere { radius } | ShapeDesc::Particle { radius } => hash_floats([*radius], h),
        ShapeDesc::Cuboid { half_extents } => hash_floats(*half_extents, h),
        ShapeDesc::Capsule {
            half_height,
            radius,
        }
        | ShapeDesc::Cylinder {
            half_height,
            radius,
        } => hash_floats([*half_height, *radius], h),
        ShapeDesc::ConvexHull { points } => {
            points.len().hash(h);
            hash_floats(points.iter().flatten().copied(), h);
        }
        ShapeDesc::TriMesh {
            vertices,
            triangles,
        } => {
            vertices.len().hash(h);
            hash_floats(vertices.iter().flatten().copied(), h);
            triangles.hash(h);
        }
        ShapeDesc::Compound { parts } => {
            parts.len().hash(h);
            for (offset, rotation, part) in parts {
                hash_floats(offset.iter().chain(rotation).copied(), h);
                hash_shape(part, h);
            }
        }
        ShapeDesc::Ground => {}
        ShapeDesc::HeightField {
            rows,
            cols,
            size,
            heights,
        } => {
            (rows, cols).hash(h);
            hash_floats(size.iter().chain(heights).copied(), h);
        }
        ShapeDesc::PointSet {
            points,
            radius,
            triangles,
            lines,
        } => {
            points.hash(h);
            hash_floats([*radius], h);
            triangles.hash(h);
            lines.hash(h);
        }
    }
}

/// How one entity looks.
#[derive(Debug, Clone, PartialEq)]
pub struct Look {
    /// Its shape's key in [`Catalogue::shape`].
    pub shape: ShapeKey,
    /// Linear RGBA (from the description's sRGB bytes).
    pub color: [f32; 4],
    /// What it is.
    pub kind: EntityKind,
    /// The client whose avatar it is.
    pub owner: Option<u64>,
    /// Where it was when described, for bodies that snapshots never move.
    pub pose: Mat4,
}

/// One instance to draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawItem {
    /// Which mesh.
    pub shape: ShapeKey,
    /// The entity's frame in the world (rotation and translation, m).
    pub model: Mat4,
    /// Linear RGBA.
    pub color: [f32; 4],
    /// How its surface is drawn.
    pub finish: Finish,
}

/// How a surface is drawn, in drawing order: opaque ones first, then the
/// see-through ones over them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Finish {
    /// Lit, its colour alone.
    Plain,
    /// Static scenery: a metre grid over its colour, so that motion over
    /// it shows.
    Gridded,
    /// Drawn see-through after everything else (water volumes, colours
    /// with alpha).
    Translucent,
}

/// A mesh made for one picture (a soft body's surface, a rope), in world
/// coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// The triangles, world, m.
    pub mesh: Mesh,
    /// Linear RGBA.
    pub color: [f32; 4],
    /// How it is drawn.
    pub finish: Finish,
}

/// Everything to draw in one picture.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DrawList {
    /// Instances, in the catalogue's order of shapes, opaque first.
    pub items: Vec<DrawItem>,
    /// Meshes of this picture alone (soft bodies and ropes).
    pub surfaces: Vec<Surface>,
}

/// The entities described so far, and their shapes.
#[derive(Debug, Default)]
pub struct Catalogue {
    looks: HashMap<EntityId, Look>,
    shapes: HashMap<ShapeKey, ShapeDesc>,
    /// Soft bodies and fluids, drawn from their points.
    sets: BTreeMap<EntityId, EntityDesc>,
}

/// An sRGB byte as a linear intensity.
fn linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn pose(position: DVec3, rotation: DQuat) -> Mat4 {
    let r = rotation.as_quat();
    let r = if r.is_finite() && r.length_squared() > 0.0 {
        r.normalize()
    } else {
        Quat::IDENTITY
    };
    Mat4::from_rotation_translation(r, position.as_vec3())
}

impl Catalogue {
    /// An empty catalogue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Learns (or relearns) how `desc`'s entity looks.
    pub fn learn(&mut self, desc: &EntityDesc) {
        if let ShapeDesc::PointSet { radius, .. } = desc.shape {
            // Its points are drawn as particles where it has no surface.
            let ball = ShapeDesc::Particle { radius };
            self.shapes.entry(shape_key(&ball)).or_insert(ball);
            self.sets.insert(desc.id, desc.clone());
        }
        let key = shape_key(&desc.shape);
        self.shapes.entry(key).or_insert_with(|| desc.shape.clone());
        let [r, g, b, a] = desc.color;
        let rotation = DQuat::from_array(desc.rotation);
        self.looks.insert(
            desc.id,
            Look {
                shape: key,
                color: [linear(r), linear(g), linear(b), f32::from(a) / 255.0],
                kind: desc.kind,
                owner: desc.owner,
                pose: pose(DVec3::from_array(desc.position), rotation),
            },
        );
    }

    /// Forgets an entity that left.
    pub fn forget(&mut self, id: EntityId) {
        self.looks.remove(&id);
        self.sets.remove(&id);
    }

    /// True once `id` has been described (a point of a soft body or
    /// fluid, once its set has).
    pub fn knows(&self, id: EntityId) -> bool {
        self.looks.contains_key(&id)
            || self
                .sets
                .range(..id)
                .next_back()
                .is_some_and(|(_, set)| set.point_index(id).is_some())
    }

    /// Entities described.
    pub fn len(&self) -> usize {
        self.looks.len()
    }

    /// True before anything was described.
    pub fn is_empty(&self) -> bool {
        self.looks.is_empty()
    }

    /// The shape behind `key`.
    pub fn shape(&self, key: ShapeKey) -> Option<&ShapeDesc> {
        self.shapes.get(&key)
    }

    /// The avatar of client `client_id`, if described.
    pub fn avatar_of(&self, client_id: u64) -> Option<EntityId> {
        self.looks
            .iter()
            .filter(|(_, l)| l.kind == EntityKind::Avatar && l.owner == Some(client_id))
            .map(|(&id, _)| id)
            .min()
    }

    /// The frame's entities where it has them, and the described entities
    /// it does not move (static scenery, water) where they were described.
    /// Entities not yet described are left out.
    pub fn draw_list(&self, frame: &Sample) -> DrawList {
        let mut items = Vec::with_capacity(self.looks.len());
        let mut placed = std::collections::HashSet::with_capacity(frame.entities.len());
        for e in &frame.entities {
            let Some(look) = self.looks.get(&e.id) else {
                continue;
            };
            placed.insert(e.id);
            items.push(item(look, pose(e.position, e.rotation)));
        }
        for (id, look) in &self.looks {
            if !placed.contains(id) && matches!(look.kind, EntityKind::Static | EntityKind::Water) {
                items.push(item(look, look.pose));
            }
        }
        let mut surfaces = Vec::new();
        for (id, desc) in &self.sets {
            let (Some(look), Some(set)) =
                (self.looks.get(id), PointSetSample::gather(desc, frame, &[]))
            else {
                continue;
            };
            let drawn = item(look, Mat4::IDENTITY);
            let mesh = surface_of(&set);
            if mesh.indices.is_empty() {
                // No surface (a fluid): a ball per point.
                let ball = shape_key(&ShapeDesc::Particle {
                    radius: set.radius(),
                });
                items.extend(set.drawn_points().map(|p| DrawItem {
                    shape: ball,
                    model: Mat4::from_translation(p),
                    ..drawn
                }));
            } else {
                surfaces.push(Surface {
                    mesh,
                    color: drawn.color,
                    finish: drawn.finish,
                });
            }
        }
        // Opaque first, then see-through; within each, by mesh (so each
        // mesh's instances are one run), then by position for a stable order.
        items.sort_by(|a, b| {
            (a.finish, a.shape).cmp(&(b.finish, b.shape)).then_with(|| {
                let (pa, pb) = (a.model.w_axis.to_array(), b.model.w_axis.to_array());
                pa.partial_cmp(&pb).unwrap_or(std::cmp::Ordering::Equal)
            })
        });
        DrawList { items, surfaces }
    }
}

fn item(look: &Look, model: Mat4) -> DrawItem {
    let finish = if look.kind == EntityKind::Water || look.color[3] < 0.99 {
        Finish::Translucent
    } else if look.kind == EntityKind::Static {
        Finish::Gridded
    } else {
        Finish::Plain
    };
    DrawItem {
        shape: look.shape,
        model,
        color: look.color,
        finish,
    }
}

/// Where an entity is in `frame`, m.
pub fn position_in(frame: &Sample, id: EntityId) -> Option<Vec3> {
    frame.get(id).map(|e| e.position.as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_client::interp::RenderedEntity;

    fn desc(id: EntityId, kind: EntityKind, shape: ShapeDesc) -> EntityDesc {
        EntityDesc {
            id,
            kind,
            shape,
            color: [255, 128, 0, 255],
            owner: None,
            name: String::new(),
            position: [0.0, 5.0, 0.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    fn rendered(id: EntityId, x: f64) -> RenderedEntity {
        RenderedEntity {
            id,
            position: DVec3::new(x, 1.0, 0.0),
            rotation: DQuat::IDENTITY,
            extrapolated: false,
        }
    }

    #[test]
    fn equal_shapes_share_a_key_and_different_ones_do_not() {
        let a = ShapeDesc::Cuboid {
            half_extents: [0.5, 0.5, 0.5],
        };
        let b = ShapeDesc::Cuboid {
            half_extents: [0.5, 0.5, 0.25],
        };
        assert_eq!(shape_key(&a), shape_key(&a.clone()));
        assert_ne!(shape_key(&a), shape_key(&b));
        assert_ne!(
            shape_key(&ShapeDesc::Sphere { radius: 1.0 }),
            shape_key(&ShapeDesc::Particle { radius: 1.0 })
        );
    }

    #[test]
    fn moving_bodies_are_drawn_where_the_frame_has_them_and_scenery_where_described() {
        let mut cat = Catalogue::new();
        let ball = ShapeDesc::Sphere { radius: 0.5 };
        cat.learn(&desc(1, EntityKind::Dynamic, ball.clone()));
        cat.learn(&desc(2, EntityKind::Dynamic, ball));
        cat.learn(&desc(3, EntityKind::Static, ShapeDesc::Ground));
        let frame = Sample {
            render_tick: 10.0,
            entities: vec![rendered(1, 3.0), rendered(9, 0.0)],
        };
        let list = cat.draw_list(&frame);
        // 1 from the frame, 3 (static) from its description; 2 is out of
        // view and 9 is not described yet.
        assert_eq!(list.items.len(), 2);
        let moved = list
            .items
            .iter()
            .find(|i| i.shape != shape_key(&ShapeDesc::Ground))
            .unwrap();
        assert_eq!(moved.model.w_axis.truncate(), Vec3::new(3.0, 1.0, 0.0));
        let ground = list
            .items
            .iter()
            .find(|i| i.shape == shape_key(&ShapeDesc::Ground))
            .unwrap();
        assert_eq!(ground.model.w_axis.truncate(), Vec3::new(0.0, 5.0, 0.0));
        assert!(
            ground.finish == Finish::Gridded && moved.finish != Finish::Gridded,
            "only scenery is gridded"
        );
    }

    #[test]
    fn water_is_drawn_after_the_opaque_bodies() {
        let mut cat = Catalogue::new();
        cat.learn(&desc(
            1,
            EntityKind::Water,
            ShapeDesc::Cuboid {
                half_extents: [1.0; 3],
            },
        ));
        cat.learn(&desc(2, EntityKind::Static, ShapeDesc::Ground));
        let list = cat.draw_list(&Sample::default());
        assert!(
            list.items[0].finish != Finish::Translucent
                && list.items[1].finish == Finish::Translucent
        );
    }

    #[test]
    fn colours_are_made_linear_and_a_bad_rotation_is_drawn_unturned() {
        let mut cat = Catalogue::new();
        let mut d = desc(1, EntityKind::Static, ShapeDesc::Sphere { radius: 1.0 });
        d.color = [255, 0, 188, 128];
        d.rotation = [0.0, 0.0, 0.0, 0.0];
        cat.learn(&d);
        let list = cat.draw_list(&Sample::default());
        let c = list.items[0].color;
        assert_eq!(c[0], 1.0);
        assert_eq!(c[1], 0.0);
        assert!(
            (c[2] - 0.5).abs() < 0.01,
            "sRGB 188 is about half intensity"
        );
        assert!(list.items[0].model.is_finite());
    }

    #[test]
    fn soft_bodies_are_drawn_as_surfaces_and_fluids_as_balls() {
        let set = |id, kind, points, triangles| EntityDesc {
            shape: ShapeDesc::PointSet {
                points,
                radius: 0.05,
                triangles,
                lines: vec![],
            },
            ..desc(id, kind, ShapeDesc::Ground)
        };
        let mut cat = Catalogue::new();
        cat.learn(&set(10, EntityKind::SoftBody, 3, vec![[0, 1, 2]]));
        cat.learn(&set(20, EntityKind::Fluid, 5, vec![]));
        // The cloth's three points, and two of the fluid's five.
        let frame = Sample {
            render_tick: 1.0,
            entities: vec![
                rendered(11, 0.0),
                rendered(12, 1.0),
                rendered(13, 2.0),
                rendered(21, 5.0),
                rendered(23, 6.0),
            ],
        };
        let mut moved = frame.clone();
        moved.entities[2].position.z = 1.0;
        let list = cat.draw_list(&moved);
        assert_eq!(list.surfaces.len(), 1);
        assert_eq!(list.surfaces[0].mesh.triangle_count(), 1);
        let balls: Vec<_> = list
            .items
            .iter()
            .map(|i| i.model.w_axis.truncate())
            .collect();
        assert_eq!(balls, [Vec3::new(5.0, 1.0, 0.0), Vec3::new(6.0, 1.0, 0.0)]);
        let ball = ShapeDesc::Particle { radius: 0.05 };
        assert_eq!(list.items[0].shape, shape_key(&ball));
        assert_eq!(cat.shape(shape_key(&ball)), Some(&ball));
        assert!(cat.knows(12) && cat.knows(25) && !cat.knows(26));
        cat.forget(10);
        assert!(cat.draw_list(&moved).surfaces.is_empty());
        assert!(!cat.knows(12));
    }

    #[test]
    fn the_avatar_is_found_by_its_owner() {
        let mut cat = Catalogue::new();
        let mut d = desc(7, EntityKind::Avatar, ShapeDesc::Sphere { radius: 1.0 });
        d.owner = Some(42);
        cat.learn(&d);
        assert_eq!(cat.avatar_of(42), Some(7));
        assert_eq!(cat.avatar_of(41), None);
        cat.forget(7);
        assert_eq!(cat.avatar_of(42), None);
    }
}
