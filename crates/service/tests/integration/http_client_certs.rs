//! HTTPS with client-certificate login (`[http.tls] client_ca_file`, `client_roles`,
//! `certificates_only`), checked with a real rustls client over loopback. A plant CA (rcgen)
//! issues the server's certificate and the clients': an operator panel named by its
//! subject CN, a viewer named by a DNS subject alternative name (its CN named nowhere), a
//! certificate of the plant CA named nowhere; a second CA issues a certificate with the
//! operator's very CN. Asserted on the HTTP status lines and the audit log: each mapped
//! certificate gets its role's routes and no more, a token still works (and decides) unless
//! the server says certificates only, a certificate of another CA fails the handshake.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::sync::Arc;

use common::start_with;
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};

/// A CA that signs certificates.
struct Ca {
    pem: String,
    der: Vec<u8>,
    issuer: Issuer<'static, KeyPair>,
}

fn ca(name: &str) -> Ca {
    let key = KeyPair::generate().unwrap();
    let mut p = CertificateParams::new(Vec::<String>::new()).unwrap();
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.distinguished_name.push(DnType::CommonName, name);
    p.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let cert = p.self_signed(&key).unwrap();
    Ca {
        pem: cert.pem(),
        der: cert.der().to_vec(),
        issuer: Issuer::new(p, key),
    }
}

/// A certificate (PEM) and its key (PEM) issued by `ca`: subject CN `cn`, DNS or IP
/// subject alternative names `sans`, for server or client authentication.
fn issue(ca: &Ca, cn: &str, sans: &[&str], client: bool) -> (String, String) {
    let key = KeyPair::generate().unwrap();
    let mut p =
        CertificateParams::new(sans.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap();
    p.distinguished_name.push(DnType::CommonName, cn);
    p.extended_key_usages = vec![if client {
        ExtendedKeyUsagePurpose::ClientAuth
    } else {
        ExtendedKeyUsagePurpose::ServerAuth
    }];
    let cert = p.signed_by(&key, &ca.issuer).unwrap();
    (cert.pem(), key.serialize_pem())
}

/// One request over TLS trusting only `root_der`, with an optional client certificate and
/// token: the response text, or the TLS/IO error (a refused handshake).
async fn https(
    addr: std::net::SocketAddr,
    root_der: &[u8],
    client: Option<&(String, String)>,
    method: &str,
    path: &str,
    token: Option<&str>,
) -> Result<String, String> {
    use rustls::pki_types::pem::PemObject;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut roots = rustls::RootCertStore::empty();
    roots
        .add(rustls::pki_types::CertificateDer::from(root_der.to_vec()))
        .unwrap();
    let b = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots);
    let cfg = match client {
        None => b.with_no_client_auth(),
        Some((cert, key)) => {
            let chain = rustls::pki_types::CertificateDer::pem_slice_iter(cert.as_bytes())
                .map(|c| c.unwrap())
                .collect();
            let key = rustls::pki_types::PrivateKeyDer::from_pem_slice(key.as_bytes()).unwrap();
            b.with_client_auth_cert(chain, key).unwrap()
        }
    };
    let conn = tokio_rustls::TlsConnector::from(Arc::new(cfg));
    let tcp = tokio::net::TcpStream::connect(addr).await.unwrap();
    let name = rustls::pki_types::ServerName::try_from("127.0.0.1").unwrap();
    let mut tls = conn.connect(name, tcp).await.map_err(|e| e.to_string())?;
    let auth = token
        .map(|t| format!("Authorization: Bearer {t}\r\n"))
        .unwrap_or_default();
    tls.write_all(
        format!(
            "{method} {path} HTTP/1.1\r\nHost: {addr}\r\n{auth}Content-Length: 0\r\n\
             Connection: close\r\n\r\n"
        )
        .as_bytes(),
    )
    .await
    .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    // In TLS 1.3 the server judges the client's certificate after the client has finished
    // its side of the handshake: a refusal arrives as an alert on the first read.
    tls.read_to_end(&mut out).await.map_err(|e| e.to_string())?;
    Ok(String::from_utf8_lossy(&out).to_string())
}

fn status_of(text: &str) -> u16 {
    assert!(text.starts_with("HTTP/1.1 "), "no HTTP answer: {text:?}");
    text[9..12].parse().unwrap()
}

fn body_json(text: &str) -> serde_json::Value {
    let i = text.find("\r\n\r\n").unwrap();
    serde_json::from_str(&text[i + 4..]).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_certificates_map_to_roles_and_other_cas_fail_the_handshake() {
    let plant = ca("gearcomp test plant CA");
    let other = ca("another CA");
    let server = issue(&plant, "127.0.0.1", &["127.0.0.1"], false);
    let operator = issue(&plant, "hmi-cell-3", &[], true);
    let viewer = issue(&plant, "pc-17", &["viewer.plant.local"], true);
    let unnamed = issue(&plant, "intruder", &["intruder.plant.local"], true);
    let foreign = issue(&other, "hmi-cell-3", &[], true);

    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("api.crt"), &server.0).unwrap();
    std::fs::write(dir.path().join("api.key"), &server.1).unwrap();
    std::fs::write(dir.path().join("plant-ca.pem"), &plant.pem).unwrap();
    let tls = |only: bool| {
        format!(
            "[http]\nport = 0\n[http.tls]\ncert_file = \"api.crt\"\nkey_file = \"api.key\"\n\
             client_ca_file = \"plant-ca.pem\"\ncertificates_only = {only}\n\
             client_roles = [{{ name = \"hmi-cell-3\", role = \"operator\" }}, \
             {{ name = \"viewer.plant.local\", role = \"read_only\" }}]\n"
        )
    };
    let run = start_with(
        dir.path(),
        &format!(
            "{}[storage]\npath = \"mtls.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
            tls(false)
        ),
    )
    .await;
    assert_eq!(run.scheme, "https");
    let (addr, root) = (run.addr, plant.der.clone());
    let op_token = run.generated.clone().unwrap().operator;
    let ro_token = run.generated.clone().unwrap().read_only;
    let req = |client: Option<&(String, String)>,
               method: &'static str,
               path: &'static str,
               token: Option<String>| {
        let (root, client) = (root.clone(), client.cloned());
        async move { https(addr, &root, client.as_ref(), method, path, token.as_deref()).await }
    };

    // The operator panel's certificate (by its CN), no token: status as operator, and the
    // operator routes; the audit log names the certificate.
    let t = req(Some(&operator), "GET", "/api/status", None)
        .await
        .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    assert_eq!(body_json(&t)["role"], "operator", "{t}");
    let t = req(Some(&operator), "POST", "/api/stop/ack", None)
        .await
        .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    // The audit row reaches the record with the next commit.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    loop {
        let t = req(Some(&operator), "GET", "/api/audit", None)
            .await
            .unwrap();
        let audit = body_json(&t);
        if audit.as_array().unwrap().iter().any(|a| {
            a["action"] == "acknowledge_stop"
                && a["token_id"] == "cert:hmi-cell-3"
                && a["role"] == "operator"
        }) {
            break;
        }
        assert!(std::time::Instant::now() < deadline, "{audit}");
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    // The dashboard page opens with the certificate alone.
    let t = req(Some(&operator), "GET", "/", None).await.unwrap();
    assert_eq!(status_of(&t), 200, "{t}");

    // The viewer's certificate (by its DNS name): reads, but no operator route.
    let t = req(Some(&viewer), "GET", "/api/status", None)
        .await
        .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    assert_eq!(body_json(&t)["role"], "read_only", "{t}");
    for path in ["/api/stop/ack", "/api/alarms/1/ack"] {
        let t = req(Some(&viewer), "POST", path, None).await.unwrap();
        assert_eq!(status_of(&t), 403, "{path}: {t}");
        assert!(t.contains("client certificate is read_only"), "{t}");
    }
    // Tokens are still accepted and decide when presented: without a certificate, and
    // beside the viewer's certificate (the operator token acts as operator); an unknown
    // token is refused even with the operator's certificate.
    let t = req(None, "GET", "/api/status", Some(ro_token.clone()))
        .await
        .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    let t = req(
        Some(&viewer),
        "POST",
        "/api/stop/ack",
        Some(op_token.clone()),
    )
    .await
    .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    let t = req(Some(&operator), "GET", "/api/status", Some("gco_0".into()))
        .await
        .unwrap();
    assert_eq!(status_of(&t), 401, "{t}");
    // A certificate of the plant CA named in no entry, or no certificate, without a token:
    // 401 saying why.
    let t = req(Some(&unnamed), "GET", "/api/status", None)
        .await
        .unwrap();
    assert_eq!(status_of(&t), 401, "{t}");
    assert!(
        t.contains("intruder") && t.contains("http.tls.client_roles"),
        "{t}"
    );
    let t = req(None, "GET", "/api/status", None).await.unwrap();
    assert_eq!(status_of(&t), 401, "{t}");
    // A certificate of another CA (with the operator's very CN) fails the handshake, with
    // or without a token: no HTTP answer at all.
    for token in [None, Some(op_token.clone())] {
        let e = req(Some(&foreign), "GET", "/api/status", token)
            .await
            .unwrap_err();
        eprintln!("foreign CA: {e}");
        assert!(e.to_lowercase().contains("alert"), "{e}");
    }
    run.stop().await.unwrap();

    // certificates_only: no certificate fails the handshake even with a valid token; a
    // token beside a certificate is ignored (the viewer stays a viewer).
    let run = start_with(
        dir.path(),
        &format!(
            "{}[storage]\npath = \"mtls-only.db\"\n[input]\nkind = \"simulator\"\nspeedup = 60.0\n",
            tls(true)
        ),
    )
    .await;
    let addr = run.addr;
    let op_token = run.generated.clone().unwrap().operator;
    let root = plant.der.clone();
    let e = https(addr, &root, None, "GET", "/api/status", Some(&op_token))
        .await
        .unwrap_err();
    eprintln!("certificates_only, no certificate: {e}");
    assert!(e.to_lowercase().contains("alert"), "{e}");
    let t = https(addr, &root, Some(&operator), "POST", "/api/stop/ack", None)
        .await
        .unwrap();
    assert_eq!(status_of(&t), 200, "{t}");
    let t = https(
        addr,
        &root,
        Some(&viewer),
        "POST",
        "/api/stop/ack",
        Some(&op_token),
    )
    .await
    .unwrap();
    assert_eq!(status_of(&t), 403, "{t}");
    let t = https(
        addr,
        &root,
        Some(&unnamed),
        "GET",
        "/api/status",
        Some(&op_token),
    )
    .await
    .unwrap();
    assert_eq!(status_of(&t), 401, "{t}");
    assert!(t.contains("client certificates only"), "{t}");
    run.stop().await.unwrap();

    // Keys that need the plant CA are refused without it, naming the key.
    let p = dir.path().join("bad.toml");
    std::fs::write(
        &p,
        "[http]\nport = 0\n[http.tls]\ncert_file = \"api.crt\"\nkey_file = \"api.key\"\n\
         certificates_only = true\n",
    )
    .unwrap();
    let e = gearcomp_service::ServiceConfig::load(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("http.tls.client_ca_file"), "{e}");
    std::fs::write(
        &p,
        "[http]\nport = 0\n[http.tls]\ncert_file = \"api.crt\"\nkey_file = \"api.key\"\n\
         client_ca_file = \"plant-ca.pem\"\n",
    )
    .unwrap();
    let e = gearcomp_service::ServiceConfig::load(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("http.tls.client_roles"), "{e}");
}
