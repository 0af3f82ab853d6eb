//! OPC UA against an independent stack: python asyncua (opcua_asyncua_server.py, started
//! here as a subprocess) standing in for the CNC. One test writes the offsets of two axes
//! into a Float (REAL) and an Int16 (INT, counts of 1 nm) node, an Int16 heartbeat, and
//! checks the connect-time type check and the Int16 range check (alarm and hold, no wrap);
//! the other logs in over Basic256Sha256 SignAndEncrypt and Sign, with user name / password
//! and with an X.509 user certificate, trusts the server's certificate copied into
//! `pki_dir/trusted` under a name of our own, and checks the named refusals (untrusted
//! server certificate, wrong password, security None against a secure-only server).
//!
//! The server needs python3 with asyncua (`pip install -r .ci/requirements.txt`): under
//! CI=true a missing asyncua fails the tests, elsewhere they are skipped with a note.
#![cfg(feature = "opcua")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{active_message, alarm_active as active, free_port, start_with, Api};

const SCRIPT: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/integration/opcua_asyncua_server.py"
);

/// Whether the asyncua server can run here; under CI=true its absence is a failure.
fn asyncua_or_skip() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import asyncua"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but python3 cannot import asyncua: .ci/run installs it with \
             `pip install -r .ci/requirements.txt`"
        );
        eprintln!("SKIPPED: python3 with asyncua not found (pip install -r .ci/requirements.txt)");
    }
    ok
}

/// The python asyncua server and what it reported: every change of a writable node.
struct PyCnc {
    child: Child,
    stdin: ChildStdin,
    ready: serde_json::Value,
    /// Node name → (value, variant type) of its latest change.
    latest: Arc<Mutex<HashMap<String, (serde_json::Value, String)>>>,
    /// Every change, in order.
    log: Arc<Mutex<Vec<(String, serde_json::Value)>>>,
}

impl PyCnc {
    fn start(port: u16, dir: &std::path::Path, secure: Option<&str>) -> PyCnc {
        let mut cmd = Command::new("python3");
        cmd.arg(SCRIPT)
            .args(["--port", &port.to_string(), "--dir"])
            .arg(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        if let Some(pw) = secure {
            cmd.arg("--secure").env("GC_ASYNCUA_PASSWORD", pw);
        }
        let mut child = cmd.spawn().unwrap();
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let latest: Arc<Mutex<HashMap<String, (serde_json::Value, String)>>> = Arc::default();
        let log: Arc<Mutex<Vec<(String, serde_json::Value)>>> = Arc::default();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        {
            let (latest, log) = (latest.clone(), log.clone());
            std::thread::spawn(move || {
                for line in BufReader::new(stdout).lines() {
                    let Ok(line) = line else { break };
                    let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
                        continue;
                    };
                    if v["ready"] == true {
                        let _ = ready_tx.send(v);
                        continue;
                    }
                    let name = v["node"].as_str().unwrap_or("").to_string();
                    let ty = v["type"].as_str().unwrap_or("").to_string();
                    log.lock().unwrap().push((name.clone(), v["value"].clone()));
                    latest
                        .lock()
                        .unwrap()
                        .insert(name, (v["value"].clone(), ty));
                }
            });
        }
        let ready = ready_rx
            .recv_timeout(Duration::from_secs(60))
            .expect("the asyncua server did not report ready within 60 s");
        PyCnc {
            child,
            stdin,
            ready,
            latest,
            log,
        }
    }

    fn ns(&self) -> u64 {
        self.ready["ns"].as_u64().unwrap()
    }

    fn set(&mut self, name: &str, v: f64) {
        writeln!(self.stdin, "set {name} {v}").unwrap();
        self.stdin.flush().unwrap();
    }

    fn value(&self, name: &str) -> Option<(serde_json::Value, String)> {
        self.latest.lock().unwrap().get(name).cloned()
    }

    /// Waits (bounded) until node `name` holds `want` with variant type `ty`.
    async fn wait_value(&self, name: &str, want: serde_json::Value, ty: &str, secs: f64) {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        loop {
            let got = self.value(name);
            if got.as_ref().is_some_and(|(v, t)| *v == want && t == ty) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{name} = {got:?}, expected {want} ({ty}); changes {:?}",
                self.log.lock().unwrap()
            );
            tokio::time::sleep(Duration::from_millis(30)).await;
        }
    }
}

impl Drop for PyCnc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Engine AB with two axes: Z = −3.75·(A − B) µm (JPH0761598B2's grinder law) and
/// X = 2.5·(A − B) µm, no averaging, dead band or rate limit.
fn engine_zx() -> String {
    format!(
        "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"measuring_system\" }}\nmax_offset_um = 100.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = 2.5\n",
        common::engine_ab(5.0)
    )
}

fn input_head(port: u16, db: &str, ns: u64) -> String {
    common::opcua_input_head(port, &format!("path = \"{db}\""), ns, 0.3)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_asyncua_float_and_int16_outputs() {
    if !asyncua_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_zx()).unwrap();
    let port = free_port();
    let mut cnc = PyCnc::start(port, &dir.path().join("server"), None);
    let ns = cnc.ns();
    cnc.set("Temp.A", 24.0);
    // Z into a Float (REAL) node in µm, X into an Int16 (INT) node in counts of 1 nm
    // (scale 1000 counts per µm); the heartbeat an Int16; the stop output pointed at a
    // read-only Double node, which the connect check must refuse.
    let config = format!(
        "{}offset_outputs = [\n  {{ axis = \"Z\", node = \"ns={ns};s=Comp.F\", data_type = \"REAL\" }},\n  \
         {{ axis = \"X\", node = \"ns={ns};s=Comp.I16\", data_type = \"Int16\", scale = 1000.0 }},\n]\n\
         heartbeat = {{ node = \"ns={ns};s=Beat\", data_type = \"Int16\", period_s = 0.1 }}\n\
         stop_output = {{ node = \"ns={ns};s=Comp.RO\" }}\n",
        input_head(port, "a1.db", ns)
    );
    let run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // A − B = 4 K: Z = −15 µm (exact in binary32), X = 10 µm = 10000 counts.
    cnc.wait_value("Comp.F", serde_json::json!(-15.0), "Float", 30.0)
        .await;
    cnc.wait_value("Comp.I16", serde_json::json!(10000), "Int16", 10.0)
        .await;
    // The heartbeat counts in the Int16 node.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !cnc
        .value("Beat")
        .is_some_and(|(v, t)| v.as_i64().unwrap_or(0) >= 3 && t == "Int16")
    {
        assert!(Instant::now() < deadline, "Beat = {:?}", cnc.value("Beat"));
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    // The stop node is a read-only Double: named at connect, never written.
    let alarms = api.wait_active(&ro, "opcua.stop_output", 10.0).await;
    let m = active_message(&alarms, "opcua.stop_output");
    assert!(
        m.contains("Comp.RO") && m.contains("Double") && m.contains("Boolean"),
        "{m}"
    );

    // 24.4 °C: Z = −3.75·4.4 = −16.5 µm (the binary32 nearest), X = 11 µm = 11000 counts.
    cnc.set("Temp.A", 24.4);
    cnc.wait_value("Comp.F", serde_json::json!(-16.5), "Float", 10.0)
        .await;
    cnc.wait_value("Comp.I16", serde_json::json!(11000), "Int16", 10.0)
        .await;

    // 35 °C: X = 37.5 µm = 37500 counts > 32767: alarm, the node keeps 11000 (no wrap to
    // −28036); Z = −56.25 µm still goes out.
    cnc.set("Temp.A", 35.0);
    cnc.wait_value("Comp.F", serde_json::json!(-56.25), "Float", 10.0)
        .await;
    let alarms = api.wait_active(&ro, "opcua.offset_output.X", 10.0).await;
    let m = active_message(&alarms, "opcua.offset_output.X");
    assert!(
        m.contains("Int16") && m.contains("32767") && m.contains("keeps its last value"),
        "{m}"
    );
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(
        cnc.value("Comp.I16"),
        Some((serde_json::json!(11000), "Int16".to_string()))
    );
    assert!(
        !cnc.log
            .lock()
            .unwrap()
            .iter()
            .any(|(n, v)| n == "Comp.I16" && v.as_i64().is_some_and(|c| c < 0)),
        "a wrapped Int16 was written"
    );
    // Back to 24 °C: 10000 counts fit again, the alarm clears.
    cnc.set("Temp.A", 24.0);
    cnc.wait_value("Comp.I16", serde_json::json!(10000), "Int16", 10.0)
        .await;
    api.wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
        !active(v, "opcua.offset_output.X")
    })
    .await;
    run.stop().await.unwrap();

    // The earlier single-output form, as a Double, pointed at the Float node: the connect
    // check names the node, the type found and the type configured, and nothing is written.
    let writes_before = cnc.log.lock().unwrap().len();
    let config = format!(
        "{}offset_output = {{ axis = \"Z\", node = \"ns={ns};s=Comp.F\" }}\n",
        input_head(port, "a2.db", ns)
    );
    let run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.offset_output.Z", 20.0).await;
    let m = active_message(&alarms, "opcua.offset_output.Z");
    assert!(
        m.contains("Comp.F")
            && m.contains("has data type Float")
            && m.contains("Double")
            && m.contains("input.offset_output.data_type"),
        "{m}"
    );
    tokio::time::sleep(Duration::from_millis(500)).await;
    let after: Vec<_> = cnc.log.lock().unwrap()[writes_before..]
        .iter()
        .filter(|(n, _)| n == "Comp.F")
        .cloned()
        .collect();
    assert!(
        after.is_empty(),
        "written despite the type check: {after:?}"
    );
    run.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_asyncua_secure_logins_and_trust() {
    if !asyncua_or_skip() {
        return;
    }
    const PASSWORD: &str = "s3cret-Plant-pw";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), common::engine_ab(5.0)).unwrap();
    std::fs::write(dir.path().join("ua.pw"), format!("{PASSWORD}\n")).unwrap();
    std::fs::write(dir.path().join("wrong.pw"), "not-the-password\n").unwrap();
    let port = free_port();
    let mut cnc = PyCnc::start(port, &dir.path().join("server"), Some(PASSWORD));
    let ns = cnc.ns();
    cnc.set("Temp.A", 24.0);
    let out = format!("offset_output = {{ axis = \"Z\", node = \"ns={ns};s=Comp.D\" }}\n");
    let secure = |db: &str, mode: &str, login: &str| {
        format!(
            "{}security_policy = \"Basic256Sha256\"\nsecurity_mode = \"{mode}\"\n\
             pki_dir = \"pki\"\n{login}{out}",
            input_head(port, db, ns)
        )
    };

    // 1. SignAndEncrypt, user + password file; the server's certificate not yet trusted.
    let run = start_with(
        dir.path(),
        &secure(
            "s1.db",
            "SignAndEncrypt",
            "user = \"op\"\npassword_file = \"ua.pw\"\n",
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.certificate", 30.0).await;
    let m = active_message(&alarms, "opcua.certificate");
    assert!(
        m.contains("not trusted") && m.contains("rejected") && m.contains("trusted"),
        "{m}"
    );
    // The documented trust step, under a file name of our own.
    let trusted = dir.path().join("pki").join("trusted");
    std::fs::create_dir_all(&trusted).unwrap();
    std::fs::copy(
        cnc.ready["server_cert"].as_str().unwrap(),
        trusted.join("plant-cnc-17.der"),
    )
    .unwrap();
    // −3.75·(24 − 20) = −15 µm, over the encrypted session.
    cnc.wait_value("Comp.D", serde_json::json!(-15.0), "Double", 30.0)
        .await;
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
            !active(v, "opcua.certificate") && !active(v, "opcua.connection")
        })
        .await;
    assert!(!alarms.to_string().contains(PASSWORD));
    run.stop().await.unwrap();

    // 2. Sign only, X.509 user certificate login.
    let login = format!(
        "user_certificate = \"{}\"\nuser_private_key = \"{}\"\n",
        cnc.ready["user_cert"].as_str().unwrap(),
        cnc.ready["user_key"].as_str().unwrap()
    );
    let run = start_with(dir.path(), &secure("s2.db", "Sign", &login)).await;
    cnc.set("Temp.A", 24.4);
    cnc.wait_value(
        "Comp.D",
        serde_json::json!(-3.75 * (24.4 - 20.0)),
        "Double",
        30.0,
    )
    .await;
    run.stop().await.unwrap();

    // 3. The wrong password: opcua.login names the user, never a password.
    let run = start_with(
        dir.path(),
        &secure(
            "s3.db",
            "SignAndEncrypt",
            "user = \"op\"\npassword_file = \"wrong.pw\"\n",
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.login", 30.0).await;
    let m = active_message(&alarms, "opcua.login");
    assert!(m.contains("\"op\"") && m.contains("refused"), "{m}");
    let all = alarms.to_string();
    assert!(!all.contains("not-the-password") && !all.contains(PASSWORD));
    run.stop().await.unwrap();

    // 4. Security None against a server offering only Basic256Sha256.
    let run = start_with(
        dir.path(),
        &format!("{}pki_dir = \"pki\"\n{out}", input_head(port, "s4.db", ns)),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let alarms = api.wait_active(&ro, "opcua.security_policy", 30.0).await;
    let m = active_message(&alarms, "opcua.security_policy");
    assert!(
        m.contains("requires a secure policy")
            && m.contains("Basic256Sha256/SignAndEncrypt")
            && m.contains("Basic256Sha256/Sign")
            && !m.contains("BadTcpEndpointUrlInvalid"),
        "{m}"
    );
    run.stop().await.unwrap();
}
