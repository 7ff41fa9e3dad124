//! The sandbox's input: a stick, a facing angle and two buttons, in five
//! bytes.
//!
//! ## Layout (36 bits, least significant bit first, in 5 bytes)
//!
//! ```text
//! movement x   8  (x + 1) × 127 rounded: 0..=254, so 0 is exact
//! movement z   8
//! yaw         12  the facing angle in 4096ths of a turn
//! buttons      8  buttons::ALL at most
//! padding      4  zero
//! ```
//!
//! The decoder refuses what the encoder never writes (an index of 255, an
//! undefined button, padding that is not zero), so every input the rules
//! read is a value of this type.

use std::f64::consts::TAU;

use inertia_protocol::input::{GameInput, InputDecodeError};

/// Bytes of a [`SandboxInput`] on the wire.
pub const SANDBOX_INPUT_BYTES: usize = 5;

/// Buttons a player can hold, as bits of [`SandboxInput::buttons`].
pub mod buttons {
    /// Jump (acts on the press, when the avatar stands on something).
    pub const JUMP: u8 = 1;
    /// Push what is in front of the avatar.
    pub const PUSH: u8 = 2;
    /// Every defined button.
    pub const ALL: u8 = JUMP | PUSH;
}

/// Bits of each movement axis.
const MOVEMENT_BITS: u32 = 8;
/// Bits of the yaw angle.
const YAW_BITS: u32 = 12;
/// An axis in [−1, 1] maps to 0..=254.
const MOVEMENT_STEPS: f64 = 127.0;
const MOVEMENT_MAX_INDEX: u64 = 254;

/// What a sandbox player wants for one tick.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SandboxInput {
    /// Desired movement in the horizontal plane (x, z), each in [−1, 1];
    /// the rules clamp its length to 1.
    pub movement: [f32; 2],
    /// Facing angle about +Y, rad.
    pub yaw: f32,
    /// Held buttons ([`buttons`]).
    pub buttons: u8,
}

impl SandboxInput {
    /// The input as it arrives after the trip: movement on a grid of 1/127
    /// per axis (NaN as 0, clamped to [−1, 1]), yaw in [0, 2π) rad in
    /// steps of 2π/4096 (not finite as 0), undefined buttons dropped.
    /// Quantizing twice changes nothing.
    pub fn quantized(&self) -> SandboxInput {
        SandboxInput {
            movement: self.movement.map(|m| movement_value(movement_index(m))),
            yaw: yaw_value(yaw_index(self.yaw)),
            buttons: self.buttons & buttons::ALL,
        }
    }
}

impl GameInput for SandboxInput {
    const BYTES: usize = SANDBOX_INPUT_BYTES;

    /// Writes the quantized input ([`SandboxInput::quantized`]).
    fn encode(&self, out: &mut [u8]) {
        let bits = movement_index(self.movement[0])
            | movement_index(self.movement[1]) << MOVEMENT_BITS
            | yaw_index(self.yaw) << (2 * MOVEMENT_BITS)
            | u64::from(self.buttons & buttons::ALL) << (2 * MOVEMENT_BITS + YAW_BITS);
        out.copy_from_slice(&bits.to_le_bytes()[..SANDBOX_INPUT_BYTES]);
    }

    fn decode(bytes: &[u8]) -> Result<Self, InputDecodeError> {
        let mut le = [0u8; 8];
        le[..SANDBOX_INPUT_BYTES].copy_from_slice(bytes);
        let bits = u64::from_le_bytes(le);
        let field = |at: u32, width: u32| (bits >> at) & ((1 << width) - 1);
        let mut movement = [0.0f32; 2];
        for (k, m) in movement.iter_mut().enumerate() {
            let index = field(k as u32 * MOVEMENT_BITS, MOVEMENT_BITS);
            if index > MOVEMENT_MAX_INDEX {
                return Err(InputDecodeError::Invalid(
                    "a movement index off the grid".into(),
                ));
            }
            *m = movement_value(index);
        }
        let yaw = yaw_value(field(2 * MOVEMENT_BITS, YAW_BITS));
        let held = field(2 * MOVEMENT_BITS + YAW_BITS, 8) as u8;
        if held & !buttons::ALL != 0 {
            return Err(InputDecodeError::Invalid("undefined buttons".into()));
        }
        if bits >> (2 * MOVEMENT_BITS + YAW_BITS + 8) != 0 {
            return Err(InputDecodeError::Invalid("nonzero padding".into()));
        }
        Ok(SandboxInput {
            movement,
            yaw,
            buttons: held,
        })
    }
}

fn movement_index(x: f32) -> u64 {
    let x = if x.is_nan() {
        0.0
    } else {
        f64::from(x).clamp(-1.0, 1.0)
    };
    ((x + 1.0) * MOVEMENT_STEPS).round() as u64
}

fn movement_value(i: u64) -> f32 {
    (i as f64 / MOVEMENT_STEPS - 1.0) as f32
}

fn yaw_index(yaw: f32) -> u64 {
    if !yaw.is_finite() {
        return 0;
    }
    let turns = f64::from(yaw) / TAU;
    let frac = turns - turns.floor();
    ((frac * f64::from(1u32 << YAW_BITS)).round() as u64) & ((1 << YAW_BITS) - 1)
}

fn yaw_value(i: u64) -> f32 {
    (i as f64 * TAU / f64::from(1u32 << YAW_BITS)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trip(input: SandboxInput) -> SandboxInput {
        SandboxInput::from_payload(&input.to_payload()).unwrap()
    }

    #[test]
    fn inputs_round_trip_quantized() {
        let i = SandboxInput {
            movement: [0.5, -1.0],
            yaw: 1.0,
            buttons: buttons::JUMP,
        };
        assert_eq!(trip(i), i.quantized());
        assert_eq!(trip(i.quantized()), i.quantized());
        let q = SandboxInput {
            movement: [0.0, 1.0],
            yaw: -std::f32::consts::FRAC_PI_2,
            buttons: 0,
        }
        .quantized();
        assert_eq!(q.movement, [0.0, 1.0]);
        assert!((q.yaw - 3.0 * std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        let nan = SandboxInput {
            movement: [f32::NAN, 7.0],
            yaw: f32::INFINITY,
            buttons: 0xff,
        }
        .quantized();
        assert_eq!(nan.movement, [0.0, 1.0]);
        assert_eq!(nan.yaw, 0.0);
        assert_eq!(nan.buttons, buttons::ALL);
    }

    #[test]
    fn what_the_encoder_never_writes_is_refused() {
        let good = SandboxInput::default().to_payload();
        let with = |k: usize, b: u8| {
            let mut bytes = good.as_bytes().to_vec();
            bytes[k] = b;
            SandboxInput::decode(&bytes)
        };
        assert!(with(0, 255).is_err(), "movement index 255");
        // Buttons are bits 28..36: byte 3's high nibble and byte 4's low one.
        assert!(with(3, 0x40).is_err(), "an undefined button");
        assert!(with(4, 0x10).is_err(), "padding");
        assert!(with(3, 0x10).is_ok(), "jump");
    }
}
