//! MQTT input and output (rumqttc): readings as JSON on
//! `<prefix>/<machine>/channel/<channel>`, the applied offset published (retained, QoS 1)
//! on `<prefix>/<machine>/offset/<axis>`.
//!
//! A reading is stamped with the service clock when it arrives. A malformed payload raises
//! an alarm naming the topic and what was wrong, and is dropped (the channel then goes
//! stale in the engine, which freezes the axes reading it); a good payload on that topic
//! clears it. A lost broker is retried with exponential back-off.

use std::sync::mpsc::SyncSender;
use std::time::Duration;

use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};
use tokio::sync::watch;

use crate::config::MqttInput;
use crate::cycle::{Clock, InputMsg, OffsetOut};

/// Parses a reading payload: a JSON number, or an object with a numeric `value`.
///
/// Returns the value, or a message saying what is wrong.
pub fn parse_reading(payload: &[u8]) -> Result<f64, String> {
    let v: serde_json::Value = serde_json::from_slice(payload).map_err(|e| {
        format!("payload is not JSON ({e}); expected a number or {{\"value\": number}}")
    })?;
    let x = match &v {
        serde_json::Value::Number(n) => n.as_f64(),
        serde_json::Value::Object(m) => match m.get("value") {
            Some(serde_json::Value::Number(n)) => n.as_f64(),
            Some(other) => return Err(format!("\"value\" = {other}; expected a finite number")),
            None => return Err("no \"value\" key; expected {\"value\": number}".into()),
        },
        other => {
            return Err(format!(
                "payload {other}; expected a number or {{\"value\": number}}"
            ))
        }
    };
    match x {
        Some(x) if x.is_finite() => Ok(x),
        _ => Err("value is not a finite number".into()),
    }
}

/// The JSON published for an axis offset.
pub fn offset_payload(time_s: f64, seq: u64, offset_um: f64) -> String {
    serde_json::json!({ "time_s": time_s, "seq": seq, "offset_um": offset_um }).to_string()
}

/// Everything the MQTT adapter needs.
pub struct MqttParts {
    /// The configuration.
    pub cfg: MqttInput,
    /// Machine name (topic level).
    pub machine: String,
    /// Engine channels in order.
    pub channels: Vec<String>,
    /// Axis names in order.
    pub axes: Vec<String>,
    /// The service clock.
    pub clock: Clock,
    /// To the cycle.
    pub tx: SyncSender<InputMsg>,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
}

fn send(tx: &SyncSender<InputMsg>, m: InputMsg) {
    // try_send: an async task must not block; a full queue is itself raised as an alarm
    // by the cycle falling behind, so a dropped reading only makes the channel stale.
    let _ = tx.try_send(m);
}

/// Runs until the task is aborted.
pub async fn run(p: MqttParts) {
    let MqttParts {
        cfg,
        machine,
        channels,
        axes,
        clock,
        tx,
        mut offsets,
    } = p;
    let client_id = cfg
        .client_id
        .clone()
        .unwrap_or_else(|| format!("gearcomp-{machine}"));
    let mut opts = MqttOptions::new(client_id, cfg.host.clone(), cfg.port);
    opts.set_keep_alive(Duration::from_secs(cfg.keep_alive_s));
    let (client, mut eventloop) = AsyncClient::new(opts, 256);
    let base = format!("{}/{}", cfg.topic_prefix, machine);
    let channel_prefix = format!("{base}/channel/");

    if cfg.publish_offset {
        let client = client.clone();
        let base = base.clone();
        tokio::spawn(async move {
            let mut last_seq = 0u64;
            while offsets.changed().await.is_ok() {
                let o = *offsets.borrow_and_update();
                if o.seq == last_seq {
                    continue;
                }
                last_seq = o.seq;
                for (i, name) in axes.iter().enumerate().take(o.n_axes as usize) {
                    let topic = format!("{base}/offset/{name}");
                    let payload = offset_payload(o.time_s, o.seq, o.offsets_um[i]);
                    // Queued in the client; rumqttc re-sends QoS 1 messages after a
                    // reconnect. The value is absolute, so a duplicate cannot apply twice.
                    let _ = client.publish(topic, QoS::AtLeastOnce, true, payload).await;
                }
            }
        });
    }

    let conn_key = "mqtt.connection".to_string();
    let mut failures = 0u32;
    loop {
        match eventloop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                failures = 0;
                let _ = client.try_subscribe(format!("{channel_prefix}+"), QoS::AtLeastOnce);
                send(
                    &tx,
                    InputMsg::ClearAlarm {
                        key: conn_key.clone(),
                    },
                );
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                let now = clock.now_s();
                let Some(name) = p.topic.strip_prefix(&channel_prefix) else {
                    continue;
                };
                let key = format!("mqtt.payload.{name}");
                let Some(ch) = channels.iter().position(|c| c == name) else {
                    send(
                        &tx,
                        InputMsg::RaiseAlarm {
                            key,
                            message: format!(
                                "MQTT topic {}: channel {name:?} is not configured (channels: {})",
                                p.topic,
                                channels.join(", ")
                            ),
                        },
                    );
                    continue;
                };
                match parse_reading(&p.payload) {
                    Ok(raw) => {
                        send(&tx, InputMsg::ClearAlarm { key });
                        send(
                            &tx,
                            InputMsg::Sample {
                                channel: ch as u16,
                                raw,
                                stamp_s: now,
                            },
                        );
                    }
                    Err(msg) => {
                        let shown: String = String::from_utf8_lossy(&p.payload)
                            .chars()
                            .take(80)
                            .collect();
                        send(
                            &tx,
                            InputMsg::RaiseAlarm {
                                key,
                                message: format!("MQTT topic {}: {msg} (got {shown:?})", p.topic),
                            },
                        );
                    }
                }
            }
            Ok(_) => {}
            Err(e) => {
                failures = failures.saturating_add(1);
                let wait_s = cfg.reconnect.wait_s(failures);
                send(
                    &tx,
                    InputMsg::RaiseAlarm {
                        key: conn_key.clone(),
                        message: format!(
                            "MQTT broker {}:{}: {e}; retrying with back-off ({wait_s} s)",
                            cfg.host, cfg.port
                        ),
                    },
                );
                tokio::time::sleep(Duration::from_secs_f64(wait_s)).await;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn payload_forms() {
        assert_eq!(parse_reading(b"21.5").unwrap(), 21.5);
        assert_eq!(parse_reading(br#"{"value": -3}"#).unwrap(), -3.0);
        assert!(parse_reading(br#"{"value": "hot"}"#)
            .unwrap_err()
            .contains("value"));
        assert!(parse_reading(br#"{"temp": 1}"#)
            .unwrap_err()
            .contains("no \"value\""));
        assert!(parse_reading(b"not json").unwrap_err().contains("not JSON"));
        assert!(parse_reading(b"[1]").is_err());
        assert!(parse_reading(b"1e999").is_err());
    }

    proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = parse_reading(&bytes);
        }

        #[test]
        fn numbers_round_trip(x in -1e9f64..1e9) {
            let s = serde_json::json!({ "value": x }).to_string();
            prop_assert_eq!(parse_reading(s.as_bytes()).unwrap(), x);
        }
    }
}
