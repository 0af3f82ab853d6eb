//! TLS to PostgreSQL (`[storage] tls`, `ca_file`) against a real server the test starts
//! with `ssl = on` and a certificate signed by a CA generated here with rcgen: the
//! server's own `pg_stat_ssl` proves the service's sessions are encrypted; a server whose
//! certificate chains to another CA, or names another host, is refused at start; a
//! server without TLS is refused by `require`; configuration mistakes name the key.
#![cfg(feature = "postgres")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;
use crate::postgres_common;

use std::path::Path;

use gearcomp_service::service::start;
use gearcomp_service::storage::open_store;
use gearcomp_service::ServiceConfig;
use postgres_common::{PgServer, ServerTls};
use rcgen::{BasicConstraints, CertificateParams, DnType, IsCa, Issuer, KeyPair, KeyUsagePurpose};

/// A CA (its PEM) and the server certificate it signed for the names `sans`.
struct Pki {
    ca_pem: String,
    server: ServerTls,
}

fn ca(name: &str) -> (String, Issuer<'static, KeyPair>) {
    let key = KeyPair::generate().unwrap();
    let mut p = CertificateParams::new(Vec::<String>::new()).unwrap();
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.distinguished_name.push(DnType::CommonName, name);
    p.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let cert = p.self_signed(&key).unwrap();
    (cert.pem(), Issuer::new(p, key))
}

fn pki(sans: &[&str]) -> Pki {
    let (ca_pem, issuer) = ca("gearcomp test plant CA");
    let key = KeyPair::generate().unwrap();
    let mut p =
        CertificateParams::new(sans.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap();
    p.distinguished_name.push(DnType::CommonName, sans[0]);
    let cert = p.signed_by(&key, &issuer).unwrap();
    Pki {
        ca_pem,
        server: ServerTls {
            cert_pem: cert.pem(),
            key_pem: key.serialize_pem(),
        },
    }
}

/// A machine.toml for the simulator recording into `url` with the given `[storage]` lines.
fn toml(machine: &str, url: &str, storage_extra: &str) -> String {
    format!(
        "[machine]\nname = \"{machine}\"\n[storage]\nbackend = \"postgres\"\nurl = \"{url}\"\n\
         commit_interval_s = 0.05\n{storage_extra}\n[http]\nport = 0\n\
         [input]\nkind = \"simulator\"\nspeedup = 6000\n"
    )
}

fn load(dir: &Path, text: &str) -> gearcomp_service::Result<ServiceConfig> {
    let p = dir.join("machine.toml");
    std::fs::write(&p, text).unwrap();
    ServiceConfig::load(&p)
}

/// `(ssl, version)` of every session of the machine's service, as the server sees it.
fn sessions(server: &PgServer, machine: &str) -> Vec<(bool, Option<String>)> {
    let mut c = server.client();
    c.query(
        "SELECT s.ssl, s.version FROM pg_stat_ssl s JOIN pg_stat_activity a ON a.pid = s.pid \
         WHERE a.application_name = $1",
        &[&format!("gearcomp-serve {machine}")],
    )
    .unwrap()
    .iter()
    .map(|r| (r.get(0), r.get(1)))
    .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn verify_full_with_the_plant_ca_encrypts_every_session_and_stores_samples() {
    let keys = pki(&["localhost"]);
    let server = tokio::task::block_in_place(|| PgServer::try_start_tls(keys.server).unwrap());
    let dir = tempfile::tempdir().unwrap();
    // Relative to the configuration file's folder, like every other path.
    std::fs::write(dir.path().join("plant-ca.pem"), &keys.ca_pem).unwrap();
    let url = format!("postgresql://postgres@localhost:{}/postgres", server.port);
    let text = toml(
        "tls-1",
        &url,
        "tls = \"verify-full\"\nca_file = \"plant-ca.pem\"",
    );
    let running = common::start_with(dir.path(), &text).await;
    let described = running.store.describe();
    assert!(described.contains("tls verify-full"), "{described}");
    let token = running.generated.clone().unwrap().read_only;
    let api = common::Api::new(&running);
    api.wait_for("/api/status", &token, 20.0, |v| {
        v["committed_samples"].as_u64().unwrap_or(0) > 200
    })
    .await;
    // A read through the API's pool while the writer holds its own session.
    let (code, hist) = api.get("/api/offsets?limit=5", Some(&token)).await;
    assert_eq!(code, 200, "{hist}");
    let seen = tokio::task::block_in_place(|| sessions(&server, "tls-1"));
    // The writer's session and the read pool's: both encrypted (TLS 1.2 or 1.3).
    assert!(seen.len() >= 2, "{seen:?}");
    for (ssl, version) in &seen {
        assert!(*ssl, "an unencrypted session of the service: {seen:?}");
        assert!(
            matches!(version.as_deref(), Some("TLSv1.3") | Some("TLSv1.2")),
            "{seen:?}"
        );
    }
    let committed = running.stop().await.unwrap();
    assert!(committed > 200);
    let stored: i64 = tokio::task::block_in_place(|| {
        server
            .client()
            .query_one(
                "SELECT COUNT(*) FROM samples s JOIN machines m ON m.id = s.machine_id \
                 WHERE m.name = 'tls-1'",
                &[],
            )
            .unwrap()
            .get(0)
    });
    assert_eq!(stored as u64, committed);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wrong_ca_or_wrong_host_name_is_refused_at_start_and_require_does_not_verify() {
    let keys = pki(&["localhost"]);
    let (other_ca, _) = ca("some other CA");
    let server = tokio::task::block_in_place(|| PgServer::try_start_tls(keys.server).unwrap());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("other-ca.pem"), &other_ca).unwrap();
    std::fs::write(dir.path().join("plant-ca.pem"), &keys.ca_pem).unwrap();
    let by_name = format!("postgresql://postgres@localhost:{}/postgres", server.port);
    let by_ip = format!("postgresql://postgres@127.0.0.1:{}/postgres", server.port);

    // A server certificate from another CA: an impostor as far as the service knows.
    let cfg = load(
        dir.path(),
        &toml(
            "tls-2",
            &by_name,
            "tls = \"verify-full\"\nca_file = \"other-ca.pem\"",
        ),
    )
    .unwrap();
    let e = start(cfg).await.err().expect("start must fail").to_string();
    assert!(
        e.contains("tls verify-full") && e.contains("TLS handshake") && e.contains("UnknownIssuer"),
        "{e}"
    );

    // The right CA, but the URL names a host the certificate does not (127.0.0.1).
    let cfg = load(
        dir.path(),
        &toml(
            "tls-2",
            &by_ip,
            "tls = \"verify-full\"\nca_file = \"plant-ca.pem\"",
        ),
    )
    .unwrap();
    let e = start(cfg).await.err().expect("start must fail").to_string();
    assert!(
        e.contains("TLS handshake") && e.contains("not valid for name \"127.0.0.1\""),
        "{e}"
    );
    // The same through the URL's sslmode (no storage.tls): the same check.
    let cfg = load(
        dir.path(),
        &toml(
            "tls-2",
            &format!("{by_ip}?sslmode=verify-full"),
            "ca_file = \"plant-ca.pem\"",
        ),
    )
    .unwrap();
    let e = start(cfg).await.err().expect("start must fail").to_string();
    assert!(e.contains("not valid for name \"127.0.0.1\""), "{e}");

    // `require` encrypts without checking the certificate (libpq's meaning): connects.
    let cfg = load(dir.path(), &toml("tls-3", &by_ip, "tls = \"require\"")).unwrap();
    let store = tokio::task::block_in_place(|| open_store(&cfg).unwrap());
    assert!(
        store.describe().contains("tls require"),
        "{}",
        store.describe()
    );
    let seen = tokio::task::block_in_place(|| sessions(&server, "tls-3"));
    assert!(!seen.is_empty() && seen.iter().all(|s| s.0), "{seen:?}");
    tokio::task::block_in_place(move || drop(store));
}

#[test]
fn require_against_a_server_without_tls_fails_clearly() {
    let server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let cfg = load(
        dir.path(),
        &toml("tls-4", &server.url(), "tls = \"require\""),
    )
    .unwrap();
    let e = open_store(&cfg).err().expect("must fail").to_string();
    assert!(
        e.contains("tls require") && e.contains("server does not support TLS"),
        "{e}"
    );
    // The same server with the default (disable) still works as before.
    let cfg = load(dir.path(), &toml("tls-4", &server.url(), "")).unwrap();
    let store = open_store(&cfg).unwrap();
    assert!(
        store.describe().contains("tls disable"),
        "{}",
        store.describe()
    );
    assert!(sessions(&server, "tls-4").iter().all(|s| !s.0));
}

#[test]
fn configuration_mistakes_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let url = "postgresql://gearcomp:s3cret@127.0.0.1:1/plant";
    let err = |extra: &str| {
        load(dir.path(), &toml("tls-5", url, extra))
            .unwrap_err()
            .to_string()
    };

    let e = err("tls = \"verify-full\"");
    assert!(
        e.contains("storage.ca_file") && e.contains("verify-full"),
        "{e}"
    );
    let e = err("tls = \"require\"\nca_file = \"ca.pem\"");
    assert!(
        e.contains("storage.ca_file") && e.contains("verify-full"),
        "{e}"
    );
    let e = err("tls = \"verify-ca\"");
    assert!(e.contains("tls") && e.contains("verify-full"), "{e}");
    // The URL's sslmode and storage.tls must agree; prefer/allow are not offered.
    let e = load(
        dir.path(),
        &toml(
            "tls-5",
            &format!("{url}?sslmode=require"),
            "tls = \"disable\"",
        ),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("storage.tls") && e.contains("sslmode=require"),
        "{e}"
    );
    let e = load(
        dir.path(),
        &toml("tls-5", &format!("{url}?sslmode=prefer"), ""),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("storage.url") && e.contains("sslmode=prefer"),
        "{e}"
    );
    assert!(!e.contains("s3cret"), "{e}");

    // TLS on SQLite is refused, naming the key.
    for (extra, key) in [
        ("tls = \"require\"", "storage.tls"),
        ("ca_file = \"ca.pem\"", "storage.ca_file"),
    ] {
        let e = ServiceConfig::from_toml_str(&format!("[storage]\n{extra}\n"), "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(key) && e.contains("sqlite"), "{e}");
    }

    // ca_file missing or not PEM: named with its resolved path, before any connection.
    let tls = "tls = \"verify-full\"\nca_file = \"plant-ca.pem\"";
    let cfg = load(dir.path(), &toml("tls-5", url, tls)).unwrap();
    let path = dir.path().join("plant-ca.pem");
    let e = open_store(&cfg).err().expect("no CA file").to_string();
    assert!(
        e.contains("storage.ca_file")
            && e.contains(&path.display().to_string())
            && e.contains("PEM"),
        "{e}"
    );
    std::fs::write(&path, "not a certificate\n").unwrap();
    let e = open_store(&cfg).err().expect("not PEM").to_string();
    assert!(
        e.contains("storage.ca_file") && e.contains("no CERTIFICATE block"),
        "{e}"
    );
    // A PEM block that is not a certificate at all.
    std::fs::write(
        &path,
        "-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n",
    )
    .unwrap();
    let e = open_store(&cfg).err().expect("not X.509").to_string();
    assert!(e.contains("storage.ca_file") && e.contains("X.509"), "{e}");
}
