//! What a player wants each tick: where to roll. Three bytes: the stick's
//! two axes (−127 to 127 each, −128 refused) and a dash flag (0 or 1).

use inertia_protocol::input::{GameInput, InputDecodeError};

/// One tick of a player's wishes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Drive {
    /// The stick: x and z, −127 to 127 each (full right and full back at
    /// 127).
    pub stick: [i8; 2],
    /// Roll twice as hard.
    pub dash: bool,
}

impl GameInput for Drive {
    const BYTES: usize = 3;

    fn encode(&self, out: &mut [u8]) {
        out[0] = self.stick[0] as u8;
        out[1] = self.stick[1] as u8;
        out[2] = u8::from(self.dash);
    }

    fn decode(bytes: &[u8]) -> Result<Self, InputDecodeError> {
        let stick = [bytes[0] as i8, bytes[1] as i8];
        if stick.contains(&i8::MIN) {
            return Err(InputDecodeError::Invalid("a stick at -128".into()));
        }
        let dash = match bytes[2] {
            0 => false,
            1 => true,
            _ => {
                return Err(InputDecodeError::Invalid(
                    "a dash that is not 0 or 1".into(),
                ))
            }
        };
        Ok(Drive { stick, dash })
    }
}
