//! OPC UA security against our own stack's server (async-opcua) offering only Basic256Sha256
//! Sign and SignAndEncrypt endpoints: the service refuses the server's certificate until it
//! is copied into `pki_dir/trusted` under a name of our own (the documented trust step),
//! then logs in with user name / password (password from the environment) over
//! SignAndEncrypt and with an X.509 user certificate over Sign, writing the offset; a user
//! certificate the server does not know and security None give named alarms. The same
//! logins against an independent stack (python asyncua) are in `opcua_asyncua.rs`.
#![cfg(feature = "opcua")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{
    active_message, add_variable, alarm_active as active, free_port, opcua_input_head, start_with,
    Api,
};
use opcua::crypto::{CertificateStore, SecurityPolicy, X509Data};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{ServerBuilder, ServerHandle, ServerUserToken};
use opcua::types::{DataTypeId, DataValue, MessageSecurityMode, StatusCode, Variant};

const NS_URI: &str = "urn:gearcomp-secure-cnc";
const PASSWORD: &str = "Plant-pw-4840";

struct SecureCnc {
    handle: ServerHandle,
    task: tokio::task::JoinHandle<Result<(), String>>,
    writes: Arc<Mutex<Vec<f64>>>,
    server_cert: PathBuf,
}

/// Writes a fresh RSA user certificate and key (DER, PEM) named `name` into `dir`.
fn user_cert(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
    let (c, k) = (
        dir.join(format!("{name}.der")),
        dir.join(format!("{name}.pem")),
    );
    let data = X509Data {
        common_name: name.into(),
        ..X509Data::sample_cert()
    };
    CertificateStore::create_certificate_and_key(&data, true, &c, &k).unwrap();
    (c, k)
}

impl SecureCnc {
    async fn start(
        port: u16,
        pki: &Path,
        known_user_cert: &Path,
        trust_clients: bool,
    ) -> SecureCnc {
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", port))
            .await
            .unwrap();
        let ids = ["op", "certuser"];
        let (server, handle) = ServerBuilder::new()
            .application_name("gearcomp secure test CNC")
            .application_uri("urn:gearcomp-secure-cnc-server")
            .product_uri("urn:gearcomp-secure-cnc-server")
            .host("127.0.0.1")
            .port(port)
            .discovery_urls(vec![format!("opc.tcp://127.0.0.1:{port}/")])
            .pki_dir(pki)
            .certificate_path("own/cert.der")
            .private_key_path("private/private.pem")
            .create_sample_keypair(true)
            .trust_client_certs(trust_clients)
            .add_user_token("op", ServerUserToken::user_pass("op", PASSWORD))
            .add_user_token(
                "certuser",
                ServerUserToken::x509("certuser", known_user_cert),
            )
            .add_endpoint(
                "b256_sign",
                (
                    "/",
                    SecurityPolicy::Basic256Sha256,
                    MessageSecurityMode::Sign,
                    &ids as &[&str],
                ),
            )
            .add_endpoint(
                "b256_sae",
                (
                    "/",
                    SecurityPolicy::Basic256Sha256,
                    MessageSecurityMode::SignAndEncrypt,
                    &ids as &[&str],
                ),
            )
            .with_node_manager(simple_node_manager(
                NamespaceMetadata {
                    namespace_uri: NS_URI.to_owned(),
                    ..Default::default()
                },
                "cnc",
            ))
            .build()
            .unwrap();
        let nm = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .unwrap();
        let ns = handle.get_namespace_index(NS_URI).unwrap();
        assert_eq!(ns, 2, "the configuration assumes ns=2");
        let writes: Arc<Mutex<Vec<f64>>> = Arc::default();
        {
            let mut space = nm.address_space().write();
            for (name, v) in [("Temp.A", 24.0f64), ("Temp.B", 20.0)] {
                add_variable(&mut space, ns, name, DataTypeId::Double, v, false);
            }
            let comp = add_variable(&mut space, ns, "TempComp", DataTypeId::Double, 0.0f64, true);
            let w = writes.clone();
            nm.inner()
                .add_write_callback(comp, move |dv: DataValue, _| match dv.value {
                    Some(Variant::Double(x)) => {
                        w.lock().unwrap().push(x);
                        StatusCode::Good
                    }
                    _ => StatusCode::BadTypeMismatch,
                });
        }
        let task = tokio::spawn(server.run_with(listener));
        SecureCnc {
            handle,
            task,
            writes,
            server_cert: pki.join("own").join("cert.der"),
        }
    }

    async fn wait_write(&self, want: f64, secs: f64) {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        while self.writes.lock().unwrap().last() != Some(&want) {
            assert!(
                Instant::now() < deadline,
                "TempComp writes {:?}, expected {want}",
                self.writes.lock().unwrap()
            );
            tokio::time::sleep(Duration::from_millis(30)).await;
        }
    }

    async fn stop(self) {
        self.handle.cancel();
        let _ = tokio::time::timeout(Duration::from_secs(10), self.task).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_secure_logins_against_async_opcua() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), common::engine_ab(5.0)).unwrap();
    let users = dir.path().join("users");
    std::fs::create_dir_all(&users).unwrap();
    let (known_cert, known_key) = user_cert(&users, "gearcomp-user");
    let (stranger_cert, stranger_key) = user_cert(&users, "stranger");
    let port = free_port();
    let cnc = SecureCnc::start(port, &dir.path().join("server-pki"), &known_cert, true).await;
    // The password reaches the service through the environment only.
    std::env::set_var("GEARCOMP_TEST_OPCUA_SECURE_PW", PASSWORD);
    let cfg_at = |port: u16, db: &str, mode: &str, login: &str| {
        format!(
            "{}security_policy = \"Basic256Sha256\"\nsecurity_mode = \"{mode}\"\npki_dir = \"pki\"\n\
             {login}offset_output = {{ axis = \"Z\", node = \"ns=2;s=TempComp\" }}\n",
            opcua_input_head(port, &format!("path = \"{db}\""), 2, 0.3)
        )
    };
    let cfg = |db: &str, mode: &str, login: &str| cfg_at(port, db, mode, login);
    let password_login = "user = \"op\"\npassword_env = \"GEARCOMP_TEST_OPCUA_SECURE_PW\"\n";

    // 1. SignAndEncrypt, user + password: the server's certificate is not trusted yet.
    let run = start_with(dir.path(), &cfg("s1.db", "SignAndEncrypt", password_login)).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.certificate", 30.0).await;
    let m = active_message(&alarms, "opcua.certificate");
    assert!(m.contains("not trusted") && m.contains("rejected"), "{m}");
    assert!(cnc.writes.lock().unwrap().is_empty());
    // The documented trust step, under a file name of our own (not `CN [thumbprint].der`).
    let trusted = dir.path().join("pki").join("trusted");
    std::fs::create_dir_all(&trusted).unwrap();
    std::fs::copy(&cnc.server_cert, trusted.join("cnc-hall-3.der")).unwrap();
    // Cz = −3.75·(24 − 20) = −15 µm over the encrypted session.
    cnc.wait_write(-15.0, 30.0).await;
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
            !active(v, "opcua.certificate") && !active(v, "opcua.connection")
        })
        .await;
    assert!(!alarms.to_string().contains(PASSWORD));
    run.stop().await.unwrap();

    // 2. Sign, X.509 user certificate the server knows.
    let before = cnc.writes.lock().unwrap().len();
    let login = format!(
        "user_certificate = \"{}\"\nuser_private_key = \"{}\"\n",
        known_cert.display(),
        known_key.display()
    );
    let run = start_with(dir.path(), &cfg("s2.db", "Sign", &login)).await;
    let deadline = Instant::now() + Duration::from_secs(30);
    while cnc.writes.lock().unwrap().len() == before {
        assert!(Instant::now() < deadline, "no write with the X.509 login");
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    assert_eq!(cnc.writes.lock().unwrap().last(), Some(&-15.0));
    run.stop().await.unwrap();

    // 3. A user certificate the server does not know: opcua.login names it.
    let login = format!(
        "user_certificate = \"{}\"\nuser_private_key = \"{}\"\n",
        stranger_cert.display(),
        stranger_key.display()
    );
    let run = start_with(dir.path(), &cfg("s3.db", "SignAndEncrypt", &login)).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.login", 30.0).await;
    let m = active_message(&alarms, "opcua.login");
    assert!(m.contains("stranger.der") && m.contains("refused"), "{m}");
    run.stop().await.unwrap();
    cnc.stop().await;

    // 4. A server that does not trust this client's certificate: opcua.certificate says so
    // and names the certificate to trust on the server.
    let port = free_port();
    let strict = SecureCnc::start(port, &dir.path().join("strict-pki"), &known_cert, false).await;
    std::fs::copy(&strict.server_cert, trusted.join("strict-cnc.der")).unwrap();
    let run = start_with(
        dir.path(),
        &cfg_at(port, "s4.db", "SignAndEncrypt", password_login),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.certificate", 30.0).await;
    let m = active_message(&alarms, "opcua.certificate");
    assert!(
        m.contains("does not trust this client's certificate") && m.contains("own/cert.der"),
        "{m}"
    );
    assert!(strict.writes.lock().unwrap().is_empty());
    run.stop().await.unwrap();
    strict.stop().await;
}
