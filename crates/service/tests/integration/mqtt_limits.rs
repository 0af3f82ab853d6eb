//! MQTT input against an embedded rumqttd broker on loopback, as an attacker or a broken
//! gateway would use it: an oversized retained message waiting on a channel topic before
//! the service connects, an oversized live message, a flood of distinct unconfigured
//! topics (one with a 5,000-character name), and a broker that requires a login.
//! Asserted on the record: the input keeps delivering readings (offsets computed by hand
//! from JPH0761598B2's Cz = −3.75·(A − B)), the connection is never dropped, each cause is
//! one alarm with a count, keys stay short, and a password never appears in an alarm.
#![cfg(feature = "mqtt")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::time::{Duration, Instant};

use common::{engine_ab, free_port, start_with, Api};
use rumqttc::{AsyncClient, Event, MqttOptions, Outgoing, QoS};

/// A broker forwarding payloads up to 1 MiB (far above the service's limit), optionally
/// requiring `user = password` logins.
pub fn start_broker(port: u16, auth: Option<(&str, &str)>) {
    let auth = auth
        .map(|(u, p)| format!("[v4.1.connections.auth]\n{u} = \"{p}\"\n"))
        .unwrap_or_default();
    let cfg = format!(
        r#"
id = 0
[router]
max_connections = 100
max_outgoing_packet_count = 200
max_segment_size = 4194304
max_segment_count = 10
[v4.1]
name = "v4-1"
listen = "127.0.0.1:{port}"
next_connection_delay_ms = 1
[v4.1.connections]
connection_timeout_ms = 5000
max_payload_size = 1048576
max_inflight_count = 100
dynamic_filters = true
{auth}"#
    );
    let config: rumqttd::Config = toml::from_str(&cfg).unwrap();
    std::thread::spawn(move || {
        let mut broker = rumqttd::Broker::new(config);
        let _ = broker.start();
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "broker did not listen on {port}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A gateway client; its event loop runs in a task. `login` for a broker with auth.
pub fn gateway(port: u16, id: &str, login: Option<(&str, &str)>) -> AsyncClient {
    let mut opts = MqttOptions::new(id, "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    opts.set_max_packet_size(4 * 1024 * 1024, 4 * 1024 * 1024);
    if let Some((u, p)) = login {
        opts.set_credentials(u, p);
    }
    let (c, mut el) = AsyncClient::new(opts, 512);
    tokio::spawn(async move {
        loop {
            match el.poll().await {
                Ok(Event::Outgoing(Outgoing::Disconnect)) => return,
                Ok(_) => {}
                Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
            }
        }
    });
    c
}

fn machine_toml(machine: &str, port: u16, extra: &str) -> String {
    format!(
        "[machine]\nname = \"{machine}\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
         [http]\nport = 0\n[storage]\npath = \"{machine}.db\"\n\
         [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
         reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n{extra}"
    )
}

/// Publishes A and B every 50 ms until the applied offset is `want_um` (bounded).
async fn feed_until(api: &Api, ro: &str, gw: &AsyncClient, m: &str, a: f64, b: f64, want_um: f64) {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        for (ch, v) in [("A", a), ("B", b)] {
            gw.publish(
                format!("gearcomp/{m}/channel/{ch}"),
                QoS::AtLeastOnce,
                false,
                v.to_string(),
            )
            .await
            .unwrap();
        }
        let (_, st) = api.get("/api/status", Some(ro)).await;
        if st["axes"][0]["offset_um"].as_f64() == Some(want_um) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "offset {want_um} µm never applied: {st}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn alarms_with(v: &serde_json::Value, key: &str) -> Vec<serde_json::Value> {
    v.as_array()
        .unwrap()
        .iter()
        .filter(|a| a["key"] == key)
        .cloned()
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_and_retained_poison_messages_leave_the_input_running() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    let port = free_port();
    start_broker(port, None);
    let gw = gateway(port, "gw-poison", None);
    // The poison: 64 KiB retained on channel A before the service connects. It is a valid
    // reading apart from its size ({"value": 99, "pad": …}): the size check must come
    // first, so 99 °C never reaches the engine.
    let poison = format!(r#"{{"value": 99.0, "pad": "{}"}}"#, "x".repeat(64 * 1024));
    gw.publish(
        "gearcomp/p1/channel/A",
        QoS::AtLeastOnce,
        true,
        poison.clone(),
    )
    .await
    .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;

    let run = start_with(dir.path(), &machine_toml("p1", port, "")).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // The retained poison arrives at the subscription: dropped, alarmed, named.
    let all = api
        .wait_for("/api/alarms", &ro, 15.0, |v| {
            !alarms_with(v, "mqtt.payload.A").is_empty()
        })
        .await;
    let msg = alarms_with(&all, "mqtt.payload.A")[0]["message"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("(retained)")
            && msg.contains(&format!("payload of {} bytes", poison.len()))
            && msg.contains("input.max_payload_bytes = 10240"),
        "{msg}"
    );
    assert!(msg.chars().count() < 400, "{msg}");

    // Readings flow: A = 24, B = 20 → −3.75·4 = −15 µm; the good A clears the alarm.
    feed_until(&api, &ro, &gw, "p1", 24.0, 20.0, -15.0).await;
    api.wait_for("/api/alarms", &ro, 10.0, |v| {
        alarms_with(v, "mqtt.payload.A")
            .iter()
            .all(|a| !a["cleared_s"].is_null())
    })
    .await;

    // Cleared: no longer listed as active (acknowledged or not); still listed as
    // unacknowledged.
    let (_, act) = api.get("/api/alarms?active=true", Some(&ro)).await;
    assert!(alarms_with(&act, "mqtt.payload.A").is_empty(), "{act}");
    let (_, unack) = api.get("/api/alarms?unacknowledged=true", Some(&ro)).await;
    assert_eq!(alarms_with(&unack, "mqtt.payload.A").len(), 1, "{unack}");

    // A live oversized message (20 KiB, over the client library's 10 KiB default that
    // used to end the session) on B, then new readings: 24.4 − 20 → −16.5 µm.
    let big = format!(r#"{{"value": 1.0, "pad": "{}"}}"#, "y".repeat(20 * 1024));
    gw.publish("gearcomp/p1/channel/B", QoS::AtLeastOnce, false, big)
        .await
        .unwrap();
    api.wait_for("/api/alarms", &ro, 10.0, |v| {
        !alarms_with(v, "mqtt.payload.B").is_empty()
    })
    .await;
    feed_until(&api, &ro, &gw, "p1", 24.4, 20.0, -3.75 * (24.4 - 20.0)).await;

    // The session never dropped: not one connection alarm in the whole record, and the
    // poison's 99 °C never reached the record.
    let (_, all) = api.get("/api/alarms?limit=10000", Some(&ro)).await;
    assert!(alarms_with(&all, "mqtt.connection").is_empty(), "{all}");
    let db = run.db.clone();
    run.stop().await.unwrap();
    let conn = gearcomp_service::storage::open_read(&db).unwrap();
    let (n, max_raw): (i64, f64) = conn
        .query_row("SELECT COUNT(*), MAX(raw) FROM samples", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert!(n >= 4, "{n} samples");
    assert!(
        max_raw <= 24.4,
        "an oversized reading was used: max raw {max_raw}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_of_unknown_topics_is_one_alarm_with_a_count() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    let port = free_port();
    start_broker(port, None);
    let run = start_with(dir.path(), &machine_toml("f1", port, "")).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let gw = gateway(port, "gw-flood", None);
    // Connected and subscribed: a reading arrives.
    feed_until(&api, &ro, &gw, "f1", 24.0, 20.0, -15.0).await;

    // 200 distinct unconfigured channels plus one whose name is 5,000 characters.
    let long = "z".repeat(5000);
    for i in 0..200 {
        gw.publish(
            format!("gearcomp/f1/channel/nope{i}"),
            QoS::AtLeastOnce,
            false,
            "1.0",
        )
        .await
        .unwrap();
    }
    gw.publish(
        format!("gearcomp/f1/channel/{long}"),
        QoS::AtLeastOnce,
        false,
        "1.0",
    )
    .await
    .unwrap();

    let all = api
        .wait_for("/api/alarms?limit=10000", &ro, 20.0, |v| {
            alarms_with(v, "mqtt.unknown_topic")
                .first()
                .is_some_and(|a| a["count"] == 201)
        })
        .await;
    let rows = all.as_array().unwrap();
    // One row for the cause; nothing else raised by the flood.
    assert_eq!(alarms_with(&all, "mqtt.unknown_topic").len(), 1, "{all}");
    assert!(
        rows.iter()
            .all(|a| a["key"] == "mqtt.unknown_topic"
                || !a["key"].as_str().unwrap().contains("nope")),
        "{all}"
    );
    for a in rows {
        assert!(a["key"].as_str().unwrap().chars().count() <= 121, "{a}");
        assert!(
            a["message"].as_str().unwrap().chars().count() <= 1001,
            "{a}"
        );
    }
    let msg = alarms_with(&all, "mqtt.unknown_topic")[0]["message"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("nope0") && msg.contains("not configured"),
        "{msg}"
    );
    // The input still works after the flood: 24.4 − 20 → −16.5 µm.
    feed_until(&api, &ro, &gw, "f1", 24.4, 20.0, -3.75 * (24.4 - 20.0)).await;
    run.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn broker_login_from_the_environment_or_a_file_never_shown() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    let port = free_port();
    let (user, pw) = ("gearcomp", "Tr0ub4dor-and-3");
    start_broker(port, Some((user, pw)));
    let var = format!("GEARCOMP_TEST_MQTT_PASSWORD_{port}");
    std::env::set_var(&var, pw);

    // The right password from the environment: readings flow.
    let good = start_with(
        dir.path(),
        &machine_toml(
            "l1",
            port,
            &format!("username = \"{user}\"\npassword_env = \"{var}\"\n"),
        ),
    )
    .await;
    let ro = good.generated.clone().unwrap().read_only;
    let api = Api::new(&good);
    let gw = gateway(port, "gw-login", Some((user, pw)));
    feed_until(&api, &ro, &gw, "l1", 24.0, 20.0, -15.0).await;

    // A wrong password from a file (relative to the configuration): refused, alarmed,
    // and neither password appears in the alarm.
    let dir2 = tempfile::tempdir().unwrap();
    std::fs::write(dir2.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    std::fs::write(dir2.path().join("mqtt.pw"), "not-the-password\n").unwrap();
    let bad = start_with(
        dir2.path(),
        &machine_toml(
            "l2",
            port,
            &format!("username = \"{user}\"\npassword_file = \"mqtt.pw\"\n"),
        ),
    )
    .await;
    let ro2 = bad.generated.clone().unwrap().read_only;
    let api2 = Api::new(&bad);
    let all = api2
        .wait_for("/api/alarms", &ro2, 15.0, |v| {
            !alarms_with(v, "mqtt.connection").is_empty()
        })
        .await;
    let text = all.to_string();
    assert!(
        !text.contains("not-the-password") && !text.contains(pw),
        "{text}"
    );
    // Still refused a moment later: no sample reached the record.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let (_, st) = api2.get("/api/status", Some(&ro2)).await;
    assert_eq!(st["samples_received"], 0, "{st}");
    let (_, all) = api2.get("/api/alarms", Some(&ro2)).await;
    assert!(
        alarms_with(&all, "mqtt.connection")
            .iter()
            .all(|a| a["cleared_s"].is_null()),
        "{all}"
    );
    bad.stop().await.unwrap();

    // A missing variable is refused at start, naming the key and the variable.
    let dir3 = tempfile::tempdir().unwrap();
    std::fs::write(dir3.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    let p = dir3.path().join("machine.toml");
    std::fs::write(
        &p,
        machine_toml(
            "l3",
            port,
            &format!("username = \"{user}\"\npassword_env = \"{var}_UNSET\"\n"),
        ),
    )
    .unwrap();
    let cfg = gearcomp_service::ServiceConfig::load(&p).unwrap();
    let e = match gearcomp_service::service::start(cfg).await {
        Ok(_) => panic!("started without its broker password"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("input.password_env") && e.contains("_UNSET"),
        "{e}"
    );
    good.stop().await.unwrap();
}

/// Stands in for a broker that accepts each session and drops it at once: answers the
/// CONNECT with a CONNACK (accepted), then closes. Returns the arrival instants of `n`
/// connection attempts.
fn accept_then_drop(listener: std::net::TcpListener, n: usize) -> Vec<Instant> {
    use std::io::{Read, Write};
    let mut seen = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    listener.set_nonblocking(true).unwrap();
    while seen.len() < n {
        assert!(Instant::now() < deadline, "only {} attempts", seen.len());
        match listener.accept() {
            Ok((mut s, _)) => {
                seen.push(Instant::now());
                s.set_nonblocking(false).unwrap();
                s.set_read_timeout(Some(Duration::from_millis(500)))
                    .unwrap();
                let mut buf = [0u8; 256];
                let _ = s.read(&mut buf);
                // CONNACK: type 2, remaining length 2, no session present, return code 0.
                let _ = s.write_all(&[0x20, 0x02, 0x00, 0x00]);
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(2)),
        }
    }
    seen
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_that_drops_at_once_does_not_reset_the_back_off() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let (min_s, max_s) = (0.1, 0.8);
    let run = start_with(
        dir.path(),
        &format!(
            "[machine]\nname = \"b1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
             [http]\nport = 0\n[storage]\npath = \"b1.db\"\n\
             [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
             reconnect = {{ min_s = {min_s}, max_s = {max_s} }}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let at = tokio::task::spawn_blocking(move || accept_then_drop(listener, 6))
        .await
        .unwrap();
    let gaps: Vec<f64> = at.windows(2).map(|w| (w[1] - w[0]).as_secs_f64()).collect();
    eprintln!("attempt gaps (s): {gaps:?}");
    // Each accepted-then-dropped session counts as a failure: the waits double
    // 0.1, 0.2, 0.4, 0.8, 0.8 s (a gap is the wait plus the attempt itself, so at least
    // the wait). Reset at every CONNACK, every gap would be about 0.1 s.
    for (k, g) in gaps.iter().enumerate() {
        let wait = (min_s * 2f64.powi(k as i32)).min(max_s);
        assert!(*g >= wait * 0.95, "gap {k} = {g:.3} s < {wait} s: {gaps:?}");
    }
    // One connection alarm for the whole episode, not one per session.
    let api = Api::new(&run);
    let (_, all) = api.get("/api/alarms?limit=1000", Some(&ro)).await;
    assert_eq!(alarms_with(&all, "mqtt.connection").len(), 1, "{all}");
    run.stop().await.unwrap();
}

/// A plant CA with the certificates it signed: the broker's for 127.0.0.1 and a client
/// certificate (CN `gearcomp-t1`, client authentication) for the service.
struct Pki {
    ca: String,
    cert: String,
    key: String,
    client_cert: String,
    client_key: String,
}

fn broker_pki() -> Pki {
    use rcgen::{
        BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer,
        KeyPair, KeyUsagePurpose,
    };
    let ca_key = KeyPair::generate().unwrap();
    let mut p = CertificateParams::new(Vec::<String>::new()).unwrap();
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.distinguished_name
        .push(DnType::CommonName, "gearcomp test plant CA");
    p.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let ca = p.self_signed(&ca_key).unwrap();
    let issuer = Issuer::new(p, ca_key);
    let key = KeyPair::generate().unwrap();
    let mut p = CertificateParams::new(vec!["127.0.0.1".to_string()]).unwrap();
    p.distinguished_name.push(DnType::CommonName, "127.0.0.1");
    let cert = p.signed_by(&key, &issuer).unwrap();
    let client_key = KeyPair::generate().unwrap();
    let mut p = CertificateParams::new(Vec::<String>::new()).unwrap();
    p.distinguished_name.push(DnType::CommonName, "gearcomp-t1");
    p.extended_key_usages = vec![ExtendedKeyUsagePurpose::ClientAuth];
    let client_cert = p.signed_by(&client_key, &issuer).unwrap();
    Pki {
        ca: ca.pem(),
        cert: cert.pem(),
        key: key.serialize_pem(),
        client_cert: client_cert.pem(),
        client_key: client_key.serialize_pem(),
    }
}

/// A TLS-only broker (rumqttd with rustls) requiring a login and a client certificate
/// issued by the plant CA (rumqttd's `verify-client-cert`: `capath` is the CA it trusts
/// for clients).
fn start_tls_broker(port: u16, dir: &std::path::Path, pki: &Pki, login: (&str, &str)) {
    std::fs::write(dir.join("broker.crt"), &pki.cert).unwrap();
    std::fs::write(dir.join("broker.key"), &pki.key).unwrap();
    std::fs::write(dir.join("client-ca.pem"), &pki.ca).unwrap();
    let cfg = format!(
        r#"
id = 0
[router]
max_connections = 100
max_outgoing_packet_count = 200
max_segment_size = 1048576
max_segment_count = 10
[v4.1]
name = "v4-tls"
listen = "127.0.0.1:{port}"
next_connection_delay_ms = 1
[v4.1.tls]
capath = "{}"
certpath = "{}"
keypath = "{}"
[v4.1.connections]
connection_timeout_ms = 5000
max_payload_size = 20480
max_inflight_count = 100
dynamic_filters = true
[v4.1.connections.auth]
{} = "{}"
"#,
        dir.join("client-ca.pem").display(),
        dir.join("broker.crt").display(),
        dir.join("broker.key").display(),
        login.0,
        login.1
    );
    let config: rumqttd::Config = toml::from_str(&cfg).unwrap();
    std::thread::spawn(move || {
        let mut broker = rumqttd::Broker::new(config);
        let _ = broker.start();
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "broker did not listen on {port}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Waits for the `mqtt.connection` alarm of a service that must not get a session and
/// returns its message; asserts that nothing was received.
async fn refused_with(api: &Api, ro: &str) -> String {
    let all = api
        .wait_for("/api/alarms", ro, 15.0, |v| {
            !alarms_with(v, "mqtt.connection").is_empty()
        })
        .await;
    let (_, st) = api.get("/api/status", Some(ro)).await;
    assert_eq!(st["samples_received"], 0, "{st}");
    alarms_with(&all, "mqtt.connection")[0]["message"]
        .as_str()
        .unwrap()
        .to_string()
}

/// A service configuration directory: the engine, the password file, the plant CA the
/// service trusts for the broker, and (optionally) its client certificate and key.
fn tls_dir(ca: &str, client: Option<(&str, &str)>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(5.0)).unwrap();
    std::fs::write(dir.path().join("plant-ca.pem"), ca).unwrap();
    std::fs::write(dir.path().join("mqtt.pw"), "s3cret over TLS\n").unwrap();
    if let Some((cert, key)) = client {
        std::fs::write(dir.path().join("gearcomp.crt"), cert).unwrap();
        std::fs::write(dir.path().join("gearcomp.key"), key).unwrap();
    }
    dir
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tls_broker_with_login_and_client_certificate_wrong_ca_or_certificate_refused() {
    let pki = broker_pki();
    let dir = tls_dir(&pki.ca, Some((&pki.client_cert, &pki.client_key)));
    let port = free_port();
    let login = ("gearcomp", "s3cret over TLS");
    start_tls_broker(port, dir.path(), &pki, login);

    // The gateway over TLS too (same CA, a client certificate of the plant CA).
    let mut roots = rustls::RootCertStore::empty();
    for c in rustls::pki_types::pem::PemObject::pem_slice_iter(pki.ca.as_bytes()) {
        roots.add(c.unwrap()).unwrap();
    }
    let gw_chain: Vec<rustls::pki_types::CertificateDer<'static>> =
        rustls::pki_types::pem::PemObject::pem_slice_iter(pki.client_cert.as_bytes())
            .map(|c| c.unwrap())
            .collect();
    let gw_key: rustls::pki_types::PrivateKeyDer<'static> =
        rustls::pki_types::pem::PemObject::from_pem_slice(pki.client_key.as_bytes()).unwrap();
    let ccfg = rustls::ClientConfig::builder_with_provider(std::sync::Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots)
    .with_client_auth_cert(gw_chain, gw_key)
    .unwrap();
    let mut opts = MqttOptions::new("gw-tls", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    opts.set_credentials(login.0, login.1);
    opts.set_transport(rumqttc::Transport::Tls(rumqttc::TlsConfiguration::Rustls(
        std::sync::Arc::new(ccfg),
    )));
    let (gw, mut el) = AsyncClient::new(opts, 64);
    tokio::spawn(async move {
        loop {
            if el.poll().await.is_err() {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    });

    let login_keys = "username = \"gearcomp\"\npassword_file = \"mqtt.pw\"\n";
    let mtls = format!(
        "{login_keys}tls = {{ ca_file = \"plant-ca.pem\", cert_file = \"gearcomp.crt\", \
         key_file = \"gearcomp.key\" }}\n"
    );
    // The right certificate and password: readings flow, no connection alarm.
    let run = start_with(dir.path(), &machine_toml("t1", port, &mtls)).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    feed_until(&api, &ro, &gw, "t1", 24.0, 20.0, -15.0).await;
    let (_, all) = api.get("/api/alarms", Some(&ro)).await;
    assert!(alarms_with(&all, "mqtt.connection").is_empty(), "{all}");

    // The key's text never appears in an alarm (its base64 body, any line of it).
    let key_lines: Vec<&str> = pki
        .client_key
        .lines()
        .filter(|l| !l.starts_with("-----"))
        .collect();
    let leaks = |msg: &str| {
        msg.contains("s3cret")
            || msg.contains("PRIVATE KEY")
            || key_lines.iter().any(|l| msg.contains(l))
    };

    // A broker certificate from another CA: refused (the connection alarm names the
    // certificate problem), nothing received, never a fallback to plain TCP.
    let other = broker_pki();
    let dir2 = tls_dir(&other.ca, Some((&pki.client_cert, &pki.client_key)));
    let bad = start_with(dir2.path(), &machine_toml("t2", port, &mtls)).await;
    let msg = refused_with(&Api::new(&bad), &bad.generated.clone().unwrap().read_only).await;
    eprintln!("broker certificate of another CA: {msg}");
    let lower = msg.to_lowercase();
    assert!(
        lower.contains("certificate") || lower.contains("issuer"),
        "{msg}"
    );
    assert!(!leaks(&msg), "{msg}");
    bad.stop().await.unwrap();

    // No client certificate: the broker refuses the handshake; the alarm says the broker
    // requires one and which keys to set.
    let dir4 = tls_dir(&pki.ca, None);
    let tls_only = format!("{login_keys}tls = {{ ca_file = \"plant-ca.pem\" }}\n");
    let none = start_with(dir4.path(), &machine_toml("t4", port, &tls_only)).await;
    let msg = refused_with(&Api::new(&none), &none.generated.clone().unwrap().read_only).await;
    eprintln!("no client certificate: {msg}");
    assert!(
        msg.contains("requires a client certificate") && msg.contains("input.tls.cert_file"),
        "{msg}"
    );
    none.stop().await.unwrap();

    // A client certificate from another CA (with the right password): refused, the alarm
    // names the certificate file and the cause.
    let dir5 = tls_dir(&pki.ca, Some((&other.client_cert, &other.client_key)));
    let foreign = start_with(dir5.path(), &machine_toml("t5", port, &mtls)).await;
    let msg = refused_with(
        &Api::new(&foreign),
        &foreign.generated.clone().unwrap().read_only,
    )
    .await;
    eprintln!("client certificate of another CA: {msg}");
    assert!(
        msg.contains("refused the client certificate") && msg.contains("gearcomp.crt"),
        "{msg}"
    );
    assert!(!leaks(&msg), "{msg}");
    foreign.stop().await.unwrap();

    // Without TLS against the TLS port: no session either.
    let dir3 = tls_dir(&pki.ca, None);
    let plain = start_with(dir3.path(), &machine_toml("t3", port, login_keys)).await;
    refused_with(
        &Api::new(&plain),
        &plain.generated.clone().unwrap().read_only,
    )
    .await;
    plain.stop().await.unwrap();
    run.stop().await.unwrap();
}
