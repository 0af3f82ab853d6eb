//! The record writer of one machine: its buffer, batch numbers (exactly once across
//! unknown commit outcomes), alarms, the bounded buffer and the spill file (see the module
//! doc of `storage::postgres`). The connection, the commits (binary `COPY`) and the
//! reconnection with back-off belong to the process's shared writer ([`super::hub`]), which
//! drives one `Writer` per machine.

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use postgres::binary_copy::BinaryCopyInWriter;
use postgres::types::{ToSql, Type};
use postgres::Client;

use super::common::Target;
use super::schema::LOCK_CLASS;
use super::spill::Spill;
use crate::config::Backoff;
use crate::error::{invalid, Result, ServiceError};
use crate::storage::{unix_now_s, Record, StoreStats, WriterParams};

/// Most records written in one transaction when catching up after an outage.
pub(super) const CHUNK_RECORDS: usize = 100_000;

/// How long a stopping service keeps trying to write what is left in memory.
pub const SHUTDOWN_RETRY: Duration = Duration::from_secs(10);

/// A chunk whose `COMMIT` was sent but whose outcome is not known yet.
#[derive(Debug, Clone, Copy)]
pub(super) struct Attempt {
    pub(super) batch: i64,
    pub(super) records: usize,
    samples: u64,
    /// The chunk is spilled rows up to this `seq` (deleted from the file once committed).
    spill_upto: Option<i64>,
}

/// One machine's writer state: the records waiting, the batch numbers, the counters.
pub(super) struct Writer {
    pub(super) target: Target,
    pub(super) pending: VecDeque<Record>,
    /// Id of the next sample (ids are 1, 2, … per machine).
    pub(super) next_id: u64,
    pub(super) attempted: Option<Attempt>,
    /// The last batch number known committed (`machines.last_batch`).
    pub(super) last_batch: i64,
    pub(super) bound: usize,
    pub(super) backoff: Backoff,
    pub(super) last_error: String,
    pub(super) down_alarm: bool,
    pub(super) full_alarm: bool,
    pub(super) dropped: u64,
    pub(super) dropped_from_s: f64,
    /// The local file taking records beyond the bound.
    pub(super) spill: Spill,
    /// True from the first spilled record until the spill is written: every newer record
    /// goes to the spill too, so the arrival order is kept.
    pub(super) spilling: bool,
    pub(super) spill_alarm: bool,
    /// The spill could not be written: records beyond the bound are dropped as without
    /// a spill until it has drained.
    pub(super) spill_failed: bool,
    pub(super) spill_error: String,
    /// `pending` holds spilled rows up to this `seq`, loaded to be written.
    pub(super) loaded: Option<i64>,
    pub(super) params: WriterParams,
    pub(super) stats: Arc<StoreStats>,
}

/// Connects and takes `target`'s writer lock (a session advisory lock on the machine id),
/// retrying for up to `patience` (a killed predecessor's session may take a moment to
/// end); returns the session holding it and the machine's `last_batch`.
pub(super) fn lock_machine(target: &Target, patience: Duration) -> Result<(Client, i64)> {
    let t0 = Instant::now();
    loop {
        let mut c = target.connect()?;
        let got: bool = c
            .query_one(
                "SELECT pg_try_advisory_lock($1, $2)",
                &[&LOCK_CLASS, &target.machine_id],
            )?
            .try_get(0)?;
        if got {
            let last: i64 = c
                .query_one(
                    "SELECT last_batch FROM machines WHERE id = $1",
                    &[&target.machine_id],
                )?
                .try_get(0)?;
            return Ok((c, last));
        }
        if t0.elapsed() >= patience {
            return Err(busy(target));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The refusal of a second writer for a machine that has one running.
pub(super) fn busy(target: &Target) -> ServiceError {
    invalid(
        "machine.name",
        &target.machine,
        format!(
            "a machine no other running gearcomp serve writes to {}",
            target.describe
        ),
    )
}

impl Writer {
    /// Takes the database's `last_batch` after (re)connecting: settles a chunk in doubt.
    pub(super) fn connected(&mut self, last_batch: i64) {
        self.settle(last_batch);
        self.last_batch = last_batch;
    }

    /// Resolves a chunk in doubt: the database's `last_batch` tells whether it went in.
    fn settle(&mut self, last_batch: i64) {
        if let Some(a) = self.attempted.take() {
            if last_batch >= a.batch {
                self.committed(a);
            }
        }
    }

    fn committed(&mut self, a: Attempt) {
        self.pending.drain(..a.records.min(self.pending.len()));
        if let Some(upto) = a.spill_upto {
            self.loaded = None;
            // Only now that PostgreSQL has them; a failed delete is settled at next start.
            if let Err(e) = self.spill.delete_upto(upto) {
                eprintln!("gearcomp serve: {e}");
            }
        }
        self.next_id += a.samples;
        self.stats.commits.fetch_add(1, Ordering::Relaxed);
        if a.samples > 0 {
            self.stats
                .last_sample_id
                .store(self.next_id - 1, Ordering::Release);
            self.stats
                .committed_samples
                .fetch_add(a.samples, Ordering::Release);
        }
        self.publish();
    }

    pub(super) fn publish(&self) {
        // A chunk loaded from the spill is counted there, not twice.
        let memory = if self.loaded.is_some() {
            0
        } else {
            self.pending.len()
        };
        self.stats
            .buffered_records
            .store(memory as u64, Ordering::Release);
        self.stats
            .spilled_records
            .store(self.spill.len(), Ordering::Release);
    }

    /// Takes one record: into the memory buffer, beyond its bound into the spill file
    /// (and every later one too while anything is spilled), or, if the spill cannot be
    /// written, drops it (counted, alarmed).
    fn push(&mut self, r: Record) {
        if self.spilling && !self.spill_failed {
            self.spill.stage(r);
            return;
        }
        let cap = if matches!(r, Record::Sample { .. }) {
            self.bound
        } else {
            self.bound.saturating_mul(2)
        };
        if self.spilling {
            // The spill failed while older records wait in it: a sample kept in memory
            // would get an id before them, so samples are dropped; the rest (ordered by
            // time in every query) is kept.
            if !matches!(r, Record::Sample { .. }) && self.pending.len() < cap {
                self.pending.push_back(r);
            } else {
                self.drop_record();
            }
            return;
        }
        if self.pending.len() < cap {
            self.pending.push_back(r);
            return;
        }
        if !self.spill_failed {
            self.spilling = true;
            self.spill.stage(r);
            return;
        }
        self.drop_record();
    }

    /// Counts one dropped record and raises `storage.buffer_full` at the first.
    fn drop_record(&mut self) {
        let now = self.params.clock.now_s();
        if self.dropped == 0 {
            self.dropped_from_s = now;
        }
        self.dropped += 1;
        self.stats.dropped_records.fetch_add(1, Ordering::Release);
        if !self.full_alarm {
            self.full_alarm = true;
            let message = format!(
                "storage.buffer_records = {} reached while {} is unreachable and the spill \
                 file {} cannot be written ({}): new raw samples are dropped (counted in \
                 /api/status dropped_records); averages, offsets and alarms are kept up to {} \
                 records",
                self.bound,
                self.target.describe,
                self.spill.path().display(),
                self.spill_error,
                self.bound.saturating_mul(2)
            );
            eprintln!("gearcomp serve: {message}");
            self.pending.push_back(Record::AlarmRaised {
                time_s: now,
                key: "storage.buffer_full".into(),
                message,
            });
        }
    }

    /// Raises `storage.spilling` (in memory, ahead of the spill: alarms are few).
    pub(super) fn raise_spilling(&mut self, message: String) {
        self.spill_alarm = true;
        eprintln!("gearcomp serve: {message}");
        self.pending.push_back(Record::AlarmRaised {
            time_s: self.params.clock.now_s(),
            key: "storage.spilling".into(),
            message,
        });
    }

    /// Commits the staged spill records to the file; if that fails they are handled as
    /// without a spill (samples dropped and counted, the rest kept in memory).
    fn commit_spill(&mut self) {
        if self.spill.staged() == 0 {
            return;
        }
        match self.spill.commit() {
            Ok(()) => {
                if !self.spill_alarm {
                    let message = format!(
                        "storage.buffer_records = {} reached while {} is unreachable: newer \
                         records go to the spill file {} ({} so far; /api/status \
                         storage.spilled_records counts them) and are written in order when \
                         the server is back",
                        self.bound,
                        self.target.describe,
                        self.spill.path().display(),
                        self.spill.len()
                    );
                    self.raise_spilling(message);
                }
            }
            Err((e, records)) => {
                self.spill_failed = true;
                eprintln!("gearcomp serve: spill failed: {e}");
                self.spill_error = e;
                for r in records {
                    if !matches!(r, Record::Sample { .. })
                        && self.pending.len() < self.bound.saturating_mul(2)
                    {
                        self.pending.push_back(r);
                    } else {
                        self.drop_record();
                    }
                }
                if self.spill.is_empty() {
                    self.spilling = false;
                }
            }
        }
        self.publish();
    }

    /// When memory is written and records wait in the spill: loads the next chunk of
    /// them into `pending`, or, once the spill is empty, ends spilling.
    fn next_from_spill(&mut self) {
        self.commit_spill();
        if !self.spilling {
            return;
        }
        match self.spill.load(CHUNK_RECORDS) {
            Ok(Some((records, upto))) => {
                self.pending.extend(records);
                self.loaded = Some(upto);
            }
            Ok(None) if self.spill_failed => {
                // Nothing readable left: back to memory (records staged meanwhile were
                // handled by `commit_spill`).
                self.spilling = false;
            }
            Ok(None) => {
                self.spilling = false;
                self.spill_failed = false;
                if self.spill_alarm {
                    self.spill_alarm = false;
                    eprintln!(
                        "gearcomp serve: spill file {} written to {}",
                        self.spill.path().display(),
                        self.target.describe
                    );
                    self.pending.push_back(Record::AlarmCleared {
                        time_s: self.params.clock.now_s(),
                        key: "storage.spilling".into(),
                    });
                }
            }
            Err(e) => {
                // Rows that cannot be read stay in the file for the next start.
                eprintln!("gearcomp serve: {e}");
                self.spill_failed = true;
                self.spill_error = e.to_string();
                self.spilling = false;
            }
        }
        self.publish();
    }

    /// Clears the buffer-full alarm once the buffer has drained, leaving a record of what
    /// was lost.
    fn after_drain(&mut self) {
        if self.full_alarm && self.pending.len() < self.bound / 2 {
            self.full_alarm = false;
            let now = self.params.clock.now_s();
            let message = format!(
                "{} records (raw samples first) were dropped between {:.3} s and {:.3} s \
                 because {} was unreachable and storage.buffer_records = {} was reached",
                self.dropped, self.dropped_from_s, now, self.target.describe, self.bound
            );
            eprintln!("gearcomp serve: {message}");
            self.dropped = 0;
            for r in [
                Record::AlarmCleared {
                    time_s: now,
                    key: "storage.buffer_full".into(),
                },
                Record::AlarmRaised {
                    time_s: now,
                    key: "storage.records_dropped".into(),
                    message,
                },
                Record::AlarmCleared {
                    time_s: now,
                    key: "storage.records_dropped".into(),
                },
            ] {
                self.pending.push_back(r);
            }
        }
    }

    /// The store became unreachable (the shared writer's connection failed): alarm once.
    pub(super) fn fail(&mut self, e: &ServiceError) {
        self.last_error = e.to_string();
        self.stats.unreachable.store(true, Ordering::Release);
        if !self.down_alarm {
            self.down_alarm = true;
            let message = format!(
                "{} unreachable ({e}); retrying with back-off {}…{} s, records kept in memory \
                 (storage.buffer_records = {})",
                self.target.describe, self.backoff.min_s, self.backoff.max_s, self.bound
            );
            eprintln!("gearcomp serve: {message}");
            let time_s = self.params.clock.now_s();
            self.push(Record::AlarmRaised {
                time_s,
                key: "storage.connection".into(),
                message,
            });
        }
        self.publish();
    }

    /// True when nothing waits for the database (memory and spill written).
    pub(super) fn drained(&self) -> bool {
        self.pending.is_empty() && !self.spilling
    }

    /// The next chunk to write (loading spilled records first when memory is written), as
    /// batch `last_batch + 1`; `None` when nothing waits. The chunk is `pending[..records]`.
    pub(super) fn prepare(&mut self) -> Option<Attempt> {
        if self.pending.is_empty() && self.spilling {
            self.next_from_spill();
        }
        if self.pending.is_empty() {
            return None;
        }
        let n = self.pending.len().min(CHUNK_RECORDS);
        let samples = self
            .pending
            .range(..n)
            .filter(|r| matches!(r, Record::Sample { .. }))
            .count() as u64;
        // The writer lock makes this machine's member of the shared writer the only one
        // advancing its `last_batch`.
        let batch = self.last_batch + 1;
        let a = Attempt {
            batch,
            records: n,
            samples,
            spill_upto: self.loaded,
        };
        if let Some(upto) = self.loaded {
            // Recorded before sending, so a crash in between is settled at next start.
            if let Err(e) = self.spill.mark_in_flight(batch, upto) {
                eprintln!("gearcomp serve: {e}");
            }
        }
        self.attempted = Some(a);
        Some(a)
    }

    /// The chunk of `a` is committed.
    pub(super) fn done(&mut self, a: Attempt) {
        self.attempted = None;
        self.last_batch = a.batch;
        self.committed(a);
    }

    /// After everything waiting was written: clears the outage alarms (the records they
    /// add are written by the next round). Returns true when it added records.
    pub(super) fn after_write(&mut self) -> bool {
        let before = self.pending.len();
        self.after_drain();
        if self.down_alarm {
            self.down_alarm = false;
            self.stats.unreachable.store(false, Ordering::Release);
            eprintln!(
                "gearcomp serve: {} reachable again; buffered records written",
                self.target.describe
            );
            self.pending.push_back(Record::AlarmCleared {
                time_s: self.params.clock.now_s(),
                key: "storage.connection".into(),
            });
        }
        self.publish();
        self.pending.len() > before
    }

    /// Takes the records the machine sent since the last call, in order.
    pub(super) fn take(&mut self, records: VecDeque<Record>) {
        for r in records {
            self.push(r);
        }
    }

    /// Commits the staged spill records when their commit interval is up.
    pub(super) fn spill_due(&mut self, now: Instant) {
        if self
            .spill
            .staged_since
            .is_some_and(|t| now >= t + self.params.commit_interval)
        {
            self.commit_spill();
            self.publish();
        }
    }

    /// Every sender is gone and the shared writer gave up writing what is left (or it
    /// was all written): keeps the rest in the spill file for the next start.
    pub(super) fn finish(mut self) -> Result<()> {
        if self.drained() {
            return Ok(());
        }
        self.commit_spill();
        if self.loaded.is_some() {
            // A chunk read from the spill: it is still in the file.
            self.pending.clear();
        }
        let memory: Vec<Record> = self.pending.drain(..).collect();
        let in_doubt = self
            .attempted
            .filter(|a| a.spill_upto.is_none())
            .map(|a| (a.batch, a.records));
        let kept = if self.spill_failed && !memory.is_empty() {
            Err(invalid(
                "storage.spill_path",
                self.spill.path().display(),
                "writable",
            ))
        } else {
            self.spill.prepend(&memory, in_doubt)
        };
        match kept {
            Ok(()) if self.spill.staged() == 0 => {
                eprintln!(
                    "gearcomp serve: {} unreachable at stop; {} records kept in the spill file \
                     {}, written at the next start",
                    self.target.describe,
                    self.spill.len(),
                    self.spill.path().display()
                );
                Ok(())
            }
            Ok(()) => Err(ServiceError::Unflushed {
                records: self.spill.staged() as u64,
                store: self.target.describe.clone(),
                cause: format!("{}; {}", self.last_error, self.spill_error),
            }),
            Err(e) => Err(ServiceError::Unflushed {
                records: (memory.len() + self.spill.staged()) as u64,
                store: self.target.describe.clone(),
                cause: format!("{}; the spill file too: {e}", self.last_error),
            }),
        }
    }
}

/// One machine's chunk of a shared transaction.
#[derive(Clone)]
pub(super) struct Part<'a> {
    /// The machine's key.
    pub mid: i32,
    /// Its records, in arrival order.
    pub chunk: std::collections::vec_deque::Iter<'a, Record>,
    /// Id of its first sample.
    pub first_id: u64,
    /// Its batch number (`machines.last_batch` after the commit).
    pub batch: i64,
}

/// Writes the chunks of several machines in one transaction: each machine's events
/// (alarms, audit, models) in order, the newest resume state of each, the series of all
/// with one binary COPY per table, then every machine's `last_batch`.
pub(super) fn write_chunks(client: &mut Client, parts: &[Part<'_>]) -> Result<()> {
    let mut tx = client.transaction()?;
    let (mut n_s, mut n_a, mut n_o, mut n_t) = (0usize, 0usize, 0usize, 0usize);
    // Only the newest resume state of a machine is kept: one upsert per machine.
    let (mut r_mid, mut r_time, mut r_state) = (Vec::new(), Vec::new(), Vec::new());
    for p in parts {
        let mid = p.mid;
        let mut resume: Option<(f64, &str)> = None;
        for r in p.chunk.clone() {
            match r {
                Record::Sample { .. } => n_s += 1,
                Record::Average { .. } => n_a += 1,
                Record::Offset { .. } => n_o += 1,
                Record::Target { .. } => n_t += 1,
                Record::AlarmRaised {
                    time_s,
                    key,
                    message,
                } => {
                    tx.execute(
                        "INSERT INTO alarms (machine_id, time_s, key, message) \
                         VALUES ($1, $2, $3, $4)",
                        &[&mid, time_s, &pg_text(key), &pg_text(message)],
                    )?;
                }
                Record::AlarmCleared { time_s, key } => {
                    tx.execute(
                        "UPDATE alarms SET cleared_s = $1 \
                         WHERE machine_id = $2 AND key = $3 AND cleared_s IS NULL",
                        &[time_s, &mid, &pg_text(key)],
                    )?;
                }
                Record::AlarmAcknowledged { id, by } => {
                    tx.execute(
                        "UPDATE alarms SET acknowledged_by = $1, acknowledged_unix_s = $2 \
                         WHERE id = $3 AND machine_id = $4",
                        &[&pg_text(by), &unix_now_s(), id, &mid],
                    )?;
                }
                Record::Audit {
                    token_id,
                    role,
                    action,
                    detail,
                } => {
                    tx.execute(
                        "INSERT INTO audit (machine_id, unix_s, token_id, role, action, detail) \
                         VALUES ($1, $2, $3, $4, $5, $6)",
                        &[
                            &mid,
                            &unix_now_s(),
                            &pg_text(token_id),
                            &pg_text(role),
                            &pg_text(action),
                            &pg_text(detail),
                        ],
                    )?;
                }
                Record::Model {
                    source,
                    config_toml,
                } => {
                    tx.execute(
                        "INSERT INTO models (machine_id, unix_s, source, config_toml) \
                         VALUES ($1, $2, $3, $4)",
                        &[&mid, &unix_now_s(), &pg_text(source), &pg_text(config_toml)],
                    )?;
                }
                Record::Resume { time_s, state } => resume = Some((*time_s, state)),
            }
        }
        if let Some((t, state)) = resume {
            r_mid.push(mid);
            r_time.push(t);
            r_state.push(state);
        }
    }
    if !r_mid.is_empty() {
        tx.execute(
            "INSERT INTO resume_state (machine_id, time_s, state) \
             SELECT * FROM unnest($1::int4[], $2::float8[], $3::text[]) \
             ON CONFLICT (machine_id) DO UPDATE SET time_s = EXCLUDED.time_s, \
             state = EXCLUDED.state",
            &[&r_mid, &r_time, &r_state],
        )?;
    }
    const F8: Type = Type::FLOAT8;
    const I4: Type = Type::INT4;
    if n_s > 0 {
        let sink = tx.copy_in(
            "COPY samples (machine_id, id, time_s, channel, raw) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, Type::INT8, F8, I4, F8]);
        for p in parts {
            let mut id = p.first_id as i64;
            for r in p.chunk.clone() {
                if let Record::Sample {
                    time_s,
                    channel,
                    raw,
                } = r
                {
                    let ch = i32::from(*channel);
                    let raw = finite(*raw);
                    w.write(&[&p.mid, &id, time_s, &ch, &raw])?;
                    id += 1;
                }
            }
        }
        w.finish()?;
    }
    if n_a > 0 {
        let sink = tx.copy_in(
            "COPY averages (machine_id, time_s, channel, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for p in parts {
            for r in p.chunk.clone() {
                if let Record::Average {
                    time_s,
                    channel,
                    value,
                } = r
                {
                    let ch = i32::from(*channel);
                    w.write(&[&p.mid, time_s, &ch, &finite(*value)])?;
                }
            }
        }
        w.finish()?;
    }
    if n_o > 0 {
        let sink = tx.copy_in(
            "COPY offsets (machine_id, time_s, axis, offset_um, target_um, law_um, status) \
             FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8, F8, F8, Type::TEXT]);
        for p in parts {
            for r in p.chunk.clone() {
                if let Record::Offset {
                    time_s,
                    axis,
                    offset_um,
                    target_um,
                    law_um,
                    status,
                } = r
                {
                    let ax = i32::from(*axis);
                    let vals: [&(dyn ToSql + Sync); 7] = [
                        &p.mid,
                        time_s,
                        &ax,
                        &finite(*offset_um),
                        &finite(*target_um),
                        &finite(*law_um),
                        status,
                    ];
                    w.write(&vals)?;
                }
            }
        }
        w.finish()?;
    }
    if n_t > 0 {
        let sink = tx.copy_in(
            "COPY target_values (machine_id, time_s, target, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for p in parts {
            for r in p.chunk.clone() {
                if let Record::Target {
                    time_s,
                    target,
                    value,
                } = r
                {
                    let t = i32::from(*target);
                    w.write(&[&p.mid, time_s, &t, &finite(*value)])?;
                }
            }
        }
        w.finish()?;
    }
    let mids: Vec<i32> = parts.iter().map(|p| p.mid).collect();
    let batches: Vec<i64> = parts.iter().map(|p| p.batch).collect();
    tx.execute(
        "UPDATE machines m SET last_batch = v.batch \
         FROM unnest($1::int4[], $2::int8[]) AS v(id, batch) WHERE m.id = v.id",
        &[&mids, &batches],
    )?;
    tx.commit()?;
    Ok(())
}

/// NaN and ±∞ are stored as NULL, as in the SQLite record.
pub(super) fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// PostgreSQL's `text` cannot hold U+0000 (the server refuses the whole transaction, so
/// one such character would hold a machine's record back for good); SQLite keeps it.
/// Every text the running service records (alarm keys and messages, audit fields,
/// model sources) passes here: a NUL is stored as U+FFFD, the replacement character,
/// and nothing else changes. An alarm cleared later by the same key finds its row,
/// since the key is mapped the same way both times.
pub(super) fn pg_text(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains('\0') {
        std::borrow::Cow::Owned(s.replace('\0', "\u{FFFD}"))
    } else {
        std::borrow::Cow::Borrowed(s)
    }
}

#[cfg(test)]
mod text_tests {
    use super::pg_text;

    #[test]
    fn nul_becomes_the_replacement_character_and_nothing_else_changes() {
        assert_eq!(pg_text("bad\0text\0"), "bad\u{FFFD}text\u{FFFD}");
        assert_eq!(pg_text("Prüfplatz \u{1F600}\t"), "Prüfplatz \u{1F600}\t");
        assert!(matches!(
            pg_text("plain"),
            std::borrow::Cow::Borrowed("plain")
        ));
        // Written out by code point: every char except U+0000 is kept.
        for c in ['\u{1}', 'a', '\u{7f}', '\u{FFFD}', '\u{10FFFF}'] {
            assert_eq!(pg_text(&c.to_string()), c.to_string());
        }
    }
}
