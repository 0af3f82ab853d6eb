//! The spill file: records that arrive while PostgreSQL is unreachable and the memory
//! buffer (`storage.buffer_records`) is full go to a local SQLite database instead of
//! being dropped, and are written to PostgreSQL in arrival order once it is back.
//!
//! * **Crash-safe**: SQLite in WAL mode with `synchronous = FULL`, one transaction per
//!   commit (the writer commits at the `storage.commit_interval_s` cadence), so a crash
//!   loses at most what the SQLite record itself would.
//! * **Order**: rows are keyed by `seq`, ascending in arrival order. Records still in
//!   memory when a stopping service gives up are put *before* the spilled ones
//!   (negative `seq` below the smallest), so the file keeps the arrival order.
//! * **Exactly once**: before a chunk of spilled rows is sent, the file records
//!   `(batch, upto)` — the PostgreSQL batch number and the last `seq` of the chunk — in
//!   `meta`. Rows are deleted only once that batch is known committed; after a crash the
//!   next start compares `upto`'s batch with `machines.last_batch` and deletes the rows
//!   only if the batch went in.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use rusqlite::{params, Connection, OpenFlags, OptionalExtension};

use crate::error::{invalid, Result};
use crate::storage::Record;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS records (seq INTEGER PRIMARY KEY, kind INTEGER NOT NULL,
    time_s REAL, i INTEGER, a REAL, b REAL, c REAL, s1 TEXT, s2 TEXT, s3 TEXT, s4 TEXT);
";

/// The columns of one spilled record.
type Row = (
    i64,
    i64,
    Option<f64>,
    Option<i64>,
    Option<f64>,
    Option<f64>,
    Option<f64>,
    Option<String>,
    Option<String>,
    Option<String>,
    Option<String>,
);

/// The spill file of one machine, opened when first needed.
pub(super) struct Spill {
    path: PathBuf,
    machine: String,
    db: Option<Connection>,
    /// Records taken but not yet committed to the file.
    staged: Vec<Record>,
    /// When the oldest staged record arrived (commit due `commit_interval` later).
    pub staged_since: Option<Instant>,
    /// Committed rows not yet known written to PostgreSQL.
    rows: u64,
    /// Rows with `seq <= done_upto` are in PostgreSQL (deleted, or to be deleted).
    done_upto: i64,
    /// Next `seq` to append.
    next_seq: i64,
}

impl Spill {
    /// A spill at `path` for `machine`; nothing is opened yet.
    pub fn new(path: PathBuf, machine: String) -> Self {
        Self {
            path,
            machine,
            db: None,
            staged: Vec::new(),
            staged_since: None,
            rows: 0,
            done_upto: i64::MIN,
            next_seq: 1,
        }
    }

    /// The file, for messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Records in the spill (committed or staged).
    pub fn len(&self) -> u64 {
        self.rows + self.staged.len() as u64
    }

    /// True when nothing is spilled or staged.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Records staged but not committed to the file.
    pub fn staged(&self) -> usize {
        self.staged.len()
    }

    fn bad(&self, why: impl std::fmt::Display) -> crate::error::ServiceError {
        invalid(
            "storage.spill_path",
            format!("{:?}", self.path.display().to_string()),
            format!(
                "a writable SQLite spill file of machine {:?} ({why})",
                self.machine
            ),
        )
    }

    /// Opens (creating if `create`) the file and checks it belongs to this machine.
    fn open(&mut self, create: bool) -> Result<&mut Connection> {
        if self.db.is_none() {
            let mut flags = OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_NO_MUTEX;
            if create {
                flags |= OpenFlags::SQLITE_OPEN_CREATE;
            }
            let db = Connection::open_with_flags(&self.path, flags).map_err(|e| self.bad(e))?;
            let setup = || -> rusqlite::Result<Option<String>> {
                db.pragma_update(None, "journal_mode", "WAL")?;
                db.pragma_update(None, "synchronous", "FULL")?;
                db.execute_batch(SCHEMA)?;
                db.execute(
                    "INSERT OR IGNORE INTO meta (key, value) VALUES ('machine', ?1)",
                    [&self.machine],
                )?;
                db.query_row("SELECT value FROM meta WHERE key = 'machine'", [], |r| {
                    r.get(0)
                })
                .optional()
            };
            let owner = setup().map_err(|e| self.bad(e))?;
            if owner.as_deref() != Some(self.machine.as_str()) {
                return Err(self.bad(format!(
                    "it holds the records of machine {:?}",
                    owner.unwrap_or_default()
                )));
            }
            let (n, min, max): (i64, Option<i64>, Option<i64>) = db
                .query_row(
                    "SELECT COUNT(*), MIN(seq), MAX(seq) FROM records",
                    [],
                    |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
                )
                .map_err(|e| self.bad(e))?;
            self.rows = n.max(0) as u64;
            self.done_upto = min.map_or(0, |m| m - 1);
            self.next_seq = max.map_or(1, |m| m + 1);
            self.db = Some(db);
        }
        self.db
            .as_mut()
            .ok_or_else(|| invalid("storage.spill_path", "", "open"))
    }

    /// At start: opens an existing file, and deletes the rows of a chunk that PostgreSQL
    /// committed (`last_batch` ≥ the chunk's batch) before the previous process ended.
    /// Returns the records left to write.
    pub fn resume(&mut self, last_batch: i64) -> Result<u64> {
        if !self.path.exists() {
            return Ok(0);
        }
        self.open(false)?;
        self.settle(last_batch)?;
        Ok(self.rows)
    }

    /// Deletes the chunk in flight if PostgreSQL's `last_batch` shows it committed.
    pub fn settle(&mut self, last_batch: i64) -> Result<()> {
        let Some(db) = self.db.as_mut() else {
            return Ok(());
        };
        let get = |k: &str| -> rusqlite::Result<Option<i64>> {
            db.query_row("SELECT value FROM meta WHERE key = ?1", [k], |r| {
                r.get::<_, String>(0)
            })
            .optional()
            .map(|v| v.and_then(|s| s.parse().ok()))
        };
        let mark = get("batch").and_then(|b| Ok((b, get("upto")?)));
        let (Some(batch), Some(upto)) = mark.map_err(|e| self.bad(e))? else {
            return Ok(());
        };
        if last_batch >= batch {
            self.delete_upto(upto)?;
        }
        Ok(())
    }

    /// Keys of alarms raised in the spill and not cleared there (a process that ended
    /// during the outage never cleared them).
    pub fn open_alarm_keys(&mut self) -> Result<Vec<String>> {
        let done = self.done_upto;
        let Some(db) = self.db.as_mut() else {
            return Ok(Vec::new());
        };
        let run = || -> rusqlite::Result<Vec<String>> {
            let mut st = db.prepare(
                "SELECT kind, s1 FROM records WHERE seq > ?1 AND kind IN (4, 5) ORDER BY seq",
            )?;
            let mut open: Vec<String> = Vec::new();
            let rows = st.query_map([done], |r| {
                Ok((r.get::<_, i64>(0)?, r.get::<_, Option<String>>(1)?))
            })?;
            for row in rows {
                let (kind, key) = row?;
                let key = key.unwrap_or_default();
                open.retain(|k| k != &key);
                if kind == 4 {
                    open.push(key);
                }
            }
            Ok(open)
        };
        run().map_err(|e| self.bad(e))
    }

    /// Takes a record; it reaches the file at the next [`Spill::commit`].
    pub fn stage(&mut self, r: Record) {
        self.staged_since.get_or_insert_with(Instant::now);
        self.staged.push(r);
    }

    /// Writes the staged records in one transaction. On failure they are handed back
    /// (the caller decides what is dropped) and the file is left as it was.
    pub fn commit(&mut self) -> std::result::Result<(), (String, Vec<Record>)> {
        if self.staged.is_empty() {
            return Ok(());
        }
        let staged = std::mem::take(&mut self.staged);
        self.staged_since = None;
        let first = self.next_seq;
        match self.insert(first, &staged) {
            Ok(()) => {
                self.next_seq = first + staged.len() as i64;
                self.rows += staged.len() as u64;
                Ok(())
            }
            Err(e) => Err((e.to_string(), staged)),
        }
    }

    /// Puts `records` (older than anything spilled) before the spilled rows; `in_doubt`
    /// is a PostgreSQL batch that may hold the first `records` of them
    /// (`(batch, count)`), recorded so the next start can settle it.
    pub fn prepend(&mut self, records: &[Record], in_doubt: Option<(i64, usize)>) -> Result<()> {
        if records.is_empty() {
            return Ok(());
        }
        self.open(true)?;
        let first = self.done_upto + 1 - records.len() as i64;
        self.insert(first, records)?;
        self.rows += records.len() as u64;
        self.done_upto = first - 1;
        if let Some((batch, n)) = in_doubt {
            self.mark_in_flight(batch, first + n as i64 - 1)?;
        }
        Ok(())
    }

    fn insert(&mut self, first: i64, records: &[Record]) -> Result<()> {
        let db = self.open(true)?;
        let run = |db: &mut Connection| -> rusqlite::Result<()> {
            let tx = db.transaction()?;
            {
                let mut st = tx.prepare_cached(
                    "INSERT INTO records (seq, kind, time_s, i, a, b, c, s1, s2, s3, s4) \
                     VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
                )?;
                for (k, r) in records.iter().enumerate() {
                    let (kind, t, i, a, b, c, s) = encode(r);
                    st.execute(params![
                        first + k as i64,
                        kind,
                        t,
                        i,
                        a,
                        b,
                        c,
                        s[0],
                        s[1],
                        s[2],
                        s[3]
                    ])?;
                }
            }
            tx.commit()
        };
        let r = run(db);
        r.map_err(|e| self.bad(e))
    }

    /// The oldest committed rows, at most `max`: the records and the last `seq`.
    pub fn load(&mut self, max: usize) -> Result<Option<(Vec<Record>, i64)>> {
        let done = self.done_upto;
        let Some(db) = self.db.as_mut() else {
            return Ok(None);
        };
        let run = || -> rusqlite::Result<Vec<Row>> {
            let mut st = db.prepare_cached(
                "SELECT seq, kind, time_s, i, a, b, c, s1, s2, s3, s4 FROM records \
                 WHERE seq > ?1 ORDER BY seq LIMIT ?2",
            )?;
            let rows = st.query_map(params![done, max as i64], |r| {
                Ok((
                    r.get(0)?,
                    r.get(1)?,
                    r.get(2)?,
                    r.get(3)?,
                    r.get(4)?,
                    r.get(5)?,
                    r.get(6)?,
                    r.get(7)?,
                    r.get(8)?,
                    r.get(9)?,
                    r.get(10)?,
                ))
            })?;
            rows.collect()
        };
        let rows = run().map_err(|e| self.bad(e))?;
        let Some(last) = rows.last().map(|r| r.0) else {
            return Ok(None);
        };
        Ok(Some((rows.into_iter().map(decode).collect(), last)))
    }

    /// Records that the chunk ending at `upto` goes to PostgreSQL as batch `batch`.
    pub fn mark_in_flight(&mut self, batch: i64, upto: i64) -> Result<()> {
        let db = self.open(true)?;
        let run = |db: &mut Connection| -> rusqlite::Result<()> {
            let tx = db.transaction()?;
            tx.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES ('batch', ?1), ('upto', ?2)",
                params![batch.to_string(), upto.to_string()],
            )?;
            tx.commit()
        };
        let r = run(db);
        r.map_err(|e| self.bad(e))
    }

    /// Forgets the rows up to `upto` (PostgreSQL committed them). Even if the delete
    /// fails they are never read again by this process; the `meta` mark settles them at
    /// the next start.
    pub fn delete_upto(&mut self, upto: i64) -> Result<()> {
        if upto > self.done_upto {
            let db = self.db.as_mut();
            let n: u64 = match db {
                Some(db) => db
                    .query_row(
                        "SELECT COUNT(*) FROM records WHERE seq > ?1 AND seq <= ?2",
                        params![self.done_upto, upto],
                        |r| r.get::<_, i64>(0),
                    )
                    .map_err(|e| self.bad(e))?
                    .max(0) as u64,
                None => 0,
            };
            self.rows = self.rows.saturating_sub(n);
            self.done_upto = upto;
        }
        let Some(db) = self.db.as_mut() else {
            return Ok(());
        };
        let run = |db: &mut Connection| -> rusqlite::Result<()> {
            let tx = db.transaction()?;
            tx.execute("DELETE FROM records WHERE seq <= ?1", [upto])?;
            tx.execute("DELETE FROM meta WHERE key IN ('batch', 'upto')", [])?;
            tx.commit()
        };
        let r = run(db);
        r.map_err(|e| self.bad(e))
    }
}

/// The latest time of a record in the spill file at `path` (`None` without one), so a
/// restarted service's clock resumes after what is still waiting there.
pub(super) fn max_time_s(path: &Path) -> Result<Option<f64>> {
    if !path.exists() {
        return Ok(None);
    }
    let bad = |e: rusqlite::Error| {
        invalid(
            "storage.spill_path",
            format!("{:?}", path.display().to_string()),
            format!("a readable SQLite spill file ({e})"),
        )
    };
    let db = Connection::open_with_flags(path, OpenFlags::SQLITE_OPEN_READ_WRITE).map_err(bad)?;
    db.execute_batch(SCHEMA).map_err(bad)?;
    db.query_row("SELECT MAX(time_s) FROM records", [], |r| r.get(0))
        .map_err(bad)
}

/// The columns of a record: kind, time, integer, three reals, four texts.
#[allow(clippy::type_complexity)]
fn encode(
    r: &Record,
) -> (
    i64,
    Option<f64>,
    Option<i64>,
    Option<f64>,
    Option<f64>,
    Option<f64>,
    [Option<&str>; 4],
) {
    match r {
        Record::Sample {
            time_s,
            channel,
            raw,
        } => (
            0,
            Some(*time_s),
            Some(i64::from(*channel)),
            Some(*raw),
            None,
            None,
            [None; 4],
        ),
        Record::Average {
            time_s,
            channel,
            value,
        } => (
            1,
            Some(*time_s),
            Some(i64::from(*channel)),
            Some(*value),
            None,
            None,
            [None; 4],
        ),
        Record::Offset {
            time_s,
            axis,
            offset_um,
            target_um,
            law_um,
            status,
        } => (
            2,
            Some(*time_s),
            Some(i64::from(*axis)),
            Some(*offset_um),
            Some(*target_um),
            Some(*law_um),
            [Some(status), None, None, None],
        ),
        Record::Target {
            time_s,
            target,
            value,
        } => (
            3,
            Some(*time_s),
            Some(i64::from(*target)),
            Some(*value),
            None,
            None,
            [None; 4],
        ),
        Record::AlarmRaised {
            time_s,
            key,
            message,
        } => (
            4,
            Some(*time_s),
            None,
            None,
            None,
            None,
            [Some(key), Some(message), None, None],
        ),
        Record::AlarmCleared { time_s, key } => (
            5,
            Some(*time_s),
            None,
            None,
            None,
            None,
            [Some(key), None, None, None],
        ),
        Record::AlarmAcknowledged { id, by } => (
            6,
            None,
            Some(*id),
            None,
            None,
            None,
            [Some(by), None, None, None],
        ),
        Record::Audit {
            token_id,
            role,
            action,
            detail,
        } => (
            7,
            None,
            None,
            None,
            None,
            None,
            [Some(token_id), Some(role), Some(action), Some(detail)],
        ),
        Record::Model {
            source,
            config_toml,
        } => (
            8,
            None,
            None,
            None,
            None,
            None,
            [Some(source), Some(config_toml), None, None],
        ),
        Record::Resume { time_s, state } => (
            9,
            Some(*time_s),
            None,
            None,
            None,
            None,
            [Some(state), None, None, None],
        ),
    }
}

/// A record from its columns. SQLite keeps NaN as NULL: NULL reads back as NaN, which
/// PostgreSQL stores as NULL again, as it would have without the spill.
fn decode(row: Row) -> Record {
    let (_, kind, t, i, a, b, c, s1, s2, s3, s4) = row;
    let t = t.unwrap_or(f64::NAN);
    let i = i.unwrap_or(0);
    let (a, b, c) = (
        a.unwrap_or(f64::NAN),
        b.unwrap_or(f64::NAN),
        c.unwrap_or(f64::NAN),
    );
    let (s1, s2, s3, s4) = (
        s1.unwrap_or_default(),
        s2.unwrap_or_default(),
        s3.unwrap_or_default(),
        s4.unwrap_or_default(),
    );
    let small = |v: i64| u16::try_from(v).unwrap_or(u16::MAX);
    match kind {
        0 => Record::Sample {
            time_s: t,
            channel: small(i),
            raw: a,
        },
        1 => Record::Average {
            time_s: t,
            channel: small(i),
            value: a,
        },
        2 => Record::Offset {
            time_s: t,
            axis: u8::try_from(i).unwrap_or(u8::MAX),
            offset_um: a,
            target_um: b,
            law_um: c,
            status: intern(s1),
        },
        3 => Record::Target {
            time_s: t,
            target: small(i),
            value: a,
        },
        4 => Record::AlarmRaised {
            time_s: t,
            key: s1,
            message: s2,
        },
        5 => Record::AlarmCleared { time_s: t, key: s1 },
        6 => Record::AlarmAcknowledged { id: i, by: s1 },
        7 => Record::Audit {
            token_id: s1,
            role: intern(s2),
            action: intern(s3),
            detail: s4,
        },
        9 => Record::Resume {
            time_s: t,
            state: s1,
        },
        _ => Record::Model {
            source: s1,
            config_toml: s2,
        },
    }
}

/// A `'static` copy of a status, role or action name read back from the file. These come
/// from a small fixed set (axis statuses, token roles, API actions), so each distinct
/// name is leaked once and reused: memory stays bounded by the set.
fn intern(s: String) -> &'static str {
    static SET: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
    let mut set = SET
        .get_or_init(|| Mutex::new(HashSet::new()))
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    if let Some(v) = set.get(s.as_str()) {
        return v;
    }
    let v: &'static str = Box::leak(s.into_boxed_str());
    set.insert(v);
    v
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    fn sample(i: i64) -> Record {
        Record::Sample {
            time_s: i as f64,
            channel: 1,
            raw: i as f64 * 0.5,
        }
    }

    #[test]
    fn records_come_back_in_order_and_a_committed_chunk_is_settled_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.db");
        let mut s = Spill::new(path.clone(), "m1".into());
        for i in 0..10 {
            s.stage(sample(i));
        }
        s.commit().map_err(|(e, _)| e).unwrap();
        // Older records left in memory go first; the first 3 of them were in doubt.
        s.prepend(&[sample(-2), sample(-1)], None).unwrap();
        assert_eq!(s.len(), 12);
        let (chunk, upto) = s.load(5).unwrap().unwrap();
        let times: Vec<f64> = chunk
            .iter()
            .map(|r| match r {
                Record::Sample { time_s, .. } => *time_s,
                _ => f64::NAN,
            })
            .collect();
        assert_eq!(times, [-2.0, -1.0, 0.0, 1.0, 2.0]);
        s.mark_in_flight(7, upto).unwrap();
        drop(s);
        // A new process: PostgreSQL did not commit batch 7 → everything is still there.
        let mut s = Spill::new(path.clone(), "m1".into());
        assert_eq!(s.resume(6).unwrap(), 12);
        drop(s);
        // It did → the 5 rows of the chunk are gone, the rest stays in order.
        let mut s = Spill::new(path.clone(), "m1".into());
        assert_eq!(s.resume(7).unwrap(), 7);
        let (chunk, _) = s.load(100).unwrap().unwrap();
        assert!(matches!(chunk[0], Record::Sample { time_s, .. } if time_s == 3.0));
        assert_eq!(max_time_s(&path).unwrap(), Some(9.0));
        // Another machine's file is refused, naming the key.
        let mut other = Spill::new(path, "m2".into());
        let e = other.resume(0).unwrap_err().to_string();
        assert!(e.contains("storage.spill_path") && e.contains("m1"), "{e}");
    }
}
