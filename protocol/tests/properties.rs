//! The game's properties in snapshots: a change reaches the client under
//! loss and stays right (eventually consistent), an unchanged property
//! costs nothing, a new entity's properties come with it and a removed
//! one's go, and both ends must agree on the schema.

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{DQuat, DVec3};
use inertia_protocol::property::{
    FrameProperties, PropertyDecl, PropertyKind, PropertyRow, PropertySchema, PropertyValue,
};
use inertia_protocol::rng::SplitMix;
use inertia_protocol::snapshot::QuantizedFrame;
use inertia_protocol::{
    EntityId, EntityState, Interest, PriorityAccumulator, SnapshotConfig, SnapshotDecoder,
    SnapshotEncoder,
};

fn schema() -> Arc<PropertySchema> {
    Arc::new(PropertySchema {
        entity: vec![
            PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
            PropertyDecl::new("team", PropertyKind::UInt { bits: 2 }),
            PropertyDecl::new("alive", PropertyKind::Bool),
        ],
        match_state: vec![
            PropertyDecl::new("score_red", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("score_blue", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("clock", PropertyKind::F32),
        ],
    })
}

fn still(id: EntityId) -> EntityState {
    EntityState {
        id,
        position: DVec3::new(f64::from(id), 0.0, 0.0),
        rotation: DQuat::IDENTITY,
        linear_velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        asleep: true,
    }
}

/// The server's side of the test: entities and their property rows.
struct World {
    entities: Vec<EntityState>,
    rows: BTreeMap<EntityId, Vec<u64>>,
    match_state: Vec<u64>,
    tick: u64,
}

impl World {
    fn new(n: u32) -> Self {
        Self {
            entities: (1..=n).map(still).collect(),
            rows: BTreeMap::new(),
            match_state: vec![0, 0, 0],
            tick: 0,
        }
    }

    fn frame(&self, config: &SnapshotConfig) -> QuantizedFrame {
        let props = FrameProperties {
            entities: self
                .rows
                .iter()
                .filter(|(id, _)| self.entities.iter().any(|e| e.id == **id))
                .map(|(id, r)| (*id, PropertyRow::from(r.clone())))
                .collect(),
            match_state: Some(self.match_state.clone().into()),
        };
        QuantizedFrame::new(self.tick, 1.0, false, &self.entities, config)
            .with_properties(Arc::new(props))
    }

    /// What a client should hold of entity `id`.
    fn row(&self, id: EntityId) -> Vec<u64> {
        self.rows.get(&id).cloned().unwrap_or_else(|| vec![0; 3])
    }
}

fn held(dec: &SnapshotDecoder, seq: u16, id: EntityId) -> Vec<u64> {
    dec.view(seq)
        .and_then(|v| v.properties().entity(id).map(|r| r.to_vec()))
        .unwrap_or_else(|| vec![0; 3])
}

#[test]
fn issue_43_property_changes_reach_the_client_under_loss_and_unchanged_ones_cost_nothing() {
    let config = SnapshotConfig::default();
    let mut enc = SnapshotEncoder::new(config)
        .unwrap()
        .with_properties(schema());
    let mut dec = SnapshotDecoder::new(config)
        .unwrap()
        .with_properties(schema());
    let mut pri = PriorityAccumulator::new(Interest::everything());
    let mut world = World::new(300);
    let mut rng = SplitMix(0x9e37);
    let mut newest = None;
    let mut sent_values = 0;
    for step in 0..400 {
        world.tick += 2;
        let changing = step < 300;
        if changing {
            // A tenth of the entities take a new health; a team changes
            // now and then; the clock runs; a goal is scored sometimes.
            for _ in 0..30 {
                let id = 1 + (rng.next_u64() % 300) as u32;
                let row = world.rows.entry(id).or_insert_with(|| vec![100, 0, 1]);
                row[0] = rng.next_u64() % 101;
                if rng.next_u64() % 10 == 0 {
                    row[1] = rng.next_u64() % 4;
                }
            }
            world.match_state[2] = PropertyValue::F32(step as f32 * 0.5)
                .to_raw(PropertyKind::F32)
                .unwrap();
            if step % 50 == 7 {
                world.match_state[0] += 1;
            }
        }
        let frame = world.frame(&config);
        let bytes = enc.encode_frame(&frame, &mut pri, 1200);
        sent_values += enc.last_report().properties;
        // 20 % of snapshots and of acknowledgements lost while changing.
        let lost = |rng: &mut SplitMix| changing && rng.next_u64() % 5 == 0;
        if lost(&mut rng) {
            continue;
        }
        let got = dec.decode(&bytes).expect("decodes");
        if got.newest {
            newest = Some(got.sequence);
        }
        if !lost(&mut rng) {
            enc.on_ack(got.sequence);
        }
    }
    assert!(sent_values > 0);
    // Converged: the client's newest view holds every entity's properties
    // and the match's as the server has them.
    let seq = newest.expect("snapshots arrived");
    for id in 1..=300 {
        assert_eq!(held(&dec, seq, id), world.row(id), "entity {id}");
    }
    let view = dec.view(seq).unwrap();
    assert_eq!(
        view.properties().match_state().map(|r| r.to_vec()),
        Some(world.match_state.clone())
    );
    // Nothing changed for a while: the section is its fixed bits only
    // (the match's changed bit and an empty count, 5 bits), nothing per
    // property.
    let report = enc.last_report();
    assert_eq!(report.properties, 0);
    assert!(report.property_bits <= 5, "{} bits", report.property_bits);
}

#[test]
fn issue_43_a_new_entitys_properties_come_with_it_and_a_removed_ones_go() {
    let config = SnapshotConfig::default();
    let mut enc = SnapshotEncoder::new(config)
        .unwrap()
        .with_properties(schema());
    let mut dec = SnapshotDecoder::new(config)
        .unwrap()
        .with_properties(schema());
    let mut pri = PriorityAccumulator::new(Interest::everything());
    let mut world = World::new(5);
    world.rows.insert(3, vec![55, 2, 1]);
    let mut step = |world: &World, enc: &mut SnapshotEncoder, dec: &mut SnapshotDecoder| {
        let got = dec
            .decode(&enc.encode_frame(&world.frame(&config), &mut pri, 1200))
            .unwrap();
        enc.on_ack(got.sequence);
        got
    };
    let got = step(&world, &mut enc, &mut dec);
    assert_eq!(got.updated.len(), 5);
    assert_eq!(got.properties, vec![(3, PropertyRow::from(vec![55, 2, 1]))]);

    // A new entity with properties: they come in its first snapshot.
    world.tick += 1;
    world.entities.push(still(9));
    world.rows.insert(9, vec![100, 1, 1]);
    let got = step(&world, &mut enc, &mut dec);
    assert_eq!(got.updated.iter().map(|e| e.id).collect::<Vec<_>>(), [9]);
    assert_eq!(
        got.properties,
        vec![(9, PropertyRow::from(vec![100, 1, 1]))]
    );

    // Entity 3 goes: so do its properties.
    world.tick += 1;
    world.entities.retain(|e| e.id != 3);
    world.rows.remove(&3);
    let got = step(&world, &mut enc, &mut dec);
    assert_eq!(got.removed, [3]);
    assert!(got.properties.is_empty());
    let view = dec.view(got.sequence).unwrap();
    assert!(view.properties().entity(3).is_none());
    assert!(view.properties().entity(9).is_some());
}

#[test]
fn issue_43_both_ends_must_know_the_schema() {
    let config = SnapshotConfig::default();
    let mut enc = SnapshotEncoder::new(config)
        .unwrap()
        .with_properties(schema());
    let mut pri = PriorityAccumulator::new(Interest::everything());
    let mut world = World::new(3);
    world.rows.insert(2, vec![1, 1, 1]);
    let bytes = enc.encode_frame(&world.frame(&config), &mut pri, 1200);
    // A decoder that reads no properties finds bytes it cannot account
    // for; one with the schema reads them.
    let mut blind = SnapshotDecoder::new(config).unwrap();
    assert!(blind.decode(&bytes).is_err());
    let mut dec = SnapshotDecoder::new(config)
        .unwrap()
        .with_properties(schema());
    assert!(dec.decode(&bytes).is_ok());
    // Every cut of it is refused, never a panic.
    for cut in 0..bytes.len() {
        let mut d = SnapshotDecoder::new(config)
            .unwrap()
            .with_properties(schema());
        assert!(d.decode(&bytes[..cut]).is_err(), "cut at {cut}");
    }
}
