//! Helpers shared by the service's integration tests (loopback only).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use gearcomp_service::service::{start, Running};
use gearcomp_service::ServiceConfig;

/// A free TCP port on 127.0.0.1 (bound, read, released).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Two °C channels A and B, Cz = −3.75·(A − B) on axis Z, no averaging, dead band or rate
/// limit, stale after `stale_s`.
pub fn engine_ab(stale_s: f64) -> String {
    let ch = |n: &str| {
        format!(
            "[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = {stale_s}\n"
        )
    };
    format!(
        "{}{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"measuring_system\" }}\nmax_offset_um = 100.0\n[[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n",
        ch("A"),
        ch("B")
    )
}

/// Starts the service from a configuration text written into `dir`.
pub async fn start_with(dir: &std::path::Path, toml: &str) -> Running {
    let p = dir.join("machine.toml");
    std::fs::write(&p, toml).unwrap();
    let cfg = ServiceConfig::load(&p).unwrap();
    start(cfg).await.unwrap()
}

/// An HTTP client for the service.
pub struct Api {
    pub base: String,
    pub client: reqwest::Client,
}

impl Api {
    pub fn new(r: &Running) -> Self {
        Self {
            base: format!("http://{}", r.addr),
            client: reqwest::Client::builder()
                .timeout(Duration::from_secs(5))
                .build()
                .unwrap(),
        }
    }

    pub async fn get(&self, path: &str, token: Option<&str>) -> (u16, serde_json::Value) {
        let mut rq = self.client.get(format!("{}{path}", self.base));
        if let Some(t) = token {
            rq = rq.bearer_auth(t);
        }
        let r = rq.send().await.unwrap();
        let code = r.status().as_u16();
        let v = r.json().await.unwrap_or(serde_json::Value::Null);
        (code, v)
    }

    /// Polls `path` until `pred` holds (bounded).
    /// Waits (bounded) until the alarm list at `path` (`/api/alarms`, optionally with a query)
    /// holds an alarm `key`, and returns that alarm.
    pub async fn wait_alarm(
        &self,
        path: &str,
        token: &str,
        key: &str,
        secs: f64,
    ) -> serde_json::Value {
        let v = self
            .wait_for(path, token, secs, |v| {
                v.as_array().unwrap().iter().any(|a| a["key"] == key)
            })
            .await;
        v.as_array()
            .unwrap()
            .iter()
            .find(|a| a["key"] == key)
            .unwrap()
            .clone()
    }

    pub async fn wait_for(
        &self,
        path: &str,
        token: &str,
        secs: f64,
        pred: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        loop {
            let (code, v) = self.get(path, Some(token)).await;
            if code == 200 && pred(&v) {
                return v;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting on {path}: {v}"
            );
            tokio::time::sleep(Duration::from_millis(40)).await;
        }
    }
}
