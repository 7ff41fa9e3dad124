/* The Inertia client SDK's C ABI (libinertia). See client-ffi/README.md. */

#ifndef INERTIA_H
#define INERTIA_H

/* Made by cbindgen from client-ffi/src: do not edit; run INERTIA_WRITE_HEADER=1 cargo test -p inertia-client-ffi --test header */

#include <stddef.h>
#include <stdint.h>

/*
 The version of this ABI: the layout of its structs and the meaning of
 its calls. It changes whenever either does; a binding checks it once
 against the one it was written for.
 */
#define INERTIA_ABI_VERSION 5

/*
 No entity: a replay centred on the player's own avatar.
 */
#define INERTIA_NO_ENTITY UINT32_MAX

/*
 Longest entity name, bytes, with its NUL.
 */
#define INERTIA_NAME_BYTES 65

/*
 Longest event text (why the connection ended), bytes, with its NUL.
 */
#define INERTIA_TEXT_BYTES 256

/*
 Longest game message, bytes (the protocol's bound: every message
 fits an event whole).
 */
#define INERTIA_EVENT_DATA_BYTES 1024

/*
 Longest game name, bytes, with its NUL.
 */
#define INERTIA_GAME_NAME_BYTES 33

/*
 Longest property name, bytes, with its NUL.
 */
#define INERTIA_PROPERTY_NAME_BYTES 33

/*
 The outcome of a call. Anything but `INERTIA_STATUS_OK` leaves a
 message for [`inertia_last_error`] on the calling thread.
 */
typedef enum InertiaStatus {
  /*
   Done.
   */
  INERTIA_STATUS_OK = 0,
  /*
   A pointer that must not be null was, or a string was not UTF-8, or
   a value was out of range.
   */
  INERTIA_STATUS_INVALID_ARGUMENT = 1,
  /*
   The connection could not be made, or the server refused it.
   */
  INERTIA_STATUS_CONNECT_FAILED = 2,
  /*
   The connection has ended (the client handle is still to be freed
   with `inertia_disconnect`).
   */
  INERTIA_STATUS_DISCONNECTED = 3,
  /*
   The caller's buffer was too small: what fitted was written, and the
   count says how many there are.
   */
  INERTIA_STATUS_BUFFER_TOO_SMALL = 4,
  /*
   No such entity (or not of the kind asked for).
   */
  INERTIA_STATUS_NOT_FOUND = 5,
  /*
   The library failed inside (a bug): the handle may be used again,
   but report it with the message.
   */
  INERTIA_STATUS_INTERNAL = 6,
} InertiaStatus;

/*
 A property's kind.
 */
enum InertiaPropertyKind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  /*
   A flag.
   */
  INERTIA_PROPERTY_KIND_BOOL = 0,
  /*
   An unsigned integer of `bits` bits.
   */
  INERTIA_PROPERTY_KIND_U_INT = 1,
  /*
   A signed integer of `bits` bits.
   */
  INERTIA_PROPERTY_KIND_INT = 2,
  /*
   A 32-bit float.
   */
  INERTIA_PROPERTY_KIND_F32 = 3,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum InertiaPropertyKind InertiaPropertyKind;
#else
typedef uint32_t InertiaPropertyKind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 How a game message travels.
 */
enum InertiaDelivery
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  /*
   On the control stream: arrives once, in order with every other
   reliable message.
   */
  INERTIA_DELIVERY_RELIABLE = 0,
  /*
   In a datagram of its own: may be lost.
   */
  INERTIA_DELIVERY_UNRELIABLE = 1,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum InertiaDelivery InertiaDelivery;
#else
typedef uint32_t InertiaDelivery;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 What an event is.
 */
enum InertiaEventKind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  /*
   No event was waiting.
   */
  INERTIA_EVENT_KIND_NONE = 0,
  /*
   `entity` was described to us: read it with `inertia_entity_info`.
   */
  INERTIA_EVENT_KIND_SPAWNED = 1,
  /*
   `entity` left the world or our view.
   */
  INERTIA_EVENT_KIND_DESPAWNED = 2,
  /*
   The server's timeline jumped (a seek, a rewind): `from_tick` to
   `to_tick`. A moment to cut or fade.
   */
  INERTIA_EVENT_KIND_DISCONTINUITY = 3,
  /*
   Drawing fell far behind after an outage and jumped forwards.
   */
  INERTIA_EVENT_KIND_RESYNC = 4,
  /*
   The connection ended: `text` says why.
   */
  INERTIA_EVENT_KIND_DISCONNECTED = 5,
  /*
   A message of the game's from the server's rules: its `data_len`
   bytes in `data`, read as the game lays its messages out;
   `delivery` says how it came.
   */
  INERTIA_EVENT_KIND_MESSAGE = 6,
  /*
   `entity`'s properties changed, as of tick `to_tick`.
   */
  INERTIA_EVENT_KIND_PROPERTIES = 7,
  /*
   The match's properties changed, as of tick `to_tick`.
   */
  INERTIA_EVENT_KIND_MATCH_STATE = 8,
  /*
   The replay asked for (`inertia_kill_cam`, `inertia_replay`) started:
   it shows ticks `from_tick` to `to_tick`; draw it with
   `inertia_replay_sample`.
   */
  INERTIA_EVENT_KIND_REPLAY_STARTED = 9,
  /*
   The replay asked for was refused: `text` says why.
   */
  INERTIA_EVENT_KIND_REPLAY_REFUSED = 10,
  /*
   The replay ended: `text` says how (`finished`, `cancelled`,
   `replaced`, `window_passed`); draw the live world again.
   */
  INERTIA_EVENT_KIND_REPLAY_ENDED = 11,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum InertiaEventKind InertiaEventKind;
#else
typedef uint32_t InertiaEventKind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 What kind of thing an entity is.
 */
enum InertiaEntityKind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  /*
   Never moves (ground, walls, scenery).
   */
  INERTIA_ENTITY_KIND_STATIC = 0,
  /*
   Moved by the simulation.
   */
  INERTIA_ENTITY_KIND_DYNAMIC = 1,
  /*
   Moved by a script or its owner's inputs.
   */
  INERTIA_ENTITY_KIND_KINEMATIC = 2,
  /*
   A player's avatar.
   */
  INERTIA_ENTITY_KIND_AVATAR = 3,
  /*
   A volume of water (drawn, not collided).
   */
  INERTIA_ENTITY_KIND_WATER = 4,
  /*
   A soft body (rope, cloth, jelly), drawn from its points.
   */
  INERTIA_ENTITY_KIND_SOFT_BODY = 5,
  /*
   A fluid, drawn from its particles.
   */
  INERTIA_ENTITY_KIND_FLUID = 6,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum InertiaEntityKind InertiaEntityKind;
#else
typedef uint32_t InertiaEntityKind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 An entity's shape, as far as `InertiaEntityInfo::dims` describes it.
 */
enum InertiaShapeKind
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  /*
   A ball: `dims[0]` radius.
   */
  INERTIA_SHAPE_KIND_SPHERE = 0,
  /*
   A box: `dims` half extents.
   */
  INERTIA_SHAPE_KIND_CUBOID = 1,
  /*
   A capsule along +Y: `dims[0]` half height, `dims[1]` radius.
   */
  INERTIA_SHAPE_KIND_CAPSULE = 2,
  /*
   A cylinder along +Y: `dims[0]` half height, `dims[1]` radius.
   */
  INERTIA_SHAPE_KIND_CYLINDER = 3,
  /*
   A convex hull: `dims` half extents of its bounding box.
   */
  INERTIA_SHAPE_KIND_CONVEX_HULL = 4,
  /*
   A triangle mesh (scenery): `dims` half extents of its bounding box.
   */
  INERTIA_SHAPE_KIND_TRI_MESH = 5,
  /*
   Several shapes: `dims` unused.
   */
  INERTIA_SHAPE_KIND_COMPOUND = 6,
  /*
   A particle: `dims[0]` radius.
   */
  INERTIA_SHAPE_KIND_PARTICLE = 7,
  /*
   The infinite ground plane through the origin, normal +Y.
   */
  INERTIA_SHAPE_KIND_GROUND = 8,
  /*
   Terrain: `dims[0]` and `dims[2]` its size along X and Z.
   */
  INERTIA_SHAPE_KIND_HEIGHT_FIELD = 9,
  /*
   A point set (soft body or fluid): `dims[0]` the drawing radius of a
   point, `points` how many.
   */
  INERTIA_SHAPE_KIND_POINT_SET = 10,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum InertiaShapeKind InertiaShapeKind;
#else
typedef uint32_t InertiaShapeKind;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

/*
 A connected client (opaque to C).
 */
typedef struct InertiaClient InertiaClient;

/*
 How to connect ([`crate::client::inertia_connect_with`]); zeroed is
 the defaults.
 */
typedef struct InertiaConnectOptions {
  /*
   Nonzero: predict the own avatar (the server's game must walk it as
   the default sandbox does).
   */
  uint8_t predict;
} InertiaConnectOptions;

/*
 What the server told us when we joined.
 */
typedef struct InertiaServerInfo {
  /*
   Our client id (from the connect token).
   */
  uint64_t client_id;
  /*
   The server's tick when it welcomed us.
   */
  uint64_t tick;
  /*
   Physics ticks per second of simulation time, Hz.
   */
  uint32_t tick_hz;
  /*
   Snapshots per second, Hz.
   */
  uint32_t snapshot_hz;
  /*
   Snapshot position grid step, m.
   */
  double position_resolution;
  /*
   The server's build (NUL-terminated).
   */
  char server_version[64];
  /*
   Bytes of the game's input (`inertia_set_input_bytes` takes exactly
   this many; the stock server's sandbox takes 5).
   */
  uint32_t input_bytes;
  /*
   Properties the game declares per entity (`inertia_property_decl`).
   */
  uint32_t entity_properties;
  /*
   Properties the game declares per match.
   */
  uint32_t match_properties;
  /*
   The game's name (NUL-terminated; empty when its rules give none):
   pick the controls and the HUD by it.
   */
  char game[INERTIA_GAME_NAME_BYTES];
} InertiaServerInfo;

/*
 One property a game declares.
 */
typedef struct InertiaPropertyDecl {
  /*
   Its name (NUL-terminated, UTF-8).
   */
  char name[INERTIA_PROPERTY_NAME_BYTES];
  /*
   Its kind.
   */
  InertiaPropertyKind kind;
  /*
   Its width on the wire, bits.
   */
  uint32_t bits;
} InertiaPropertyDecl;

/*
 One property's value, in every form that holds it: read the one of
 its kind (a flag is 0 or 1 in all three).
 */
typedef struct InertiaPropertyValue {
  /*
   Its kind.
   */
  InertiaPropertyKind kind;
  /*
   As an unsigned integer (a flag, an unsigned; a signed one's two's
   complement).
   */
  uint64_t as_u64;
  /*
   As a signed integer.
   */
  int64_t as_i64;
  /*
   As a float (exact for a float, a flag and integers up to 2^53).
   */
  double as_f64;
} InertiaPropertyValue;

/*
 One entity where the picture draws it.
 */
typedef struct InertiaEntityState {
  /*
   The entity (a point of a soft body or fluid has its own id after
   its set's: see `inertia_point_set`).
   */
  uint32_t id;
  /*
   1 when the pose was extrapolated past the newest snapshot.
   */
  uint8_t extrapolated;
  /*
   Position of its origin, m.
   */
  double x;
  /*
   Position, m.
   */
  double y;
  /*
   Position, m.
   */
  double z;
  /*
   Orientation, a unit quaternion.
   */
  double qx;
  /*
   Orientation.
   */
  double qy;
  /*
   Orientation.
   */
  double qz;
  /*
   Orientation.
   */
  double qw;
} InertiaEntityState;

/*
 One event. Fields a kind does not use are zero.
 */
typedef struct InertiaEvent {
  /*
   What happened.
   */
  InertiaEventKind kind;
  /*
   The entity it is about.
   */
  uint32_t entity;
  /*
   How a message came.
   */
  InertiaDelivery delivery;
  /*
   Tick before a jump.
   */
  double from_tick;
  /*
   Tick after a jump.
   */
  double to_tick;
  /*
   Text (NUL-terminated, UTF-8).
   */
  char text[INERTIA_TEXT_BYTES];
  /*
   Bytes of `data` used.
   */
  uint32_t data_len;
  /*
   A message's bytes.
   */
  uint8_t data[INERTIA_EVENT_DATA_BYTES];
} InertiaEvent;

/*
 How an entity looks, from its description.
 */
typedef struct InertiaEntityInfo {
  /*
   The entity.
   */
  uint32_t id;
  /*
   What it is.
   */
  InertiaEntityKind kind;
  /*
   Its shape.
   */
  InertiaShapeKind shape;
  /*
   Points of a point set; 0 otherwise.
   */
  uint32_t points;
  /*
   Sizes, m (see [`InertiaShapeKind`]).
   */
  float dims[3];
  /*
   Colour, sRGB bytes: red, green, blue, alpha.
   */
  uint8_t color[4];
  /*
   1 when `owner` is set (a player's avatar).
   */
  uint8_t has_owner;
  /*
   The client whose avatar it is.
   */
  uint64_t owner;
  /*
   Where it was when described, m (scenery stays there).
   */
  double x;
  /*
   Position, m.
   */
  double y;
  /*
   Position, m.
   */
  double z;
  /*
   Orientation when described.
   */
  double qx;
  /*
   Orientation.
   */
  double qy;
  /*
   Orientation.
   */
  double qz;
  /*
   Orientation.
   */
  double qw;
  /*
   Its name (NUL-terminated, UTF-8).
   */
  char name[INERTIA_NAME_BYTES];
} InertiaEntityInfo;

/*
 How the connection is doing.
 */
typedef struct InertiaStats {
  /*
   Round trip, ms (QUIC's smoothed estimate).
   */
  double rtt_ms;
  /*
   Fraction of snapshots lost lately, 0 to 1.
   */
  double loss;
  /*
   Snapshot bandwidth lately, kbit/s.
   */
  double kbps;
  /*
   Snapshot time in hand ahead of the picture, ms.
   */
  double buffer_ms;
  /*
   The picture's delay behind the newest snapshot, ms.
   */
  double delay_ms;
  /*
   Snapshots received.
   */
  uint64_t snapshots_received;
  /*
   Snapshot bytes received.
   */
  uint64_t bytes_received;
  /*
   Times the picture ran out of snapshots.
   */
  uint64_t stalls;
  /*
   Timeline jumps.
   */
  uint64_t discontinuities;
  /*
   How much later than the fastest arrivals snapshots come (95th
   percentile), ms.
   */
  double jitter_ms;
  /*
   Input bandwidth lately, kbit/s.
   */
  double kbps_out;
  /*
   The margin inputs are stamped ahead with, beyond the round trip
   and the jitter, ticks.
   */
  double input_margin_ticks;
  /*
   The tick the newest input was stamped for (0 before the first).
   */
  uint64_t input_tick;
  /*
   Inputs the server applied on their tick.
   */
  uint64_t inputs_on_time;
  /*
   Inputs that reached the server after their tick (applied late).
   */
  uint64_t inputs_late;
  /*
   Inputs the server refused (too far ahead, too many).
   */
  uint64_t inputs_refused;
  /*
   With prediction on: the 99th percentile of the distance between
   where the own avatar was predicted and where the server put it, m.
   */
  double prediction_error_p99_m;
  /*
   With prediction on: the largest such distance, m.
   */
  double prediction_error_max_m;
  /*
   With prediction on: the largest move of the drawn avatar in one
   tick that was a correction rather than its predicted motion, m.
   */
  double prediction_snap_max_m;
  /*
   With prediction on: times the prediction was rolled back and
   replayed.
   */
  uint64_t prediction_corrections;
} InertiaStats;

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

/*
 The ABI version of the library loaded ([`INERTIA_ABI_VERSION`]).
 */
uint32_t inertia_abi_version(void);

/*
 Connects to the server at `address` (`"IP:PORT"`) with a connect token
 (`token_len` bytes at `token`, as the game's backend handed it out) and
 blocks until the server welcomes or refuses us (a few seconds at most).
 On success `*out` is the new handle.

 # Safety
 `address` is a NUL-terminated string; `token` holds `token_len` bytes;
 `out` is writable.
 */
enum InertiaStatus inertia_connect(const char *address,
                                   const uint8_t *token,
                                   size_t token_len,
                                   struct InertiaClient **out);

/*
 [`inertia_connect`] with options (`options` may be null: the
 defaults). With `predict` set the library predicts the own avatar
 (with the default sandbox game's walking settings, which the server's
 game must share): `inertia_sample` then draws it where prediction puts
 it, answering the input at once, and `InertiaStats` reports the
 corrections.

 # Safety
 As [`inertia_connect`]; `options` is null or readable.
 */
enum InertiaStatus inertia_connect_with(const char *address,
                                        const uint8_t *token,
                                        size_t token_len,
                                        const struct InertiaConnectOptions *options,
                                        struct InertiaClient **out);

/*
 Connects to a dev-mode server with a token made from its credentials
 file (`inertia-data/dev-credentials.json` where the server runs), as
 client `client_id` (0: one made up from the clock). For development
 only: a released game gets its tokens from its backend.

 # Safety
 `credentials_path` is a NUL-terminated string; `out` is writable.
 */
enum InertiaStatus inertia_connect_dev(const char *credentials_path,
                                       uint64_t client_id,
                                       struct InertiaClient **out);

/*
 Says goodbye, closes the connection (blocking up to about two seconds)
 and frees the handle. Null is ignored. The handle must not be used
 again.

 # Safety
 `client` is null or a live handle, not used by another thread.
 */
void inertia_disconnect(struct InertiaClient *client);

/*
 What the server told us when we joined.

 # Safety
 `client` is a live handle; `out` is writable.
 */
enum InertiaStatus inertia_server_info(struct InertiaClient *client, struct InertiaServerInfo *out);

/*
 The declaration of property `index` of the game's schema: a match
 property when `of_match` is nonzero, else an entity property.
 `INERTIA_STATUS_NOT_FOUND` past the counts `InertiaServerInfo` gives.

 # Safety
 `client` is a live handle; `out` is writable.
 */
enum InertiaStatus inertia_property_decl(struct InertiaClient *client,
                                         uint8_t of_match,
                                         uint32_t index,
                                         struct InertiaPropertyDecl *out);

/*
 An entity's properties as of the tick last drawn (`inertia_sample`),
 in the schema's order, into `out` (room for `capacity`); `*count` is
 how many the game declares. `INERTIA_STATUS_NOT_FOUND` for an entity
 not in view.

 # Safety
 `client` is a live handle; `out` has room for `capacity` values (or is
 null with `capacity` 0); `count` is writable.
 */
enum InertiaStatus inertia_properties(struct InertiaClient *client,
                                      uint32_t entity,
                                      struct InertiaPropertyValue *out,
                                      size_t capacity,
                                      size_t *count);

/*
 The match's properties (the score, the clock) as of the tick last
 drawn, in the schema's order, as `inertia_properties` writes them.

 # Safety
 As `inertia_properties`.
 */
enum InertiaStatus inertia_match_state(struct InertiaClient *client,
                                       struct InertiaPropertyValue *out,
                                       size_t capacity,
                                       size_t *count);

/*
 Sets the sandbox game's input (the stock server's) for every tick from
 now on, until changed: movement in the horizontal plane (`move_x`,
 `move_z`, each in [−1, 1], the length clamped to 1), facing `yaw` (rad
 about +Y) and held `buttons` (1 jump, 2 push). Each tick's input is
 stamped with the tick the server will be at when it arrives, and the
 server applies it on that tick (`InertiaStats::inputs_late` counts
 those that came too late). `INERTIA_STATUS_INVALID_ARGUMENT` when the
 server runs another game (see `inertia_set_input_bytes`).

 # Safety
 `client` is a live handle.
 */
enum InertiaStatus inertia_set_input(struct InertiaClient *client,
                                     float move_x,
                                     float move_z,
                                     float yaw,
                                     uint8_t buttons);

/*
 Sets the game's input for every tick from now on, until changed: its
 `len` bytes at `bytes`, encoded as the game lays its input out, exactly
 `InertiaServerInfo::input_bytes` long (at most 64). Stamped and sent as
 `inertia_set_input` says. `INERTIA_STATUS_INVALID_ARGUMENT`, changing
 nothing, for another length or a null `bytes` with a length.

 # Safety
 `client` is a live handle; `bytes` points to `len` readable bytes (or
 is null with `len` 0).
 */
enum InertiaStatus inertia_set_input_bytes(struct InertiaClient *client,
                                           const uint8_t *bytes,
                                           size_t len);

/*
 Sends a message of the game's to the server's rules: its `len` bytes
 at `bytes` (at most `INERTIA_EVENT_DATA_BYTES`), laid out as the game
 lays its messages out, `delivery` reliable (in order, once) or
 unreliable (may be lost). `INERTIA_STATUS_INVALID_ARGUMENT`, sending
 nothing, for a longer message or a null `bytes` with a length;
 `INERTIA_STATUS_DISCONNECTED` once the connection has ended. The
 server takes at most its game's rate (30 a second unless the game says
 otherwise) and refuses the rest.

 # Safety
 `client` is a live handle; `bytes` points to `len` readable bytes (or
 is null with `len` 0).
 */
enum InertiaStatus inertia_send_message(struct InertiaClient *client,
                                        const uint8_t *bytes,
                                        size_t len,
                                        InertiaDelivery delivery);

/*
 Asks for the kill-cam: the last `seconds` of the match at `speed` times
 real time (1: as it happened), centred on entity `focus` (the one that
 hit the player; `INERTIA_NO_ENTITY`: the own avatar), beside the live
 match. The answer comes as an event (`INERTIA_EVENT_KIND_REPLAY_STARTED`,
 `_REFUSED`, then `_ENDED`); while it plays, draw
 `inertia_replay_sample`. A speed out of 0.05..=8 or not finite is
 `INERTIA_STATUS_INVALID_ARGUMENT`, and nothing is sent.

 # Safety
 `client` is a live handle.
 */
enum InertiaStatus inertia_kill_cam(struct InertiaClient *client,
                                    float seconds,
                                    float speed,
                                    uint32_t focus);

/*
 Asks for a replay of ticks `from_tick` to `to_tick` (inclusive) at
 `speed`, centred on `focus` (`INERTIA_NO_ENTITY`: the own avatar); as
 `inertia_kill_cam`.

 # Safety
 `client` is a live handle.
 */
enum InertiaStatus inertia_replay(struct InertiaClient *client,
                                  uint64_t from_tick,
                                  uint64_t to_tick,
                                  float speed,
                                  uint32_t focus);

/*
 Stops the replay playing, if any.

 # Safety
 `client` is a live handle.
 */
enum InertiaStatus inertia_cancel_replay(struct InertiaClient *client);

/*
 Draws the replay now, as `inertia_sample` draws the live world: `*count`
 is 0 before any replayed state came.

 # Safety
 As `inertia_sample`.
 */
enum InertiaStatus inertia_replay_sample(struct InertiaClient *client,
                                         struct InertiaEntityState *out,
                                         size_t capacity,
                                         size_t *count);

/*
 Takes the oldest waiting event into `*out`; its kind is
 `INERTIA_EVENT_KIND_NONE` when none was waiting. Call it until then
 every frame.

 # Safety
 `client` is a live handle; `out` is writable.
 */
enum InertiaStatus inertia_poll_event(struct InertiaClient *client, struct InertiaEvent *out);

/*
 Draws the world now: advances the picture's clock and writes where each
 entity is (interpolated between snapshots), ascending by id, into `out`
 (room for `capacity`). `*count` is how many the picture holds; when more
 than `capacity`, the first `capacity` are written and the status is
 `INERTIA_STATUS_BUFFER_TOO_SMALL`. Scenery that never moves is not in
 the picture: it stays where `inertia_entity_info` places it.

 # Safety
 `client` is a live handle; `out` holds `capacity` writable states (or
 is null with 0); `count` is writable.
 */
enum InertiaStatus inertia_sample(struct InertiaClient *client,
                                  struct InertiaEntityState *out,
                                  size_t capacity,
                                  size_t *count);

/*
 How entity `id` looks (its description), into `*out`;
 `INERTIA_STATUS_NOT_FOUND` when it was not described to us.

 # Safety
 `client` is a live handle; `out` is writable.
 */
enum InertiaStatus inertia_entity_info(struct InertiaClient *client,
                                       uint32_t id,
                                       struct InertiaEntityInfo *out);

/*
 The points of soft body or fluid `set` in the picture of the last
 `inertia_sample`: `positions` gets x, y, z (m) for each point (room for
 `capacity` points, so `3 × capacity` floats) and `present` 1 for each
 point known (0: not placed yet, or out of view; its position is then
 0). `*count` is the set's points; past `capacity` the status is
 `INERTIA_STATUS_BUFFER_TOO_SMALL` with the first `capacity` written.
 Its triangles and lines come from `inertia_point_set_triangles` and
 `inertia_point_set_lines`.

 # Safety
 `client` is a live handle; `positions` holds `3 × capacity` writable
 floats and `present` `capacity` bytes (either null with 0); `count` is
 writable.
 */
enum InertiaStatus inertia_point_set(struct InertiaClient *client,
                                     uint32_t set,
                                     float *positions,
                                     uint8_t *present,
                                     size_t capacity,
                                     size_t *count);

/*
 A point set's surface triangles, three point indices each
 (counter-clockwise seen from outside), into `out` (room for `capacity`
 indices); `*count` is how many indices there are (3 per triangle). A
 set's triangles change only when a spawn event names it again (a
 cloth that tore).

 # Safety
 `client` is a live handle; `out` holds `capacity` writable indices (or
 is null with 0); `count` is writable.
 */
enum InertiaStatus inertia_point_set_triangles(struct InertiaClient *client,
                                               uint32_t set,
                                               uint32_t *out,
                                               size_t capacity,
                                               size_t *count);

/*
 A point set's lines (a rope's segments), two point indices each, as
 [`inertia_point_set_triangles`] gives triangles.

 # Safety
 As [`inertia_point_set_triangles`].
 */
enum InertiaStatus inertia_point_set_lines(struct InertiaClient *client,
                                           uint32_t set,
                                           uint32_t *out,
                                           size_t capacity,
                                           size_t *count);

/*
 How the connection is doing, into `*out`; `INERTIA_STATUS_DISCONNECTED`
 (with the figures still written) once it has ended.

 # Safety
 `client` is a live handle; `out` is writable.
 */
enum InertiaStatus inertia_stats(struct InertiaClient *client, struct InertiaStats *out);

/*
 Copies the message of the last failed call on this thread into `buf`
 (at most `len` bytes, NUL-terminated, cut at a character boundary) and
 returns its whole length in bytes without the NUL, so a caller can size
 its buffer; 0 when no call failed yet. `buf` may be null when `len` is 0.

 Thread-safe: each thread has its own last error.

 # Safety
 `buf` is null, or valid for writes of `len` bytes.
 */
size_t inertia_last_error(char *buf, size_t len);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* INERTIA_H */
