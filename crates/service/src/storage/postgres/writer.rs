//! The writer thread of one machine: batched commits (binary `COPY`), exactly once across
//! unknown commit outcomes, reconnection with back-off, the bounded buffer and the spill
//! file (see the module doc of `storage::postgres`).

use super::*;

/// Most records written in one transaction when catching up after an outage.
pub(super) const CHUNK_RECORDS: usize = 100_000;

/// How long a stopping service keeps trying to write what is left in memory.
pub const SHUTDOWN_RETRY: Duration = Duration::from_secs(10);

/// A chunk whose `COMMIT` was sent but whose outcome is not known yet.
#[derive(Debug, Clone, Copy)]
pub(super) struct Attempt {
    batch: i64,
    records: usize,
    samples: u64,
    /// The chunk is spilled rows up to this `seq` (deleted from the file once committed).
    spill_upto: Option<i64>,
}

/// The writer thread's state: the connection (if any), the records waiting, the counters.
pub(super) struct Writer {
    pub(super) target: Target,
    pub(super) client: Option<Client>,
    pub(super) pending: VecDeque<Record>,
    /// Id of the next sample (ids are 1, 2, … per machine).
    pub(super) next_id: u64,
    pub(super) attempted: Option<Attempt>,
    /// The last batch number known committed (`machines.last_batch`).
    pub(super) last_batch: i64,
    pub(super) bound: usize,
    pub(super) backoff: Backoff,
    pub(super) failures: u32,
    pub(super) retry_at: Instant,
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

impl Writer {
    /// Connects and takes the machine's writer lock, retrying for up to `patience` (a
    /// killed predecessor's session may take a moment to end).
    pub(super) fn connect_locked(&mut self, patience: Duration) -> Result<()> {
        let t0 = Instant::now();
        loop {
            let mut c = self.target.connect()?;
            let got: bool = c
                .query_one(
                    "SELECT pg_try_advisory_lock($1, $2)",
                    &[&LOCK_CLASS, &self.target.machine_id],
                )?
                .try_get(0)?;
            if got {
                let last: i64 = c
                    .query_one(
                        "SELECT last_batch FROM machines WHERE id = $1",
                        &[&self.target.machine_id],
                    )?
                    .try_get(0)?;
                self.settle(last);
                self.last_batch = last;
                self.client = Some(c);
                return Ok(());
            }
            if t0.elapsed() >= patience {
                return Err(invalid(
                    "machine.name",
                    &self.target.machine,
                    format!(
                        "a machine no other running gearcomp serve writes to {}",
                        self.target.describe
                    ),
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
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

    fn fail(&mut self, e: &ServiceError) {
        self.client = None;
        self.failures += 1;
        self.last_error = e.to_string();
        let wait = self.backoff.wait_s(self.failures);
        self.retry_at = Instant::now() + Duration::from_secs_f64(wait);
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

    /// Writes what is waiting, chunk by chunk; returns false if the store is unreachable
    /// (the records stay, in order).
    fn flush(&mut self) -> bool {
        while !self.write_pending() {
            // The alarms that closing an outage adds are written in the same flush.
        }
        self.publish();
        self.pending.is_empty() && !self.spilling
    }

    /// Writes every waiting chunk. Returns false when the alarms closing an outage were
    /// added (call again to write them), true otherwise, also when the store is
    /// unreachable (the records stay, in order).
    fn write_pending(&mut self) -> bool {
        loop {
            if self.pending.is_empty() && self.spilling {
                self.next_from_spill();
            }
            if self.pending.is_empty() {
                break;
            }
            if self.client.is_none() {
                if Instant::now() < self.retry_at {
                    return true;
                }
                if let Err(e) = self.connect_locked(Duration::ZERO) {
                    self.fail(&e);
                    return true;
                }
            }
            let n = self.pending.len().min(CHUNK_RECORDS);
            let samples = self
                .pending
                .range(..n)
                .filter(|r| matches!(r, Record::Sample { .. }))
                .count() as u64;
            let Some(client) = self.client.as_mut() else {
                return true;
            };
            // The writer lock makes this thread the only one advancing `last_batch`.
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
            match write_chunk(
                client,
                self.target.machine_id,
                self.pending.range(..n),
                self.next_id,
                batch,
            ) {
                Ok(()) => {
                    self.attempted = None;
                    self.last_batch = batch;
                    self.committed(a);
                    self.failures = 0;
                }
                Err(e) => {
                    self.fail(&e);
                    return true;
                }
            }
        }
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
        self.pending.is_empty()
    }

    /// The loop: take records as they come, write them at the latest `commit_interval`
    /// after the oldest unwritten one arrived (or at the next reconnect attempt).
    pub(super) fn run(mut self, rx: Receiver<Record>) -> Result<()> {
        let mut oldest: Option<Instant> = None;
        loop {
            let db_due = match (oldest, self.client.is_some()) {
                (None, _) => None,
                (Some(t), true) => Some(t + self.params.commit_interval),
                (Some(t), false) => Some(self.retry_at.max(t + self.params.commit_interval)),
            };
            // The spill file commits at the same cadence, whether or not the server is up.
            let spill_due = self
                .spill
                .staged_since
                .map(|t| t + self.params.commit_interval);
            let due = match (db_due, spill_due) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
            let got = match due {
                None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
                Some(d) => rx.recv_timeout(d.saturating_duration_since(Instant::now())),
            };
            match got {
                Ok(r) => {
                    self.push(r);
                    oldest.get_or_insert_with(Instant::now);
                    if due.is_none_or(|d| Instant::now() < d) {
                        continue;
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.commit_spill();
            self.flush();
            if self.pending.is_empty() && !self.spilling {
                oldest = None;
            } else {
                // Unwritten records (or the alarms the flush itself added) stay due.
                oldest.get_or_insert_with(Instant::now);
            }
            self.publish();
        }
        // Every sender is gone: write what is left, retrying for a bounded time.
        let until = Instant::now() + SHUTDOWN_RETRY;
        while !self.flush() && Instant::now() < until {
            let wait = self
                .retry_at
                .min(until)
                .saturating_duration_since(Instant::now());
            std::thread::sleep(wait.max(Duration::from_millis(10)));
        }
        if self.pending.is_empty() && !self.spilling {
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

/// Writes one chunk in one transaction: events (alarms, audit, models) in order, the
/// series with binary COPY, then `last_batch`.
pub(super) fn write_chunk<'a>(
    client: &mut Client,
    mid: i32,
    chunk: impl Iterator<Item = &'a Record> + Clone,
    first_id: u64,
    batch: i64,
) -> Result<()> {
    let mut tx = client.transaction()?;
    let (mut n_s, mut n_a, mut n_o, mut n_t) = (0usize, 0usize, 0usize, 0usize);
    for r in chunk.clone() {
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
                    "INSERT INTO alarms (machine_id, time_s, key, message) VALUES ($1, $2, $3, $4)",
                    &[&mid, time_s, key, message],
                )?;
            }
            Record::AlarmCleared { time_s, key } => {
                tx.execute(
                    "UPDATE alarms SET cleared_s = $1 \
                     WHERE machine_id = $2 AND key = $3 AND cleared_s IS NULL",
                    &[time_s, &mid, key],
                )?;
            }
            Record::AlarmAcknowledged { id, by } => {
                tx.execute(
                    "UPDATE alarms SET acknowledged_by = $1, acknowledged_unix_s = $2 \
                     WHERE id = $3 AND machine_id = $4",
                    &[by, &unix_now_s(), id, &mid],
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
                    &[&mid, &unix_now_s(), token_id, role, action, detail],
                )?;
            }
            Record::Model {
                source,
                config_toml,
            } => {
                tx.execute(
                    "INSERT INTO models (machine_id, unix_s, source, config_toml) \
                     VALUES ($1, $2, $3, $4)",
                    &[&mid, &unix_now_s(), source, config_toml],
                )?;
            }
            Record::Resume { time_s, state } => {
                tx.execute(
                    "INSERT INTO resume_state (machine_id, time_s, state) VALUES ($1, $2, $3) \
                     ON CONFLICT (machine_id) DO UPDATE SET time_s = EXCLUDED.time_s, \
                     state = EXCLUDED.state",
                    &[&mid, time_s, state],
                )?;
            }
        }
    }
    const F8: Type = Type::FLOAT8;
    const I4: Type = Type::INT4;
    if n_s > 0 {
        let sink = tx.copy_in(
            "COPY samples (machine_id, id, time_s, channel, raw) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, Type::INT8, F8, I4, F8]);
        let mut id = first_id as i64;
        for r in chunk.clone() {
            if let Record::Sample {
                time_s,
                channel,
                raw,
            } = r
            {
                let ch = i32::from(*channel);
                let raw = finite(*raw);
                w.write(&[&mid, &id, time_s, &ch, &raw])?;
                id += 1;
            }
        }
        w.finish()?;
    }
    if n_a > 0 {
        let sink = tx.copy_in(
            "COPY averages (machine_id, time_s, channel, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for r in chunk.clone() {
            if let Record::Average {
                time_s,
                channel,
                value,
            } = r
            {
                let ch = i32::from(*channel);
                w.write(&[&mid, time_s, &ch, &finite(*value)])?;
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
        for r in chunk.clone() {
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
                    &mid,
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
        w.finish()?;
    }
    if n_t > 0 {
        let sink = tx.copy_in(
            "COPY target_values (machine_id, time_s, target, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for r in chunk {
            if let Record::Target {
                time_s,
                target,
                value,
            } = r
            {
                let t = i32::from(*target);
                w.write(&[&mid, time_s, &t, &finite(*value)])?;
            }
        }
        w.finish()?;
    }
    tx.execute(
        "UPDATE machines SET last_batch = $1 WHERE id = $2",
        &[&batch, &mid],
    )?;
    tx.commit()?;
    Ok(())
}

/// NaN and ±∞ are stored as NULL, as in the SQLite record.
pub(super) fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}
