//! The version of the whole wire protocol, below everything that speaks
//! it (the control channel, the datagrams, connect tokens).

/// The version of the whole wire protocol (control, datagrams and tokens).
/// A client and server speak only when theirs are equal. 5: inputs carry
/// the game's own bytes, and the welcome says how many. 6: the game's
/// messages both ways (reliable on the control stream, unreliable in
/// message datagrams) in place of the server's events, and the game's
/// properties (their schema in the welcome, a section in every
/// snapshot). 7: the welcome names the game. 8: players' replays of the
/// recent past (asked and answered on the control stream, played in
/// replay datagrams).
pub const PROTOCOL_VERSION: u16 = 8;
