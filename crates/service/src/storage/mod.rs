//! The record, whichever database keeps it: every raw sample, averaged value, offset
//! written, target and alarm. This module holds what is backend-neutral — the records the
//! cycle sends ([`Record`]), the rows the API reads, the [`Store`] trait, the CSV export —
//! and picks the backend ([`open_store`]): [`sqlite`] (an embedded file, the default) or
//! [`postgres`] (one plant database for many machines).
//!
//! One writer thread per record receives [`Record`]s over a bounded channel and commits
//! them in batches; the count of committed samples is published in [`StoreStats`]: a
//! sample is *acknowledged* once it is counted there.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use serde::Serialize;

pub use crate::clock::unix_now_s;
use crate::clock::Clock;
use crate::config::{ServiceConfig, StorageBackend};
use crate::error::{Result, ServiceError};

#[cfg(feature = "postgres")]
pub mod postgres;
pub mod sqlite;

// The SQLite functions keep their paths (`storage::open`, `storage::writer_loop`, …).
pub use sqlite::*;

/// One thing to keep; every variant except the alarms is `Copy` and allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// A raw reading as it arrived.
    Sample {
        /// Acquisition time, s (service clock).
        time_s: f64,
        /// Channel index.
        channel: u16,
        /// Raw value (Ω, °C, µm: the channel's sensor unit).
        raw: f64,
    },
    /// An averaged, time-filtered value formed by the engine.
    Average {
        /// Cycle time, s.
        time_s: f64,
        /// Channel index.
        channel: u16,
        /// Value in °C or µm.
        value: f64,
    },
    /// The offset of one axis after a cycle (logged when averaged or changed).
    Offset {
        /// Cycle time, s.
        time_s: f64,
        /// Axis index.
        axis: u8,
        /// Applied offset (what goes to the CNC), µm.
        offset_um: f64,
        /// Running compensation the offset moves to, µm.
        target_um: f64,
        /// The law's value, µm (NaN before the first evaluation).
        law_um: f64,
        /// Axis status name.
        status: &'static str,
    },
    /// A reference value delivered with the inputs (e.g. a probe's measured drift).
    Target {
        /// Time, s.
        time_s: f64,
        /// Target index (see `targets` table).
        target: u16,
        /// Value, µm.
        value: f64,
    },
    /// An alarm became active.
    AlarmRaised {
        /// Time, s.
        time_s: f64,
        /// Stable key (kind and subject), used to clear it.
        key: String,
        /// Human-readable text naming field, value and range.
        message: String,
    },
    /// An alarm is no longer active.
    AlarmCleared {
        /// Time, s.
        time_s: f64,
        /// Key given when raised.
        key: String,
    },
    /// An operator acknowledged an alarm.
    AlarmAcknowledged {
        /// Alarm row id.
        id: i64,
        /// Token id of the operator.
        by: String,
    },
    /// An operator action for the audit log.
    Audit {
        /// Token id (first 8 hex digits of the token's hash).
        token_id: String,
        /// Role of the token.
        role: &'static str,
        /// What was done.
        action: &'static str,
        /// Details.
        detail: String,
    },
    /// The state a restarted service resumes from (`cycle::ResumeState::encode`); only
    /// the newest is kept.
    Resume {
        /// Cycle time it was taken at, s.
        time_s: f64,
        /// The encoded state.
        state: String,
    },
    /// A model put in use.
    Model {
        /// Where it came from.
        source: String,
        /// The engine configuration, TOML.
        config_toml: String,
    },
}

/// Counters published by the writer thread.
#[derive(Debug, Default)]
pub struct StoreStats {
    /// Samples committed (acknowledged) since the service started, plus those found at start.
    pub committed_samples: AtomicU64,
    /// Highest committed sample row id.
    pub last_sample_id: AtomicU64,
    /// Transactions committed since start.
    pub commits: AtomicU64,
    /// True while the store cannot be written (PostgreSQL unreachable); records wait in
    /// memory meanwhile.
    pub unreachable: AtomicBool,
    /// Records waiting in memory for the store (PostgreSQL backend).
    pub buffered_records: AtomicU64,
    /// Records dropped because the memory buffer was full (raw samples first; alarmed).
    pub dropped_records: AtomicU64,
    /// Records waiting in the local spill file for PostgreSQL (`storage.spill_path`).
    pub spilled_records: AtomicU64,
}

/// One point of a time series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    /// Time, s (service clock).
    pub time_s: f64,
    /// Value (null when not finite).
    pub value: Option<f64>,
}

/// Which series a history query reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesKind {
    /// Raw samples.
    Raw,
    /// Averaged values.
    Average,
}

/// A time range with a row limit; the newest rows are kept when the limit cuts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// From, s (inclusive).
    pub from_s: f64,
    /// To, s (inclusive).
    pub to_s: f64,
    /// Most rows returned.
    pub limit: u32,
}

/// One logged offset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OffsetRow {
    /// Cycle time, s.
    pub time_s: f64,
    /// Axis name.
    pub axis: String,
    /// Applied offset, µm.
    pub offset_um: Option<f64>,
    /// Running compensation, µm.
    pub target_um: Option<f64>,
    /// Law value, µm.
    pub law_um: Option<f64>,
    /// Axis status.
    pub status: String,
}

/// One alarm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AlarmRow {
    /// Row id (used to acknowledge).
    pub id: i64,
    /// Raised at, s.
    pub time_s: f64,
    /// Kind and subject.
    pub key: String,
    /// Text.
    pub message: String,
    /// Cleared at, s (None while active).
    pub cleared_s: Option<f64>,
    /// Who acknowledged it (token id), if anyone.
    pub acknowledged_by: Option<String>,
}

/// Exports whichever record `store` is as a CSV that `gearcomp fit` reads.
pub fn export_csv_from(store: &dyn Store, out: &Path) -> Result<usize> {
    write_export(&store.export_data()?, out)
}

/// One indexed value of a time series: (time s, channel/target/axis index, value).
pub type IndexedRow = (f64, i64, Option<f64>);

/// What the CSV export needs, read from either backend (each series in time order, ties
/// in insertion order).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExportData {
    /// Channel names, index order.
    pub channels: Vec<String>,
    /// Target names, index order.
    pub targets: Vec<String>,
    /// Axis names, index order.
    pub axes: Vec<String>,
    /// Averaged values.
    pub averages: Vec<IndexedRow>,
    /// Target values.
    pub target_values: Vec<IndexedRow>,
    /// Applied offsets, µm.
    pub offsets: Vec<IndexedRow>,
}

/// Writes the CSV that `gearcomp fit` reads: `time_s`, one column per channel (averaged
/// value, °C or µm), one per target (e.g. `measured_drift_um`), one per axis
/// (`<axis>_offset_um`). One row per time at which the engine formed averages; targets
/// and offsets take their latest value at or before that time; rows with an empty column
/// are left out. Returns the rows written.
pub fn write_export(d: &ExportData, out: &Path) -> Result<usize> {
    let (channels, targets, axes) = (&d.channels, &d.targets, &d.axes);
    let file = std::fs::File::create(out).map_err(|source| ServiceError::Io {
        action: "create",
        path: out.display().to_string(),
        source,
    })?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
    let mut header = vec!["time_s".to_string()];
    header.extend(channels.iter().cloned());
    header.extend(targets.iter().cloned());
    header.extend(axes.iter().map(|a| format!("{a}_offset_um")));
    w.write_record(&header)?;

    // Merge the three time-ordered streams in one pass.
    let (avg, tgt, off) = (&d.averages, &d.target_values, &d.offsets);
    let nc = channels.len();
    let mut row_vals = vec![f64::NAN; nc + targets.len() + axes.len()];
    let (mut it, mut io) = (0usize, 0usize);
    let mut rows = 0usize;
    let mut i = 0usize;
    while i < avg.len() {
        let t = avg[i].0;
        while it < tgt.len() && tgt[it].0 <= t {
            let (_, k, v) = tgt[it];
            if let Some(slot) = row_vals.get_mut(nc + k.max(0) as usize) {
                *slot = v.unwrap_or(f64::NAN);
            }
            it += 1;
        }
        while io < off.len() && off[io].0 <= t {
            let (_, k, v) = off[io];
            if let Some(slot) = row_vals.get_mut(nc + targets.len() + k.max(0) as usize) {
                *slot = v.unwrap_or(f64::NAN);
            }
            io += 1;
        }
        while i < avg.len() && avg[i].0 == t {
            let (_, k, v) = avg[i];
            if let Some(slot) = row_vals
                .get_mut(k.max(0) as usize)
                .filter(|_| (k as usize) < nc)
            {
                *slot = v.unwrap_or(f64::NAN);
            }
            i += 1;
        }
        // A row is only useful to the fit when every column has a value.
        if row_vals.iter().all(|v| v.is_finite()) {
            let mut rec = Vec::with_capacity(row_vals.len() + 1);
            rec.push(format!("{t}"));
            rec.extend(row_vals.iter().map(|v| format!("{v}")));
            w.write_record(&rec)?;
            rows += 1;
        }
    }
    w.flush().map_err(|source| ServiceError::Io {
        action: "write",
        path: out.display().to_string(),
        source,
    })?;
    Ok(rows)
}

/// One operator action of the audit log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AuditRow {
    /// When, s since the Unix epoch.
    pub unix_s: f64,
    /// Token id (first 8 hex digits of its hash).
    pub token_id: String,
    /// Role of the token.
    pub role: String,
    /// What was done.
    pub action: String,
    /// Details.
    pub detail: String,
}

/// What the writer thread needs besides the records.
#[derive(Debug, Clone, Copy)]
pub struct WriterParams {
    /// Longest time between two commits (what a crash can lose).
    pub commit_interval: Duration,
    /// The service clock, to stamp the store's own alarms.
    pub clock: Clock,
}

/// The record, whichever database keeps it: the service, the HTTP API and the CSV export
/// go through this and do not know the backend. Reads are safe from any thread; writes of
/// the live record go through the one writer thread that [`Store::spawn_writer`] starts,
/// which commits in batches at the latest every `commit_interval`.
pub trait Store: Send + Sync {
    /// `sqlite` or `postgres`.
    fn backend(&self) -> &'static str;
    /// Where the record is, for messages (never a password).
    fn describe(&self) -> String;
    /// Writes the names of channels, axes and targets; an existing record must use the
    /// same order (it would be misread otherwise).
    fn register_names(
        &self,
        channels: &[String],
        axes: &[String],
        targets: &[String],
    ) -> Result<()>;
    /// The latest time in the record, s (−∞ when empty); the service clock resumes after it.
    fn last_time_s(&self) -> Result<f64>;
    /// Closes the alarms a previous run left open, at `time_s`.
    fn close_stale_alarms(&self, time_s: f64) -> Result<()>;
    /// Stored token hashes with their role names.
    fn token_hashes(&self) -> Result<Vec<(String, String)>>;
    /// Stores a token hash.
    fn add_token(&self, role: &str, sha256: &str) -> Result<()>;
    /// Deletes the tokens whose hash starts with `id` (the 8 hex digits the audit log
    /// shows); returns how many.
    fn remove_token(&self, id: &str) -> Result<usize>;
    /// Records a model put in use.
    fn add_model(&self, source: &str, config_toml: &str) -> Result<()>;
    /// The newest resume state kept by a previous run (`Record::Resume`), if any.
    fn resume_state(&self) -> Result<Option<String>>;
    /// Committed samples: (count, highest sample id).
    fn sample_totals(&self) -> Result<(u64, u64)>;
    /// A channel's history in a time range (newest `limit` rows, returned oldest first).
    fn channel_history(&self, channel: u16, kind: SeriesKind, range: Range) -> Result<Vec<Point>>;
    /// Offsets of all axes in a time range (newest `limit` rows, oldest first).
    fn offset_history(&self, range: Range) -> Result<Vec<OffsetRow>>;
    /// Alarms, newest first; only active or unacknowledged ones when asked.
    fn alarms(&self, active_only: bool, limit: u32) -> Result<Vec<AlarmRow>>;
    /// Whether an alarm with this id exists (in this machine's record).
    fn alarm_exists(&self, id: i64) -> Result<bool>;
    /// Operator actions, newest first.
    fn audit_log(&self, limit: u32) -> Result<Vec<AuditRow>>;
    /// Everything the CSV export needs.
    fn export_data(&self) -> Result<ExportData>;
    /// Starts the one writer thread: it commits what arrives on `rx` in batches until
    /// every sender is dropped, and publishes what is committed in `stats`.
    fn spawn_writer(
        &self,
        rx: Receiver<Record>,
        params: WriterParams,
        stats: Arc<StoreStats>,
    ) -> Result<JoinHandle<Result<()>>>;
    /// Capacity of the bounded record queue that feeds [`Store::spawn_writer`] (a full
    /// queue holds the cycle back rather than dropping a record); it is allocated up
    /// front, so it is sized to what the backend's writer needs.
    fn record_queue(&self) -> usize {
        RECORD_QUEUE
    }
}

/// Capacity of the record queue of a writer that drains it itself (SQLite): the records
/// of one commit interval at the highest rate the service is tested at.
pub const RECORD_QUEUE: usize = 1 << 16;

/// Opens the store a configuration names (creating the schema if needed).
pub fn open_store(cfg: &ServiceConfig) -> Result<Arc<dyn Store>> {
    match cfg.storage.backend {
        StorageBackend::Sqlite => {
            // Creates the file and schema now so read connections find them. A folder, a
            // missing folder or a file that is no SQLite database is refused naming the key.
            open(&cfg.storage.path).map_err(|e| {
                crate::error::invalid(
                    "storage.path",
                    cfg.storage.path.display(),
                    format!("an SQLite record file this service can create or open ({e})"),
                )
            })?;
            Ok(Arc::new(SqliteStore::new(&cfg.storage.path)))
        }
        #[cfg(feature = "postgres")]
        StorageBackend::Postgres => Ok(Arc::new(postgres::PgStore::open(cfg)?)),
        #[cfg(not(feature = "postgres"))]
        StorageBackend::Postgres => Err(crate::error::invalid(
            "storage.backend",
            "\"postgres\"",
            "\"sqlite\" (this build has no `postgres` feature)",
        )),
    }
}
