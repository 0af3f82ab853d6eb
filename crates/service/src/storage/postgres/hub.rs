//! The shared writer: one per process and database (same `storage.url`, password, TLS
//! mode and CA file), however many machines the process runs. It holds **one** session,
//! which takes every member machine's writer lock, and commits the records of all members
//! in one transaction (one binary `COPY` per table) at the latest every commit interval.
//!
//! Two threads: the *collector* moves what each machine's record queue holds into the
//! machine's inbox (growing on demand up to [`INBOX_RECORDS`], then holding the machine's
//! cycle back as the queue's bound does), every [`COLLECT_EVERY`]; it never waits for the
//! database, so a commit in progress never fills a queue. The *committer* owns the
//! session and every member's [`Writer`] (buffer, batch numbers, spill, alarms): each
//! member keeps every guarantee of a writer of its own (exactly once through its own
//! `machines.last_batch`, its resume state in the same commit as its offsets, the spill
//! and its replay, its alarms), and a member whose senders are all gone is written out
//! (for up to [`SHUTDOWN_RETRY`]) and leaves; the last one to leave ends the shared writer
//! and its session.

use std::collections::HashMap;
use std::collections::VecDeque;
use std::sync::atomic::AtomicU64;
use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;
use std::sync::mpsc::{channel, Sender, TryRecvError};
use std::sync::OnceLock;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use postgres::Client;

use super::connect::Connection;
use super::schema::LOCK_CLASS;
use super::writer::{busy, write_chunks, Attempt, Part, Writer, CHUNK_RECORDS, SHUTDOWN_RETRY};
use crate::config::Backoff;
use crate::error::{Result, ServiceError};
use crate::storage::Record;

/// How often the collector empties the record queues into the inboxes.
pub const COLLECT_EVERY: Duration = Duration::from_millis(2);

/// Most records an inbox holds before its machine's queue is left to fill.
pub const INBOX_RECORDS: usize = 1 << 16;

/// How often the committer looks for work when nothing is due sooner.
const TICK: Duration = Duration::from_millis(5);

/// Most records of all machines in one transaction (each machine's chunk is at most
/// `CHUNK_RECORDS`).
const TXN_RECORDS: usize = 2 * CHUNK_RECORDS;

/// What the collector hands to the committer for one machine.
#[derive(Default)]
struct Inbox {
    records: VecDeque<Record>,
    /// When the oldest record in `records` was collected.
    oldest: Option<Instant>,
    /// Every sender is gone and the queue is empty.
    closed: bool,
}

type SharedInbox = Arc<Mutex<Inbox>>;

fn lock(inbox: &SharedInbox) -> std::sync::MutexGuard<'_, Inbox> {
    inbox.lock().unwrap_or_else(|p| p.into_inner())
}

/// A machine joining the shared writer.
struct Join {
    writer: Box<Writer>,
    rx: Receiver<Record>,
    /// The machine's writer result, sent when it leaves.
    done: Sender<Result<()>>,
    /// Whether it was admitted (its lock taken on the shared session).
    reply: Sender<Result<()>>,
}

struct Member {
    w: Box<Writer>,
    inbox: SharedInbox,
    /// When the oldest record not yet written arrived.
    oldest: Option<Instant>,
    /// Set once every sender is gone: until when the rest is tried.
    closing: Option<Instant>,
    done: Sender<Result<()>>,
    /// Chunks of this machine alone that the server refused in a row (the session
    /// stayed up), and when it is tried again.
    refused: u32,
    retry_at: Instant,
}

struct Handle {
    id: u64,
    tx: Sender<Join>,
}

fn hubs() -> &'static Mutex<HashMap<String, Handle>> {
    static HUBS: OnceLock<Mutex<HashMap<String, Handle>>> = OnceLock::new();
    HUBS.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Hands a machine's writer to the shared writer of its database (starting it if the
/// process has none), waits until its lock is taken there, and returns a handle that
/// ends with the machine's writer result once its record queue is closed and written.
pub(super) fn join(
    key: &str,
    writer: Writer,
    rx: Receiver<Record>,
) -> Result<JoinHandle<Result<()>>> {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    let (reply, replied) = channel();
    let (done, finished) = channel();
    let conn = writer.target.conn.clone();
    let backoff = writer.backoff;
    let msg = Join {
        writer: Box::new(writer),
        rx,
        done,
        reply,
    };
    {
        let mut map = hubs().lock().unwrap_or_else(|p| p.into_inner());
        let unsent = match map.get(key) {
            Some(h) => h.tx.send(msg).err().map(|e| e.0),
            None => Some(msg),
        };
        if let Some(msg) = unsent {
            let id = NEXT.fetch_add(1, Ordering::Relaxed);
            let (tx, rx) = channel();
            let _ = tx.send(msg);
            let hub = Hub {
                id,
                key: key.to_string(),
                conn,
                client: None,
                backoff,
                failures: 0,
                retry_at: Instant::now(),
                members: Vec::new(),
            };
            std::thread::Builder::new()
                .name("gearcomp-store".into())
                .spawn(move || hub.run(rx))
                .map_err(|source| ServiceError::Io {
                    action: "start",
                    path: "the store thread".into(),
                    source,
                })?;
            map.insert(key.to_string(), Handle { id, tx });
        }
    }
    replied
        .recv()
        .map_err(|_| ServiceError::Stopped("the store thread"))??;
    std::thread::Builder::new()
        .name("gearcomp-store-wait".into())
        .stack_size(64 * 1024)
        .spawn(move || {
            finished
                .recv()
                .unwrap_or(Err(ServiceError::Stopped("the store thread")))
        })
        .map_err(|source| ServiceError::Io {
            action: "start",
            path: "the store thread".into(),
            source,
        })
}

/// The collector: empties every machine's record queue into its inbox.
fn collect(joined: Receiver<(SharedInbox, Receiver<Record>)>) {
    let mut queues: Vec<(SharedInbox, Receiver<Record>)> = Vec::new();
    loop {
        loop {
            match joined.try_recv() {
                Ok(q) => queues.push(q),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) if queues.is_empty() => return,
                Err(TryRecvError::Disconnected) => break,
            }
        }
        let now = Instant::now();
        queues.retain(|(inbox, rx)| {
            let mut ib = lock(inbox);
            while ib.records.len() < INBOX_RECORDS {
                match rx.try_recv() {
                    Ok(r) => {
                        ib.oldest.get_or_insert(now);
                        ib.records.push_back(r);
                    }
                    Err(TryRecvError::Empty) => return true,
                    Err(TryRecvError::Disconnected) => {
                        ib.closed = true;
                        return false;
                    }
                }
            }
            true
        });
        std::thread::sleep(COLLECT_EVERY);
    }
}

struct Hub {
    id: u64,
    key: String,
    /// The first member's connection settings (the key makes them the same for all).
    conn: Connection,
    client: Option<Client>,
    backoff: Backoff,
    failures: u32,
    retry_at: Instant,
    members: Vec<Member>,
}

impl Hub {
    fn run(mut self, joins: Receiver<Join>) {
        let (to_collector, collector_rx) = channel();
        let collector = std::thread::Builder::new()
            .name("gearcomp-store-collect".into())
            .spawn(move || collect(collector_rx));
        if let Err(e) = collector {
            // Without a collector nothing could be written: refuse every machine.
            let e = ServiceError::Io {
                action: "start",
                path: "the store collector thread".into(),
                source: e,
            };
            self.leave_all(&joins, &e.to_string());
            return;
        }
        loop {
            while let Ok(j) = joins.try_recv() {
                self.admit(j, &to_collector);
            }
            if self.members.is_empty() {
                // Leave the registry under its lock, so a machine joining meanwhile is
                // either seen here or starts a new shared writer.
                let mut map = hubs().lock().unwrap_or_else(|p| p.into_inner());
                match joins.try_recv() {
                    Ok(j) => {
                        drop(map);
                        self.admit(j, &to_collector);
                        continue;
                    }
                    Err(_) => {
                        if map.get(&self.key).is_some_and(|h| h.id == self.id) {
                            map.remove(&self.key);
                        }
                        break;
                    }
                }
            }
            let now = Instant::now();
            self.take_inboxes(now);
            for m in &mut self.members {
                m.w.spill_due(now);
            }
            let reachable = self.client.is_some() || now >= self.retry_at;
            let due = self.members.iter().any(|m| {
                m.closing.is_some_and(|_| !m.w.drained())
                    || m.oldest
                        .is_some_and(|t| now >= t + m.w.params.commit_interval)
            });
            if due && reachable {
                self.flush();
                let now = Instant::now();
                for m in &mut self.members {
                    if m.w.drained() {
                        m.oldest = None;
                    } else {
                        // Unwritten records (or the alarms the flush added) stay due.
                        m.oldest.get_or_insert(now);
                    }
                }
            }
            self.leave_finished();
            std::thread::sleep(TICK);
        }
        // Dropping the session releases the locks; the collector ends with its channel.
        drop(to_collector);
    }

    /// Refuses every machine waiting to join (the shared writer could not start).
    fn leave_all(&mut self, joins: &Receiver<Join>, why: &str) {
        let mut map = hubs().lock().unwrap_or_else(|p| p.into_inner());
        while let Ok(j) = joins.try_recv() {
            let _ = j.reply.send(Err(ServiceError::Connect {
                store: j.writer.target.describe.clone(),
                cause: why.to_string(),
            }));
        }
        if map.get(&self.key).is_some_and(|h| h.id == self.id) {
            map.remove(&self.key);
        }
    }

    /// Takes a machine in: its writer lock on the shared session, its `last_batch`.
    fn admit(&mut self, j: Join, to_collector: &Sender<(SharedInbox, Receiver<Record>)>) {
        let Join {
            mut writer,
            rx,
            done,
            reply,
        } = j;
        let mid = writer.target.machine_id;
        if self.members.iter().any(|m| m.w.target.machine_id == mid) {
            let _ = reply.send(Err(busy(&writer.target)));
            return;
        }
        if self.client.is_none() {
            if let Err(e) = self.connect() {
                let _ = reply.send(Err(e));
                return;
            }
        }
        let taken = self.client.as_mut().map(|c| -> Result<Option<i64>> {
            let got: bool = c
                .query_one("SELECT pg_try_advisory_lock($1, $2)", &[&LOCK_CLASS, &mid])?
                .try_get(0)?;
            if !got {
                return Ok(None);
            }
            Ok(Some(
                c.query_one("SELECT last_batch FROM machines WHERE id = $1", &[&mid])?
                    .try_get(0)?,
            ))
        });
        match taken {
            Some(Ok(Some(last))) => {
                writer.connected(last);
                writer.publish();
                let inbox = SharedInbox::default();
                let _ = to_collector.send((inbox.clone(), rx));
                // Records the writer holds already (alarms of a spill left by an earlier
                // run) are due at once.
                let oldest = (!writer.pending.is_empty()).then(Instant::now);
                self.members.push(Member {
                    w: writer,
                    inbox,
                    oldest,
                    closing: None,
                    done,
                    refused: 0,
                    retry_at: Instant::now(),
                });
                let _ = reply.send(Ok(()));
            }
            Some(Ok(None)) => {
                let _ = reply.send(Err(busy(&writer.target)));
            }
            Some(Err(e)) => {
                self.client = None;
                let _ = reply.send(Err(e));
            }
            None => {
                let _ = reply.send(Err(ServiceError::Stopped("the store thread")));
            }
        }
    }

    /// Opens the shared session and takes every member's lock and `last_batch` (settling
    /// a chunk whose commit outcome was unknown).
    fn connect(&mut self) -> Result<()> {
        let mut c = self.conn.connect()?;
        let ids: Vec<i32> = self.members.iter().map(|m| m.w.target.machine_id).collect();
        if !ids.is_empty() {
            let refused: Vec<i32> = c
                .query(
                    "SELECT id FROM unnest($2::int4[]) AS id \
                     WHERE NOT pg_try_advisory_lock($1, id)",
                    &[&LOCK_CLASS, &ids],
                )?
                .iter()
                .map(|r| r.try_get(0))
                .collect::<std::result::Result<_, _>>()?;
            if let Some(m) = self
                .members
                .iter()
                .find(|m| refused.contains(&m.w.target.machine_id))
            {
                return Err(busy(&m.w.target));
            }
            let rows = c.query(
                "SELECT id, last_batch FROM machines WHERE id = ANY($1)",
                &[&ids],
            )?;
            for r in rows {
                let (id, last): (i32, i64) = (r.try_get(0)?, r.try_get(1)?);
                if let Some(m) = self
                    .members
                    .iter_mut()
                    .find(|m| m.w.target.machine_id == id)
                {
                    m.w.connected(last);
                }
            }
        }
        self.client = Some(c);
        Ok(())
    }

    /// Moves what the collector gathered into each member's writer.
    fn take_inboxes(&mut self, now: Instant) {
        for m in &mut self.members {
            let (records, oldest, closed) = {
                let mut ib = lock(&m.inbox);
                (std::mem::take(&mut ib.records), ib.oldest.take(), ib.closed)
            };
            if !records.is_empty() {
                m.w.take(records);
                if let Some(t) = oldest {
                    m.oldest = Some(m.oldest.map_or(t, |o| o.min(t)));
                }
            }
            if closed && m.closing.is_none() {
                m.closing = Some(now + SHUTDOWN_RETRY);
            }
        }
    }

    /// The connection failed: every member alarms, the session is retried with back-off.
    fn fail(&mut self, e: &ServiceError) {
        self.client = None;
        self.failures += 1;
        let wait = self.backoff.wait_s(self.failures);
        self.retry_at = Instant::now() + Duration::from_secs_f64(wait);
        for m in &mut self.members {
            m.w.fail(e);
        }
    }

    /// Writes what every member has waiting, in transactions of all members' chunks,
    /// then the alarms that closing an outage adds. Stops at the first failure (records
    /// stay, in order).
    fn flush(&mut self) {
        for _ in 0..3 {
            if !self.write_round() {
                return;
            }
            let mut added = false;
            for m in &mut self.members {
                if m.w.drained() {
                    added |= m.w.after_write();
                }
            }
            if !added {
                return;
            }
        }
    }

    /// Writes until nothing waits; false when the database is unreachable.
    fn write_round(&mut self) -> bool {
        loop {
            if !self
                .members
                .iter()
                .any(|m| !m.w.pending.is_empty() || m.w.spilling)
            {
                return true;
            }
            if self.client.is_none() {
                if Instant::now() < self.retry_at {
                    return false;
                }
                if let Err(e) = self.connect() {
                    self.fail(&e);
                    return false;
                }
            }
            let mut attempts: Vec<(usize, Attempt)> = Vec::new();
            let mut total = 0usize;
            let now = Instant::now();
            for (i, m) in self.members.iter_mut().enumerate() {
                if total >= TXN_RECORDS {
                    break;
                }
                if now < m.retry_at {
                    continue;
                }
                if let Some(a) = m.w.prepare() {
                    total += a.records;
                    attempts.push((i, a));
                }
            }
            if attempts.is_empty() {
                return true;
            }
            match self.write(&attempts) {
                Ok(()) => {
                    self.failures = 0;
                    for (i, a) in attempts {
                        self.members[i].done(a);
                    }
                }
                Err(e) if self.client.as_ref().is_none_or(|c| c.is_closed()) => {
                    self.fail(&e);
                    return false;
                }
                Err(e) => {
                    // The server refused the transaction but the session is up: write
                    // each machine alone, so one machine's refused records hold back only
                    // that machine (retried with its own back-off, as its own writer was).
                    if attempts.len() == 1 {
                        let i = attempts[0].0;
                        self.refuse(i, &e);
                        continue;
                    }
                    for (i, a) in attempts {
                        match self.write(&[(i, a)]) {
                            Ok(()) => self.members[i].done(a),
                            Err(e) if self.client.as_ref().is_none_or(|c| c.is_closed()) => {
                                self.fail(&e);
                                return false;
                            }
                            Err(e) => self.refuse(i, &e),
                        }
                    }
                }
            }
        }
    }

    /// One transaction with the chunks of `attempts` (`(member, chunk)`).
    fn write(&mut self, attempts: &[(usize, Attempt)]) -> Result<()> {
        let Some(client) = self.client.as_mut() else {
            return Err(ServiceError::Stopped("the store session"));
        };
        let parts: Vec<Part<'_>> = attempts
            .iter()
            .map(|(i, a)| {
                let w = &self.members[*i].w;
                Part {
                    mid: w.target.machine_id,
                    chunk: w.pending.range(..a.records),
                    first_id: w.next_id,
                    batch: a.batch,
                }
            })
            .collect();
        write_chunks(client, &parts)
    }

    /// The server refused member `i`'s chunk on its own: it alarms and waits its back-off.
    fn refuse(&mut self, i: usize, e: &ServiceError) {
        let m = &mut self.members[i];
        m.refused += 1;
        m.retry_at = Instant::now() + Duration::from_secs_f64(m.w.backoff.wait_s(m.refused));
        m.w.fail(e);
    }
}

impl Member {
    /// Its chunk is committed.
    fn done(&mut self, a: Attempt) {
        self.refused = 0;
        self.w.done(a);
    }
}

impl Hub {
    /// Members whose senders are gone leave once written, or when their time is up (the
    /// rest then goes to their spill file); their lock is released.
    fn leave_finished(&mut self) {
        let now = Instant::now();
        let mut i = 0;
        while i < self.members.len() {
            let m = &self.members[i];
            let leave = m.closing.is_some_and(|until| m.w.drained() || now >= until);
            if !leave {
                i += 1;
                continue;
            }
            let m = self.members.swap_remove(i);
            let mid = m.w.target.machine_id;
            if let Some(c) = self.client.as_mut() {
                if c.execute("SELECT pg_advisory_unlock($1, $2)", &[&LOCK_CLASS, &mid])
                    .is_err()
                {
                    self.client = None;
                }
            }
            let _ = m.done.send(m.w.finish());
        }
    }
}
