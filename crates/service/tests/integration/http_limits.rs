//! The HTTP server as an attacker on the plant network would use it, on loopback:
//! 2,000 idle connections that never send a header, an unauthenticated 10 MB upload, and
//! HTTPS (rustls) checked with a client that trusts only the test's CA. Asserted on what
//! the server answers: the API still answers, idle connections are closed by the server,
//! the upload gets 401 before its body is read, a body trickled a byte at a time gets 408
//! once `http.body_read_timeout_s` has passed, HTTPS serves and refuses the wrong CA, and
//! a non-loopback bind without TLS is refused naming the key that allows it.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::time::Duration;

use common::{start_with, Api};
use rcgen::{CertificateParams, DnType, KeyPair};

/// Sends `head` (and `body_bytes` bytes of body) on a fresh connection; returns the status
/// line the server answered with (empty if it closed without one).
fn raw_request(addr: std::net::SocketAddr, head: &str, body_bytes: usize) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(head.as_bytes()).unwrap();
    // The server may answer and close before taking the body: a failed write is fine.
    let chunk = vec![b'x'; 64 * 1024];
    let mut sent = 0;
    while sent < body_bytes {
        let n = chunk.len().min(body_bytes - sent);
        if s.write_all(&chunk[..n]).is_err() {
            break;
        }
        sent += n;
    }
    let mut buf = Vec::new();
    let mut tmp = [0u8; 4096];
    while !buf.windows(2).any(|w| w == b"\r\n") {
        match s.read(&mut tmp) {
            Ok(0) | Err(_) => break,
            Ok(n) => buf.extend_from_slice(&tmp[..n]),
        }
    }
    String::from_utf8_lossy(&buf)
        .lines()
        .next()
        .unwrap_or("")
        .to_string()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idle_connections_and_big_uploads_cannot_stop_the_api() {
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\nmax_connections = 64\nheader_read_timeout_s = 1.0\n\
         body_read_timeout_s = 1.0\n\
         [storage]\npath = \"idle.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
    )
    .await;
    let g = run.generated.clone().unwrap();
    let (op, ro) = (g.operator.clone(), g.read_only.clone());
    let addr = run.addr;

    // 2,000 connections that send nothing (a bounded loop; a refused one is counted).
    let idle = tokio::task::spawn_blocking(move || {
        let mut v = Vec::new();
        let mut refused = 0;
        for _ in 0..2000 {
            match TcpStream::connect_timeout(&addr, Duration::from_secs(1)) {
                Ok(s) => v.push(s),
                Err(_) => refused += 1,
            }
        }
        (v, refused)
    })
    .await
    .unwrap();
    let (idle, refused) = idle;
    assert!(idle.len() + refused == 2000);

    // The API answers while they are held open: bounded retries (each ≤ 2 s).
    let api = Api::new(&run);
    let client = reqwest::Client::builder()
        .timeout(Duration::from_secs(2))
        .build()
        .unwrap();
    let mut answered = None;
    for attempt in 0..20 {
        let r = client
            .get(format!("{}/api/status", api.base))
            .bearer_auth(&ro)
            .send()
            .await;
        if let Ok(r) = r {
            if r.status().as_u16() == 200 {
                answered = Some(attempt);
                break;
            }
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    let attempt = answered.expect("the API did not answer with 2,000 idle connections open");
    eprintln!(
        "API answered at attempt {attempt} with {} idle connections open",
        idle.len()
    );

    // Every idle connection was closed by the server (beyond the limit at once, within it
    // after the 1 s header-read timeout): a read sees end of stream or a reset. Polled
    // without blocking, bounded: connections that overflowed the kernel's accept queue
    // under load reach the server later (SYN-ACK retries) and are closed then.
    let closed = tokio::task::spawn_blocking(move || {
        let mut open: Vec<TcpStream> = idle;
        for s in &open {
            s.set_nonblocking(true).unwrap();
        }
        let deadline = std::time::Instant::now() + Duration::from_secs(40);
        let mut closed = 0;
        while !open.is_empty() && std::time::Instant::now() < deadline {
            open.retain(|s| {
                let mut b = [0u8; 1];
                match (&*s).read(&mut b) {
                    Ok(0) => {
                        closed += 1;
                        false
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => true,
                    Err(_) => {
                        closed += 1;
                        false
                    }
                    Ok(_) => true,
                }
            });
            std::thread::sleep(Duration::from_millis(100));
        }
        closed
    })
    .await
    .unwrap();
    assert_eq!(closed + refused, 2000, "idle connections left open");

    // An unauthenticated 10 MB PUT is refused with 401 before its body is read.
    let head = format!(
        "PUT /api/model HTTP/1.1\r\nHost: {addr}\r\nContent-Type: text/plain\r\n\
         Content-Length: {}\r\n\r\n",
        10 * 1024 * 1024
    );
    let line = tokio::task::spawn_blocking(move || raw_request(addr, &head, 256 * 1024))
        .await
        .unwrap();
    assert!(line.starts_with("HTTP/1.1 401"), "{line:?}");
    // A read-only token is refused with 403, also before the body.
    let head = format!(
        "PUT /api/model HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {ro}\r\n\
         Content-Length: {}\r\n\r\n",
        10 * 1024 * 1024
    );
    let line = tokio::task::spawn_blocking(move || raw_request(addr, &head, 0))
        .await
        .unwrap();
    assert!(line.starts_with("HTTP/1.1 403"), "{line:?}");
    // The operator's oversized body gets 413 naming the limit.
    let r = api
        .client
        .put(format!("{}/api/model", api.base))
        .bearer_auth(&op)
        .body(vec![b'#'; 2 * 1024 * 1024])
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 413);
    let v: serde_json::Value = r.json().await.unwrap();
    assert!(v["error"].as_str().unwrap().contains("1048576"), "{v}");

    // An operator's body sent a byte at a time (slow-body attack): 10 bytes of a
    // 1000-byte body, then one byte every 200 ms. The server answers 408 naming the key
    // once `http.body_read_timeout_s` (1 s here) has passed since the headers, and closes
    // the connection, however long the client keeps trickling.
    let head = format!(
        "PUT /api/model HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {op}\r\n\
         Content-Type: text/plain\r\nContent-Length: 1000\r\n\r\n# model..\n"
    );
    let (elapsed, response) = tokio::task::spawn_blocking(move || trickle(addr, &head))
        .await
        .unwrap();
    assert!(response.starts_with("HTTP/1.1 408"), "{response:?}");
    let json = response.split("\r\n\r\n").nth(1).unwrap_or("");
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    assert_eq!(
        v["error"],
        "body not received whole within http.body_read_timeout_s = 1 s; expected the whole \
         body within that time"
    );
    assert!(
        elapsed >= Duration::from_millis(900) && elapsed < Duration::from_secs(8),
        "answered after {elapsed:?}"
    );
    // The API still answers.
    let r = client
        .get(format!("{}/api/status", api.base))
        .bearer_auth(&ro)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    run.stop().await.unwrap();
}

/// Sends `head`, then one body byte every 200 ms for up to 20 s, until the server has
/// answered and closed the connection; returns the time from the head to the close and
/// everything the server sent.
fn trickle(addr: std::net::SocketAddr, head: &str) -> (Duration, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    s.write_all(head.as_bytes()).unwrap();
    let t0 = std::time::Instant::now();
    let mut got = Vec::new();
    let mut tmp = [0u8; 4096];
    while t0.elapsed() < Duration::from_secs(20) {
        match s.read(&mut tmp) {
            Ok(0) => break,
            Ok(n) => got.extend_from_slice(&tmp[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                // Still open: one more byte (a failed write means the server closed).
                if s.write_all(b"#").is_err() && !got.is_empty() {
                    break;
                }
            }
            Err(_) => break,
        }
    }
    (t0.elapsed(), String::from_utf8_lossy(&got).into_owned())
}

/// A self-signed certificate for 127.0.0.1 and localhost: (cert PEM, key PEM, DER).
fn self_signed() -> (String, String, Vec<u8>) {
    let key = KeyPair::generate().unwrap();
    let mut p =
        CertificateParams::new(vec!["localhost".to_string(), "127.0.0.1".to_string()]).unwrap();
    p.distinguished_name
        .push(DnType::CommonName, "gearcomp test service");
    let cert = p.self_signed(&key).unwrap();
    (cert.pem(), key.serialize_pem(), cert.der().to_vec())
}

/// GET `path` over TLS trusting only `root_der`; the status line, or the TLS error.
async fn https_get(
    addr: std::net::SocketAddr,
    root_der: &[u8],
    path: &str,
    token: &str,
) -> Result<String, String> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut roots = rustls::RootCertStore::empty();
    roots
        .add(rustls::pki_types::CertificateDer::from(root_der.to_vec()))
        .unwrap();
    let cfg = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots)
    .with_no_client_auth();
    let conn = tokio_rustls::TlsConnector::from(Arc::new(cfg));
    let tcp = tokio::net::TcpStream::connect(addr).await.unwrap();
    let name = rustls::pki_types::ServerName::try_from("127.0.0.1").unwrap();
    let mut tls = conn.connect(name, tcp).await.map_err(|e| e.to_string())?;
    tls.write_all(
        format!(
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {token}\r\n\
             Connection: close\r\n\r\n"
        )
        .as_bytes(),
    )
    .await
    .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    let _ = tls.read_to_end(&mut out).await;
    let text = String::from_utf8_lossy(&out).to_string();
    Ok(text)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn https_with_rustls_and_no_plaintext_on_the_plant_network() {
    let dir = tempfile::tempdir().unwrap();
    let (cert, key, der) = self_signed();
    std::fs::write(dir.path().join("api.crt"), cert).unwrap();
    std::fs::write(dir.path().join("api.key"), key).unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\ntls = { cert_file = \"api.crt\", key_file = \"api.key\" }\n\
         [storage]\npath = \"tls.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
    )
    .await;
    assert_eq!(run.scheme, "https");
    let ro = run.generated.clone().unwrap().read_only;
    let addr = run.addr;

    // The right CA: 200 with the status JSON naming the machine.
    let text = https_get(addr, &der, "/api/status", &ro).await.unwrap();
    assert!(text.starts_with("HTTP/1.1 200"), "{text}");
    assert!(text.contains("\"machine\""), "{text}");
    // Without a token: 401 over TLS too.
    let text = https_get(addr, &der, "/api/status", "none").await.unwrap();
    assert!(text.starts_with("HTTP/1.1 401"), "{text}");
    // A client trusting another CA refuses the server.
    let (_, _, other) = self_signed();
    let e = https_get(addr, &other, "/api/status", &ro)
        .await
        .unwrap_err();
    assert!(e.to_lowercase().contains("certificate"), "{e}");
    // Plain HTTP to the HTTPS port gets no HTTP answer.
    let line = tokio::task::spawn_blocking(move || {
        raw_request(
            addr,
            &format!("GET /api/status HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
            0,
        )
    })
    .await
    .unwrap();
    assert!(!line.starts_with("HTTP/1.1 200"), "{line:?}");
    run.stop().await.unwrap();

    // A non-loopback bind without TLS is refused, naming the key that would allow it.
    let p = dir.path().join("open.toml");
    std::fs::write(&p, "[http]\nbind = \"0.0.0.0\"\nport = 0\n").unwrap();
    let e = gearcomp_service::ServiceConfig::load(&p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("http.bind") && e.contains("0.0.0.0") && e.contains("http.allow_plaintext"),
        "{e}"
    );
    std::fs::write(
        &p,
        "[http]\nbind = \"0.0.0.0\"\nport = 0\nallow_plaintext = true\n",
    )
    .unwrap();
    gearcomp_service::ServiceConfig::load(&p).unwrap();
    // A key that does not belong to the certificate is refused at start.
    let (_, other_key, _) = self_signed();
    std::fs::write(dir.path().join("other.key"), other_key).unwrap();
    std::fs::write(
        &p,
        "[http]\nport = 0\ntls = { cert_file = \"api.crt\", key_file = \"other.key\" }\n\
         [storage]\npath = \"tls2.db\"\n",
    )
    .unwrap();
    let cfg = gearcomp_service::ServiceConfig::load(&p).unwrap();
    let e = match gearcomp_service::service::start(cfg).await {
        Ok(_) => panic!("started with a key of another certificate"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("http.tls.key_file"), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tokens_in_an_owner_only_file_issued_and_revoked_while_running() {
    use gearcomp_service::auth;
    use gearcomp_service::config::Role;
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\n[storage]\npath = \"tok.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
    )
    .await;
    let g = run.generated.clone().unwrap();
    // First start: the tokens are also in <record>.tokens, owner-only, as is the record.
    let file = g.file.clone().unwrap();
    assert_eq!(file, dir.path().join("tok.db.tokens"));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains(&format!("operator {}", g.operator)), "{text}");
    assert!(
        text.contains(&format!("read_only {}", g.read_only)),
        "{text}"
    );
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        for p in [file.clone(), dir.path().join("tok.db")] {
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "{}", p.display());
        }
    }
    let api = Api::new(&run);

    // Issued while the service runs (what `gearcomp serve --issue-token` does): accepted
    // within the reload period, then revoked: refused again.
    let store = gearcomp_service::storage::SqliteStore::new(&dir.path().join("tok.db"));
    let tfile = dir.path().join("late.token");
    let id = auth::issue_token(&store, Role::ReadOnly, &tfile).unwrap();
    let text = std::fs::read_to_string(&tfile).unwrap();
    let tok = text
        .lines()
        .find_map(|l| l.strip_prefix("read_only "))
        .unwrap()
        .to_string();
    let wait_code = |want: u16| {
        let api = &api;
        let tok = tok.clone();
        async move {
            for _ in 0..100 {
                if api.get("/api/status", Some(&tok)).await.0 == want {
                    return true;
                }
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
            false
        }
    };
    assert!(wait_code(200).await, "issued token never accepted");
    assert_eq!(auth::revoke_token(&store, &id).unwrap(), 1);
    assert!(wait_code(401).await, "revoked token still accepted");
    // The first tokens still work.
    assert_eq!(api.get("/api/status", Some(&g.operator)).await.0, 200);
    run.stop().await.unwrap();
}

/// Every slot taken by connections that never send a byte, with a header timeout of a
/// minute: a new client still gets its answer at once, because the connection that has
/// waited longest without a request being served gives its slot up. A request being
/// served (an operator's body half sent) keeps its connection and gets its answer.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idle_connections_give_their_slots_to_new_clients() {
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\nmax_connections = 16\nheader_read_timeout_s = 60.0\n\
         body_read_timeout_s = 60.0\n\
         [storage]\npath = \"slots.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
    )
    .await;
    let g = run.generated.clone().unwrap();
    let (op, ro) = (g.operator.clone(), g.read_only.clone());
    let addr = run.addr;

    // A request in progress: the headers and half of a 40-byte body that is no TOML.
    let body = b"this is [[ not an engine configuration \n";
    let head = format!(
        "PUT /api/model HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {op}\r\n\
         Content-Type: text/plain\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    let mut busy = TcpStream::connect(addr).unwrap();
    busy.write_all(head.as_bytes()).unwrap();
    busy.write_all(&body[..20]).unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;

    // 200 connections that send nothing, far more than the 16 slots.
    let idle = tokio::task::spawn_blocking(move || {
        (0..200)
            .filter_map(|_| TcpStream::connect_timeout(&addr, Duration::from_secs(2)).ok())
            .collect::<Vec<_>>()
    })
    .await
    .unwrap();
    assert_eq!(idle.len(), 200);

    // Each new client is answered on its first attempt, within a few seconds (before the
    // change a slot came free only after the 60 s header timeout).
    for _ in 0..5 {
        let client = reqwest::Client::builder()
            .timeout(Duration::from_secs(5))
            .build()
            .unwrap();
        let t0 = std::time::Instant::now();
        let r = client
            .get(format!("http://{addr}/api/status"))
            .bearer_auth(&ro)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status().as_u16(), 200);
        assert!(t0.elapsed() < Duration::from_secs(3), "{:?}", t0.elapsed());
    }

    // The request in progress was never cut: the rest of its body gets the engine's
    // refusal of it.
    let answer = tokio::task::spawn_blocking(move || {
        busy.set_read_timeout(Some(Duration::from_secs(10)))
            .unwrap();
        busy.write_all(&body[20..]).unwrap();
        let mut got = Vec::new();
        let mut tmp = [0u8; 4096];
        while !got.windows(4).any(|w| w == b"\r\n\r\n") {
            match busy.read(&mut tmp) {
                Ok(0) | Err(_) => break,
                Ok(n) => got.extend_from_slice(&tmp[..n]),
            }
        }
        String::from_utf8_lossy(&got).into_owned()
    })
    .await
    .unwrap();
    assert!(answer.starts_with("HTTP/1.1 400"), "{answer:?}");

    // The idle connections were closed by the server, all but those still holding a slot.
    let closed = tokio::task::spawn_blocking(move || {
        idle.iter()
            .filter(|s| {
                s.set_nonblocking(true).unwrap();
                let mut b = [0u8; 1];
                !matches!((&**s).read(&mut b), Err(e) if e.kind() == std::io::ErrorKind::WouldBlock)
            })
            .count()
    })
    .await
    .unwrap();
    assert!(
        closed >= 200 - 16,
        "{closed} of 200 idle connections closed"
    );
    run.stop().await.unwrap();
}
