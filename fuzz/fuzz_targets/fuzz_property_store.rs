//! The game's properties as keyframes and checkpoints save them: restoring
//! never panics, a refused restore changes nothing, and what restores
//! saves to the same bytes (the saved form is canonical).
#![no_main]

use std::sync::Arc;

use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema};
use inertia_server::properties::PropertyStore;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let schema = Arc::new(PropertySchema {
        entity: vec![
            PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
            PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            PropertyDecl::new("speed", PropertyKind::F32),
        ],
        match_state: vec![
            PropertyDecl::new("over", PropertyKind::Bool),
            PropertyDecl::new("bonus", PropertyKind::Int { bits: 64 }),
        ],
    });
    let mut store = PropertyStore::new(schema);
    let before = store.clone();
    match store.restore(data) {
        Ok(()) if !data.is_empty() => assert_eq!(store.to_bytes(), data, "not canonical"),
        Ok(()) => {}
        Err(_) => assert_eq!(store, before, "a refused restore changed the store"),
    }
});
