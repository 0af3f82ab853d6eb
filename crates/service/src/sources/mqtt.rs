//! MQTT input and output (rumqttc): readings as JSON on
//! `<prefix>/<machine>/channel/<channel>` and axis positions (mm) on
//! `<prefix>/<machine>/position/<axis>`; the applied offset published (retained, QoS 1)
//! on `<prefix>/<machine>/offset/<axis>`, the stop / feed-hold state (retained, QoS 1) on
//! `<prefix>/<machine>/stop`, a heartbeat on `<prefix>/<machine>/heartbeat` and the infeed
//! pulses of a pulse axis on `<prefix>/<machine>/pulses/<axis>` (see [`run_pulses`]).
//!
//! A reading is stamped with the service clock when it arrives. A malformed payload raises
//! an alarm naming the topic and what was wrong, and is dropped (the channel then goes
//! stale in the engine, which freezes the axes reading it); a good payload on that topic
//! clears it. A lost broker is retried with exponential back-off.

use super::InputTx;
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
            Some(other) => {
                return Err(format!(
                    "\"value\" = {}; expected a finite number",
                    crate::error::shorten_message(&other.to_string())
                ))
            }
            None => return Err("no \"value\" key; expected {\"value\": number}".into()),
        },
        other => {
            return Err(format!(
                "payload {}; expected a number or {{\"value\": number}}",
                crate::error::shorten_message(&other.to_string())
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

/// The JSON published for the stop / feed-hold state (retained): `stop` stays true from
/// the engine's stop request until the operator acknowledges it (`POST /api/stop/ack`).
pub fn stop_payload(time_s: f64, stop: bool) -> String {
    let t = if time_s.is_finite() {
        serde_json::json!(time_s)
    } else {
        serde_json::Value::Null
    };
    serde_json::json!({ "stop": stop, "time_s": t }).to_string()
}

/// The JSON of one heartbeat: a counter that moves while the cycle steps, the cycle's
/// step count and the service time.
pub fn heartbeat_payload(beat: u64, cycles: u64, time_s: f64) -> String {
    serde_json::json!({ "beat": beat, "cycles": cycles, "time_s": time_s }).to_string()
}

/// The JSON of one pulse batch: `pulses` (signed, one pulse = `pulse_um`) and `total`,
/// the cumulative count after it. A PLC applies `total` minus the total it last applied,
/// so a batch delivered twice (QoS 1 is at least once) or a retained batch read again
/// after a reconnect moves nothing.
pub fn pulse_payload(pulses: i64, total: i64, pulse_um: f64) -> String {
    serde_json::json!({ "pulses": pulses, "total": total, "pulse_um": pulse_um }).to_string()
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
    pub tx: InputTx,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
    /// The cycle's step count (`Cycle::alive`), for the heartbeat.
    pub alive: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

fn send(tx: &InputTx, m: InputMsg) {
    // try_send: an async task must not block; a message dropped on a full queue is
    // counted in the alarm input.queue_full (InputTx), the channel goes stale.
    let _ = tx.try_send(m);
}

/// A connection counts as established once it has stayed up this long: only then is the
/// connection alarm cleared and the back-off reset, so a broker that accepts and at once
/// drops the client (or a poison message that ends each session) neither resets the wait
/// nor flaps the alarm.
pub const STABLE_CONNECTION_S: f64 = 1.0;

/// The alarm of messages on topics under the channel prefix that name no configured
/// channel: one alarm for every such topic, with a count.
pub const UNKNOWN_TOPIC_KEY: &str = "mqtt.unknown_topic";

/// An unknown-topic alarm clears when no such message has arrived for this long.
pub const UNKNOWN_TOPIC_QUIET_S: f64 = 60.0;

/// The MQTT protocol's largest packet (remaining length 268,435,455 plus a 5-byte fixed
/// header). The client accepts any packet the broker forwards, so an oversized message
/// is dropped by [`check_payload`] instead of ending the connection; the broker's own
/// limit bounds the memory.
pub const MQTT_PROTOCOL_MAX_PACKET: usize = 268_435_455 + 5;

/// Longest topic text quoted in an alarm.
const TOPIC_SHOWN_CHARS: usize = 120;

fn shown(text: &str, n: usize) -> String {
    let mut it = text.chars();
    let head: String = it.by_ref().take(n).collect();
    if it.next().is_some() {
        format!("{head}… ({} bytes)", text.len())
    } else {
        head
    }
}

/// A message under the channel or position prefix naming no configured channel or axis:
/// counted in the one alarm [`UNKNOWN_TOPIC_KEY`] (raised with the first, its count sent by
/// [`timers`]).
fn unknown_topic(
    state: &std::sync::Mutex<ConnState>,
    tx: &InputTx,
    topic: &str,
    (what, plural): (&str, &str),
    name: &str,
    configured: &[String],
) {
    let mut s = lock(state);
    s.unknown_count += 1;
    s.unknown_last = Some(std::time::Instant::now());
    if s.unknown_count == 1 {
        drop(s);
        let raised = tx.try_send(InputMsg::RaiseAlarm {
            key: UNKNOWN_TOPIC_KEY.into(),
            message: format!(
                "MQTT topic {}: {what} {:?} is not configured ({plural}: {}); \
                 further messages on unconfigured topics are counted in this alarm",
                shown(topic, TOPIC_SHOWN_CHARS),
                shown(name, 40),
                configured.join(", ")
            ),
        });
        if raised.is_err() {
            // Queue full: raised with the next one.
            lock(state).unknown_count = 0;
        }
    }
}

/// The messages refused on one topic (a channel's or an axis position's): one alarm from
/// the first refusal until an accepted message clears it, its count every refusal since
/// (so none is dropped silently: `/api/alarms` shows how many).
#[derive(Debug, Clone, Default)]
struct Refused {
    /// The alarm reached the cycle.
    raised: bool,
    /// Messages refused since the last accepted one.
    count: u64,
}

impl Refused {
    /// One more message refused: the alarm raised (with `message`) if it is not yet, and
    /// the count sent. A full queue counts the lost message in `input.queue_full`; the
    /// next refusal raises the alarm with the whole count.
    fn refused(&mut self, tx: &InputTx, key: String, message: impl FnOnce() -> String) {
        self.count += 1;
        if !self.raised {
            self.raised = tx
                .try_send(InputMsg::RaiseAlarm {
                    key: key.clone(),
                    message: message(),
                })
                .is_ok();
        }
        if self.raised && self.count > 1 {
            let _ = tx.try_send(InputMsg::AlarmCount {
                key,
                count: self.count,
            });
        }
    }

    /// A message accepted: the alarm cleared, the count back to 0.
    fn accepted(&mut self, tx: &InputTx, key: impl FnOnce() -> String) {
        if self.raised && tx.try_send(InputMsg::ClearAlarm { key: key() }).is_ok() {
            self.raised = false;
        }
        if !self.raised {
            self.count = 0;
        }
    }
}

/// Refuses a payload over `max_bytes` with a message naming its size and the limit.
pub fn check_payload(len: usize, max_bytes: u32) -> Result<(), String> {
    if len > max_bytes as usize {
        Err(format!(
            "payload of {len} bytes exceeds input.max_payload_bytes = {max_bytes}; dropped"
        ))
    } else {
        Ok(())
    }
}

/// State shared by the receive loop and its timer task.
#[derive(Default)]
struct ConnState {
    /// When the current connection was acknowledged.
    connected_at: Option<std::time::Instant>,
    /// The connection alarm is raised.
    conn_alarm: bool,
    /// Unknown-topic messages so far in the current alarm, and the count last sent.
    unknown_count: u64,
    unknown_sent: u64,
    unknown_last: Option<std::time::Instant>,
}

fn lock(s: &std::sync::Mutex<ConnState>) -> std::sync::MutexGuard<'_, ConnState> {
    match s.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    }
}

/// Clears the connection alarm once the connection is stable, sends the unknown-topic
/// count and clears that alarm once quiet; ends when the receive loop is gone.
async fn timers(state: std::sync::Weak<std::sync::Mutex<ConnState>>, tx: InputTx) {
    let mut tick = tokio::time::interval(Duration::from_millis(250));
    loop {
        tick.tick().await;
        let Some(state) = state.upgrade() else { return };
        let mut s = lock(&state);
        if s.conn_alarm
            && s.connected_at
                .is_some_and(|t| t.elapsed().as_secs_f64() >= STABLE_CONNECTION_S)
            && tx
                .try_send(InputMsg::ClearAlarm {
                    key: "mqtt.connection".into(),
                })
                .is_ok()
        {
            s.conn_alarm = false;
        }
        if s.unknown_count > 0 {
            if s.unknown_count != s.unknown_sent
                && tx
                    .try_send(InputMsg::AlarmCount {
                        key: UNKNOWN_TOPIC_KEY.into(),
                        count: s.unknown_count,
                    })
                    .is_ok()
            {
                s.unknown_sent = s.unknown_count;
            }
            if s.unknown_last
                .is_some_and(|t| t.elapsed().as_secs_f64() >= UNKNOWN_TOPIC_QUIET_S)
                && tx
                    .try_send(InputMsg::ClearAlarm {
                        key: UNKNOWN_TOPIC_KEY.into(),
                    })
                    .is_ok()
            {
                s.unknown_count = 0;
                s.unknown_sent = 0;
            }
        }
    }
}

/// The rustls client configuration of `input.tls` (ring provider; the broker must chain
/// to the CA file), checked at start; the error names the key and the file.
pub fn tls_config(
    t: &crate::config::MqttTls,
) -> crate::error::Result<std::sync::Arc<rustls::ClientConfig>> {
    use crate::error::invalid;
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::CertificateDer;
    let certs: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(&t.ca_file)
        .and_then(|it| it.collect::<std::result::Result<Vec<_>, _>>())
        .map_err(|e| {
            invalid(
                "input.tls.ca_file",
                format!("{} ({e})", t.ca_file.display()),
                "a readable PEM file with the plant CA's certificate",
            )
        })?;
    let mut roots = rustls::RootCertStore::empty();
    for c in certs {
        roots.add(c).map_err(|e| {
            invalid(
                "input.tls.ca_file",
                format!("{} ({e})", t.ca_file.display()),
                "CA certificates rustls accepts",
            )
        })?;
    }
    if roots.is_empty() {
        return Err(invalid(
            "input.tls.ca_file",
            t.ca_file.display(),
            "a PEM file with at least one CERTIFICATE block",
        ));
    }
    let provider = std::sync::Arc::new(rustls::crypto::ring::default_provider());
    let builder = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| invalid("input.tls", e, "TLS 1.2 or 1.3 with the ring provider"))?
        .with_root_certificates(roots);
    let cfg = match (&t.cert_file, &t.key_file) {
        (None, None) => builder.with_no_client_auth(),
        (Some(cert_file), Some(key_file)) => {
            let (chain, key) = client_identity(cert_file, key_file)?;
            builder.with_client_auth_cert(chain, key).map_err(|e| {
                // The message names the file, never the key's content.
                invalid(
                    "input.tls.key_file",
                    format!("{} ({e})", key_file.display()),
                    "the private key of the certificate in input.tls.cert_file",
                )
            })?
        }
        (Some(_), None) => {
            return Err(invalid(
                "input.tls.key_file",
                "missing",
                "the client certificate's private key (PEM) with input.tls.cert_file",
            ))
        }
        (None, Some(_)) => {
            return Err(invalid(
                "input.tls.cert_file",
                "missing",
                "the client certificate (PEM) with input.tls.key_file",
            ))
        }
    };
    Ok(std::sync::Arc::new(cfg))
}

/// The client certificate chain and key of `input.tls.cert_file` / `key_file`; errors
/// name the key and the file (never the key's content).
fn client_identity(
    cert_file: &std::path::Path,
    key_file: &std::path::Path,
) -> crate::error::Result<(
    Vec<rustls::pki_types::CertificateDer<'static>>,
    rustls::pki_types::PrivateKeyDer<'static>,
)> {
    use crate::error::invalid;
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::{CertificateDer, PrivateKeyDer};
    let chain: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(cert_file)
        .and_then(|it| it.collect::<std::result::Result<Vec<_>, _>>())
        .map_err(|e| {
            invalid(
                "input.tls.cert_file",
                format!("{} ({e})", cert_file.display()),
                "a readable PEM file with this service's client certificate chain",
            )
        })?;
    if chain.is_empty() {
        return Err(invalid(
            "input.tls.cert_file",
            cert_file.display(),
            "a PEM file with at least one CERTIFICATE block",
        ));
    }
    let key = PrivateKeyDer::from_pem_file(key_file).map_err(|e| {
        invalid(
            "input.tls.key_file",
            format!("{} ({e})", key_file.display()),
            "a readable PEM file with the private key (PKCS#8, PKCS#1 or SEC1)",
        )
    })?;
    Ok((chain, key))
}

/// What a failed connection means, for the connection alarm: the broker's own error, and
/// for a TLS alert about the client certificate (the broker refused ours, or wanted one
/// and got none) the cause in the plant's terms.
pub fn connection_cause(error: &str, tls: Option<&crate::config::MqttTls>) -> String {
    let Some(t) = tls else {
        return error.to_string();
    };
    let e = error.to_lowercase();
    let client_cert_alert = [
        "certificaterequired",
        "certificate_required",
        "unknownca",
        "unknown_ca",
        "badcertificate",
        "bad_certificate",
        "certificateunknown",
        "certificate_unknown",
        "certificateexpired",
        "certificaterevoked",
        "accessdenied",
        "decrypterror",
    ]
    .iter()
    .any(|a| e.contains("alert") && e.contains(a));
    if !client_cert_alert {
        return error.to_string();
    }
    match &t.cert_file {
        None => format!(
            "{error}: the broker requires a client certificate and none is configured \
             (set input.tls.cert_file and input.tls.key_file)"
        ),
        Some(f) => format!(
            "{error}: the broker refused the client certificate in input.tls.cert_file = {} \
             (not issued by a CA the broker trusts, expired, or not for client \
             authentication)",
            f.display()
        ),
    }
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
        alive,
    } = p;
    let client_id = cfg
        .client_id
        .clone()
        .unwrap_or_else(|| format!("gearcomp-{machine}"));
    let mut opts = MqttOptions::new(client_id, cfg.host.clone(), cfg.port);
    // Validated: a whole number of seconds 5…3600.
    opts.set_keep_alive(Duration::from_secs_f64(cfg.keep_alive_s));
    // Incoming: anything the broker forwards (see MQTT_PROTOCOL_MAX_PACKET); outgoing:
    // the library's default, far above an offset message.
    opts.set_max_packet_size(MQTT_PROTOCOL_MAX_PACKET, 10 * 1024);
    let conn_key = "mqtt.connection".to_string();
    match cfg.credentials() {
        Ok(Some((user, password))) => {
            opts.set_credentials(user, password);
        }
        Ok(None) => {}
        Err(e) => {
            // Checked at start; the file or variable has gone since.
            send(
                &tx,
                InputMsg::RaiseAlarm {
                    key: conn_key.clone(),
                    message: format!("MQTT broker {}:{}: {e}", cfg.host, cfg.port),
                },
            );
        }
    }
    if let Some(t) = &cfg.tls {
        match tls_config(t) {
            Ok(c) => {
                opts.set_transport(rumqttc::Transport::Tls(rumqttc::TlsConfiguration::Rustls(
                    c,
                )));
            }
            Err(e) => {
                // Checked at start; the file has gone since. Never fall back to plain TCP.
                send(
                    &tx,
                    InputMsg::RaiseAlarm {
                        key: conn_key.clone(),
                        message: format!("MQTT broker {}:{}: {e}", cfg.host, cfg.port),
                    },
                );
                return;
            }
        }
    }
    let base = format!("{}/{}", cfg.topic_prefix, machine);
    let channel_prefix = format!("{base}/channel/");
    let position_prefix = format!("{base}/position/");
    let stop_topic = format!("{base}/stop");
    // The pulse output has a connection of its own, so a PUBACK there can only answer
    // the one batch in flight.
    let pulse_task = (cfg.publish_pulses && offsets.borrow().pulse_um.iter().any(|p| *p > 0.0))
        .then(|| {
            let mut o = opts.clone();
            o.set_client_id(format!("{}-pulses", opts.client_id()));
            tokio::spawn(run_pulses(PulseParts {
                opts: o,
                base: base.clone(),
                axes: axes.clone(),
                reconnect: cfg.reconnect,
                offsets: offsets.clone(),
                tx: tx.clone(),
            }))
        });
    let _abort_pulses = AbortOnDrop(pulse_task);
    let (client, mut eventloop) = AsyncClient::new(opts, 256);
    let stop_view = offsets.clone();

    {
        let client = client.clone();
        let base = base.clone();
        let publish_offset = cfg.publish_offset;
        let publish_stop = cfg.publish_stop;
        let stop_topic = stop_topic.clone();
        let axes = axes.clone();
        tokio::spawn(async move {
            let mut last_seq = 0u64;
            let mut last_stop = None;
            while offsets.changed().await.is_ok() {
                let o = *offsets.borrow_and_update();
                if o.seq == last_seq {
                    continue;
                }
                last_seq = o.seq;
                if publish_stop && last_stop != Some(o.stop) {
                    last_stop = Some(o.stop);
                    // Retained, so a PLC that (re)connects reads the state at once; it is
                    // published again on every new connection of ours (see below).
                    let _ = client
                        .publish(
                            stop_topic.clone(),
                            QoS::AtLeastOnce,
                            true,
                            stop_payload(o.time_s, o.stop),
                        )
                        .await;
                }
                if !publish_offset {
                    continue;
                }
                for (i, name) in axes.iter().enumerate().take(o.n_axes as usize) {
                    if !o.valid[i] {
                        // No 0 meaning "no value yet".
                        continue;
                    }
                    let topic = format!("{base}/offset/{name}");
                    let payload = offset_payload(o.time_s, o.seq, o.offsets_um[i]);
                    // Queued in the client; rumqttc re-sends QoS 1 messages after a
                    // reconnect. The value is absolute, so a duplicate cannot apply twice.
                    let _ = client.publish(topic, QoS::AtLeastOnce, true, payload).await;
                }
            }
        });
    }
    if let Some(period_s) = cfg.heartbeat_s {
        let client = client.clone();
        let topic = format!("{base}/heartbeat");
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_secs_f64(period_s));
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            let mut beat = 0u64;
            let mut last_alive = 0u64;
            loop {
                tick.tick().await;
                // A cycle that no longer steps stops the heartbeat: the PLC holds its
                // last offset and raises its own alarm.
                let a = alive.load(std::sync::atomic::Ordering::Acquire);
                if a == last_alive {
                    continue;
                }
                last_alive = a;
                beat += 1;
                let payload = heartbeat_payload(beat, a, clock.now_s());
                if client
                    .publish(topic.clone(), QoS::AtLeastOnce, false, payload)
                    .await
                    .is_err()
                {
                    return;
                }
            }
        });
    }

    let state = std::sync::Arc::new(std::sync::Mutex::new(ConnState::default()));
    tokio::spawn(timers(std::sync::Arc::downgrade(&state), tx.clone()));
    // Payload alarms raised per channel, so a flood of bad messages is one alarm (one
    // edge, one row) whose count is every message refused since it was raised.
    let mut payload_alarm = vec![Refused::default(); channels.len()];
    let mut position_alarm = vec![Refused::default(); axes.len()];
    let mut failures = 0u32;
    loop {
        match eventloop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                lock(&state).connected_at = Some(std::time::Instant::now());
                let _ = client.try_subscribe(format!("{channel_prefix}+"), QoS::AtLeastOnce);
                let _ = client.try_subscribe(format!("{position_prefix}+"), QoS::AtLeastOnce);
                if cfg.publish_stop {
                    // A new session (the broker may have restarted and lost the retained
                    // message): the current stop state again.
                    let o = *stop_view.borrow();
                    let _ = client.try_publish(
                        stop_topic.clone(),
                        QoS::AtLeastOnce,
                        true,
                        stop_payload(o.time_s, o.stop),
                    );
                }
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                let now = clock.now_s();
                if let Some(axis) = p.topic.strip_prefix(&position_prefix) {
                    let Some(ax) = axes.iter().position(|a| a == axis) else {
                        // Counted with the unknown channel topics (it was dropped silently).
                        unknown_topic(&state, &tx, &p.topic, ("axis", "axes"), axis, &axes);
                        continue;
                    };
                    let key = format!("mqtt.position.{axis}");
                    match check_payload(p.payload.len(), cfg.max_payload_bytes)
                        .and_then(|()| parse_reading(&p.payload))
                    {
                        Ok(position_mm) => {
                            position_alarm[ax].accepted(&tx, || key);
                            send(
                                &tx,
                                InputMsg::Position {
                                    axis: ax as u8,
                                    position_mm,
                                },
                            );
                        }
                        Err(msg) => {
                            // The position is unknown now: the axes whose law needs it
                            // freeze (never a law evaluated at a stale position).
                            send(
                                &tx,
                                InputMsg::Position {
                                    axis: ax as u8,
                                    position_mm: f64::NAN,
                                },
                            );
                            position_alarm[ax].refused(&tx, key, || {
                                format!(
                                    "MQTT topic {}: {msg}; expected the axis position in mm; axes reading it are frozen",
                                    shown(&p.topic, TOPIC_SHOWN_CHARS)
                                )
                            });
                        }
                    }
                    continue;
                }
                let Some(name) = p.topic.strip_prefix(&channel_prefix) else {
                    continue;
                };
                let Some(ch) = channels.iter().position(|c| c == name) else {
                    unknown_topic(
                        &state,
                        &tx,
                        &p.topic,
                        ("channel", "channels"),
                        name,
                        &channels,
                    );
                    continue;
                };
                let parsed = check_payload(p.payload.len(), cfg.max_payload_bytes)
                    .and_then(|()| parse_reading(&p.payload));
                match parsed {
                    Ok(raw) => {
                        payload_alarm[ch].accepted(&tx, || format!("mqtt.payload.{name}"));
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
                        payload_alarm[ch].refused(&tx, format!("mqtt.payload.{name}"), || {
                            let got: String =
                                String::from_utf8_lossy(&p.payload[..p.payload.len().min(320)])
                                    .chars()
                                    .take(80)
                                    .collect();
                            let retained = if p.retain { " (retained)" } else { "" };
                            format!(
                                "MQTT topic {}{retained}: {msg} (got {got:?}); the channel \
                                 holds its last reading (count: messages refused)",
                                p.topic
                            )
                        });
                    }
                }
            }
            Ok(_) => {}
            Err(e) => {
                {
                    let mut s = lock(&state);
                    // Only a connection that stayed up resets the back-off.
                    if s.connected_at
                        .take()
                        .is_some_and(|t| t.elapsed().as_secs_f64() >= STABLE_CONNECTION_S)
                    {
                        failures = 0;
                    }
                    s.conn_alarm = true;
                }
                failures = failures.saturating_add(1);
                let wait_s = cfg.reconnect.wait_s(failures);
                send(
                    &tx,
                    InputMsg::RaiseAlarm {
                        key: conn_key.clone(),
                        message: format!(
                            "MQTT broker {}:{}: {}; retrying with back-off ({wait_s} s)",
                            cfg.host,
                            cfg.port,
                            connection_cause(&e.to_string(), cfg.tls.as_ref())
                        ),
                    },
                );
                tokio::time::sleep(Duration::from_secs_f64(wait_s)).await;
            }
        }
    }
}

/// Aborts a spawned task when dropped (the adapter's own task is aborted on stop).
struct AbortOnDrop(Option<tokio::task::JoinHandle<()>>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        if let Some(t) = &self.0 {
            t.abort();
        }
    }
}

/// What the pulse output needs.
pub struct PulseParts {
    /// Connection options (the client id of the pulse connection).
    pub opts: MqttOptions,
    /// `<prefix>/<machine>`.
    pub base: String,
    /// Axis names in order.
    pub axes: Vec<String>,
    /// Reconnect back-off.
    pub reconnect: crate::config::Backoff,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
    /// To the cycle (acknowledged totals, alarms).
    pub tx: InputTx,
}

/// The pulse batch in flight.
#[derive(Debug, Clone, Copy)]
struct Batch {
    axis: usize,
    pulses: i64,
    total: i64,
    pulse_um: f64,
    /// The packet id the client gave it (ack only that one).
    pkid: Option<u16>,
    sent_at: std::time::Instant,
}

const PULSE_KEY: &str = "mqtt.pulse_output";

/// The pulse output (EP0138375 infeed pulses): one batch in flight on a connection of its
/// own; a batch is counted sent only when the broker's PUBACK for its packet arrives
/// (then reported to the cycle, which keeps the total in the resume state). A batch not
/// acknowledged when the connection drops is published again, unchanged, on the next
/// connection; a restarted service starts from the acknowledged total it kept, so the
/// device receives every pulse and, applying `total` differences, none twice.
pub async fn run_pulses(p: PulseParts) {
    let PulseParts {
        opts,
        base,
        axes,
        reconnect,
        offsets,
        tx,
    } = p;
    let (client, mut eventloop) = AsyncClient::new(opts, 16);
    let st = std::sync::Arc::new(std::sync::Mutex::new(PulseState {
        acked: offsets.borrow().pulses_acked,
        in_flight: None,
        connected: false,
        alarm: false,
    }));
    let wake = std::sync::Arc::new(tokio::sync::Notify::new());
    let topics: Vec<String> = axes.iter().map(|a| format!("{base}/pulses/{a}")).collect();
    let publish = {
        let client = client.clone();
        let topics = topics.clone();
        move |b: &Batch| {
            client.try_publish(
                topics[b.axis].clone(),
                QoS::AtLeastOnce,
                true,
                pulse_payload(b.pulses, b.total, b.pulse_um),
            )
        }
    };
    let feeder = {
        let st = st.clone();
        let wake = wake.clone();
        let publish = publish.clone();
        let tx = tx.clone();
        let axes = axes.clone();
        let mut offsets = offsets;
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    r = offsets.changed() => if r.is_err() { return },
                    _ = wake.notified() => {}
                    _ = tokio::time::sleep(Duration::from_millis(500)) => {}
                }
                let o = *offsets.borrow_and_update();
                let mut s = lock_pulses(&st);
                if let Some(b) = &s.in_flight {
                    if !s.alarm && b.sent_at.elapsed() > Duration::from_secs(5) {
                        let message = format!(
                            "MQTT pulse output: batch of {} pulses (total {}) on axis {} not acknowledged for 5 s; kept and sent again on the next connection",
                            b.pulses, b.total, axes[b.axis]
                        );
                        s.alarm = tx
                            .try_send(InputMsg::RaiseAlarm {
                                key: PULSE_KEY.into(),
                                message,
                            })
                            .is_ok();
                    }
                    continue;
                }
                if !s.connected {
                    continue;
                }
                // The next batch: the pulses issued but not acknowledged, one axis at a time.
                let n = (o.n_axes as usize).min(axes.len());
                let acked = s.acked;
                if let Some(i) =
                    (0..n).find(|&i| o.pulse_um[i] > 0.0 && o.pulse_total[i] != acked[i])
                {
                    let b = Batch {
                        axis: i,
                        pulses: o.pulse_total[i] - acked[i],
                        total: o.pulse_total[i],
                        pulse_um: o.pulse_um[i],
                        pkid: None,
                        sent_at: std::time::Instant::now(),
                    };
                    if publish(&b).is_ok() {
                        s.in_flight = Some(b);
                    }
                }
            }
        })
    };
    let _abort_feeder = AbortOnDrop(Some(feeder));
    let mut failures = 0u32;
    loop {
        match eventloop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                failures = 0;
                let mut s = lock_pulses(&st);
                s.connected = true;
                if let Some(b) = s.in_flight.as_mut() {
                    // A clean session drops what was in flight: the same batch again.
                    b.pkid = None;
                    b.sent_at = std::time::Instant::now();
                    let _ = publish(b);
                }
                drop(s);
                wake.notify_one();
            }
            Ok(Event::Outgoing(rumqttc::Outgoing::Publish(pkid))) => {
                if let Some(b) = lock_pulses(&st).in_flight.as_mut() {
                    b.pkid = Some(pkid);
                }
            }
            Ok(Event::Incoming(Packet::PubAck(a))) => {
                let mut s = lock_pulses(&st);
                let Some(b) = s.in_flight.filter(|b| b.pkid == Some(a.pkid)) else {
                    continue;
                };
                s.in_flight = None;
                s.acked[b.axis] = b.total;
                send(
                    &tx,
                    InputMsg::PulsesAcked {
                        axis: b.axis as u8,
                        total: b.total,
                    },
                );
                if s.alarm {
                    s.alarm = tx
                        .try_send(InputMsg::ClearAlarm {
                            key: PULSE_KEY.into(),
                        })
                        .is_err();
                }
                drop(s);
                wake.notify_one();
            }
            Ok(_) => {}
            Err(e) => {
                failures = failures.saturating_add(1);
                let wait_s = reconnect.wait_s(failures);
                {
                    let mut s = lock_pulses(&st);
                    s.connected = false;
                    if !s.alarm {
                        s.alarm = tx
                            .try_send(InputMsg::RaiseAlarm {
                                key: PULSE_KEY.into(),
                                message: format!(
                                    "MQTT pulse output: {e}; pulses not acknowledged are kept and sent on reconnect (retrying in {wait_s} s)"
                                ),
                            })
                            .is_ok();
                    }
                }
                tokio::time::sleep(Duration::from_secs_f64(wait_s)).await;
            }
        }
    }
}

/// The pulse output's state, shared by its event loop and its feeder.
struct PulseState {
    /// Cumulative pulses acknowledged per axis.
    acked: [i64; gearcomp_thermal::MAX_AXES],
    in_flight: Option<Batch>,
    connected: bool,
    alarm: bool,
}

fn lock_pulses(s: &std::sync::Mutex<PulseState>) -> std::sync::MutexGuard<'_, PulseState> {
    match s.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
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
        // A refused value is shown by its start and length, not whole.
        let long = format!(r#"{{"value": "{}"}}"#, "q".repeat(5000));
        let e = parse_reading(long.as_bytes()).unwrap_err();
        assert!(
            e.contains(&format!("\"{}…\" (5000 characters)", "q".repeat(80)))
                && e.chars().count() < 200,
            "{e}"
        );
        let e = parse_reading(format!("[{}1]", "1,".repeat(3000)).as_bytes()).unwrap_err();
        assert!(
            e.contains("(6003 characters)") && e.chars().count() < 200,
            "{e}"
        );
    }

    /// The client certificate's keys: one without the other, an unreadable file or a key
    /// of another certificate stop the start naming the key and the file, never the key's
    /// text.
    #[test]
    fn client_certificate_keys_are_checked_and_the_key_never_shown() {
        use rcgen::{CertificateParams, DnType, KeyPair};
        let dir = tempfile::tempdir().unwrap();
        let key = KeyPair::generate().unwrap();
        let mut p = CertificateParams::new(Vec::<String>::new()).unwrap();
        p.distinguished_name.push(DnType::CommonName, "gearcomp-x");
        let cert = p.self_signed(&key).unwrap();
        let other_key = KeyPair::generate().unwrap().serialize_pem();
        let f = |n: &str, text: &str| {
            let path = dir.path().join(n);
            std::fs::write(&path, text).unwrap();
            path
        };
        let ca = f("ca.pem", &cert.pem());
        let crt = f("c.crt", &cert.pem());
        let k = f("c.key", &key.serialize_pem());
        let wrong = f("o.key", &other_key);
        let t = |cert_file: Option<&std::path::Path>, key_file: Option<&std::path::Path>| {
            crate::config::MqttTls {
                ca_file: ca.clone(),
                cert_file: cert_file.map(Into::into),
                key_file: key_file.map(Into::into),
            }
        };
        tls_config(&t(Some(&crt), Some(&k))).unwrap();
        tls_config(&t(None, None)).unwrap();
        let e = tls_config(&t(Some(&crt), None)).unwrap_err().to_string();
        assert!(e.contains("input.tls.key_file"), "{e}");
        let e = tls_config(&t(None, Some(&k))).unwrap_err().to_string();
        assert!(e.contains("input.tls.cert_file"), "{e}");
        let e = tls_config(&t(Some(&crt), Some(&dir.path().join("missing.key"))))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("input.tls.key_file") && e.contains("missing.key"),
            "{e}"
        );
        let e = tls_config(&t(Some(&crt), Some(&wrong)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("input.tls.key_file") && e.contains("o.key"),
            "{e}"
        );
        for line in other_key.lines().chain(key.serialize_pem().lines()) {
            assert!(line.starts_with("-----") || !e.contains(line), "{e}");
        }
        // A connection error that is no certificate alert is passed on unchanged; one
        // that is names the cause.
        assert_eq!(
            connection_cause("Connection refused", Some(&t(None, None))),
            "Connection refused"
        );
        assert!(connection_cause(
            "IO: received fatal alert: CertificateRequired",
            Some(&t(None, None))
        )
        .contains("requires a client certificate"));
        assert!(connection_cause(
            "IO: received fatal alert: UnknownCA",
            Some(&t(Some(&crt), Some(&k)))
        )
        .contains("refused the client certificate"));
        assert_eq!(
            connection_cause("IO: received fatal alert: UnknownCA", None),
            "IO: received fatal alert: UnknownCA"
        );
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
