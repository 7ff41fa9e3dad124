//! Soft bodies and fluids as a game draws them: vertex and point sets.
//!
//! The server describes a soft body (rope, cloth, jelly) or a fluid as one
//! entity whose shape is a [`ShapeDesc::PointSet`], and streams its points
//! as the entities just after its id, interpolated like any entity. Here
//! they are gathered back into one [`PointSetSample`] per set: the points'
//! positions at the render tick, which of them are known, and the set's
//! triangles and lines, for a game to upload as a dynamic mesh (cloth, a
//! solid's surface), a line strip (a rope) or instanced points (a fluid).

use glam::Vec3;
use inertia_protocol::{EntityDesc, EntityId, EntityKind, ShapeDesc};

use crate::entities::{KnownEntities, LatestState};
use crate::interp::Sample;

/// One soft body or fluid at a sample's render tick.
#[derive(Debug, Clone, PartialEq)]
pub struct PointSetSample<'a> {
    /// The set's entity.
    pub id: EntityId,
    /// Its description: kind ([`EntityKind::SoftBody`] or
    /// [`EntityKind::Fluid`]), colour, name; its shape is the point set.
    pub desc: &'a EntityDesc,
    /// Each point's position, m (the origin for a point not known).
    pub positions: Vec<Vec3>,
    /// Whether each point is known: placed by a snapshot and in the
    /// client's view. A fluid's particles not emitted yet are not.
    pub present: Vec<bool>,
}

impl PointSetSample<'_> {
    /// Drawing radius of a point, m.
    pub fn radius(&self) -> f32 {
        match self.desc.shape {
            ShapeDesc::PointSet { radius, .. } => radius,
            _ => 0.0,
        }
    }

    /// The set's triangles (counter-clockwise seen from outside).
    pub fn triangles(&self) -> &[[u32; 3]] {
        match &self.desc.shape {
            ShapeDesc::PointSet { triangles, .. } => triangles,
            _ => &[],
        }
    }

    /// The set's lines (a rope's segments).
    pub fn lines(&self) -> &[[u32; 2]] {
        match &self.desc.shape {
            ShapeDesc::PointSet { lines, .. } => lines,
            _ => &[],
        }
    }

    /// The triangles whose three points are known: what to draw.
    pub fn drawn_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.triangles()
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&i| self.present[i as usize]))
    }

    /// The lines whose two points are known.
    pub fn drawn_lines(&self) -> impl Iterator<Item = [u32; 2]> + '_ {
        self.lines()
            .iter()
            .copied()
            .filter(|l| l.iter().all(|&i| self.present[i as usize]))
    }

    /// The known points' positions, m.
    pub fn drawn_points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.positions
            .iter()
            .zip(&self.present)
            .filter_map(|(&p, &known)| known.then_some(p))
    }

    /// A unit normal per point for smooth shading: the sum of the drawn
    /// triangles' area-weighted normals around it (zero for a point in no
    /// drawn triangle).
    pub fn normals(&self) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for [a, b, c] in self.drawn_triangles() {
            let (pa, pb, pc) = (
                self.positions[a as usize],
                self.positions[b as usize],
                self.positions[c as usize],
            );
            let face = (pb - pa).cross(pc - pa);
            for i in [a, b, c] {
                n[i as usize] += face;
            }
        }
        n.iter().map(|v| v.normalize_or_zero()).collect()
    }
}

impl<'a> PointSetSample<'a> {
    /// The set `desc` describes at `frame`'s render tick: a point is where
    /// the frame puts its entity (interpolated), else where `newest` (its
    /// newest state by point index, if kept) has it, else unknown. `None`
    /// when `desc` is not a point set.
    pub fn gather(
        desc: &'a EntityDesc,
        frame: &Sample,
        newest: &[Option<LatestState>],
    ) -> Option<Self> {
        let ShapeDesc::PointSet { points, .. } = desc.shape else {
            return None;
        };
        let n = points as usize;
        let mut positions = vec![Vec3::ZERO; n];
        let mut present = vec![false; n];
        for (i, latest) in newest.iter().take(n).enumerate() {
            if let Some(l) = latest {
                positions[i] = l.state.position.as_vec3();
                present[i] = true;
            }
        }
        // The frame's entities are ascending by id, so the set's points
        // are one run of them.
        let first = frame.entities.partition_point(|e| e.id <= desc.id);
        for e in &frame.entities[first..] {
            let Some(index) = desc.point_index(e.id) else {
                break;
            };
            positions[index as usize] = e.position.as_vec3();
            present[index as usize] = true;
        }
        Some(Self {
            id: desc.id,
            desc,
            positions,
            present,
        })
    }
}

/// Every soft body and fluid the table knows, drawn at `frame`'s render
/// tick ([`PointSetSample::gather`] with the newest state of each point).
pub fn point_sets<'a>(frame: &Sample, table: &'a KnownEntities) -> Vec<PointSetSample<'a>> {
    table
        .iter()
        .filter(|(_, e)| matches!(e.desc.kind, EntityKind::SoftBody | EntityKind::Fluid))
        .filter_map(|(_, e)| PointSetSample::gather(&e.desc, frame, &e.points))
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::{DQuat, DVec3};
    use inertia_protocol::snapshot::ViewEntity;

    use super::*;
    use crate::interp::RenderedEntity;

    fn cloth(id: EntityId) -> EntityDesc {
        EntityDesc {
            id,
            kind: EntityKind::SoftBody,
            shape: ShapeDesc::PointSet {
                points: 4,
                radius: 0.01,
                triangles: vec![[0, 1, 2], [1, 3, 2]],
                lines: vec![],
            },
            color: [200, 40, 40, 255],
            owner: None,
            name: "flag".into(),
            position: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    fn state(id: EntityId, p: [f64; 3]) -> ViewEntity {
        ViewEntity {
            id,
            position: DVec3::from_array(p),
            rotation: DQuat::IDENTITY,
            linear_velocity: None,
            angular_velocity: None,
            at_rest: false,
        }
    }

    fn rendered(id: EntityId, p: [f64; 3]) -> RenderedEntity {
        RenderedEntity {
            id,
            position: DVec3::from_array(p),
            rotation: DQuat::IDENTITY,
            extrapolated: false,
        }
    }

    #[test]
    fn points_are_gathered_from_the_frame_and_the_newest_states() {
        let mut table = KnownEntities::new();
        // A point's state before the set's spawn is held, then attached.
        table.update(1, state(12, [0.0, 1.0, 0.0]));
        table.spawn(cloth(10));
        assert_eq!(table.held(), 0, "the early point went to its set");
        assert_eq!(table.point_of(12), Some((10, 1)));
        assert_eq!(table.point_of(10), None, "the set itself");
        assert_eq!(table.point_of(15), None, "past its points");
        table.update(2, state(11, [0.0, 0.0, 0.0]));
        // The frame has points 0 and 2 (interpolated) and another entity
        // after the set; point 3 is not known yet.
        let frame = Sample {
            render_tick: 2.0,
            entities: vec![
                rendered(3, [9.0; 3]),
                rendered(11, [0.0, 0.0, 0.5]),
                rendered(13, [1.0, 0.0, 0.0]),
                rendered(20, [9.0; 3]),
            ],
        };
        let sets = point_sets(&frame, &table);
        assert_eq!(sets.len(), 1);
        let set = &sets[0];
        assert_eq!(set.id, 10);
        assert_eq!(set.present, [true, true, true, false]);
        assert_eq!(set.positions[0], Vec3::new(0.0, 0.0, 0.5), "the frame's");
        assert_eq!(set.positions[1], Vec3::new(0.0, 1.0, 0.0), "the newest");
        assert_eq!(set.drawn_triangles().collect::<Vec<_>>(), [[0, 1, 2]]);
        assert_eq!(set.drawn_points().count(), 3);
        let n = set.normals();
        assert!((n[0].length() - 1.0).abs() < 1e-6);
        assert_eq!(n[3], Vec3::ZERO, "in no drawn triangle");
        assert_eq!(set.radius(), 0.01);
        // A despawn takes the points with it.
        table.despawn(10);
        assert!(point_sets(&frame, &table).is_empty());
        assert_eq!(table.point_of(12), None);
    }

    #[test]
    fn a_respawned_set_keeps_the_points_it_still_has() {
        let mut table = KnownEntities::new();
        table.spawn(cloth(10));
        table.update(1, state(14, [3.0, 0.0, 0.0]));
        let mut torn = cloth(10);
        torn.shape = ShapeDesc::PointSet {
            points: 4,
            radius: 0.01,
            triangles: vec![[0, 1, 2]],
            lines: vec![],
        };
        assert!(!table.spawn(torn));
        let frame = Sample::default();
        let sets = point_sets(&frame, &table);
        assert_eq!(sets[0].positions[3], Vec3::new(3.0, 0.0, 0.0));
        assert_eq!(sets[0].triangles().len(), 1);
    }
}
