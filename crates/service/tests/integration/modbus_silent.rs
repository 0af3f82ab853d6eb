//! A Modbus device that accepts TCP connections but never answers a read (a hung
//! gateway): the connection alarm must be one alarm with a growing wait, not one that
//! clears at every connect and is raised again at every read timeout.
#![cfg(feature = "modbus")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::io::Read;
use std::time::{Duration, Instant};

use common::{engine_ab, start_with, Api};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_device_is_one_connection_alarm() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(1.0)).unwrap();
    // Accepts, reads whatever comes, answers nothing; counts the connections.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let accepted = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let acc = accepted.clone();
    std::thread::spawn(move || {
        for s in listener.incoming() {
            let Ok(mut s) = s else { return };
            acc.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            std::thread::spawn(move || {
                let mut buf = [0u8; 256];
                while let Ok(n) = s.read(&mut buf) {
                    if n == 0 {
                        return;
                    }
                }
            });
        }
    });
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"silent.db\"\n\
             [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
             registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    // Each session ends after the 3 s read timeout: wait for three sessions (bounded).
    let deadline = Instant::now() + Duration::from_secs(30);
    while accepted.load(std::sync::atomic::Ordering::SeqCst) < 3 {
        assert!(
            Instant::now() < deadline,
            "the service stopped reconnecting"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let (_, all) = Api::new(&run)
        .get("/api/alarms?limit=1000", Some(&ro))
        .await;
    let rows: Vec<&serde_json::Value> = all
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["key"] == "modbus.0.connection")
        .collect();
    // One row, still open, naming the missing answer; before, every connect cleared it.
    assert_eq!(rows.len(), 1, "{all}");
    assert!(rows[0]["cleared_s"].is_null(), "{all}");
    assert!(
        rows[0]["message"].as_str().unwrap().contains("no answer"),
        "{all}"
    );
    run.stop().await.unwrap();
}
