//! What an allocation asks of the match, read from the game server's
//! labels and annotations (sans-IO).
//!
//! A matchmaker allocates a game server with a `GameServerAllocation`
//! whose `metadata` sets labels and annotations on it. Inertia reads these
//! keys (an annotation wins over a label of the same key, since label
//! values cannot hold `/` and are at most 63 characters):
//!
//! | key | meaning |
//! |---|---|
//! | `inertia.dev/match-seconds` | the match ends (drain, then Shutdown) this many wall seconds after the allocation (1..=86400) |
//! | `inertia.dev/scene` | the scene the match asks for: a file name (`.ron` or `.json`) in the server's `--scenes-dir`, never a path |
//! | `inertia.dev/rules` | the rules variant the match asks for (at most 256 bytes) |
//! | `inertia.dev/replay-seed` | the seed the match's random choices start from (a u64) |
//!
//! A value that does not parse is reported ([`SettingError`]) and left
//! out; the others still apply.

use std::collections::BTreeMap;
use std::time::Duration;

/// Key of the match length.
pub const MATCH_SECONDS: &str = "inertia.dev/match-seconds";
/// Key of the scene.
pub const SCENE: &str = "inertia.dev/scene";
/// Key of the rules variant.
pub const RULES: &str = "inertia.dev/rules";
/// Key of the replay seed.
pub const REPLAY_SEED: &str = "inertia.dev/replay-seed";
/// Longest accepted match, s (a day).
pub const MAX_MATCH_SECONDS: u64 = 86_400;
/// Longest accepted scene or rules value, bytes.
pub const MAX_NAME_BYTES: usize = 256;

/// The match settings an allocation carried.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MatchSettings {
    /// How long the match lasts from the allocation.
    pub length: Option<Duration>,
    /// The scene asked for.
    pub scene: Option<String>,
    /// The rules variant asked for.
    pub rules: Option<String>,
    /// The seed of the match's random choices.
    pub replay_seed: Option<u64>,
}

/// A match setting whose value was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    /// Not a whole number in range.
    #[error("{key} = {value:?}: expected a whole number in {min}..={max}")]
    Number {
        key: &'static str,
        value: String,
        min: u64,
        max: u64,
    },
    /// Empty, too long, or with control characters.
    #[error("{key}: expected 1..={MAX_NAME_BYTES} bytes of printable text, got {len} bytes")]
    Name { key: &'static str, len: usize },
    /// A scene that is not a plain `.ron` or `.json` file name.
    #[error("{key} = {value:?}: expected a file name of A-Z a-z 0-9 . _ - ending .ron or .json, not a path")]
    SceneFile { key: &'static str, value: String },
}

impl MatchSettings {
    /// The settings in `labels` and `annotations`, and the values refused.
    pub fn from_metadata(
        labels: &BTreeMap<String, String>,
        annotations: &BTreeMap<String, String>,
    ) -> (MatchSettings, Vec<SettingError>) {
        let get = |key: &str| annotations.get(key).or_else(|| labels.get(key));
        let mut errors = Vec::new();
        let mut number = |key: &'static str, min: u64, max: u64| {
            let value = get(key)?;
            match value.trim().parse::<u64>() {
                Ok(n) if (min..=max).contains(&n) => Some(n),
                _ => {
                    errors.push(SettingError::Number {
                        key,
                        value: value.chars().take(64).collect(),
                        min,
                        max,
                    });
                    None
                }
            }
        };
        let length = number(MATCH_SECONDS, 1, MAX_MATCH_SECONDS).map(Duration::from_secs);
        let replay_seed = number(REPLAY_SEED, 0, u64::MAX);
        let mut name = |key: &'static str| {
            let value = get(key)?;
            let printable = !value.chars().any(char::is_control);
            if value.is_empty() || value.len() > MAX_NAME_BYTES || !printable {
                errors.push(SettingError::Name {
                    key,
                    len: value.len(),
                });
                return None;
            }
            Some(value.clone())
        };
        let scene = name(SCENE);
        let rules = name(RULES);
        // A scene names a file in the scenes directory: a plain name.
        let scene = scene.and_then(|s| {
            let plain = !s.starts_with('.')
                && s.chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
            if plain && (s.ends_with(".ron") || s.ends_with(".json")) {
                Some(s)
            } else {
                errors.push(SettingError::SceneFile {
                    key: SCENE,
                    value: s.chars().take(64).collect(),
                });
                None
            }
        });
        (
            MatchSettings {
                length,
                scene,
                rules,
                replay_seed,
            },
            errors,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn annotations_win_over_labels_and_bad_values_are_left_out() {
        let labels = map(&[(MATCH_SECONDS, "600"), (RULES, "ctf")]);
        let annotations = map(&[
            (MATCH_SECONDS, "900"),
            (SCENE, "arena.ron"),
            (REPLAY_SEED, "not a number"),
        ]);
        let (s, errors) = MatchSettings::from_metadata(&labels, &annotations);
        assert_eq!(s.length, Some(Duration::from_secs(900)));
        assert_eq!(s.scene.as_deref(), Some("arena.ron"));
        assert_eq!(s.rules.as_deref(), Some("ctf"));
        assert_eq!(s.replay_seed, None);
        assert_eq!(errors.len(), 1);
        assert!(errors[0].to_string().contains(REPLAY_SEED));
    }

    #[test]
    fn out_of_range_lengths_and_odd_names_are_refused() {
        for bad in ["0", "86401", "-5", "1e3", ""] {
            let (s, errors) =
                MatchSettings::from_metadata(&map(&[(MATCH_SECONDS, bad)]), &map(&[]));
            assert_eq!(s.length, None, "{bad:?}");
            assert_eq!(errors.len(), 1, "{bad:?}");
        }
        let long = "x".repeat(MAX_NAME_BYTES + 1);
        for bad in [
            "",
            "a\nb",
            long.as_str(),
            "../x.ron",
            "/etc/x.json",
            "arena",
            ".hidden.ron",
        ] {
            let (s, errors) = MatchSettings::from_metadata(&map(&[]), &map(&[(SCENE, bad)]));
            assert_eq!(s.scene, None);
            assert_eq!(errors.len(), 1);
        }
        let (s, errors) = MatchSettings::from_metadata(&map(&[]), &map(&[]));
        assert_eq!((s, errors.len()), (MatchSettings::default(), 0));
    }
}
