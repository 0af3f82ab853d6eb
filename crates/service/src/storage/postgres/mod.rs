//! The record in PostgreSQL: one plant database for many machines, each row keyed by the
//! machine (`machines.id`, from `[machine] name`).
//!
//! * **Schema**: created at first start, versioned in `gearcomp_schema`, migrations run
//!   under a transaction-level advisory lock so machines starting together do not race.
//! * **Batched commits**: the same rule as SQLite: one transaction at the latest every
//!   `storage.commit_interval_s`; a sample is acknowledged once committed. Samples,
//!   averages, offsets and targets go in with binary `COPY`.
//! * **Exactly once**: every transaction also sets `machines.last_batch`; when a commit's
//!   outcome is unknown (the connection broke during `COMMIT`), the writer reads it back
//!   after reconnecting and drops the batch only if it went in. Sample ids are assigned by
//!   the writer (`1, 2, …` per machine), so a gap would be visible.
//! * **Connection loss**: records wait in memory, in arrival order, while the writer
//!   reconnects with the back-off of `storage.reconnect`; the alarm `storage.connection`
//!   is raised at the first failure and cleared when the buffer is written. The buffer is
//!   bounded by `storage.buffer_records`: beyond it records go to the local spill file
//!   (`storage.spill_path`, [`spill`]), and every newer one too until it has drained, so
//!   the order is kept; alarm `storage.spilling` while records are in it. Only if the
//!   spill cannot be written are new *raw samples* dropped (counted, alarm
//!   `storage.buffer_full`, and a `storage.records_dropped` alarm naming how many and
//!   when); averages, offsets, targets and alarms, what the export and the audit need,
//!   are then still kept up to twice the bound. A clean stop with the server still down
//!   puts what is in memory into the spill. The compensation never waits for the database.
//! * **One writer per machine**: the writer holds a session advisory lock on its machine
//!   id, so a second `gearcomp serve` with the same machine name is refused.
//! * **TLS** (`storage.tls`): rustls with the *ring* provider, no system library. Every
//!   connection (the writer and the read pool) uses the same connector: `require`
//!   encrypts without checking the certificate (libpq's `require`), `verify-full` checks
//!   the chain to `storage.ca_file` and the host name.
//!
//! Rooms: [`connect`] (settings, TLS, messages without passwords), [`common`] (the
//! connection target the store and the writer share), [`schema`] (version, migrations),
//! [`writer`] (the writer's state machine), [`hub`] (the shared writer of the process),
//! [`spill`] (the local spill file); this file holds the store: registration and every
//! read. Each room imports what it uses by name, never from this file.

mod spill;

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use postgres::Client;

use crate::config::{Backoff, ServiceConfig};
use crate::error::{invalid, Result};
use crate::storage::{
    unix_now_s, AlarmRow, AuditRow, ExportData, IndexedRow, OffsetRow, Point, Range, Record,
    SeriesKind, Store, StoreStats, WriterParams,
};
use common::Target;
use connect::{connect_error, describe_connection, ConnectWith};
use schema::LOCK_CLASS;
use spill::Spill;
use writer::{lock_machine, Writer};

mod common;
mod connect;
mod hub;
mod schema;
mod writer;

pub use connect::{connection_config, Connection};
pub use hub::{COLLECT_EVERY, INBOX_RECORDS};
pub use schema::{migrate, SCHEMA_VERSION};
pub use writer::SHUTDOWN_RETRY;

/// The PostgreSQL record of one machine.
pub struct PgStore {
    target: Target,
    buffer_records: u64,
    reconnect: Backoff,
    /// The local spill file (`storage.spill_path`).
    spill_path: PathBuf,
    /// Idle read connections, reused by the API's queries.
    pool: Mutex<Vec<Client>>,
}

impl PgStore {
    /// Connects, creates the schema if needed and registers the machine.
    pub fn open(cfg: &ServiceConfig) -> Result<Self> {
        let conn = connection_config(cfg)?;
        let describe = describe_connection(&conn);
        let mut client = conn
            .config
            .connect_with(&conn)
            .map_err(|e| connect_error(&describe, &conn, cfg, &e))?;
        migrate(&mut client)?;
        let name = cfg.machine.name.clone();
        client.execute(
            "INSERT INTO machines (name, created_unix_s) VALUES ($1, $2) \
             ON CONFLICT (name) DO NOTHING",
            &[&name, &unix_now_s()],
        )?;
        let machine_id: i32 = client
            .query_one("SELECT id FROM machines WHERE name = $1", &[&name])?
            .try_get(0)?;
        let hub_key = format!(
            "{:?}\n{:?}\n{}\n{:?}",
            cfg.storage.url,
            cfg.storage.password_env,
            conn.mode.name(),
            cfg.storage.ca_file
        );
        Ok(Self {
            target: Target {
                conn,
                describe: format!("{describe} (machine {name})"),
                machine: name,
                machine_id,
                hub_key,
            },
            buffer_records: cfg.storage.buffer_records,
            reconnect: cfg.storage.reconnect,
            spill_path: cfg.storage.spill_file(&cfg.machine.name),
            pool: Mutex::new(vec![client]),
        })
    }

    /// The machine's key in this database.
    pub fn machine_id(&self) -> i32 {
        self.target.machine_id
    }

    /// Runs `f` on a pooled connection (a new one if none is idle); a pooled connection
    /// that turns out closed (the server restarted) is replaced and `f` run once more.
    fn with<T>(&self, f: impl Fn(&mut Client, i32) -> Result<T>) -> Result<T> {
        let idle = self.pool.lock().unwrap_or_else(|p| p.into_inner()).pop();
        let pooled = idle.is_some();
        let mut c = match idle {
            Some(c) if !c.is_closed() => c,
            _ => self.target.connect()?,
        };
        let mut r = f(&mut c, self.target.machine_id);
        if r.is_err() && pooled && c.is_closed() {
            c = self.target.connect()?;
            r = f(&mut c, self.target.machine_id);
        }
        if !c.is_closed() {
            let mut pool = self.pool.lock().unwrap_or_else(|p| p.into_inner());
            if pool.len() < 4 {
                pool.push(c);
            }
        }
        r
    }

    fn names(c: &mut Client, mid: i32, table: &str) -> Result<Vec<String>> {
        let rows = c.query(
            &format!("SELECT name FROM {table} WHERE machine_id = $1 ORDER BY idx"),
            &[&mid],
        )?;
        rows.iter()
            .map(|r| Ok(r.try_get::<_, String>(0)?))
            .collect()
    }
}

impl Drop for PgStore {
    fn drop(&mut self) {
        // Closing a synchronous client blocks on its own runtime, which tokio forbids on
        // an async worker: the idle connections are closed on a plain thread then.
        let idle = std::mem::take(self.pool.get_mut().unwrap_or_else(|p| p.into_inner()));
        if !idle.is_empty() && tokio::runtime::Handle::try_current().is_ok() {
            let _ = std::thread::Builder::new()
                .name("gearcomp-pg-close".into())
                .spawn(move || drop(idle));
        }
    }
}

fn lim(limit: u32) -> i64 {
    i64::from(limit)
}

impl Store for PgStore {
    fn backend(&self) -> &'static str {
        "postgres"
    }

    fn describe(&self) -> String {
        self.target.describe.clone()
    }

    fn register_names(
        &self,
        channels: &[String],
        axes: &[String],
        targets: &[String],
    ) -> Result<()> {
        self.with(|c, mid| {
            let mut tx = c.transaction()?;
            for (table, names) in [("channels", channels), ("axes", axes), ("targets", targets)] {
                for (i, n) in names.iter().enumerate() {
                    let idx = i as i32;
                    let existing = tx.query_opt(
                        &format!("SELECT name FROM {table} WHERE machine_id = $1 AND idx = $2"),
                        &[&mid, &idx],
                    )?;
                    match existing {
                        Some(row) => {
                            let e: String = row.try_get(0)?;
                            if &e != n {
                                return Err(invalid(
                                    format!("{table}[{i}]"),
                                    n,
                                    format!(
                                        "{e:?} as recorded for machine {} in this database (use a new machine name for a new channel layout)",
                                        self.target.machine
                                    ),
                                ));
                            }
                        }
                        None => {
                            tx.execute(
                                &format!(
                                    "INSERT INTO {table} (machine_id, idx, name) VALUES ($1, $2, $3)"
                                ),
                                &[&mid, &idx, n],
                            )?;
                        }
                    }
                }
            }
            tx.commit()?;
            Ok(())
        })
    }

    fn last_time_s(&self) -> Result<f64> {
        // Records still in the spill file are later than anything in the database.
        let spilled = spill::max_time_s(&self.spill_path)?.unwrap_or(f64::NEG_INFINITY);
        let db = self.with(|c, mid| {
            let mut t = f64::NEG_INFINITY;
            for table in ["samples", "averages", "offsets", "target_values", "alarms"] {
                let row = c.query_one(
                    &format!("SELECT MAX(time_s) FROM {table} WHERE machine_id = $1"),
                    &[&mid],
                )?;
                if let Some(v) = row.try_get::<_, Option<f64>>(0)? {
                    t = t.max(v);
                }
            }
            Ok(t)
        })?;
        Ok(db.max(spilled))
    }

    fn close_stale_alarms(&self, time_s: f64) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "UPDATE alarms SET cleared_s = $1 WHERE machine_id = $2 AND cleared_s IS NULL",
                &[&time_s, &mid],
            )?;
            Ok(())
        })
    }

    fn token_hashes(&self) -> Result<Vec<(String, String)>> {
        self.with(|c, mid| {
            c.query(
                "SELECT sha256, role FROM tokens WHERE machine_id = $1 ORDER BY id",
                &[&mid],
            )?
            .iter()
            .map(|r| Ok((r.try_get(0)?, r.try_get(1)?)))
            .collect()
        })
    }

    fn add_token(&self, role: &str, sha256: &str) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "INSERT INTO tokens (machine_id, role, sha256, created_unix_s) \
                 VALUES ($1, $2, $3, $4)",
                &[&mid, &role, &sha256, &unix_now_s()],
            )?;
            Ok(())
        })
    }

    fn remove_token(&self, id: &str) -> Result<usize> {
        self.with(|c, mid| {
            let n = c.execute(
                "DELETE FROM tokens WHERE machine_id = $1 AND left(sha256, length($2)) = $2",
                &[&mid, &id],
            )?;
            Ok(n as usize)
        })
    }

    fn add_model(&self, source: &str, config_toml: &str) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "INSERT INTO models (machine_id, unix_s, source, config_toml) \
                 VALUES ($1, $2, $3, $4)",
                &[&mid, &unix_now_s(), &source, &config_toml],
            )?;
            Ok(())
        })
    }

    fn resume_state(&self) -> Result<Option<String>> {
        self.with(|c, mid| {
            let row = c.query_opt(
                "SELECT state FROM resume_state WHERE machine_id = $1",
                &[&mid],
            )?;
            Ok(match row {
                Some(r) => Some(r.try_get(0)?),
                None => None,
            })
        })
    }

    fn sample_totals(&self) -> Result<(u64, u64)> {
        self.with(|c, mid| {
            let r = c.query_one(
                "SELECT COUNT(*), COALESCE(MAX(id), 0) FROM samples WHERE machine_id = $1",
                &[&mid],
            )?;
            let (n, max): (i64, i64) = (r.try_get(0)?, r.try_get(1)?);
            Ok((n.max(0) as u64, max.max(0) as u64))
        })
    }

    fn channel_history(&self, channel: u16, kind: SeriesKind, range: Range) -> Result<Vec<Point>> {
        let sql = match kind {
            SeriesKind::Raw => {
                "SELECT time_s, raw FROM samples WHERE machine_id = $1 AND channel = $2 \
                 AND time_s BETWEEN $3 AND $4 ORDER BY time_s DESC, id DESC LIMIT $5"
            }
            SeriesKind::Average => {
                "SELECT time_s, value FROM averages WHERE machine_id = $1 AND channel = $2 \
                 AND time_s BETWEEN $3 AND $4 ORDER BY time_s DESC, id DESC LIMIT $5"
            }
        };
        self.with(|c, mid| {
            let ch = i32::from(channel);
            let rows = c.query(
                sql,
                &[&mid, &ch, &range.from_s, &range.to_s, &lim(range.limit)],
            )?;
            let mut v = rows
                .iter()
                .map(|r| {
                    Ok(Point {
                        time_s: r.try_get(0)?,
                        value: r.try_get(1)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            v.reverse();
            Ok(v)
        })
    }

    fn offset_history(&self, range: Range) -> Result<Vec<OffsetRow>> {
        self.with(|c, mid| {
            let axes = Self::names(c, mid, "axes")?;
            let rows = c.query(
                "SELECT time_s, axis, offset_um, target_um, law_um, status FROM offsets \
                 WHERE machine_id = $1 AND time_s BETWEEN $2 AND $3 \
                 ORDER BY time_s DESC, id DESC LIMIT $4",
                &[&mid, &range.from_s, &range.to_s, &lim(range.limit)],
            )?;
            let mut v = rows
                .iter()
                .map(|r| {
                    let axis: i32 = r.try_get(1)?;
                    Ok(OffsetRow {
                        time_s: r.try_get(0)?,
                        axis: axes
                            .get(axis.max(0) as usize)
                            .cloned()
                            .unwrap_or_else(|| axis.to_string()),
                        offset_um: r.try_get(2)?,
                        target_um: r.try_get(3)?,
                        law_um: r.try_get(4)?,
                        status: r.try_get(5)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            v.reverse();
            Ok(v)
        })
    }

    fn alarms(&self, active_only: bool, limit: u32) -> Result<Vec<AlarmRow>> {
        let sql = if active_only {
            "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
             WHERE machine_id = $1 AND (cleared_s IS NULL OR acknowledged_by IS NULL) \
             ORDER BY id DESC LIMIT $2"
        } else {
            "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
             WHERE machine_id = $1 ORDER BY id DESC LIMIT $2"
        };
        self.with(|c, mid| {
            c.query(sql, &[&mid, &lim(limit)])?
                .iter()
                .map(|r| {
                    Ok(AlarmRow {
                        id: r.try_get(0)?,
                        time_s: r.try_get(1)?,
                        key: r.try_get(2)?,
                        message: r.try_get(3)?,
                        cleared_s: r.try_get(4)?,
                        acknowledged_by: r.try_get(5)?,
                    })
                })
                .collect()
        })
    }

    fn alarm_exists(&self, id: i64) -> Result<bool> {
        self.with(|c, mid| {
            Ok(c.query_opt(
                "SELECT 1 FROM alarms WHERE id = $1 AND machine_id = $2",
                &[&id, &mid],
            )?
            .is_some())
        })
    }

    fn audit_log(&self, limit: u32) -> Result<Vec<AuditRow>> {
        self.with(|c, mid| {
            c.query(
                "SELECT unix_s, token_id, role, action, detail FROM audit \
                 WHERE machine_id = $1 ORDER BY id DESC LIMIT $2",
                &[&mid, &lim(limit)],
            )?
            .iter()
            .map(|r| {
                Ok(AuditRow {
                    unix_s: r.try_get(0)?,
                    token_id: r.try_get(1)?,
                    role: r.try_get(2)?,
                    action: r.try_get(3)?,
                    detail: r.try_get(4)?,
                })
            })
            .collect()
        })
    }

    fn export_data(&self) -> Result<ExportData> {
        self.with(|c, mid| {
            let mut series = |sql: &str| -> Result<Vec<IndexedRow>> {
                c.query(sql, &[&mid])?
                    .iter()
                    .map(|r| {
                        Ok((
                            r.try_get(0)?,
                            i64::from(r.try_get::<_, i32>(1)?),
                            r.try_get(2)?,
                        ))
                    })
                    .collect()
            };
            let averages = series(
                "SELECT time_s, channel, value FROM averages WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            let target_values = series(
                "SELECT time_s, target, value FROM target_values WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            let offsets = series(
                "SELECT time_s, axis, offset_um FROM offsets WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            Ok(ExportData {
                channels: Self::names(c, mid, "channels")?,
                targets: Self::names(c, mid, "targets")?,
                axes: Self::names(c, mid, "axes")?,
                averages,
                target_values,
                offsets,
            })
        })
    }

    fn spawn_writer(
        &self,
        rx: Receiver<Record>,
        params: WriterParams,
        stats: Arc<StoreStats>,
    ) -> Result<JoinHandle<Result<()>>> {
        let (_, last_id) = self.sample_totals()?;
        let mut w = Writer {
            target: self.target.clone(),
            pending: VecDeque::new(),
            next_id: last_id + 1,
            attempted: None,
            last_batch: 0,
            bound: self.buffer_records.max(1) as usize,
            backoff: self.reconnect,
            last_error: String::new(),
            down_alarm: false,
            full_alarm: false,
            dropped: 0,
            dropped_from_s: 0.0,
            spill: Spill::new(self.spill_path.clone(), self.target.machine.clone()),
            spilling: false,
            spill_alarm: false,
            spill_failed: false,
            spill_error: String::new(),
            loaded: None,
            params,
            stats,
        };
        // Take the writer's lock now so a second service for this machine fails at start
        // (waiting a moment for a killed predecessor's session to end).
        let (mut c, last) = lock_machine(&self.target, Duration::from_secs(5))?;
        w.connected(last);
        // A spill left by a process that ended during an outage goes in before anything new.
        let left = w.spill.resume(w.last_batch)?;
        if left > 0 {
            w.spilling = true;
            let now = w.params.clock.now_s();
            // Alarms the earlier process raised in the spill and never cleared.
            for key in w.spill.open_alarm_keys()? {
                w.spill.stage(Record::AlarmCleared { time_s: now, key });
            }
            w.raise_spilling(format!(
                "{left} records left in the spill file {} by an earlier run are written to {} \
                 before new ones",
                w.spill.path().display(),
                w.target.describe
            ));
        }
        w.publish();
        // The lock moves to the process's shared writer, which re-reads `last_batch`.
        c.execute(
            "SELECT pg_advisory_unlock($1, $2)",
            &[&LOCK_CLASS, &self.target.machine_id],
        )?;
        drop(c);
        hub::join(&self.target.hub_key, w, rx)
    }

    fn record_queue(&self) -> usize {
        // The shared writer's collector empties the queue every `COLLECT_EVERY` into an
        // inbox that grows on demand: the queue only bridges that interval.
        RECORD_HANDOFF
    }
}

/// Capacity of a machine's record queue with PostgreSQL: 4 096 records bridge the
/// collector's 2 ms interval up to 2 million records/s.
pub const RECORD_HANDOFF: usize = 1 << 12;

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::connect::{describe_config, redact};
    use postgres::Config;
    use std::str::FromStr;

    #[test]
    fn passwords_never_appear_in_messages() {
        assert_eq!(
            redact("postgresql://gc:s3cret@db:5432/plant"),
            "postgresql://gc:***@db:5432/plant"
        );
        assert_eq!(
            redact("postgresql://gc@db/plant"),
            "postgresql://gc@db/plant"
        );
        assert!(!redact("host=db password=s3cret").contains("s3cret"));
        let c = Config::from_str("postgresql://gc:s3cret@db:6543/plant").unwrap();
        assert_eq!(describe_config(&c), "postgresql://gc@db:6543/plant");
    }
}
