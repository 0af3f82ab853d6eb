//! The table of active input-side alarms (raised and cleared by the input adapters through
//! the cycle), bounded so no input can flood the record or the API.
//!
//! - A key is kept to [`MAX_KEY_CHARS`] characters and a message to [`MAX_MESSAGE_CHARS`]
//!   (cut on a character boundary, marked with `…`), whatever a sender puts in them.
//! - At most [`MAX_ACTIVE`] keys are active at once. A further cause is not listed on its
//!   own: it counts in the one alarm [`OVERFLOW_KEY`], which clears once the table is back
//!   to half full.
//! - A repeated cause is one alarm with a count: raising an active key again, or an
//!   adapter's [`crate::cycle::InputMsg::AlarmCount`], only updates the count (shown by
//!   `/api/alarms`), it writes no new row.

use std::collections::BTreeMap;

/// Most input alarms active at once.
pub const MAX_ACTIVE: usize = 64;
/// Longest key kept, characters.
pub const MAX_KEY_CHARS: usize = 120;
/// Longest message kept, characters.
pub const MAX_MESSAGE_CHARS: usize = 1000;
/// A channel fault alarm clears only after the channel has been good this long (wall
/// clock): a fault that comes and goes from step to step is one alarm.
pub const CHANNEL_CLEAR_HOLD: std::time::Duration = std::time::Duration::from_secs(1);

/// The alarm that counts the causes beyond [`MAX_ACTIVE`].
pub const OVERFLOW_KEY: &str = "input.alarm_table_full";

/// Cuts `s` to `n` characters, marking a cut with `…`.
pub fn bounded(s: String, n: usize) -> String {
    match s.char_indices().nth(n) {
        None => s,
        Some((i, _)) => {
            let mut t = s[..i].to_string();
            t.push('…');
            t
        }
    }
}

/// What the store should record after a change of the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Edge {
    /// A new alarm row.
    Raised {
        /// Key (bounded).
        key: String,
        /// Message (bounded).
        message: String,
    },
    /// An alarm cleared.
    Cleared {
        /// Key.
        key: String,
    },
}

/// The active input alarms with their counts.
#[derive(Debug, Default, Clone)]
pub struct InputAlarms {
    active: BTreeMap<String, u64>,
    overflow: u64,
}

impl InputAlarms {
    /// A cause was seen: a new key is raised (or counted in the overflow alarm when the
    /// table is full); an active one is counted.
    pub fn raise(&mut self, key: String, message: String) -> Option<Edge> {
        let key = bounded(key, MAX_KEY_CHARS);
        if let Some(n) = self.active.get_mut(&key) {
            *n = n.saturating_add(1);
            return None;
        }
        if self.active.len() >= MAX_ACTIVE {
            self.overflow = self.overflow.saturating_add(1);
            if self.overflow == 1 {
                return Some(Edge::Raised {
                    key: OVERFLOW_KEY.into(),
                    message: bounded(
                        format!(
                            "more than {MAX_ACTIVE} input alarms active; further causes are \
                             counted here, not listed one by one (first: {key}: {message})"
                        ),
                        MAX_MESSAGE_CHARS,
                    ),
                });
            }
            return None;
        }
        self.active.insert(key.clone(), 1);
        Some(Edge::Raised {
            key,
            message: bounded(message, MAX_MESSAGE_CHARS),
        })
    }

    /// The cause is gone: clears the key (and the overflow alarm once the table is back to
    /// half full).
    pub fn clear(&mut self, key: String) -> Vec<Edge> {
        let key = bounded(key, MAX_KEY_CHARS);
        let mut out = Vec::new();
        if self.active.remove(&key).is_some() {
            out.push(Edge::Cleared { key });
        }
        if self.overflow > 0 && self.active.len() <= MAX_ACTIVE / 2 {
            self.overflow = 0;
            out.push(Edge::Cleared {
                key: OVERFLOW_KEY.into(),
            });
        }
        out
    }

    /// An adapter that counts a cause itself reports the total so far (for an active key).
    pub fn set_count(&mut self, key: String, count: u64) {
        let key = bounded(key, MAX_KEY_CHARS);
        if let Some(n) = self.active.get_mut(&key) {
            *n = count.max(1);
        }
    }

    /// Occurrences of an active cause (the overflow alarm counts the causes it holds).
    pub fn count(&self, key: &str) -> Option<u64> {
        if key == OVERFLOW_KEY && self.overflow > 0 {
            return Some(self.overflow);
        }
        self.active.get(key).copied()
    }

    /// Active alarms and their counts (overflow included).
    pub fn counts(&self) -> BTreeMap<String, u64> {
        let mut m = self.active.clone();
        if self.overflow > 0 {
            m.insert(OVERFLOW_KEY.into(), self.overflow);
        }
        m
    }

    /// Number of active keys (overflow not included).
    pub fn len(&self) -> usize {
        self.active.len()
    }

    /// No active key.
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn repeats_count_and_write_one_row() {
        let mut a = InputAlarms::default();
        assert!(a.raise("mqtt.x".into(), "m".into()).is_some());
        for _ in 0..200 {
            assert_eq!(a.raise("mqtt.x".into(), "m".into()), None);
        }
        assert_eq!(a.count("mqtt.x"), Some(201));
        assert_eq!(
            a.clear("mqtt.x".into()),
            vec![Edge::Cleared {
                key: "mqtt.x".into()
            }]
        );
        assert!(a.clear("mqtt.x".into()).is_empty());
    }

    #[test]
    fn a_5013_char_key_is_cut_and_still_clears() {
        let long = "k".repeat(5013);
        let mut a = InputAlarms::default();
        let Some(Edge::Raised { key, message }) = a.raise(long.clone(), "é".repeat(5000)) else {
            panic!()
        };
        assert_eq!(key.chars().count(), MAX_KEY_CHARS + 1);
        assert_eq!(message.chars().count(), MAX_MESSAGE_CHARS + 1);
        assert!(key.ends_with('…'));
        assert_eq!(a.clear(long).len(), 1);
        assert!(a.is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        // Any sequence of raises and clears over up to 300 distinct keys: the table never
        // holds more than MAX_ACTIVE keys, rows are written only on edges, and the table
        // agrees with a plain set model capped by the same rule.
        #[test]
        fn bounded_against_a_set_model(ops in proptest::collection::vec((0u16..300, any::<bool>()), 0..600)) {
            let mut a = InputAlarms::default();
            let mut model: std::collections::BTreeSet<u16> = Default::default();
            let mut overflowing = false;
            for (k, up) in ops {
                let key = format!("in.{k}");
                if up {
                    let e = a.raise(key.clone(), "m".into());
                    if model.contains(&k) {
                        prop_assert_eq!(e, None);
                    } else if model.len() < MAX_ACTIVE {
                        model.insert(k);
                        prop_assert_eq!(e, Some(Edge::Raised { key, message: "m".into() }));
                    } else {
                        let first = !overflowing;
                        overflowing = true;
                        prop_assert_eq!(e.is_some(), first);
                    }
                } else {
                    let e = a.clear(key.clone());
                    let was = model.remove(&k);
                    let cleared = e.contains(&Edge::Cleared { key });
                    prop_assert_eq!(cleared, was);
                    if overflowing && model.len() <= MAX_ACTIVE / 2 {
                        overflowing = false;
                        let overflow_cleared = e.contains(&Edge::Cleared { key: OVERFLOW_KEY.into() });
                        prop_assert!(overflow_cleared);
                    }
                }
                prop_assert!(a.len() <= MAX_ACTIVE);
                prop_assert_eq!(a.len(), model.len());
            }
        }
    }
}
