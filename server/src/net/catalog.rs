//! What each client has been told about the world: the entity catalog
//! (spawns and despawns, on its control stream) and the rules' messages
//! for it (reliable ones on the control stream, after the slot's spawns;
//! unreliable ones as datagrams), brought up to date at the client's
//! snapshot slots by the snapshot stage, so that a slot's control messages
//! leave with its snapshot (see [`super::snapshots`]).

use std::collections::BTreeMap;
use std::sync::Arc;

use inertia_protocol::control::{encode_frame, ServerControl};
use inertia_protocol::{EntityDesc, EntityId, ShapeDesc};

use inertia_protocol::message::Delivery;

use crate::rules::ClientId;
use crate::sim::{CatalogChange, RecentMessage};

/// What one client has been told.
#[derive(Debug, Clone)]
pub struct Told {
    /// The client.
    client: ClientId,
    /// Entities described to the client, ascending.
    known: Vec<EntityId>,
    /// The catalog version last told.
    catalog_version: Option<u64>,
    /// The number of the last message looked at
    /// ([`RecentMessage::number`]), whether it was for the client or not.
    messages_told: u64,
}

/// What one [`Told::catch_up`] told.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CaughtUp {
    /// Control-stream bytes appended.
    pub bytes: usize,
    /// Messages of the rules that had left the recent ones
    /// ([`crate::sim::RECENT_MESSAGES`]) before the client's slot looked
    /// at them: at most this many of them were for the client, and it
    /// missed those.
    pub missed: u64,
}

impl Told {
    /// `client`, told nothing of the catalog yet, to whom the rules'
    /// messages from number `first_message` on are news (those before
    /// were sent before it came).
    pub fn new(client: ClientId, first_message: u64) -> Self {
        Self {
            client,
            known: Vec::new(),
            catalog_version: None,
            messages_told: first_message.saturating_sub(1),
        }
    }

    /// Brings the client up to date with a frame's catalog (at `version`,
    /// reached by the recent `changes`) and `recent` messages: appends to
    /// `out` the control frames of the despawns, then the spawns (both in
    /// id order), then the reliable messages for the client published
    /// since the last call; pushes the datagrams of the unreliable ones
    /// onto `datagrams`. Each message is coded once for every client
    /// ([`RecentMessage::wire`]). A client told a version the changes
    /// reach from is told each change since; one told an older version (or
    /// none) is told the difference from one walk of the whole catalog.
    pub fn catch_up(
        &mut self,
        version: u64,
        catalog: &BTreeMap<EntityId, EntityDesc>,
        changes: &[Arc<CatalogChange>],
        recent: &[Arc<RecentMessage>],
        out: &mut Vec<u8>,
        datagrams: &mut Vec<Vec<u8>>,
    ) -> Result<CaughtUp, String> {
        let start = out.len();
        if self.catalog_version != Some(version) {
            let since = self
                .catalog_version
                .and_then(|told| changes_since(changes, told, version));
            match since {
                Some(since) => {
                    for change in since {
                        self.tell_change(change, catalog, out)?;
                    }
                }
                None => {
                    // What the client knows against the whole catalog; the
                    // point sets it knows may have changed shape since.
                    let mut change = CatalogChange::of_ids(
                        version,
                        self.known.iter().copied(),
                        catalog.keys().copied(),
                    );
                    change.reshaped = self
                        .known
                        .iter()
                        .filter(|id| {
                            catalog
                                .get(id)
                                .is_some_and(|d| matches!(d.shape, ShapeDesc::PointSet { .. }))
                        })
                        .copied()
                        .collect();
                    self.tell_change(&change, catalog, out)?;
                }
            }
            self.catalog_version = Some(version);
        }
        let first = recent.partition_point(|m| m.number <= self.messages_told);
        let mut missed = 0;
        if let Some(oldest) = recent[first..].first() {
            // Numbers are consecutive: those between were dropped from the
            // recent ones before this slot (whoever they were for).
            missed = oldest.number.saturating_sub(self.messages_told + 1);
        }
        for m in &recent[first..] {
            self.messages_told = m.number;
            if !m.message.to.includes(self.client) {
                continue;
            }
            let Some(wire) = m.wire() else { continue };
            match m.message.delivery {
                Delivery::Reliable => out.extend_from_slice(wire),
                Delivery::Unreliable => datagrams.push(wire.to_vec()),
            }
        }
        Ok(CaughtUp {
            bytes: out.len() - start,
            missed,
        })
    }

    /// Tells one change: its despawns of entities the client knows, then
    /// its spawns of entities still in `catalog` (a later change may have
    /// taken one away again), then the new descriptions of reshaped
    /// entities it knows (a spawn of a known id replaces its description).
    fn tell_change(
        &mut self,
        change: &CatalogChange,
        catalog: &BTreeMap<EntityId, EntityDesc>,
        out: &mut Vec<u8>,
    ) -> Result<(), String> {
        for &id in &change.despawned {
            if let Ok(i) = self.known.binary_search(&id) {
                push(out, &ServerControl::Despawn { id })?;
                self.known.remove(i);
            }
        }
        for &id in &change.spawned {
            let (Err(i), Some(desc)) = (self.known.binary_search(&id), catalog.get(&id)) else {
                continue;
            };
            push(out, &ServerControl::Spawn(desc.clone()))?;
            self.known.insert(i, id);
        }
        for &id in &change.reshaped {
            if let (Ok(_), Some(desc)) = (self.known.binary_search(&id), catalog.get(&id)) {
                push(out, &ServerControl::Spawn(desc.clone()))?;
            }
        }
        Ok(())
    }
}

/// The changes after version `told` up to `version`, when `changes` holds
/// every one of them.
fn changes_since(
    changes: &[Arc<CatalogChange>],
    told: u64,
    version: u64,
) -> Option<&[Arc<CatalogChange>]> {
    let first = changes.partition_point(|c| c.version <= told);
    let since = &changes[first..];
    let whole = since.first().is_some_and(|c| c.version == told + 1)
        && since.last().is_some_and(|c| c.version == version)
        && since.windows(2).all(|w| w[1].version == w[0].version + 1);
    whole.then_some(since)
}

fn push(out: &mut Vec<u8>, msg: &ServerControl) -> Result<(), String> {
    let frame = encode_frame(msg).map_err(|e| e.to_string())?;
    out.extend_from_slice(&frame);
    Ok(())
}

#[cfg(test)]
mod tests {
    use inertia_protocol::control::FrameDecoder;
    use inertia_protocol::{EntityKind, ShapeDesc};

    use super::*;
    use crate::rules::{OutgoingMessage, Recipients};

    fn desc(id: EntityId) -> EntityDesc {
        EntityDesc {
            id,
            kind: EntityKind::Dynamic,
            shape: ShapeDesc::Sphere { radius: 0.5 },
            color: [255; 4],
            owner: None,
            name: format!("ball {id}"),
            position: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    /// Message `number`, to everyone, reliable: its bytes say its number.
    fn event(number: u64, tick: u64) -> Arc<RecentMessage> {
        message(number, tick, Recipients::All, Delivery::Reliable)
    }

    fn message(number: u64, tick: u64, to: Recipients, delivery: Delivery) -> Arc<RecentMessage> {
        let message = OutgoingMessage {
            to,
            delivery,
            bytes: format!("#{number}").into_bytes(),
        };
        Arc::new(RecentMessage::new(number, tick, message))
    }

    /// [`Told::catch_up`] for client 1, its datagrams dropped.
    fn catch_up(
        told: &mut Told,
        version: u64,
        catalog: &BTreeMap<EntityId, EntityDesc>,
        changes: &[Arc<CatalogChange>],
        recent: &[Arc<RecentMessage>],
        out: &mut Vec<u8>,
    ) -> Result<usize, String> {
        told.catch_up(version, catalog, changes, recent, out, &mut Vec::new())
            .map(|c| c.bytes)
    }

    /// The messages in `bytes`, as a client reads them.
    fn read(bytes: &[u8]) -> Vec<ServerControl> {
        let mut frames = FrameDecoder::new();
        frames.push(bytes).unwrap();
        std::iter::from_fn(|| frames.next::<ServerControl>().map(Result::unwrap)).collect()
    }

    fn jumped(msg: &ServerControl) -> Option<String> {
        match msg {
            ServerControl::Message(bytes) => Some(String::from_utf8(bytes.clone()).unwrap()),
            _ => None,
        }
    }

    #[test]
    fn a_client_is_told_despawns_then_spawns_then_new_events_once() {
        let mut told = Told::new(1, 2);
        let catalog: BTreeMap<_, _> = [1, 2, 3].map(|id| (id, desc(id))).into();
        let mut out = Vec::new();
        catch_up(&mut told, 1, &catalog, &[], &[event(1, 10)], &mut out).unwrap();
        let msgs = read(&out);
        let spawned: Vec<_> = msgs
            .iter()
            .filter_map(|m| match m {
                ServerControl::Spawn(d) => Some(d.id),
                _ => None,
            })
            .collect();
        assert_eq!(spawned, [1, 2, 3]);
        assert!(
            msgs.iter().all(|m| jumped(m).is_none()),
            "an event from before the client came is not news"
        );

        // Entity 2 goes, 4 comes, two events happen.
        let catalog: BTreeMap<_, _> = [1, 3, 4].map(|id| (id, desc(id))).into();
        let recent = [event(1, 10), event(2, 11), event(3, 11)];
        out.clear();
        catch_up(&mut told, 2, &catalog, &[], &recent, &mut out).unwrap();
        let msgs = read(&out);
        assert!(matches!(msgs[0], ServerControl::Despawn { id: 2 }));
        assert!(matches!(&msgs[1], ServerControl::Spawn(d) if d.id == 4));
        let events: Vec<_> = msgs.iter().filter_map(jumped).collect();
        assert_eq!(events, ["#2", "#3"]);

        // Nothing new: nothing told.
        out.clear();
        assert_eq!(
            catch_up(&mut told, 2, &catalog, &[], &recent, &mut out),
            Ok(0)
        );
        assert!(out.is_empty());
    }

    #[test]
    fn issue_16_a_reshaped_point_set_is_told_again_to_clients_that_know_it() {
        let cloth = |triangles: Vec<[u32; 3]>| EntityDesc {
            kind: EntityKind::SoftBody,
            shape: ShapeDesc::PointSet {
                points: 4,
                radius: 0.01,
                triangles,
                lines: vec![],
            },
            ..desc(1)
        };
        let whole = cloth(vec![[0, 1, 2], [1, 3, 2]]);
        let torn = cloth(vec![[0, 1, 2]]);
        let before: BTreeMap<_, _> = [(1, whole), (6, desc(6))].into();
        let after: BTreeMap<_, _> = [(1, torn.clone()), (6, desc(6))].into();
        let change = Arc::new(CatalogChange::between(2, &before, &after));
        assert_eq!(change.reshaped, [1]);
        assert!(change.spawned.is_empty() && change.despawned.is_empty());
        let spawns = |bytes: &[u8]| -> Vec<EntityDesc> {
            read(bytes)
                .into_iter()
                .filter_map(|m| match m {
                    ServerControl::Spawn(d) => Some(d),
                    _ => None,
                })
                .collect()
        };
        // Told the change: the new shape alone.
        let mut told = Told::new(1, 1);
        let mut out = Vec::new();
        catch_up(&mut told, 1, &before, &[], &[], &mut out).unwrap();
        out.clear();
        catch_up(&mut told, 2, &after, &[change], &[], &mut out).unwrap();
        assert_eq!(spawns(&out), std::slice::from_ref(&torn));
        // Told by a walk of the whole catalog (the changes were lost): its
        // point sets again, whatever changed.
        let mut walked = Told::new(1, 1);
        out.clear();
        catch_up(&mut walked, 1, &before, &[], &[], &mut out).unwrap();
        out.clear();
        catch_up(&mut walked, 5, &after, &[], &[], &mut out).unwrap();
        assert_eq!(spawns(&out), [torn]);
    }

    /// The entities a client holds after reading `bytes` on top of `held`.
    fn held_after(mut held: Vec<EntityId>, bytes: &[u8]) -> Vec<EntityId> {
        for msg in read(bytes) {
            match msg {
                ServerControl::Spawn(d) => held.push(d.id),
                ServerControl::Despawn { id } => held.retain(|&h| h != id),
                _ => {}
            }
        }
        held.sort_unstable();
        held
    }

    #[test]
    fn issue_12_a_catalog_change_is_told_from_the_change_not_a_walk_of_the_catalog() {
        let catalogs: Vec<BTreeMap<EntityId, EntityDesc>> = [
            vec![1, 2, 3],
            vec![1, 3, 4],
            vec![1, 4, 5, 6],
            vec![4, 6, 7],
            vec![4, 7],
        ]
        .iter()
        .map(|ids| ids.iter().map(|&id| (id, desc(id))).collect())
        .collect();
        let empty = BTreeMap::new();
        let changes: Vec<Arc<CatalogChange>> = catalogs
            .iter()
            .enumerate()
            .map(|(v, c)| {
                let before = if v == 0 { &empty } else { &catalogs[v - 1] };
                Arc::new(CatalogChange::between(v as u64 + 1, before, c))
            })
            .collect();
        assert_eq!(changes[1].despawned, [2]);
        assert_eq!(changes[1].spawned, [4]);

        // Told each version in turn: the same bytes as a walk of the whole
        // catalog.
        let (mut by_change, mut by_walk) = (Told::new(1, 1), Told::new(1, 1));
        for (v, catalog) in catalogs.iter().enumerate() {
            let version = v as u64 + 1;
            let (mut a, mut b) = (Vec::new(), Vec::new());
            catch_up(
                &mut by_change,
                version,
                catalog,
                &changes[..=v],
                &[],
                &mut a,
            )
            .unwrap();
            catch_up(&mut by_walk, version, catalog, &[], &[], &mut b).unwrap();
            assert_eq!(a, b, "version {version}");
        }

        // A client that skipped versions is told every change since, and
        // holds what the catalog holds; one told a version older than the
        // changes reach is told the difference from a walk.
        for (told_at, changes_held) in [(1, &changes[..]), (1, &changes[3..])] {
            let mut told = Told::new(1, 1);
            let mut out = Vec::new();
            catch_up(&mut told, told_at, &catalogs[0], &[], &[], &mut out).unwrap();
            let held = held_after(Vec::new(), &out);
            out.clear();
            catch_up(&mut told, 5, &catalogs[4], changes_held, &[], &mut out).unwrap();
            assert_eq!(held_after(held, &out), [4, 7]);
            assert_eq!(told.known, [4, 7]);
        }
    }

    #[test]
    fn issue_12_events_after_a_rewind_are_told_though_their_ticks_went_back() {
        let catalog = BTreeMap::new();
        let mut told = Told::new(1, 1);
        let mut out = Vec::new();
        catch_up(&mut told, 0, &catalog, &[], &[event(1, 500)], &mut out).unwrap();
        assert_eq!(read(&out).len(), 1);
        // The world went back to tick 100 and an event happened there.
        let recent = [event(1, 500), event(2, 101)];
        out.clear();
        catch_up(&mut told, 0, &catalog, &[], &recent, &mut out).unwrap();
        let events: Vec<_> = read(&out).iter().filter_map(jumped).collect();
        assert_eq!(events, ["#2"]);
    }

    #[test]
    fn issue_43_a_client_is_told_the_messages_for_it_reliable_on_the_stream_unreliable_as_datagrams(
    ) {
        use inertia_protocol::message::MessageDatagram;
        let catalog = BTreeMap::new();
        let recent = [
            message(1, 5, Recipients::All, Delivery::Reliable),
            message(2, 5, Recipients::One(2), Delivery::Reliable),
            message(3, 5, Recipients::some([1, 3]), Delivery::Unreliable),
            message(4, 5, Recipients::AllBut(1), Delivery::Unreliable),
            message(5, 6, Recipients::AllBut(2), Delivery::Reliable),
        ];
        let mut told = Told::new(1, 1);
        let (mut out, mut datagrams) = (Vec::new(), Vec::new());
        let caught = told
            .catch_up(0, &catalog, &[], &recent, &mut out, &mut datagrams)
            .unwrap();
        assert_eq!(caught.missed, 0);
        let reliable: Vec<_> = read(&out).iter().filter_map(jumped).collect();
        assert_eq!(reliable, ["#1", "#5"]);
        let unreliable: Vec<&[u8]> = datagrams
            .iter()
            .map(|d| MessageDatagram::decode(d).unwrap())
            .collect();
        assert_eq!(unreliable, [b"#3"]);

        // A client whose slot comes after the recent messages moved past
        // some it had not looked at is told how many it may have missed.
        let later = [
            message(9, 7, Recipients::All, Delivery::Reliable),
            message(10, 7, Recipients::All, Delivery::Reliable),
        ];
        out.clear();
        let caught = told
            .catch_up(0, &catalog, &[], &later, &mut out, &mut datagrams)
            .unwrap();
        assert_eq!(caught.missed, 3);
        assert_eq!(
            read(&out).iter().filter_map(jumped).collect::<Vec<_>>(),
            ["#9", "#10"]
        );
    }
}
