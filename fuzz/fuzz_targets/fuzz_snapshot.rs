//! Snapshot datagrams from the network, several in a row so that delta
//! baselines come into play: the decoder never panics, with or without
//! the game's properties (a schema of every kind, up to 64 bits).
#![no_main]

use std::sync::Arc;

use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema};
use inertia_protocol::snapshot::{SnapshotConfig, SnapshotDecoder};
use libfuzzer_sys::fuzz_target;

fn schema() -> PropertySchema {
    PropertySchema {
        entity: vec![
            PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
            PropertyDecl::new("alive", PropertyKind::Bool),
            PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            PropertyDecl::new("owner", PropertyKind::UInt { bits: 64 }),
        ],
        match_state: vec![
            PropertyDecl::new("clock", PropertyKind::F32),
            PropertyDecl::new("bonus", PropertyKind::Int { bits: 64 }),
        ],
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the configuration, then datagrams follow, each
    // prefixed by its length as a u16 little-endian.
    let Some((&first, mut rest)) = data.split_first() else {
        return;
    };
    let mut config = SnapshotConfig::default();
    config.velocities = first & 1 != 0;
    config.rotation_bits = 4 + u32::from(first >> 1) % 13;
    let Ok(mut decoder) = SnapshotDecoder::new(config) else {
        return;
    };
    // The top bit: a game with properties.
    if first & 0x80 != 0 {
        decoder = decoder.with_properties(Arc::new(schema()));
    }
    while rest.len() >= 2 {
        let len = usize::from(u16::from_le_bytes([rest[0], rest[1]])).min(rest.len() - 2);
        let (datagram, tail) = rest[2..].split_at(len);
        rest = tail;
        let _ = decoder.decode(datagram);
        let _ = decoder.ack_state();
    }
});
