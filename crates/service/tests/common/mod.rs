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

/// [`engine_ab`] with the offset moving at most `max_step_um` per cycle.
pub fn engine_ab_rate_limited(stale_s: f64, max_step_um: f64) -> String {
    engine_ab(stale_s).replace(
        "max_offset_um = 100.0\n",
        &format!("max_offset_um = 100.0\nmax_step_um = {max_step_um:?}\n"),
    )
}

/// Starts the service from a configuration text written into `dir`.
pub async fn start_with(dir: &std::path::Path, toml: &str) -> Running {
    let p = dir.join("machine.toml");
    std::fs::write(&p, toml).unwrap();
    let cfg = ServiceConfig::load(&p).unwrap();
    start(cfg).await.unwrap()
}

/// Starts the service on a replay of `log.csv` in `dir` (engine `engine.toml`, record
/// `r.db`, `speedup` times real time, no HTTP port of its own) and waits (at most `secs`)
/// until the replay has ended. Returns the running service and its read-only token.
pub async fn replay_to_end(dir: &std::path::Path, speedup: &str, secs: f64) -> (Running, String) {
    let run = start_with(
        dir,
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[http]\nport = 0\n[storage]\npath = \"r.db\"\n\
             [input]\nkind = \"replay\"\npath = \"log.csv\"\nspeedup = {speedup}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    Api::new(&run)
        .wait_alarm("/api/alarms", &ro, "replay.ended", secs)
        .await;
    (run, ro)
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

    /// Waits (bounded) until `/api/alarms?active=true` lists an uncleared alarm `key`;
    /// returns the list.
    pub async fn wait_active(&self, token: &str, key: &str, secs: f64) -> serde_json::Value {
        self.wait_for("/api/alarms?active=true", token, secs, |v| {
            alarm_active(v, key)
        })
        .await
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

/// Channels A and B (°C), Z = −3.75·(A − B) applied as infeed pulses of 1 µm, at most
/// 0.1 µm per cycle.
pub const PULSE_ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
    valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 2.0\n\
    [[channels]]\nname = \"B\"\nsensor = { kind = \"celsius\" }\n\
    valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 2.0\n\
    [[axes]]\nname = \"Z\"\napply = { kind = \"pulses\", pulse_um = 1.0 }\n\
    max_offset_um = 100.0\nmax_step_um = 0.1\n\
    [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n";

/// What a PLC applies from a pulse-total output: each written total minus the total it
/// applied last (0 at first, kept in retained memory across power cycles), one step per
/// write. The sum of the steps is the distance it moved.
pub fn plc_steps<'a>(totals: impl IntoIterator<Item = &'a i64>) -> Vec<i64> {
    let mut last = 0i64;
    totals
        .into_iter()
        .map(|t| {
            let step = t - last;
            last = *t;
            step
        })
        .collect()
}

/// Channel A (°C) and axis Z with the SINUMERIK/TwinCAT position law: K0 = 2 + 0.5·(T − 20)
/// µm, tanβ = 0.25 + 0.0625·(T − 20) µm/mm, P0 = 100 mm.
pub const POSITION_ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
    valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
    [[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\nmax_offset_um = 100.0\n\
    [[axes.terms]]\nkind = \"position\"\nchannel = \"A\"\nt_ref_c = 20.0\noffset_um = 2.0\n\
    offset_um_per_c = 0.5\nslope_um_per_mm = 0.25\nslope_um_per_mm_per_c = 0.0625\np0_mm = 100.0\n";

/// The law by hand: K0(T) + tanβ(T)·(P − P0) with the constants of [`POSITION_ENGINE`].
/// At T = 24 °C: K0 = 4 µm, tanβ = 0.5 µm/mm, so P = 140 → 24 µm, 60 → −16 µm,
/// 100 → 4 µm, 237.5 → 72.75 µm (all exact in binary).
pub fn position_law_um(t_c: f64, p_mm: f64) -> f64 {
    let k0 = 2.0 + 0.5 * (t_c - 20.0);
    let tan_beta = 0.25 + 0.0625 * (t_c - 20.0);
    k0 + tan_beta * (p_mm - 100.0)
}

/// The anonymous async-opcua server the OPC UA tests stand up as CNC or PLC: loopback, one
/// simple node manager (`manager`, namespace `namespace_uri`, its index in `ns`), the
/// certificate store in a temporary directory. Bound to `port`, retrying while a previous
/// instance still holds it (a restart on the same port); not yet running: the test adds its
/// variables to `nm`, then spawns `server.run_with(listener)`.
#[cfg(feature = "opcua")]
pub struct OpcUaStandIn {
    pub server: opcua::server::Server,
    pub listener: tokio::net::TcpListener,
    pub handle: opcua::server::ServerHandle,
    pub nm: std::sync::Arc<opcua::server::node_manager::memory::SimpleNodeManager>,
    pub ns: u16,
    pub pki: tempfile::TempDir,
}

#[cfg(feature = "opcua")]
impl OpcUaStandIn {
    pub async fn bind(
        port: u16,
        name: &str,
        application_uri: &str,
        manager: &str,
        namespace_uri: &str,
    ) -> Self {
        use opcua::server::diagnostics::NamespaceMetadata;
        use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
        use opcua::server::ServerBuilder;

        let mut listener = None;
        for _ in 0..100 {
            match tokio::net::TcpListener::bind(("127.0.0.1", port)).await {
                Ok(l) => {
                    listener = Some(l);
                    break;
                }
                Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
            }
        }
        let listener = listener.unwrap();
        let pki = tempfile::tempdir().unwrap();
        let (server, handle) = ServerBuilder::new_anonymous(name)
            .application_uri(application_uri)
            .product_uri(application_uri)
            .host("127.0.0.1")
            .port(port)
            .discovery_urls(vec![format!("opc.tcp://127.0.0.1:{port}/")])
            .pki_dir(pki.path())
            .create_sample_keypair(false)
            .with_node_manager(simple_node_manager(
                NamespaceMetadata {
                    namespace_uri: namespace_uri.to_owned(),
                    ..Default::default()
                },
                manager,
            ))
            .build()
            .unwrap();
        let nm = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .unwrap();
        let ns = handle.get_namespace_index(namespace_uri).unwrap();
        OpcUaStandIn {
            server,
            listener,
            handle,
            nm,
            ns,
            pki,
        }
    }

    /// Spawns the server (once the test has added its variables to `nm`).
    pub fn run(self) -> OpcUaRunning {
        OpcUaRunning {
            task: tokio::spawn(self.server.run_with(self.listener)),
            handle: self.handle,
            nm: self.nm,
            ns: self.ns,
            _pki: self.pki,
        }
    }
}

/// A running [`OpcUaStandIn`]: its variables are set by the test, it stops on request.
#[cfg(feature = "opcua")]
pub struct OpcUaRunning {
    pub handle: opcua::server::ServerHandle,
    pub task: tokio::task::JoinHandle<Result<(), String>>,
    pub nm: std::sync::Arc<opcua::server::node_manager::memory::SimpleNodeManager>,
    pub ns: u16,
    _pki: tempfile::TempDir,
}

#[cfg(feature = "opcua")]
impl OpcUaRunning {
    /// Sets variable `ns=<ns>;s=<name>` to `value`, time-stamped now (subscribers see it).
    pub fn set(&self, name: &str, value: impl Into<opcua::types::Variant>) {
        self.nm
            .set_value(
                self.handle.subscriptions(),
                &opcua::types::NodeId::new(self.ns, name),
                None,
                opcua::types::DataValue::new_now(value.into()),
            )
            .unwrap();
    }

    /// Cancels the server and waits (at most 10 s) for its task.
    pub async fn stop(self) {
        self.handle.cancel();
        let _ = tokio::time::timeout(Duration::from_secs(10), self.task).await;
    }
}

/// The variable `ns=<ns>;s=<name>` (browse and display name `name`) of type `data_type`
/// holding `value`, under the Objects folder; `writable` for an output node (offset,
/// pulses, feed hold, heartbeat: the test logs the writes with a write callback on the
/// returned id), else read-only for clients.
#[cfg(feature = "opcua")]
pub fn add_variable(
    space: &mut opcua::server::address_space::AddressSpace,
    ns: u16,
    name: &str,
    data_type: opcua::types::DataTypeId,
    value: impl Into<opcua::types::Variant>,
    writable: bool,
) -> opcua::types::NodeId {
    let id = opcua::types::NodeId::new(ns, name);
    let mut b = opcua::server::address_space::VariableBuilder::new(&id, name, name)
        .data_type(data_type)
        .value(value)
        .organized_by(opcua::types::ObjectId::ObjectsFolder);
    if writable {
        b = b.writable();
    }
    b.insert(space);
    id
}

/// True when the alarm list `v` (`/api/alarms`) holds an uncleared alarm `key`.
pub fn alarm_active(v: &serde_json::Value, key: &str) -> bool {
    v.as_array()
        .unwrap()
        .iter()
        .any(|a| a["key"] == key && a["cleared_s"].is_null())
}

/// The message of the (last) uncleared alarm `key` in the alarm list `v`, empty if none.
pub fn active_message(v: &serde_json::Value, key: &str) -> String {
    v.as_array()
        .unwrap()
        .iter()
        .rev()
        .find(|a| a["key"] == key && a["cleared_s"].is_null())
        .map(|a| a["message"].as_str().unwrap().to_string())
        .unwrap_or_default()
}

/// The head of an OPC UA machine file: `engine.toml`, a 0.1 s cycle, HTTP on a free port,
/// the `[storage]` keys `storage` (e.g. `path = "ua.db"`), and `[input]` on
/// `opc.tcp://127.0.0.1:<port>/` with 0.05 s publishing, 0.1 s scans, reconnect back-off
/// 0.05…`reconnect_max_s` s and channels A and B on `ns=<ns>;s=Temp.A` / `Temp.B`. The
/// caller appends the rest of `[input]` (outputs, security, login).
pub fn opcua_input_head(
    port: u16,
    storage: &str,
    ns: impl std::fmt::Display,
    reconnect_max_s: f64,
) -> String {
    format!(
        "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
         [storage]\n{storage}\n\
         [input]\nkind = \"opcua\"\nendpoint = \"opc.tcp://127.0.0.1:{port}/\"\n\
         publishing_interval_s = 0.05\nscan_period_s = 0.1\n\
         reconnect = {{ min_s = 0.05, max_s = {reconnect_max_s} }}\n\
         channels = [{{ channel = \"A\", node = \"ns={ns};s=Temp.A\" }}, {{ channel = \"B\", node = \"ns={ns};s=Temp.B\" }}]\n"
    )
}

/// The offsets stored for engine axis 0 in the SQLite record `db`, in order.
pub fn stored_offsets(db: &std::path::Path) -> Vec<f64> {
    let conn = gearcomp_service::storage::open_read(db).unwrap();
    let mut st = conn
        .prepare("SELECT offset_um FROM offsets WHERE axis = 0 ORDER BY id")
        .unwrap();
    st.query_map([], |r| r.get(0))
        .unwrap()
        .map(|r| r.unwrap())
        .collect()
}

/// The first stored offset (from a start at 0 µm) that moved by more than `max_step_um`
/// from the one before it: (row, offset, offset before), `None` when every step is within
/// the rate limit.
pub fn step_beyond(offsets: &[f64], max_step_um: f64) -> Option<(usize, f64, f64)> {
    let mut prev = 0.0;
    for (k, &y) in offsets.iter().enumerate() {
        if (y - prev).abs() > max_step_um + 1e-9 {
            return Some((k, y, prev));
        }
        prev = y;
    }
    None
}

/// Runs `case` over `strat`: `fixed` cases from `seed`, then `fresh` ones from a new seed
/// (no persisted failures, short shrinking: each case runs a service).
pub fn fixed_then_fresh<S: proptest::strategy::Strategy>(
    strat: &S,
    seed: u64,
    fixed: u32,
    fresh: u32,
    case: impl Fn(S::Value) -> Result<(), proptest::test_runner::TestCaseError>,
) {
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let base = Config {
        failure_persistence: None,
        max_shrink_iters: 16,
        ..Config::default()
    };
    let fixed = Config {
        cases: fixed,
        rng_seed: RngSeed::Fixed(seed),
        ..base.clone()
    };
    let fresh = Config {
        cases: fresh,
        ..base
    };
    for cfg in [fixed, fresh] {
        TestRunner::new(cfg).run(strat, &case).unwrap();
    }
}
