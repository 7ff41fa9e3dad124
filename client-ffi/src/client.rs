//! The client handle and the calls on it.
//!
//! A handle is made by `inertia_connect` (or `inertia_connect_dev`) and
//! freed by `inertia_disconnect`; between the two it owns the connection
//! and the runtime thread it runs on. One handle is used by one thread at
//! a time (calls on it are not synchronised against each other); separate
//! handles may be used from separate threads.

use std::ffi::{c_char, CStr};
use std::net::SocketAddr;

use inertia_client::interp::Sample;
use inertia_client::net::ClientEvent;
use inertia_client::point_sets::PointSetSample;
use inertia_client::{BlockingClient, ConnectOptions, ReplayEvent};
use inertia_protocol::control::DisconnectReason;

use inertia_protocol::input::InputPayload;
use inertia_protocol::message::Delivery;
use inertia_protocol::property::{PropertyKind, PropertyValue};
use inertia_protocol::token::ConnectToken;
use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};

use crate::status::{guard, write_c_string, Failure, InertiaStatus};
use crate::types::*;

/// A connected client (opaque to C).
#[derive(Debug)]
pub struct InertiaClient {
    client: BlockingClient,
    /// The picture of the last `inertia_sample`, which `inertia_point_set`
    /// reads so that a frame's sets and bodies agree.
    frame: Sample,
}

/// The handle behind `client`, or a failure when it is null.
///
/// # Safety
/// `client` is null or a live handle from `inertia_connect`.
unsafe fn handle<'a>(client: *mut InertiaClient) -> Result<&'a mut InertiaClient, Failure> {
    // SAFETY: the caller passes a live handle or null.
    unsafe { client.as_mut() }.ok_or_else(|| Failure::invalid("the client handle is null"))
}

/// `out` as a reference, or a failure when it is null.
///
/// # Safety
/// `out` is null or valid for writes of a `T`.
unsafe fn out_ref<'a, T>(out: *mut T, what: &str) -> Result<&'a mut T, Failure> {
    // SAFETY: the caller passes a writable `T` or null.
    unsafe { out.as_mut() }.ok_or_else(|| Failure::invalid(format!("{what} is null")))
}

/// A caller's buffer of `capacity` items as a slice (empty when null and 0).
///
/// # Safety
/// `ptr` is valid for writes of `capacity` items, or null with 0.
unsafe fn buffer<'a, T>(ptr: *mut T, capacity: usize, what: &str) -> Result<&'a mut [T], Failure> {
    if capacity == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(Failure::invalid(format!("{what} is null")));
    }
    // SAFETY: the caller gives `capacity` writable items at `ptr`.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, capacity) })
}

/// A C string argument as UTF-8.
///
/// # Safety
/// `s` is null or a NUL-terminated string.
unsafe fn text<'a>(s: *const c_char, what: &str) -> Result<&'a str, Failure> {
    if s.is_null() {
        return Err(Failure::invalid(format!("{what} is null")));
    }
    // SAFETY: the caller passes a NUL-terminated string.
    unsafe { CStr::from_ptr(s) }
        .to_str()
        .map_err(|_| Failure::invalid(format!("{what} is not UTF-8")))
}

/// Joins `addr` with `token` and hands the new handle out through `out`.
fn join(
    addr: SocketAddr,
    token: &ConnectToken,
    options: ConnectOptions,
    out: &mut *mut InertiaClient,
) -> Result<(), Failure> {
    let client = BlockingClient::connect_with(addr, token, options)
        .map_err(|e| Failure::new(InertiaStatus::ConnectFailed, e.to_string()))?;
    let handle = Box::new(InertiaClient {
        client,
        frame: Sample::default(),
    });
    *out = Box::into_raw(handle);
    Ok(())
}

/// Connects to the server at `address` (`"IP:PORT"`) with a connect token
/// (`token_len` bytes at `token`, as the game's backend handed it out) and
/// blocks until the server welcomes or refuses us (a few seconds at most).
/// On success `*out` is the new handle.
///
/// # Safety
/// `address` is a NUL-terminated string; `token` holds `token_len` bytes;
/// `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_connect(
    address: *const c_char,
    token: *const u8,
    token_len: usize,
    out: *mut *mut InertiaClient,
) -> InertiaStatus {
    // SAFETY: as the caller promises; no options is the defaults.
    unsafe { inertia_connect_with(address, token, token_len, std::ptr::null(), out) }
}

/// [`inertia_connect`] with options (`options` may be null: the
/// defaults). With `predict` set the library predicts the own avatar
/// (with the default sandbox game's walking settings, which the server's
/// game must share): `inertia_sample` then draws it where prediction puts
/// it, answering the input at once, and `InertiaStats` reports the
/// corrections.
///
/// # Safety
/// As [`inertia_connect`]; `options` is null or readable.
#[no_mangle]
pub unsafe extern "C" fn inertia_connect_with(
    address: *const c_char,
    token: *const u8,
    token_len: usize,
    options: *const InertiaConnectOptions,
    out: *mut *mut InertiaClient,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let out = unsafe { out_ref(out, "out") }?;
        // SAFETY: null or readable, as the caller promises.
        let options = unsafe { options.as_ref() }.copied().unwrap_or_default();
        *out = std::ptr::null_mut();
        // SAFETY: as the caller promises (see the function's safety section).
        let address = unsafe { text(address, "address") }?;
        let addr: SocketAddr = address
            .parse()
            .map_err(|e| Failure::invalid(format!("address {address:?}: {e}")))?;
        if token.is_null() {
            return Err(Failure::invalid("token is null"));
        }
        // SAFETY: the caller gives `token_len` readable bytes.
        let bytes = unsafe { std::slice::from_raw_parts(token, token_len) };
        let token = ConnectToken::from_bytes(bytes)
            .map_err(|e| Failure::invalid(format!("connect token: {e}")))?;
        join(addr, &token, options.to_sdk(), out)
    })
}

/// Connects to a dev-mode server with a token made from its credentials
/// file (`inertia-data/dev-credentials.json` where the server runs), as
/// client `client_id` (0: one made up from the clock). For development
/// only: a released game gets its tokens from its backend.
///
/// # Safety
/// `credentials_path` is a NUL-terminated string; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_connect_dev(
    credentials_path: *const c_char,
    client_id: u64,
    out: *mut *mut InertiaClient,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let out = unsafe { out_ref(out, "out") }?;
        *out = std::ptr::null_mut();
        // SAFETY: as the caller promises (see the function's safety section).
        let path = unsafe { text(credentials_path, "credentials_path") }?;
        let id = (client_id != 0).then_some(client_id);
        let (addr, token, _) = inertia_client::dev::dev_token(path.as_ref(), id)
            .map_err(|e| Failure::invalid(e.to_string()))?;
        join(addr, &token, ConnectOptions::default(), out)
    })
}

/// Says goodbye, closes the connection (blocking up to about two seconds)
/// and frees the handle. Null is ignored. The handle must not be used
/// again.
///
/// # Safety
/// `client` is null or a live handle, not used by another thread.
#[no_mangle]
pub unsafe extern "C" fn inertia_disconnect(client: *mut InertiaClient) {
    if client.is_null() {
        return;
    }
    let _ = guard(|| {
        // SAFETY: a live handle made by `Box::into_raw`, given back once.
        let handle = unsafe { Box::from_raw(client) };
        handle.client.close();
        Ok(())
    });
}

/// What the server told us when we joined.
///
/// # Safety
/// `client` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_server_info(
    client: *mut InertiaClient,
    out: *mut InertiaServerInfo,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, out) = unsafe { (handle(client)?, out_ref(out, "out")?) };
        let info = h.client.server_info();
        let mut server_version = [0; 64];
        write_c_string(&mut server_version, &info.server_version);
        let mut game = [0; INERTIA_GAME_NAME_BYTES];
        write_c_string(&mut game, &info.game);
        *out = InertiaServerInfo {
            client_id: info.client_id,
            tick: info.tick,
            tick_hz: info.tick_hz,
            snapshot_hz: info.snapshot_hz,
            position_resolution: info.snapshot.grid.resolution,
            server_version,
            input_bytes: info.input_bytes as u32,
            entity_properties: info.properties.entity.len() as u32,
            match_properties: info.properties.match_state.len() as u32,
            game,
        };
        Ok(())
    })
}

/// The declaration of property `index` of the game's schema: a match
/// property when `of_match` is nonzero, else an entity property.
/// `INERTIA_STATUS_NOT_FOUND` past the counts `InertiaServerInfo` gives.
///
/// # Safety
/// `client` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_property_decl(
    client: *mut InertiaClient,
    of_match: u8,
    index: u32,
    out: *mut InertiaPropertyDecl,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, out) = unsafe { (handle(client)?, out_ref(out, "out")?) };
        let schema = h.client.property_schema();
        let list = if of_match != 0 {
            &schema.match_state
        } else {
            &schema.entity
        };
        let decl = list
            .get(index as usize)
            .ok_or_else(|| Failure::new(InertiaStatus::NotFound, format!("no property {index}")))?;
        let mut name = [0; INERTIA_PROPERTY_NAME_BYTES];
        write_c_string(&mut name, &decl.name);
        *out = InertiaPropertyDecl {
            name,
            kind: kind_of(decl.kind),
            bits: decl.kind.bits(),
        };
        Ok(())
    })
}

fn kind_of(kind: PropertyKind) -> InertiaPropertyKind {
    match kind {
        PropertyKind::Bool => InertiaPropertyKind::Bool,
        PropertyKind::UInt { .. } => InertiaPropertyKind::UInt,
        PropertyKind::Int { .. } => InertiaPropertyKind::Int,
        PropertyKind::F32 => InertiaPropertyKind::F32,
    }
}

fn value_of(v: PropertyValue) -> InertiaPropertyValue {
    match v {
        PropertyValue::Bool(b) => InertiaPropertyValue {
            kind: InertiaPropertyKind::Bool,
            as_u64: u64::from(b),
            as_i64: i64::from(b),
            as_f64: f64::from(u8::from(b)),
        },
        PropertyValue::UInt(n) => InertiaPropertyValue {
            kind: InertiaPropertyKind::UInt,
            as_u64: n,
            as_i64: n as i64,
            as_f64: n as f64,
        },
        PropertyValue::Int(n) => InertiaPropertyValue {
            kind: InertiaPropertyKind::Int,
            as_u64: n as u64,
            as_i64: n,
            as_f64: n as f64,
        },
        PropertyValue::F32(x) => InertiaPropertyValue {
            kind: InertiaPropertyKind::F32,
            as_u64: u64::from(x.to_bits()),
            as_i64: x as i64,
            as_f64: f64::from(x),
        },
    }
}

/// Writes `values` into `out` and their count into `*count`;
/// `INERTIA_STATUS_BUFFER_TOO_SMALL` when they do not all fit (the first
/// `out.len()` are written).
fn write_values(
    values: &[PropertyValue],
    out: &mut [InertiaPropertyValue],
    count: &mut usize,
) -> Result<(), Failure> {
    *count = values.len();
    for (o, v) in out.iter_mut().zip(values) {
        *o = value_of(*v);
    }
    if out.len() < values.len() {
        return Err(Failure::new(
            InertiaStatus::BufferTooSmall,
            format!("{} values, room for {}", values.len(), out.len()),
        ));
    }
    Ok(())
}

/// An entity's properties as of the tick last drawn (`inertia_sample`),
/// in the schema's order, into `out` (room for `capacity`); `*count` is
/// how many the game declares. `INERTIA_STATUS_NOT_FOUND` for an entity
/// not in view.
///
/// # Safety
/// `client` is a live handle; `out` has room for `capacity` values (or is
/// null with `capacity` 0); `count` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_properties(
    client: *mut InertiaClient,
    entity: u32,
    out: *mut InertiaPropertyValue,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises.
        let out = unsafe { buffer(out, capacity, "out") }?;
        let values = h
            .client
            .properties(entity)
            .ok_or_else(|| Failure::new(InertiaStatus::NotFound, format!("no entity {entity}")))?;
        write_values(&values, out, count)
    })
}

/// The match's properties (the score, the clock) as of the tick last
/// drawn, in the schema's order, as `inertia_properties` writes them.
///
/// # Safety
/// As `inertia_properties`.
#[no_mangle]
pub unsafe extern "C" fn inertia_match_state(
    client: *mut InertiaClient,
    out: *mut InertiaPropertyValue,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises.
        let out = unsafe { buffer(out, capacity, "out") }?;
        write_values(&h.client.match_state(), out, count)
    })
}

/// Sets the sandbox game's input (the stock server's) for every tick from
/// now on, until changed: movement in the horizontal plane (`move_x`,
/// `move_z`, each in [−1, 1], the length clamped to 1), facing `yaw` (rad
/// about +Y) and held `buttons` (1 jump, 2 push). Each tick's input is
/// stamped with the tick the server will be at when it arrives, and the
/// server applies it on that tick (`InertiaStats::inputs_late` counts
/// those that came too late). `INERTIA_STATUS_INVALID_ARGUMENT` when the
/// server runs another game (see `inertia_set_input_bytes`).
///
/// # Safety
/// `client` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn inertia_set_input(
    client: *mut InertiaClient,
    move_x: f32,
    move_z: f32,
    yaw: f32,
    buttons: u8,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        if !(move_x.is_finite() && move_z.is_finite() && yaw.is_finite()) {
            return Err(Failure::invalid("movement and yaw must be finite"));
        }
        h.client
            .set_input([move_x, move_z], yaw, buttons)
            .map_err(|e| Failure::invalid(e.to_string()))
    })
}

/// The `len` bytes at `bytes`: empty for a length of 0 (whatever the
/// pointer), refused for a null pointer with a length.
///
/// # Safety
/// `bytes` points to `len` readable bytes, or is null with `len` 0.
unsafe fn byte_slice<'a>(bytes: *const u8, len: usize) -> Result<&'a [u8], Failure> {
    if len == 0 {
        Ok(&[])
    } else if bytes.is_null() {
        Err(Failure::invalid("bytes is null"))
    } else {
        // SAFETY: as the caller promises: `len` readable bytes.
        Ok(unsafe { std::slice::from_raw_parts(bytes, len) })
    }
}

/// Sets the game's input for every tick from now on, until changed: its
/// `len` bytes at `bytes`, encoded as the game lays its input out, exactly
/// `InertiaServerInfo::input_bytes` long (at most 64). Stamped and sent as
/// `inertia_set_input` says. `INERTIA_STATUS_INVALID_ARGUMENT`, changing
/// nothing, for another length or a null `bytes` with a length.
///
/// # Safety
/// `client` is a live handle; `bytes` points to `len` readable bytes (or
/// is null with `len` 0).
#[no_mangle]
pub unsafe extern "C" fn inertia_set_input_bytes(
    client: *mut InertiaClient,
    bytes: *const u8,
    len: usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        // SAFETY: as the caller promises.
        let bytes = unsafe { byte_slice(bytes, len) }?;
        let payload = InputPayload::new(bytes).map_err(|e| Failure::invalid(e.to_string()))?;
        h.client
            .set_input_payload(payload)
            .map_err(|e| Failure::invalid(e.to_string()))
    })
}

/// Sends a message of the game's to the server's rules: its `len` bytes
/// at `bytes` (at most `INERTIA_EVENT_DATA_BYTES`), laid out as the game
/// lays its messages out, `delivery` reliable (in order, once) or
/// unreliable (may be lost). `INERTIA_STATUS_INVALID_ARGUMENT`, sending
/// nothing, for a longer message or a null `bytes` with a length;
/// `INERTIA_STATUS_DISCONNECTED` once the connection has ended. The
/// server takes at most its game's rate (30 a second unless the game says
/// otherwise) and refuses the rest.
///
/// # Safety
/// `client` is a live handle; `bytes` points to `len` readable bytes (or
/// is null with `len` 0).
#[no_mangle]
pub unsafe extern "C" fn inertia_send_message(
    client: *mut InertiaClient,
    bytes: *const u8,
    len: usize,
    delivery: InertiaDelivery,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        // SAFETY: as the caller promises.
        let bytes = unsafe { byte_slice(bytes, len) }?;
        let delivery = match delivery {
            InertiaDelivery::Reliable => Delivery::Reliable,
            InertiaDelivery::Unreliable => Delivery::Unreliable,
        };
        h.client
            .send_message_bytes(bytes.to_vec(), delivery)
            .map_err(|e| match e {
                inertia_client::ClientError::Message(
                    inertia_protocol::message::MessageRefusal::NotConnected,
                ) => Failure::new(InertiaStatus::Disconnected, e.to_string()),
                e => Failure::invalid(e.to_string()),
            })
    })
}

/// No entity: a replay centred on the player's own avatar.
pub const INERTIA_NO_ENTITY: u32 = u32::MAX;

fn replay_failure(e: inertia_client::ClientError) -> Failure {
    match e {
        inertia_client::ClientError::Replay(inertia_protocol::replay::ReplayRefusal::NotJoined) => {
            Failure::new(InertiaStatus::Disconnected, e.to_string())
        }
        e => Failure::invalid(e.to_string()),
    }
}

fn focus_of(focus: u32) -> Option<u32> {
    (focus != INERTIA_NO_ENTITY).then_some(focus)
}

/// Asks for the kill-cam: the last `seconds` of the match at `speed` times
/// real time (1: as it happened), centred on entity `focus` (the one that
/// hit the player; `INERTIA_NO_ENTITY`: the own avatar), beside the live
/// match. The answer comes as an event (`INERTIA_EVENT_KIND_REPLAY_STARTED`,
/// `_REFUSED`, then `_ENDED`); while it plays, draw
/// `inertia_replay_sample`. A speed out of 0.05..=8 or not finite is
/// `INERTIA_STATUS_INVALID_ARGUMENT`, and nothing is sent.
///
/// # Safety
/// `client` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn inertia_kill_cam(
    client: *mut InertiaClient,
    seconds: f32,
    speed: f32,
    focus: u32,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        h.client
            .kill_cam(seconds, speed, focus_of(focus))
            .map_err(replay_failure)
    })
}

/// Asks for a replay of ticks `from_tick` to `to_tick` (inclusive) at
/// `speed`, centred on `focus` (`INERTIA_NO_ENTITY`: the own avatar); as
/// `inertia_kill_cam`.
///
/// # Safety
/// `client` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn inertia_replay(
    client: *mut InertiaClient,
    from_tick: u64,
    to_tick: u64,
    speed: f32,
    focus: u32,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        h.client
            .replay(inertia_protocol::replay::ReplayRequest {
                from_tick,
                to_tick,
                speed,
                focus: focus_of(focus),
            })
            .map_err(replay_failure)
    })
}

/// Stops the replay playing, if any.
///
/// # Safety
/// `client` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn inertia_cancel_replay(client: *mut InertiaClient) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let h = unsafe { handle(client) }?;
        h.client.cancel_replay().map_err(replay_failure)
    })
}

/// Draws the replay now, as `inertia_sample` draws the live world: `*count`
/// is 0 before any replayed state came.
///
/// # Safety
/// As `inertia_sample`.
#[no_mangle]
pub unsafe extern "C" fn inertia_replay_sample(
    client: *mut InertiaClient,
    out: *mut InertiaEntityState,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises (see the function's safety section).
        let out = unsafe { buffer(out, capacity, "out") }?;
        let frame = h.client.replay_sample().unwrap_or_default();
        write_states(&frame, out, capacity, count)
    })
}

/// Takes the oldest waiting event into `*out`; its kind is
/// `INERTIA_EVENT_KIND_NONE` when none was waiting. Call it until then
/// every frame.
///
/// # Safety
/// `client` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_poll_event(
    client: *mut InertiaClient,
    out: *mut InertiaEvent,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, out) = unsafe { (handle(client)?, out_ref(out, "out")?) };
        *out = match h.client.poll_event() {
            None => InertiaEvent::default(),
            Some(e) => event_of(e),
        };
        Ok(())
    })
}

fn event_of(e: ClientEvent) -> InertiaEvent {
    let mut out = InertiaEvent::default();
    match e {
        ClientEvent::Spawned(id) => {
            out.kind = InertiaEventKind::Spawned;
            out.entity = id;
        }
        ClientEvent::Despawned(id) => {
            out.kind = InertiaEventKind::Despawned;
            out.entity = id;
        }
        ClientEvent::Discontinuity(d) => {
            out.kind = InertiaEventKind::Discontinuity;
            out.from_tick = d.from_tick as f64;
            out.to_tick = d.to_tick as f64;
        }
        ClientEvent::Resync { from_tick, to_tick } => {
            out.kind = InertiaEventKind::Resync;
            out.from_tick = from_tick;
            out.to_tick = to_tick;
        }
        ClientEvent::Disconnected(reason) => {
            out.kind = InertiaEventKind::Disconnected;
            write_c_string(&mut out.text, &reason_text(&reason));
        }
        ClientEvent::PropertiesChanged { entity, tick } => {
            match entity {
                Some(id) => {
                    out.kind = InertiaEventKind::Properties;
                    out.entity = id;
                }
                None => out.kind = InertiaEventKind::MatchState,
            }
            out.to_tick = tick as f64;
        }
        ClientEvent::Replay(ReplayEvent::Started {
            from_tick, to_tick, ..
        }) => {
            out.kind = InertiaEventKind::ReplayStarted;
            out.from_tick = from_tick as f64;
            out.to_tick = to_tick as f64;
        }
        ClientEvent::Replay(ReplayEvent::Refused(why)) => {
            out.kind = InertiaEventKind::ReplayRefused;
            write_c_string(&mut out.text, &why.to_string());
        }
        ClientEvent::Replay(ReplayEvent::Ended(why)) => {
            out.kind = InertiaEventKind::ReplayEnded;
            write_c_string(&mut out.text, why.label());
        }
        ClientEvent::Message { delivery, bytes } => {
            out.kind = InertiaEventKind::Message;
            out.delivery = match delivery {
                Delivery::Reliable => InertiaDelivery::Reliable,
                Delivery::Unreliable => InertiaDelivery::Unreliable,
            };
            // Every message fits: the protocol bounds it to this.
            let n = bytes.len().min(INERTIA_EVENT_DATA_BYTES);
            out.data[..n].copy_from_slice(&bytes[..n]);
            out.data_len = n as u32;
        }
    }
    out
}

fn reason_text(reason: &DisconnectReason) -> String {
    match reason {
        DisconnectReason::ServerShutdown => "the server is stopping".into(),
        DisconnectReason::Kicked { reason } => format!("kicked: {reason}"),
        DisconnectReason::Timeout => "timed out".into(),
        DisconnectReason::ClientLeft => "we left".into(),
        DisconnectReason::ProtocolError { what } => format!("protocol error: {what}"),
        other => format!("{other:?}"),
    }
}

/// Draws the world now: advances the picture's clock and writes where each
/// entity is (interpolated between snapshots), ascending by id, into `out`
/// (room for `capacity`). `*count` is how many the picture holds; when more
/// than `capacity`, the first `capacity` are written and the status is
/// `INERTIA_STATUS_BUFFER_TOO_SMALL`. Scenery that never moves is not in
/// the picture: it stays where `inertia_entity_info` places it.
///
/// # Safety
/// `client` is a live handle; `out` holds `capacity` writable states (or
/// is null with 0); `count` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_sample(
    client: *mut InertiaClient,
    out: *mut InertiaEntityState,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises (see the function's safety section).
        let out = unsafe { buffer(out, capacity, "out") }?;
        h.frame = h.client.sample();
        write_states(&h.frame, out, capacity, count)
    })
}

/// Writes `frame`'s entities into `out` (room for `capacity`) and their
/// number into `*count`.
fn write_states(
    frame: &Sample,
    out: &mut [InertiaEntityState],
    capacity: usize,
    count: &mut usize,
) -> Result<(), Failure> {
    *count = frame.entities.len();
    for (dst, e) in out.iter_mut().zip(&frame.entities) {
        let q = e.rotation;
        *dst = InertiaEntityState {
            id: e.id,
            extrapolated: u8::from(e.extrapolated),
            x: e.position.x,
            y: e.position.y,
            z: e.position.z,
            qx: q.x,
            qy: q.y,
            qz: q.z,
            qw: q.w,
        };
    }
    if frame.entities.len() > capacity {
        return Err(Failure::new(
            InertiaStatus::BufferTooSmall,
            format!(
                "the picture holds {} entities, the buffer {capacity}",
                frame.entities.len()
            ),
        ));
    }
    Ok(())
}

/// How entity `id` looks (its description), into `*out`;
/// `INERTIA_STATUS_NOT_FOUND` when it was not described to us.
///
/// # Safety
/// `client` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_entity_info(
    client: *mut InertiaClient,
    id: u32,
    out: *mut InertiaEntityInfo,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, out) = unsafe { (handle(client)?, out_ref(out, "out")?) };
        let info = h
            .client
            .with_entities(|t| t.get(id).map(|e| info_of(&e.desc)))
            .ok_or_else(|| {
                Failure::new(InertiaStatus::NotFound, format!("no entity {id} is known"))
            })?;
        *out = info;
        Ok(())
    })
}

fn info_of(desc: &EntityDesc) -> InertiaEntityInfo {
    let kind = match desc.kind {
        EntityKind::Static => InertiaEntityKind::Static,
        EntityKind::Dynamic => InertiaEntityKind::Dynamic,
        EntityKind::Kinematic => InertiaEntityKind::Kinematic,
        EntityKind::Avatar => InertiaEntityKind::Avatar,
        EntityKind::Water => InertiaEntityKind::Water,
        EntityKind::SoftBody => InertiaEntityKind::SoftBody,
        EntityKind::Fluid => InertiaEntityKind::Fluid,
    };
    let half_box = |points: &[[f32; 3]]| {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        std::array::from_fn(|k| {
            if points.is_empty() {
                0.0
            } else {
                (hi[k] - lo[k]) / 2.0
            }
        })
    };
    let (shape, dims, points) = match &desc.shape {
        ShapeDesc::Sphere { radius } => (InertiaShapeKind::Sphere, [*radius, 0.0, 0.0], 0),
        ShapeDesc::Cuboid { half_extents } => (InertiaShapeKind::Cuboid, *half_extents, 0),
        ShapeDesc::Capsule {
            half_height,
            radius,
        } => (InertiaShapeKind::Capsule, [*half_height, *radius, 0.0], 0),
        ShapeDesc::Cylinder {
            half_height,
            radius,
        } => (InertiaShapeKind::Cylinder, [*half_height, *radius, 0.0], 0),
        ShapeDesc::ConvexHull { points } => (InertiaShapeKind::ConvexHull, half_box(points), 0),
        ShapeDesc::TriMesh { vertices, .. } => (InertiaShapeKind::TriMesh, half_box(vertices), 0),
        ShapeDesc::Compound { .. } => (InertiaShapeKind::Compound, [0.0; 3], 0),
        ShapeDesc::Particle { radius } => (InertiaShapeKind::Particle, [*radius, 0.0, 0.0], 0),
        ShapeDesc::Ground => (InertiaShapeKind::Ground, [0.0; 3], 0),
        ShapeDesc::HeightField { size, .. } => {
            (InertiaShapeKind::HeightField, [size[0], 0.0, size[1]], 0)
        }
        ShapeDesc::PointSet { points, radius, .. } => {
            (InertiaShapeKind::PointSet, [*radius, 0.0, 0.0], *points)
        }
    };
    let mut name = [0; INERTIA_NAME_BYTES];
    write_c_string(&mut name, &desc.name);
    let [x, y, z] = desc.position;
    let [qx, qy, qz, qw] = desc.rotation;
    InertiaEntityInfo {
        id: desc.id,
        kind,
        shape,
        points,
        dims,
        color: desc.color,
        has_owner: u8::from(desc.owner.is_some()),
        owner: desc.owner.unwrap_or(0),
        x,
        y,
        z,
        qx,
        qy,
        qz,
        qw,
        name,
    }
}

/// The points of soft body or fluid `set` in the picture of the last
/// `inertia_sample`: `positions` gets x, y, z (m) for each point (room for
/// `capacity` points, so `3 × capacity` floats) and `present` 1 for each
/// point known (0: not placed yet, or out of view; its position is then
/// 0). `*count` is the set's points; past `capacity` the status is
/// `INERTIA_STATUS_BUFFER_TOO_SMALL` with the first `capacity` written.
/// Its triangles and lines come from `inertia_point_set_triangles` and
/// `inertia_point_set_lines`.
///
/// # Safety
/// `client` is a live handle; `positions` holds `3 × capacity` writable
/// floats and `present` `capacity` bytes (either null with 0); `count` is
/// writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_point_set(
    client: *mut InertiaClient,
    set: u32,
    positions: *mut f32,
    present: *mut u8,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises (see the function's safety section).
        let positions = unsafe { buffer(positions, 3 * capacity, "positions") }?;
        // SAFETY: as the caller promises (see the function's safety section).
        let present = unsafe { buffer(present, capacity, "present") }?;
        let frame = &h.frame;
        let n = h.client.with_entities(|t| {
            let e = t.get(set)?;
            let points = PointSetSample::gather(&e.desc, frame, &e.points)?;
            for (i, (p, known)) in points.positions.iter().zip(&points.present).enumerate() {
                if i >= capacity {
                    break;
                }
                positions[3 * i..3 * i + 3].copy_from_slice(&p.to_array());
                present[i] = u8::from(*known);
            }
            Some(points.positions.len())
        });
        let n = n.ok_or_else(|| {
            Failure::new(
                InertiaStatus::NotFound,
                format!("{set} is not a known point set"),
            )
        })?;
        *count = n;
        if n > capacity {
            return Err(Failure::new(
                InertiaStatus::BufferTooSmall,
                format!("the set has {n} points, the buffer room for {capacity}"),
            ));
        }
        Ok(())
    })
}

/// Copies what a point set's description lists (`triangles` or `lines`)
/// as point indices into a caller's buffer of `capacity` indices.
///
/// # Safety
/// As [`inertia_point_set_triangles`].
unsafe fn copy_indices(
    client: *mut InertiaClient,
    set: u32,
    out: *mut u32,
    capacity: usize,
    count: *mut usize,
    pick: fn(&ShapeDesc) -> Option<Vec<u32>>,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, count) = unsafe { (handle(client)?, out_ref(count, "count")?) };
        // SAFETY: as the caller promises (see the function's safety section).
        let out = unsafe { buffer(out, capacity, "out") }?;
        let indices = h
            .client
            .with_entities(|t| t.get(set).and_then(|e| pick(&e.desc.shape)))
            .ok_or_else(|| {
                Failure::new(
                    InertiaStatus::NotFound,
                    format!("{set} is not a known point set"),
                )
            })?;
        *count = indices.len();
        for (dst, &i) in out.iter_mut().zip(&indices) {
            *dst = i;
        }
        if indices.len() > capacity {
            return Err(Failure::new(
                InertiaStatus::BufferTooSmall,
                format!("{} indices, the buffer {capacity}", indices.len()),
            ));
        }
        Ok(())
    })
}

/// A point set's surface triangles, three point indices each
/// (counter-clockwise seen from outside), into `out` (room for `capacity`
/// indices); `*count` is how many indices there are (3 per triangle). A
/// set's triangles change only when a spawn event names it again (a
/// cloth that tore).
///
/// # Safety
/// `client` is a live handle; `out` holds `capacity` writable indices (or
/// is null with 0); `count` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_point_set_triangles(
    client: *mut InertiaClient,
    set: u32,
    out: *mut u32,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    // SAFETY: as the caller promises.
    unsafe {
        copy_indices(client, set, out, capacity, count, |s| match s {
            ShapeDesc::PointSet { triangles, .. } => {
                Some(triangles.iter().flatten().copied().collect())
            }
            _ => None,
        })
    }
}

/// A point set's lines (a rope's segments), two point indices each, as
/// [`inertia_point_set_triangles`] gives triangles.
///
/// # Safety
/// As [`inertia_point_set_triangles`].
#[no_mangle]
pub unsafe extern "C" fn inertia_point_set_lines(
    client: *mut InertiaClient,
    set: u32,
    out: *mut u32,
    capacity: usize,
    count: *mut usize,
) -> InertiaStatus {
    // SAFETY: as the caller promises.
    unsafe {
        copy_indices(client, set, out, capacity, count, |s| match s {
            ShapeDesc::PointSet { lines, .. } => Some(lines.iter().flatten().copied().collect()),
            _ => None,
        })
    }
}

/// How the connection is doing, into `*out`; `INERTIA_STATUS_DISCONNECTED`
/// (with the figures still written) once it has ended.
///
/// # Safety
/// `client` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn inertia_stats(
    client: *mut InertiaClient,
    out: *mut InertiaStats,
) -> InertiaStatus {
    guard(|| {
        // SAFETY: as the caller promises.
        let (h, out) = unsafe { (handle(client)?, out_ref(out, "out")?) };
        let s = h.client.stats();
        *out = InertiaStats {
            rtt_ms: s.rtt_ms,
            loss: s.loss,
            kbps: s.kbps,
            buffer_ms: s.buffer_ms,
            delay_ms: s.delay_ms,
            snapshots_received: s.snapshots_received,
            bytes_received: s.bytes_received,
            stalls: s.stalls,
            discontinuities: s.discontinuities,
            jitter_ms: s.jitter_ms,
            kbps_out: s.kbps_out,
            input_margin_ticks: s.input_margin_ticks,
            input_tick: s.input_tick,
            inputs_on_time: s.inputs_on_time,
            inputs_late: s.inputs_late,
            inputs_refused: s.inputs_refused,
            prediction_error_p99_m: s.prediction_error_p99_m,
            prediction_error_max_m: s.prediction_error_max_m,
            prediction_snap_max_m: s.prediction_snap_max_m,
            prediction_corrections: s.prediction_corrections,
        };
        if let Some(reason) = h.client.disconnected() {
            return Err(Failure::new(
                InertiaStatus::Disconnected,
                reason_text(&reason),
            ));
        }
        Ok(())
    })
}
