//! What a player wants each tick: where to run, where to face, how high to
//! kick, and two buttons. Six bytes:
//!
//! | bytes | field | range |
//! |---|---|---|
//! | 0, 1 | the stick, x and z (world axes) | −127 to 127 each (−128 refused) |
//! | 2, 3 | yaw, little-endian | 65 536ths of a turn about +y; 0 faces +z |
//! | 4 | pitch of a kick | −90 to 90 degrees above the grass (others refused) |
//! | 5 | buttons | [`buttons::JUMP`] 1, [`buttons::KICK`] 2 (other bits refused) |

use std::f64::consts::TAU;

use inertia_physics::glam::DVec3;
use inertia_protocol::input::{GameInput, InputDecodeError};

/// The buttons a player presses.
pub mod buttons {
    /// Jump (on the press, when standing).
    pub const JUMP: u8 = 1;
    /// Kick the ball within reach, along the yaw and pitch (on the press).
    pub const KICK: u8 = 2;
    /// Every defined button.
    pub const ALL: u8 = JUMP | KICK;
}

/// One tick of a player's wishes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Play {
    /// The stick: x and z, −127 to 127 each (127 runs full speed to +x or
    /// +z).
    pub stick: [i8; 2],
    /// Facing, 65 536ths of a turn about +y (0 faces +z, a quarter turn
    /// +x).
    pub yaw: u16,
    /// How high a kick goes, degrees above the grass, −90 to 90.
    pub pitch: i8,
    /// Held buttons ([`buttons`]).
    pub buttons: u8,
}

impl Play {
    /// A play from the stick in [−1, 1] per axis (clamped; NaN as 0), the
    /// yaw in radians and the pitch in degrees (clamped to ±90).
    pub fn new(stick: [f64; 2], yaw: f64, pitch_degrees: f64, buttons: u8) -> Play {
        let axis = |v: f64| {
            if v.is_nan() {
                0
            } else {
                (v.clamp(-1.0, 1.0) * 127.0).round() as i8
            }
        };
        let turns = if yaw.is_finite() { yaw / TAU } else { 0.0 };
        let yaw = ((turns - turns.floor()) * 65_536.0).round() as u32 % 65_536;
        let pitch = if pitch_degrees.is_nan() {
            0
        } else {
            pitch_degrees.clamp(-90.0, 90.0).round() as i8
        };
        Play {
            stick: [axis(stick[0]), axis(stick[1])],
            yaw: yaw as u16,
            pitch,
            buttons: buttons & buttons::ALL,
        }
    }

    /// The stick as a movement in the horizontal plane (x, z), length at
    /// most 1.
    pub fn movement(&self) -> [f32; 2] {
        let [x, z] = self.stick.map(|a| f32::from(a) / 127.0);
        let len = (x * x + z * z).sqrt();
        if len > 1.0 {
            [x / len, z / len]
        } else {
            [x, z]
        }
    }

    /// The yaw, rad.
    pub fn yaw_radians(&self) -> f64 {
        f64::from(self.yaw) / 65_536.0 * TAU
    }

    /// The unit direction a kick goes: along the yaw, raised by the pitch.
    pub fn kick_direction(&self) -> DVec3 {
        let (yaw, pitch) = (self.yaw_radians(), f64::from(self.pitch).to_radians());
        DVec3::new(
            yaw.sin() * pitch.cos(),
            pitch.sin(),
            yaw.cos() * pitch.cos(),
        )
    }
}

impl GameInput for Play {
    const BYTES: usize = 6;

    fn encode(&self, out: &mut [u8]) {
        out[0] = self.stick[0] as u8;
        out[1] = self.stick[1] as u8;
        out[2..4].copy_from_slice(&self.yaw.to_le_bytes());
        out[4] = self.pitch as u8;
        out[5] = self.buttons;
    }

    fn decode(bytes: &[u8]) -> Result<Self, InputDecodeError> {
        let stick = [bytes[0] as i8, bytes[1] as i8];
        if stick.contains(&i8::MIN) {
            return Err(InputDecodeError::Invalid("a stick at -128".into()));
        }
        let pitch = bytes[4] as i8;
        if !(-90..=90).contains(&pitch) {
            return Err(InputDecodeError::Invalid(
                format!("a pitch of {pitch} degrees, past 90").into(),
            ));
        }
        let buttons = bytes[5];
        if buttons & !buttons::ALL != 0 {
            return Err(InputDecodeError::Invalid(
                format!(
                    "buttons {buttons:#04x}, past the defined {:#04x}",
                    buttons::ALL
                )
                .into(),
            ));
        }
        Ok(Play {
            stick,
            yaw: u16::from_le_bytes([bytes[2], bytes[3]]),
            pitch,
            buttons,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plays_round_trip_and_bad_bytes_are_refused() {
        let play = Play::new(
            [1.0, -0.5],
            std::f64::consts::FRAC_PI_2,
            20.0,
            buttons::KICK,
        );
        assert_eq!(play.stick, [127, -64]);
        assert_eq!(play.yaw, 16_384);
        assert_eq!(Play::from_payload(&play.to_payload()), Ok(play));
        let d = play.kick_direction();
        assert!(
            (d.x - 20f64.to_radians().cos()).abs() < 1e-4 && d.z.abs() < 1e-4,
            "{d}"
        );
        for bad in [
            [0x80, 0, 0, 0, 0, 0],
            [0, 0, 0, 0, 91, 0],
            [0, 0, 0, 0, 0xA0, 0],
            [0, 0, 0, 0, 0, 4],
        ] {
            assert!(Play::decode(&bad).is_err(), "{bad:?}");
        }
        assert_eq!(
            Play::new([f64::NAN, 3.0], f64::INFINITY, f64::NAN, 0xFF).stick,
            [0, 127]
        );
    }
}
