//! Input adapters: each turns a protocol's readings into [`crate::cycle::InputMsg`]s.

#[cfg(feature = "modbus")]
pub mod modbus;
#[cfg(feature = "mqtt")]
pub mod mqtt;
#[cfg(feature = "opcua")]
pub mod opcua;
#[cfg(feature = "opcua")]
pub mod opcua_config;
pub mod replay;
pub mod replay_config;
pub mod sim;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Instant;

use crate::cycle::InputMsg;

/// Capacity of the input queue (messages) that the adapters fill and the cycle empties.
pub const INPUT_QUEUE: usize = 1 << 14;

/// The alarm of messages an input adapter could not queue to the cycle.
pub const QUEUE_FULL_KEY: &str = "input.queue_full";
/// The queue-full alarm clears after this long without a dropped message, s.
pub const QUEUE_FULL_QUIET_S: f64 = 60.0;

/// The input queue as the asynchronous adapters (MQTT, Modbus, OPC UA) use it: they must
/// not block the runtime, so a message that finds the queue full (the cycle fell behind,
/// e.g. held back by a slow record) is dropped, but never silently: every drop is counted
/// and, at the next message that fits, the alarm [`QUEUE_FULL_KEY`] is raised with the
/// total dropped so far (its `count`); it clears after [`QUEUE_FULL_QUIET_S`] without a
/// drop. Clones share the count (one per machine).
#[derive(Debug, Clone)]
pub struct InputTx {
    tx: SyncSender<InputMsg>,
    lost: Arc<Lost>,
}

#[derive(Debug)]
struct Lost {
    start: Instant,
    dropped: AtomicU64,
    reported: AtomicU64,
    last_drop_ms: AtomicU64,
    raised: AtomicBool,
}

impl InputTx {
    /// Wraps the cycle's input queue.
    pub fn new(tx: SyncSender<InputMsg>) -> Self {
        Self {
            tx,
            lost: Arc::new(Lost {
                start: Instant::now(),
                dropped: AtomicU64::new(0),
                reported: AtomicU64::new(0),
                last_drop_ms: AtomicU64::new(0),
                raised: AtomicBool::new(false),
            }),
        }
    }

    /// Messages dropped on a full queue so far.
    pub fn dropped(&self) -> u64 {
        self.lost.dropped.load(Ordering::Acquire)
    }

    fn now_ms(&self) -> u64 {
        u64::try_from(self.lost.start.elapsed().as_millis()).unwrap_or(u64::MAX)
    }

    /// Queues `m` without blocking; a full queue counts the message as dropped (see the
    /// type's description).
    pub fn try_send(&self, m: InputMsg) -> Result<(), TrySendError<InputMsg>> {
        match self.tx.try_send(m) {
            Ok(()) => {
                self.report();
                Ok(())
            }
            Err(TrySendError::Full(m)) => {
                self.lost.dropped.fetch_add(1, Ordering::AcqRel);
                self.lost
                    .last_drop_ms
                    .store(self.now_ms(), Ordering::Release);
                Err(TrySendError::Full(m))
            }
            Err(e) => Err(e),
        }
    }

    /// Raises or updates the queue-full alarm with the drops not yet reported, or clears
    /// it after a quiet spell.
    fn report(&self) {
        let l = &self.lost;
        let dropped = l.dropped.load(Ordering::Acquire);
        if dropped > l.reported.load(Ordering::Acquire) {
            if !l.raised.load(Ordering::Acquire) {
                let raise = InputMsg::RaiseAlarm {
                    key: QUEUE_FULL_KEY.into(),
                    message: format!(
                        "input messages dropped: the cycle fell behind and its queue of {} \
                         messages was full; the channels concerned hold their last reading \
                         and go stale (count: messages dropped)",
                        INPUT_QUEUE
                    ),
                };
                if self.tx.try_send(raise).is_err() {
                    return;
                }
                l.raised.store(true, Ordering::Release);
            }
            let count = InputMsg::AlarmCount {
                key: QUEUE_FULL_KEY.into(),
                count: dropped,
            };
            if self.tx.try_send(count).is_ok() {
                l.reported.store(dropped, Ordering::Release);
            }
        } else if l.raised.load(Ordering::Acquire) {
            let quiet_ms = self
                .now_ms()
                .saturating_sub(l.last_drop_ms.load(Ordering::Acquire));
            if quiet_ms as f64 >= QUEUE_FULL_QUIET_S * 1e3
                && self
                    .tx
                    .try_send(InputMsg::ClearAlarm {
                        key: QUEUE_FULL_KEY.into(),
                    })
                    .is_ok()
            {
                l.raised.store(false, Ordering::Release);
            }
        }
    }
}

/// The alarm of an input adapter whose task ended on an internal error (a panic).
pub const ADAPTER_STOPPED_KEY: &str = "input.adapter_stopped";

/// The text of a panic's payload (`panic!` with a literal or a formatted message).
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into())
}

/// The alarm raised when the adapter task `what` (e.g. "MQTT", "Modbus module 0") ended on
/// a panic: the input would otherwise just go silent (its channels stale, their axes
/// frozen) with nothing saying why.
pub fn adapter_panicked(tx: &InputTx, what: &str, payload: &(dyn std::any::Any + Send)) {
    let _ = tx.try_send(InputMsg::RaiseAlarm {
        key: ADAPTER_STOPPED_KEY.into(),
        message: format!(
            "the {what} input stopped on an internal error ({}); its readings no longer \
             arrive, the channels go stale and the axes reading them freeze; restart the \
             service",
            crate::error::shorten_message(&panic_text(payload))
        ),
    });
}

/// Runs the adapter `fut` as a task of its own, and raises [`ADAPTER_STOPPED_KEY`] should
/// it panic. Dropping (aborting) the returned future aborts the adapter too.
pub async fn supervised(
    what: &'static str,
    tx: InputTx,
    fut: impl std::future::Future<Output = ()> + Send + 'static,
) {
    struct AbortOnDrop(tokio::task::AbortHandle);
    impl Drop for AbortOnDrop {
        fn drop(&mut self) {
            self.0.abort();
        }
    }
    let task = tokio::spawn(fut);
    let _guard = AbortOnDrop(task.abort_handle());
    if let Err(e) = task.await {
        if e.is_panic() {
            adapter_panicked(&tx, what, e.into_panic().as_ref());
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    /// An adapter that panics raises the alarm with the panic's message; one that ends
    /// normally raises nothing; aborting the supervisor aborts the adapter.
    #[tokio::test]
    async fn a_panicking_adapter_is_alarmed() {
        let (tx, rx) = std::sync::mpsc::sync_channel::<InputMsg>(8);
        let itx = InputTx::new(tx);
        supervised("Test", itx.clone(), async {
            let words: Vec<u16> = Vec::new();
            assert_eq!(words.len(), 1, "1 word expected");
        })
        .await;
        match rx.try_recv() {
            Ok(InputMsg::RaiseAlarm { key, message }) => {
                assert_eq!(key, ADAPTER_STOPPED_KEY);
                assert!(
                    message.starts_with("the Test input stopped on an internal error (")
                        && message.contains("1 word expected"),
                    "{message}"
                );
            }
            other => panic!("expected the alarm, got {other:?}"),
        }
        supervised("Test", itx.clone(), async {}).await;
        assert!(rx.try_recv().is_err());
        let ran_on = Arc::new(AtomicBool::new(false));
        let flag = ran_on.clone();
        let sup = tokio::spawn(supervised("Test", itx, async move {
            tokio::time::sleep(std::time::Duration::from_millis(200)).await;
            flag.store(true, Ordering::SeqCst);
        }));
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        sup.abort();
        tokio::time::sleep(std::time::Duration::from_millis(400)).await;
        assert!(
            !ran_on.load(Ordering::SeqCst),
            "the adapter outlived its supervisor"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Bursts of readings into a small queue drained in between: every message either
        /// reaches the cycle or is counted, and the alarm's count (the last AlarmCount the
        /// cycle received) equals the messages that did not arrive. Reference: the
        /// readings sent minus the readings received, counted here.
        #[test]
        fn every_dropped_message_is_counted_and_alarmed(
            cap in 3usize..8,
            bursts in proptest::collection::vec((0usize..20, 0usize..20), 1..12),
        ) {
            let (tx, rx) = std::sync::mpsc::sync_channel::<InputMsg>(cap);
            let tx = InputTx::new(tx);
            let (mut sent, mut received, mut alarm_count, mut raised) = (0u64, 0u64, 0u64, false);
            let receive = |n: usize, received: &mut u64, alarm_count: &mut u64, raised: &mut bool| {
                for _ in 0..n {
                    match rx.try_recv() {
                        Ok(InputMsg::Sample { .. }) => *received += 1,
                        Ok(InputMsg::RaiseAlarm { key, .. }) if key == QUEUE_FULL_KEY => *raised = true,
                        Ok(InputMsg::AlarmCount { key, count }) if key == QUEUE_FULL_KEY => {
                            *alarm_count = count
                        }
                        Ok(_) => {}
                        Err(_) => break,
                    }
                }
            };
            for (send, drain) in bursts {
                for i in 0..send {
                    sent += 1;
                    let _ = tx.try_send(InputMsg::Sample { channel: 0, raw: i as f64, stamp_s: 0.0 });
                }
                receive(drain, &mut received, &mut alarm_count, &mut raised);
            }
            // Drain, then readings one at a time until the alarm has been delivered.
            for _ in 0..4 {
                receive(usize::MAX >> 1, &mut received, &mut alarm_count, &mut raised);
                sent += 1;
                let _ = tx.try_send(InputMsg::Sample { channel: 0, raw: 0.0, stamp_s: 0.0 });
            }
            receive(usize::MAX >> 1, &mut received, &mut alarm_count, &mut raised);
            prop_assert_eq!(tx.dropped(), sent - received);
            prop_assert_eq!(alarm_count, sent - received);
            prop_assert_eq!(raised, sent > received);
        }
    }
}
