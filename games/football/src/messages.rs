//! What players and the rules say to each other beside inputs. A kind
//! byte, then its fields; a team is its code (red 1, blue 2, none 0), a
//! client its id (u64, little-endian), a tick a u64, a line of chat its
//! length (one byte, at most [`MAX_LINE`]) and its UTF-8.

use inertia_codec::{ByteReader, ByteWriter};
use inertia_protocol::message::{GameMessage, MessageDecodeError};

use crate::properties::Team;

/// The longest chat line, bytes.
pub const MAX_LINE: usize = 100;

/// What a player asks of the rules.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ask {
    /// Say this to everyone.
    Say(String),
    /// Move me to the other team (while waiting or at a kickoff, and only
    /// when that leaves the teams at most one apart).
    SwitchTeam,
}

/// What the rules tell the players.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Tell {
    /// `client` joined `team`.
    Joined {
        /// Who.
        client: u64,
        /// Its team.
        team: Team,
    },
    /// A kickoff: play starts in a moment, `team` to kick.
    Kickoff {
        /// Who kicks off.
        team: Team,
    },
    /// `team` scored on `tick` (the ball crossed the line that tick);
    /// `scorer` is who last kicked it, if of that team; the score after it.
    Goal {
        /// The tick the goal was scored on.
        tick: u64,
        /// Who scored.
        team: Team,
        /// The player who kicked it in, if one of the scoring team's.
        scorer: Option<u64>,
        /// Red's goals, then blue's.
        score: [u8; 2],
    },
    /// The match is over: `winner` won, `score` red's then blue's.
    Over {
        /// The winners.
        winner: Team,
        /// Red's goals, then blue's.
        score: [u8; 2],
    },
    /// `client` said `text`.
    Said {
        /// Who.
        client: u64,
        /// What.
        text: String,
    },
}

fn put_line(w: &mut ByteWriter<'_>, text: &str) {
    let mut end = text.len().min(MAX_LINE);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    w.u8(end as u8);
    w.bytes(&text.as_bytes()[..end]);
}

fn line(r: &mut ByteReader<'_>) -> Result<String, MessageDecodeError> {
    let n = usize::from(r.u8()?);
    if n > MAX_LINE {
        return Err(MessageDecodeError::Invalid("a line past 100 bytes".into()));
    }
    String::from_utf8(r.bytes(n)?.to_vec())
        .map_err(|_| MessageDecodeError::Invalid("a line that is not UTF-8".into()))
}

fn team(r: &mut ByteReader<'_>) -> Result<Team, MessageDecodeError> {
    let code = r.u8()?;
    Team::from_code(u64::from(code))
        .ok_or_else(|| MessageDecodeError::Invalid(format!("team {code}").into()))
}

fn done<T>(r: &ByteReader<'_>, value: T) -> Result<T, MessageDecodeError> {
    if r.is_empty() {
        Ok(value)
    } else {
        Err(MessageDecodeError::Invalid(
            "bytes after the message".into(),
        ))
    }
}

impl GameMessage for Ask {
    /// A line past [`MAX_LINE`] is cut to it (at a character boundary).
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            Ask::Say(text) => {
                w.u8(1);
                put_line(&mut w, text);
            }
            Ask::SwitchTeam => w.u8(2),
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let ask = match r.u8()? {
            1 => Ask::Say(line(&mut r)?),
            2 => Ask::SwitchTeam,
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        done(&r, ask)
    }
}

impl GameMessage for Tell {
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            Tell::Joined { client, team } => {
                w.u8(1);
                w.u64(*client);
                w.u8(team.code());
            }
            Tell::Kickoff { team } => {
                w.u8(2);
                w.u8(team.code());
            }
            Tell::Goal {
                tick,
                team,
                scorer,
                score,
            } => {
                w.u8(3);
                w.u64(*tick);
                w.u8(team.code());
                match scorer {
                    Some(c) => {
                        w.u8(1);
                        w.u64(*c);
                    }
                    None => w.u8(0),
                }
                w.bytes(score);
            }
            Tell::Over { winner, score } => {
                w.u8(4);
                w.u8(winner.code());
                w.bytes(score);
            }
            Tell::Said { client, text } => {
                w.u8(5);
                w.u64(*client);
                put_line(&mut w, text);
            }
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let score = |r: &mut ByteReader<'_>| -> Result<[u8; 2], MessageDecodeError> {
            Ok([r.u8()?, r.u8()?])
        };
        let tell = match r.u8()? {
            1 => Tell::Joined {
                client: r.u64()?,
                team: team(&mut r)?,
            },
            2 => Tell::Kickoff {
                team: team(&mut r)?,
            },
            3 => Tell::Goal {
                tick: r.u64()?,
                team: team(&mut r)?,
                scorer: match r.u8()? {
                    0 => None,
                    1 => Some(r.u64()?),
                    other => {
                        return Err(MessageDecodeError::Invalid(
                            format!("a scorer flag of {other}").into(),
                        ))
                    }
                },
                score: score(&mut r)?,
            },
            4 => Tell::Over {
                winner: team(&mut r)?,
                score: score(&mut r)?,
            },
            5 => Tell::Said {
                client: r.u64()?,
                text: line(&mut r)?,
            },
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        done(&r, tell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_round_trip_and_bad_bytes_are_refused() {
        for ask in [Ask::Say("gl hf".into()), Ask::SwitchTeam] {
            assert_eq!(Ask::decode(&ask.to_bytes()), Ok(ask));
        }
        for tell in [
            Tell::Joined {
                client: 3,
                team: Team::Blue,
            },
            Tell::Kickoff { team: Team::Red },
            Tell::Goal {
                tick: 1234,
                team: Team::Red,
                scorer: Some(7),
                score: [1, 0],
            },
            Tell::Goal {
                tick: 99,
                team: Team::Blue,
                scorer: None,
                score: [1, 1],
            },
            Tell::Over {
                winner: Team::Blue,
                score: [1, 2],
            },
            Tell::Said {
                client: 8,
                text: "gg".into(),
            },
        ] {
            assert_eq!(Tell::decode(&tell.to_bytes()), Ok(tell));
        }
        assert!(Ask::decode(&[9]).is_err());
        assert!(Ask::decode(&[2, 0]).is_err());
        assert!(Ask::decode(&[1, 101]).is_err());
        assert!(Tell::decode(&[2, 3]).is_err(), "no team 3");
        assert!(
            Tell::decode(&[3, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2]).is_err(),
            "a scorer flag of 2"
        );
        assert_eq!(
            Ask::decode(&Ask::Say("é".repeat(80)).to_bytes()),
            Ok(Ask::Say("é".repeat(50)))
        );
    }
}
