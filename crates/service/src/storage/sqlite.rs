//! The record: every raw sample, averaged value, offset written, target and alarm, in an
//! embedded SQLite database (WAL).
//!
//! One writer thread receives [`Record`]s over a bounded channel and commits them in
//! batches: a transaction is committed at the latest `commit_interval_s` after it was
//! opened, so a crash or power cut loses at most that much (≤ 1 s by configuration).
//! `synchronous = FULL` in WAL mode makes a committed transaction durable, and SQLite's WAL
//! recovery guarantees the file opens cleanly after a kill (tested by killing the
//! process mid-write). The count of committed samples is published in [`StoreStats`]: a
//! sample is *acknowledged* once it is counted there.

use super::*;
use rusqlite::{params, Connection, OpenFlags, OptionalExtension};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS channels (idx INTEGER PRIMARY KEY, name TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS axes (idx INTEGER PRIMARY KEY, name TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS targets (idx INTEGER PRIMARY KEY, name TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS samples (id INTEGER PRIMARY KEY, time_s REAL NOT NULL,
    channel INTEGER NOT NULL, raw REAL);
CREATE INDEX IF NOT EXISTS samples_time ON samples(channel, time_s);
CREATE TABLE IF NOT EXISTS averages (id INTEGER PRIMARY KEY, time_s REAL NOT NULL,
    channel INTEGER NOT NULL, value REAL);
CREATE INDEX IF NOT EXISTS averages_time ON averages(time_s);
CREATE TABLE IF NOT EXISTS offsets (id INTEGER PRIMARY KEY, time_s REAL NOT NULL,
    axis INTEGER NOT NULL, offset_um REAL, target_um REAL, law_um REAL, status TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS offsets_time ON offsets(time_s);
CREATE TABLE IF NOT EXISTS target_values (id INTEGER PRIMARY KEY, time_s REAL NOT NULL,
    target INTEGER NOT NULL, value REAL);
CREATE INDEX IF NOT EXISTS target_values_time ON target_values(time_s);
CREATE TABLE IF NOT EXISTS alarms (id INTEGER PRIMARY KEY, time_s REAL NOT NULL,
    key TEXT NOT NULL, message TEXT NOT NULL, cleared_s REAL,
    acknowledged_by TEXT, acknowledged_unix_s REAL);
CREATE TABLE IF NOT EXISTS tokens (id INTEGER PRIMARY KEY, role TEXT NOT NULL,
    sha256 TEXT NOT NULL UNIQUE, created_unix_s REAL NOT NULL);
CREATE TABLE IF NOT EXISTS audit (id INTEGER PRIMARY KEY, unix_s REAL NOT NULL,
    token_id TEXT NOT NULL, role TEXT NOT NULL, action TEXT NOT NULL, detail TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS models (id INTEGER PRIMARY KEY, unix_s REAL NOT NULL,
    source TEXT NOT NULL, config_toml TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS resume_state (id INTEGER PRIMARY KEY CHECK (id = 1),
    time_s REAL NOT NULL, state TEXT NOT NULL);
";

/// Opens (creating if needed) the database, with WAL and the schema.
pub fn open(path: &Path) -> Result<Connection> {
    let conn = Connection::open(path)?;
    conn.busy_timeout(Duration::from_secs(5))?;
    conn.pragma_update(None, "journal_mode", "WAL")?;
    conn.pragma_update(None, "synchronous", "FULL")?;
    conn.execute_batch(SCHEMA)?;
    Ok(conn)
}

/// Opens the database for reading only (API queries, export).
pub fn open_read(path: &Path) -> Result<Connection> {
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )?;
    conn.busy_timeout(Duration::from_secs(5))?;
    Ok(conn)
}

/// Writes the names of channels, axes and targets; an existing database must use the
/// same channel order (the record would be misread otherwise).
pub fn register_names(
    conn: &Connection,
    channels: &[String],
    axes: &[String],
    targets: &[String],
) -> Result<()> {
    for (table, names) in [("channels", channels), ("axes", axes), ("targets", targets)] {
        for (i, n) in names.iter().enumerate() {
            let existing: Option<String> = conn
                .query_row(
                    &format!("SELECT name FROM {table} WHERE idx = ?1"),
                    [i as i64],
                    |r| r.get(0),
                )
                .optional()?;
            match existing {
                Some(e) if &e != n => {
                    return Err(crate::error::invalid(
                        format!("{table}[{i}]"),
                        n,
                        format!(
                            "{e:?} as recorded in this database (use a new database for a new channel layout)"
                        ),
                    ))
                }
                Some(_) => {}
                None => {
                    conn.execute(
                        &format!("INSERT INTO {table} (idx, name) VALUES (?1, ?2)"),
                        params![i as i64, n],
                    )?;
                }
            }
        }
    }
    Ok(())
}

/// The latest time in the record, s (the service clock resumes after it).
pub fn last_time_s(conn: &Connection) -> Result<f64> {
    let mut t = f64::NEG_INFINITY;
    for table in ["samples", "averages", "offsets", "target_values", "alarms"] {
        let v: Option<f64> =
            conn.query_row(&format!("SELECT MAX(time_s) FROM {table}"), [], |r| {
                r.get(0)
            })?;
        if let Some(v) = v {
            t = t.max(v);
        }
    }
    Ok(t)
}

/// The newest resume state kept in the record (see [`Record::Resume`]), if any.
pub fn resume_state(conn: &Connection) -> Result<Option<String>> {
    Ok(conn
        .query_row("SELECT state FROM resume_state WHERE id = 1", [], |r| {
            r.get(0)
        })
        .optional()?)
}

/// Alarms left open by a previous run are closed at `time_s` (their causes are re-raised
/// by the new run if still present).
pub fn close_stale_alarms(conn: &Connection, time_s: f64) -> Result<()> {
    conn.execute(
        "UPDATE alarms SET cleared_s = ?1 WHERE cleared_s IS NULL",
        [time_s],
    )?;
    Ok(())
}

/// Runs the writer loop until every sender is dropped; commits at least every
/// `commit_interval`. This thread is the only writer while the service runs: a second
/// writer would wait on SQLite's lock, which the batching holds almost all the time.
pub fn writer_loop(
    mut conn: Connection,
    rx: Receiver<Record>,
    commit_interval: Duration,
    stats: Arc<StoreStats>,
) -> Result<()> {
    let mut done = false;
    while !done {
        // Block for the first record so an idle service does not spin.
        let first = match rx.recv() {
            Ok(r) => r,
            Err(_) => break,
        };
        let opened = Instant::now();
        let tx = conn.transaction()?;
        let mut samples = 0u64;
        let mut last_id = 0u64;
        {
            let mut ins_sample = tx
                .prepare_cached("INSERT INTO samples (time_s, channel, raw) VALUES (?1, ?2, ?3)")?;
            let mut ins_avg = tx.prepare_cached(
                "INSERT INTO averages (time_s, channel, value) VALUES (?1, ?2, ?3)",
            )?;
            let mut ins_off = tx.prepare_cached(
                "INSERT INTO offsets (time_s, axis, offset_um, target_um, law_um, status) \
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
            )?;
            let mut ins_tgt = tx.prepare_cached(
                "INSERT INTO target_values (time_s, target, value) VALUES (?1, ?2, ?3)",
            )?;
            let mut rec = Some(first);
            loop {
                if let Some(r) = rec.take() {
                    match r {
                        Record::Sample {
                            time_s,
                            channel,
                            raw,
                        } => {
                            ins_sample.execute(params![time_s, channel, finite(raw)])?;
                            samples += 1;
                            last_id = tx.last_insert_rowid() as u64;
                        }
                        Record::Average {
                            time_s,
                            channel,
                            value,
                        } => {
                            ins_avg.execute(params![time_s, channel, finite(value)])?;
                        }
                        Record::Offset {
                            time_s,
                            axis,
                            offset_um,
                            target_um,
                            law_um,
                            status,
                        } => {
                            ins_off.execute(params![
                                time_s,
                                axis,
                                finite(offset_um),
                                finite(target_um),
                                finite(law_um),
                                status
                            ])?;
                        }
                        Record::Target {
                            time_s,
                            target,
                            value,
                        } => {
                            ins_tgt.execute(params![time_s, target, finite(value)])?;
                        }
                        Record::AlarmRaised {
                            time_s,
                            key,
                            message,
                        } => {
                            tx.execute(
                                "INSERT INTO alarms (time_s, key, message) VALUES (?1, ?2, ?3)",
                                params![time_s, key, message],
                            )?;
                        }
                        Record::AlarmCleared { time_s, key } => {
                            tx.execute(
                                "UPDATE alarms SET cleared_s = ?1 WHERE key = ?2 AND cleared_s IS NULL",
                                params![time_s, key],
                            )?;
                        }
                        Record::AlarmAcknowledged { id, by } => {
                            tx.execute(
                                "UPDATE alarms SET acknowledged_by = ?1, acknowledged_unix_s = ?2 WHERE id = ?3",
                                params![by, unix_now_s(), id],
                            )?;
                        }
                        Record::Audit {
                            token_id,
                            role,
                            action,
                            detail,
                        } => audit(&tx, &token_id, role, action, &detail)?,
                        Record::Resume { time_s, state } => {
                            tx.execute(
                                "INSERT INTO resume_state (id, time_s, state) VALUES (1, ?1, ?2) \
                                 ON CONFLICT (id) DO UPDATE SET time_s = excluded.time_s, state = excluded.state",
                                params![time_s, state],
                            )?;
                        }
                        Record::Model {
                            source,
                            config_toml,
                        } => {
                            tx.execute(
                                "INSERT INTO models (unix_s, source, config_toml) VALUES (?1, ?2, ?3)",
                                params![unix_now_s(), source, config_toml],
                            )?;
                        }
                    }
                }
                let left = commit_interval.saturating_sub(opened.elapsed());
                if left.is_zero() {
                    break;
                }
                match rx.recv_timeout(left) {
                    Ok(r) => rec = Some(r),
                    Err(RecvTimeoutError::Timeout) => break,
                    Err(RecvTimeoutError::Disconnected) => {
                        done = true;
                        break;
                    }
                }
            }
        }
        tx.commit()?;
        stats.commits.fetch_add(1, Ordering::Relaxed);
        if samples > 0 {
            stats.last_sample_id.store(last_id, Ordering::Release);
            stats
                .committed_samples
                .fetch_add(samples, Ordering::Release);
        }
    }
    Ok(())
}

/// SQLite stores NaN as NULL; keep that explicit.
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Counts committed rows of a table (for status and tests).
pub fn count(conn: &Connection, table: &str) -> Result<u64> {
    let n: i64 = conn.query_row(&format!("SELECT COUNT(*) FROM {table}"), [], |r| r.get(0))?;
    Ok(n.max(0) as u64)
}

/// Names of a name table (`channels`, `axes`, `targets`) in index order.
pub fn names(conn: &Connection, table: &str) -> Result<Vec<String>> {
    let mut st = conn.prepare(&format!("SELECT name FROM {table} ORDER BY idx"))?;
    let rows = st.query_map([], |r| r.get::<_, String>(0))?;
    Ok(rows.collect::<std::result::Result<_, _>>()?)
}

/// A channel's history in a time range.
pub fn channel_history(
    conn: &Connection,
    channel: u16,
    kind: SeriesKind,
    range: Range,
) -> Result<Vec<Point>> {
    let sql = match kind {
        SeriesKind::Raw => {
            "SELECT time_s, raw FROM samples WHERE channel = ?1 AND time_s BETWEEN ?2 AND ?3 \
             ORDER BY time_s DESC, id DESC LIMIT ?4"
        }
        SeriesKind::Average => {
            "SELECT time_s, value FROM averages WHERE channel = ?1 AND time_s BETWEEN ?2 AND ?3 \
             ORDER BY time_s DESC, id DESC LIMIT ?4"
        }
    };
    let mut st = conn.prepare_cached(sql)?;
    let rows = st.query_map(
        params![channel, range.from_s, range.to_s, range.limit],
        |r| {
            Ok(Point {
                time_s: r.get(0)?,
                value: r.get(1)?,
            })
        },
    )?;
    let mut v: Vec<Point> = rows.collect::<std::result::Result<_, _>>()?;
    v.reverse();
    Ok(v)
}

/// Offsets in a time range (all axes).
pub fn offset_history(conn: &Connection, range: Range) -> Result<Vec<OffsetRow>> {
    let axes = names(conn, "axes")?;
    let mut st = conn.prepare_cached(
        "SELECT time_s, axis, offset_um, target_um, law_um, status FROM offsets \
         WHERE time_s BETWEEN ?1 AND ?2 ORDER BY time_s DESC, id DESC LIMIT ?3",
    )?;
    let rows = st.query_map(params![range.from_s, range.to_s, range.limit], |r| {
        let axis: i64 = r.get(1)?;
        Ok(OffsetRow {
            time_s: r.get(0)?,
            axis: axes
                .get(axis.max(0) as usize)
                .cloned()
                .unwrap_or_else(|| axis.to_string()),
            offset_um: r.get(2)?,
            target_um: r.get(3)?,
            law_um: r.get(4)?,
            status: r.get(5)?,
        })
    })?;
    let mut v: Vec<OffsetRow> = rows.collect::<std::result::Result<_, _>>()?;
    v.reverse();
    Ok(v)
}

/// Alarms, newest first; only active (not cleared) or unacknowledged ones when asked.
pub fn alarms(conn: &Connection, active_only: bool, limit: u32) -> Result<Vec<AlarmRow>> {
    let sql = if active_only {
        "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
         WHERE cleared_s IS NULL OR acknowledged_by IS NULL ORDER BY id DESC LIMIT ?1"
    } else {
        "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
         ORDER BY id DESC LIMIT ?1"
    };
    let mut st = conn.prepare_cached(sql)?;
    let rows = st.query_map([limit], |r| {
        Ok(AlarmRow {
            id: r.get(0)?,
            time_s: r.get(1)?,
            key: r.get(2)?,
            message: r.get(3)?,
            cleared_s: r.get(4)?,
            acknowledged_by: r.get(5)?,
        })
    })?;
    Ok(rows.collect::<std::result::Result<_, _>>()?)
}

/// Writes an audit row (operator actions).
pub fn audit(
    conn: &Connection,
    token_id: &str,
    role: &str,
    action: &str,
    detail: &str,
) -> Result<()> {
    conn.execute(
        "INSERT INTO audit (unix_s, token_id, role, action, detail) VALUES (?1, ?2, ?3, ?4, ?5)",
        params![unix_now_s(), token_id, role, action, detail],
    )?;
    Ok(())
}

/// Exports the SQLite record at `db` as a CSV that `gearcomp fit` reads (see
/// [`write_export`]). Returns the rows written.
pub fn export_csv(db: &Path, out: &Path) -> Result<usize> {
    write_export(&SqliteStore::new(db).export_data()?, out)
}

/// The database path a configuration points at, for messages.
pub fn describe(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

/// The embedded SQLite record: a file, one writer connection in the writer thread and a
/// short-lived read-only connection per query.
#[derive(Debug, Clone)]
pub struct SqliteStore {
    path: PathBuf,
}

impl SqliteStore {
    /// The record in the SQLite file `path` (created by [`open`] or the first write).
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
        }
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Store for SqliteStore {
    fn backend(&self) -> &'static str {
        "sqlite"
    }

    fn describe(&self) -> String {
        describe(&self.path).display().to_string()
    }

    fn register_names(
        &self,
        channels: &[String],
        axes: &[String],
        targets: &[String],
    ) -> Result<()> {
        register_names(&open(&self.path)?, channels, axes, targets)
    }

    fn last_time_s(&self) -> Result<f64> {
        last_time_s(&open_read(&self.path)?)
    }

    fn close_stale_alarms(&self, time_s: f64) -> Result<()> {
        close_stale_alarms(&open(&self.path)?, time_s)
    }

    fn token_hashes(&self) -> Result<Vec<(String, String)>> {
        let conn = open_read(&self.path)?;
        let mut st = conn.prepare("SELECT sha256, role FROM tokens ORDER BY id")?;
        let rows = st.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?;
        Ok(rows.collect::<std::result::Result<_, _>>()?)
    }

    fn add_token(&self, role: &str, sha256: &str) -> Result<()> {
        open(&self.path)?.execute(
            "INSERT INTO tokens (role, sha256, created_unix_s) VALUES (?1, ?2, ?3)",
            params![role, sha256, unix_now_s()],
        )?;
        Ok(())
    }

    fn remove_token(&self, id: &str) -> Result<usize> {
        Ok(open(&self.path)?.execute(
            "DELETE FROM tokens WHERE substr(sha256, 1, length(?1)) = ?1",
            params![id],
        )?)
    }

    fn add_model(&self, source: &str, config_toml: &str) -> Result<()> {
        open(&self.path)?.execute(
            "INSERT INTO models (unix_s, source, config_toml) VALUES (?1, ?2, ?3)",
            params![unix_now_s(), source, config_toml],
        )?;
        Ok(())
    }

    fn resume_state(&self) -> Result<Option<String>> {
        // The writable open creates the table in a record written by an older version.
        resume_state(&open(&self.path)?)
    }

    fn sample_totals(&self) -> Result<(u64, u64)> {
        let conn = open_read(&self.path)?;
        let (n, max): (i64, Option<i64>) =
            conn.query_row("SELECT COUNT(*), MAX(id) FROM samples", [], |r| {
                Ok((r.get(0)?, r.get(1)?))
            })?;
        Ok((n.max(0) as u64, max.unwrap_or(0).max(0) as u64))
    }

    fn channel_history(&self, channel: u16, kind: SeriesKind, range: Range) -> Result<Vec<Point>> {
        channel_history(&open_read(&self.path)?, channel, kind, range)
    }

    fn offset_history(&self, range: Range) -> Result<Vec<OffsetRow>> {
        offset_history(&open_read(&self.path)?, range)
    }

    fn alarms(&self, active_only: bool, limit: u32) -> Result<Vec<AlarmRow>> {
        alarms(&open_read(&self.path)?, active_only, limit)
    }

    fn alarm_exists(&self, id: i64) -> Result<bool> {
        let n: i64 = open_read(&self.path)?.query_row(
            "SELECT COUNT(*) FROM alarms WHERE id = ?1",
            [id],
            |r| r.get(0),
        )?;
        Ok(n > 0)
    }

    fn audit_log(&self, limit: u32) -> Result<Vec<AuditRow>> {
        let conn = open_read(&self.path)?;
        let mut st = conn.prepare(
            "SELECT unix_s, token_id, role, action, detail FROM audit ORDER BY id DESC LIMIT ?1",
        )?;
        let rows = st.query_map([limit], |r| {
            Ok(AuditRow {
                unix_s: r.get(0)?,
                token_id: r.get(1)?,
                role: r.get(2)?,
                action: r.get(3)?,
                detail: r.get(4)?,
            })
        })?;
        Ok(rows.collect::<std::result::Result<_, _>>()?)
    }

    fn export_data(&self) -> Result<ExportData> {
        let conn = open_read(&self.path)?;
        let series = |sql: &str| -> Result<Vec<IndexedRow>> {
            let mut st = conn.prepare(sql)?;
            let rows = st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))?;
            Ok(rows.collect::<std::result::Result<_, _>>()?)
        };
        Ok(ExportData {
            channels: names(&conn, "channels")?,
            targets: names(&conn, "targets")?,
            axes: names(&conn, "axes")?,
            averages: series("SELECT time_s, channel, value FROM averages ORDER BY time_s, id")?,
            target_values: series(
                "SELECT time_s, target, value FROM target_values ORDER BY time_s, id",
            )?,
            offsets: series("SELECT time_s, axis, offset_um FROM offsets ORDER BY time_s, id")?,
        })
    }

    fn spawn_writer(
        &self,
        rx: Receiver<Record>,
        params: WriterParams,
        stats: Arc<StoreStats>,
    ) -> Result<JoinHandle<Result<()>>> {
        let conn = open(&self.path)?;
        std::thread::Builder::new()
            .name("gearcomp-store".into())
            .spawn(move || writer_loop(conn, rx, params.commit_interval, stats))
            .map_err(|source| ServiceError::Io {
                action: "start",
                path: "the store thread".into(),
                source,
            })
    }
}
