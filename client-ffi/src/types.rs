//! The plain structs and enums the C ABI passes: `#[repr(C)]`, scalar
//! fields only (no pointers), so C# can declare them blittable and copy
//! arrays of them without marshalling. Units: m, m/s, rad, s.

use std::ffi::c_char;

/// Longest entity name, bytes, with its NUL.
pub const INERTIA_NAME_BYTES: usize = 65;
/// Longest event text (why the connection ended), bytes, with its NUL.
pub const INERTIA_TEXT_BYTES: usize = 256;
/// Longest game message, bytes (the protocol's bound: every message
/// fits an event whole).
pub const INERTIA_EVENT_DATA_BYTES: usize = 1024;

const _: () = assert!(INERTIA_EVENT_DATA_BYTES == inertia_protocol::message::MAX_MESSAGE_BYTES);

/// How a game message travels.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InertiaDelivery {
    /// On the control stream: arrives once, in order with every other
    /// reliable message.
    Reliable = 0,
    /// In a datagram of its own: may be lost.
    Unreliable = 1,
}

/// What the server told us when we joined.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct InertiaServerInfo {
    /// Our client id (from the connect token).
    pub client_id: u64,
    /// The server's tick when it welcomed us.
    pub tick: u64,
    /// Physics ticks per second of simulation time, Hz.
    pub tick_hz: u32,
    /// Snapshots per second, Hz.
    pub snapshot_hz: u32,
    /// Snapshot position grid step, m.
    pub position_resolution: f64,
    /// The server's build (NUL-terminated).
    pub server_version: [c_char; 64],
    /// Bytes of the game's input (`inertia_set_input_bytes` takes exactly
    /// this many; the stock server's sandbox takes 5).
    pub input_bytes: u32,
    /// Properties the game declares per entity (`inertia_property_decl`).
    pub entity_properties: u32,
    /// Properties the game declares per match.
    pub match_properties: u32,
    /// The game's name (NUL-terminated; empty when its rules give none):
    /// pick the controls and the HUD by it.
    pub game: [c_char; INERTIA_GAME_NAME_BYTES],
}

/// Longest game name, bytes, with its NUL.
pub const INERTIA_GAME_NAME_BYTES: usize = 33;

/// Longest property name, bytes, with its NUL.
pub const INERTIA_PROPERTY_NAME_BYTES: usize = 33;

/// A property's kind.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InertiaPropertyKind {
    /// A flag.
    #[default]
    Bool = 0,
    /// An unsigned integer of `bits` bits.
    UInt = 1,
    /// A signed integer of `bits` bits.
    Int = 2,
    /// A 32-bit float.
    F32 = 3,
}

/// One property a game declares.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct InertiaPropertyDecl {
    /// Its name (NUL-terminated, UTF-8).
    pub name: [c_char; INERTIA_PROPERTY_NAME_BYTES],
    /// Its kind.
    pub kind: InertiaPropertyKind,
    /// Its width on the wire, bits.
    pub bits: u32,
}

/// One property's value, in every form that holds it: read the one of
/// its kind (a flag is 0 or 1 in all three).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct InertiaPropertyValue {
    /// Its kind.
    pub kind: InertiaPropertyKind,
    /// As an unsigned integer (a flag, an unsigned; a signed one's two's
    /// complement).
    pub as_u64: u64,
    /// As a signed integer.
    pub as_i64: i64,
    /// As a float (exact for a float, a flag and integers up to 2^53).
    pub as_f64: f64,
}

/// One entity where the picture draws it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct InertiaEntityState {
    /// The entity (a point of a soft body or fluid has its own id after
    /// its set's: see `inertia_point_set`).
    pub id: u32,
    /// 1 when the pose was extrapolated past the newest snapshot.
    pub extrapolated: u8,
    /// Position of its origin, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Position, m.
    pub z: f64,
    /// Orientation, a unit quaternion.
    pub qx: f64,
    /// Orientation.
    pub qy: f64,
    /// Orientation.
    pub qz: f64,
    /// Orientation.
    pub qw: f64,
}

/// What kind of thing an entity is.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InertiaEntityKind {
    /// Never moves (ground, walls, scenery).
    Static = 0,
    /// Moved by the simulation.
    Dynamic = 1,
    /// Moved by a script or its owner's inputs.
    Kinematic = 2,
    /// A player's avatar.
    Avatar = 3,
    /// A volume of water (drawn, not collided).
    Water = 4,
    /// A soft body (rope, cloth, jelly), drawn from its points.
    SoftBody = 5,
    /// A fluid, drawn from its particles.
    Fluid = 6,
}

/// An entity's shape, as far as `InertiaEntityInfo::dims` describes it.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InertiaShapeKind {
    /// A ball: `dims[0]` radius.
    Sphere = 0,
    /// A box: `dims` half extents.
    Cuboid = 1,
    /// A capsule along +Y: `dims[0]` half height, `dims[1]` radius.
    Capsule = 2,
    /// A cylinder along +Y: `dims[0]` half height, `dims[1]` radius.
    Cylinder = 3,
    /// A convex hull: `dims` half extents of its bounding box.
    ConvexHull = 4,
    /// A triangle mesh (scenery): `dims` half extents of its bounding box.
    TriMesh = 5,
    /// Several shapes: `dims` unused.
    Compound = 6,
    /// A particle: `dims[0]` radius.
    Particle = 7,
    /// The infinite ground plane through the origin, normal +Y.
    Ground = 8,
    /// Terrain: `dims[0]` and `dims[2]` its size along X and Z.
    HeightField = 9,
    /// A point set (soft body or fluid): `dims[0]` the drawing radius of a
    /// point, `points` how many.
    PointSet = 10,
}

/// How an entity looks, from its description.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct InertiaEntityInfo {
    /// The entity.
    pub id: u32,
    /// What it is.
    pub kind: InertiaEntityKind,
    /// Its shape.
    pub shape: InertiaShapeKind,
    /// Points of a point set; 0 otherwise.
    pub points: u32,
    /// Sizes, m (see [`InertiaShapeKind`]).
    pub dims: [f32; 3],
    /// Colour, sRGB bytes: red, green, blue, alpha.
    pub color: [u8; 4],
    /// 1 when `owner` is set (a player's avatar).
    pub has_owner: u8,
    /// The client whose avatar it is.
    pub owner: u64,
    /// Where it was when described, m (scenery stays there).
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Position, m.
    pub z: f64,
    /// Orientation when described.
    pub qx: f64,
    /// Orientation.
    pub qy: f64,
    /// Orientation.
    pub qz: f64,
    /// Orientation.
    pub qw: f64,
    /// Its name (NUL-terminated, UTF-8).
    pub name: [c_char; INERTIA_NAME_BYTES],
}

/// What an event is.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InertiaEventKind {
    /// No event was waiting.
    None = 0,
    /// `entity` was described to us: read it with `inertia_entity_info`.
    Spawned = 1,
    /// `entity` left the world or our view.
    Despawned = 2,
    /// The server's timeline jumped (a seek, a rewind): `from_tick` to
    /// `to_tick`. A moment to cut or fade.
    Discontinuity = 3,
    /// Drawing fell far behind after an outage and jumped forwards.
    Resync = 4,
    /// The connection ended: `text` says why.
    Disconnected = 5,
    /// A message of the game's from the server's rules: its `data_len`
    /// bytes in `data`, read as the game lays its messages out;
    /// `delivery` says how it came.
    Message = 6,
    /// `entity`'s properties changed, as of tick `to_tick`.
    Properties = 7,
    /// The match's properties changed, as of tick `to_tick`.
    MatchState = 8,
    /// The replay asked for (`inertia_kill_cam`, `inertia_replay`) started:
    /// it shows ticks `from_tick` to `to_tick`; draw it with
    /// `inertia_replay_sample`.
    ReplayStarted = 9,
    /// The replay asked for was refused: `text` says why.
    ReplayRefused = 10,
    /// The replay ended: `text` says how (`finished`, `cancelled`,
    /// `replaced`, `window_passed`); draw the live world again.
    ReplayEnded = 11,
}

/// One event. Fields a kind does not use are zero.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct InertiaEvent {
    /// What happened.
    pub kind: InertiaEventKind,
    /// The entity it is about.
    pub entity: u32,
    /// How a message came.
    pub delivery: InertiaDelivery,
    /// Tick before a jump.
    pub from_tick: f64,
    /// Tick after a jump.
    pub to_tick: f64,
    /// Text (NUL-terminated, UTF-8).
    pub text: [c_char; INERTIA_TEXT_BYTES],
    /// Bytes of `data` used.
    pub data_len: u32,
    /// A message's bytes.
    pub data: [u8; INERTIA_EVENT_DATA_BYTES],
}

impl Default for InertiaEvent {
    fn default() -> Self {
        Self {
            kind: InertiaEventKind::None,
            entity: 0,
            delivery: InertiaDelivery::Reliable,
            from_tick: 0.0,
            to_tick: 0.0,
            text: [0; INERTIA_TEXT_BYTES],
            data_len: 0,
            data: [0; INERTIA_EVENT_DATA_BYTES],
        }
    }
}

/// How the connection is doing.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct InertiaStats {
    /// Round trip, ms (QUIC's smoothed estimate).
    pub rtt_ms: f64,
    /// Fraction of snapshots lost lately, 0 to 1.
    pub loss: f64,
    /// Snapshot bandwidth lately, kbit/s.
    pub kbps: f64,
    /// Snapshot time in hand ahead of the picture, ms.
    pub buffer_ms: f64,
    /// The picture's delay behind the newest snapshot, ms.
    pub delay_ms: f64,
    /// Snapshots received.
    pub snapshots_received: u64,
    /// Snapshot bytes received.
    pub bytes_received: u64,
    /// Times the picture ran out of snapshots.
    pub stalls: u64,
    /// Timeline jumps.
    pub discontinuities: u64,
    /// How much later than the fastest arrivals snapshots come (95th
    /// percentile), ms.
    pub jitter_ms: f64,
    /// Input bandwidth lately, kbit/s.
    pub kbps_out: f64,
    /// The margin inputs are stamped ahead with, beyond the round trip
    /// and the jitter, ticks.
    pub input_margin_ticks: f64,
    /// The tick the newest input was stamped for (0 before the first).
    pub input_tick: u64,
    /// Inputs the server applied on their tick.
    pub inputs_on_time: u64,
    /// Inputs that reached the server after their tick (applied late).
    pub inputs_late: u64,
    /// Inputs the server refused (too far ahead, too many).
    pub inputs_refused: u64,
    /// With prediction on: the 99th percentile of the distance between
    /// where the own avatar was predicted and where the server put it, m.
    pub prediction_error_p99_m: f64,
    /// With prediction on: the largest such distance, m.
    pub prediction_error_max_m: f64,
    /// With prediction on: the largest move of the drawn avatar in one
    /// tick that was a correction rather than its predicted motion, m.
    pub prediction_snap_max_m: f64,
    /// With prediction on: times the prediction was rolled back and
    /// replayed.
    pub prediction_corrections: u64,
}

/// How to connect ([`crate::client::inertia_connect_with`]); zeroed is
/// the defaults.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct InertiaConnectOptions {
    /// Nonzero: predict the own avatar (the server's game must walk it as
    /// the default sandbox does).
    pub predict: u8,
}

impl InertiaConnectOptions {
    /// The SDK's options.
    pub(crate) fn to_sdk(self) -> inertia_client::ConnectOptions {
        inertia_client::ConnectOptions {
            predict: (self.predict != 0).then(inertia_client::predict::PredictionConfig::default),
            ..inertia_client::ConnectOptions::default()
        }
    }
}
