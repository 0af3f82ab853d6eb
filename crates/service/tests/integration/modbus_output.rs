//! The Modbus offset output when the device restarts or loses its register (issue 14
//! item 2): written again on every new connection, read back every `refresh_s`, alarmed
//! when the device does not hold it; and never a write before a valid offset exists.
#![cfg(feature = "modbus")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::future;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{engine_ab, free_port, start_with, Api};
use tokio_modbus::prelude::*;
use tokio_modbus::server::tcp::{accept_tcp_connection, Server};

/// A temperature module with a holding-register table; every write is logged.
#[derive(Clone, Default)]
pub struct Module {
    pub input: Arc<Mutex<[u16; 4]>>,
    pub holding: Arc<Mutex<[u16; 16]>>,
    pub coils: Arc<Mutex<[bool; 16]>>,
    pub writes: Arc<Mutex<Vec<(u16, u16)>>>,
}

impl tokio_modbus::server::Service for Module {
    type Request = Request<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = future::Ready<Result<Response, ExceptionCode>>;

    fn call(&self, req: Self::Request) -> Self::Future {
        let read = |regs: &[u16], addr: u16, cnt: u16| -> Result<Vec<u16>, ExceptionCode> {
            let (a, n) = (addr as usize, cnt as usize);
            regs.get(a..a + n)
                .map(<[u16]>::to_vec)
                .ok_or(ExceptionCode::IllegalDataAddress)
        };
        future::ready(match req {
            Request::ReadInputRegisters(a, n) => {
                read(&*self.input.lock().unwrap(), a, n).map(Response::ReadInputRegisters)
            }
            Request::ReadHoldingRegisters(a, n) => {
                read(&*self.holding.lock().unwrap(), a, n).map(Response::ReadHoldingRegisters)
            }
            Request::WriteSingleRegister(a, v) => {
                match self.holding.lock().unwrap().get_mut(a as usize) {
                    Some(r) => {
                        *r = v;
                        self.writes.lock().unwrap().push((a, v));
                        Ok(Response::WriteSingleRegister(a, v))
                    }
                    None => Err(ExceptionCode::IllegalDataAddress),
                }
            }
            Request::WriteMultipleRegisters(a, vs) => {
                let mut h = self.holding.lock().unwrap();
                match h.get_mut(a as usize..a as usize + vs.len()) {
                    Some(r) => {
                        r.copy_from_slice(&vs);
                        let mut w = self.writes.lock().unwrap();
                        w.extend(vs.iter().enumerate().map(|(i, v)| (a + i as u16, *v)));
                        Ok(Response::WriteMultipleRegisters(a, vs.len() as u16))
                    }
                    None => Err(ExceptionCode::IllegalDataAddress),
                }
            }
            Request::WriteSingleCoil(a, v) => {
                match self.coils.lock().unwrap().get_mut(a as usize) {
                    Some(c) => {
                        *c = v;
                        Ok(Response::WriteSingleCoil(a, v))
                    }
                    None => Err(ExceptionCode::IllegalDataAddress),
                }
            }
            Request::ReadCoils(a, n) => {
                let c = self.coils.lock().unwrap();
                c.get(a as usize..(a + n) as usize)
                    .map(|s| Response::ReadCoils(s.to_vec()))
                    .ok_or(ExceptionCode::IllegalDataAddress)
            }
            _ => Err(ExceptionCode::IllegalFunction),
        })
    }
}

/// Serves the module on 127.0.0.1:`port` (Modbus TCP, every connection to the same
/// registers) until the task ends.
pub async fn serve_module(port: u16, m: Module) {
    let listener = tokio::net::TcpListener::bind(("127.0.0.1", port))
        .await
        .unwrap();
    let server = Server::new(listener);
    let new_service = move |_addr| Ok(Some(m.clone()));
    let on_connected = |stream, addr| {
        let ns = new_service.clone();
        async move { accept_tcp_connection(stream, addr, ns) }
    };
    let _ = server.serve(&on_connected, |_e| {}).await;
}

/// A device on its own runtime: dropping it closes every connection, as a power cycle
/// does.
pub struct Device {
    rt: Option<tokio::runtime::Runtime>,
}

impl Device {
    pub fn start(port: u16, m: Module) -> Self {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        rt.spawn(serve_module(port, m));
        Self { rt: Some(rt) }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

pub async fn wait_until(what: &str, secs: f64, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    while !f() {
        assert!(Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn module_at(a_c: f64, b_c: f64) -> Module {
    let m = Module::default();
    *m.input.lock().unwrap() = [(a_c * 10.0) as u16, (b_c * 10.0) as u16, 0, 0];
    m
}

fn reg(m: &Module, a: usize) -> i16 {
    m.holding.lock().unwrap()[a] as i16
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn device_restart_and_lost_register_get_the_offset_again() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(1.0)).unwrap();
    let port = free_port();
    // Cz = −3.75·(24.0 − 20.0) = −15 µm → −150 counts of 0.1 µm.
    let m1 = module_at(24.0, 20.0);
    let dev = Device::start(port, m1.clone());
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"mb.db\"\n\
             [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             offset_output = {{ axis = \"Z\", address = 10, um_per_count = 0.1, refresh_s = 0.2 }}\n\
             [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
             registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    wait_until("first write", 15.0, || reg(&m1, 10) == -150).await;

    // The device loses its register while connected: read back, alarmed, written again.
    m1.holding.lock().unwrap()[10] = 0;
    let msg = api
        .wait_alarm("/api/alarms", &ro, "modbus.offset_output.held", 10.0)
        .await["message"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("register 10 holds 0 counts, expected -150 counts (-15 µm"),
        "{msg}"
    );
    wait_until("rewrite after the loss", 10.0, || reg(&m1, 10) == -150).await;
    // The next read-back finds it held: the alarm clears.
    api.wait_for("/api/alarms", &ro, 10.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .any(|a| a["key"] == "modbus.offset_output.held" && a["cleared_s"].is_number())
    })
    .await;

    // Power cycle: every connection dropped, a fresh device with the register at 0.
    drop(dev);
    let m2 = module_at(24.0, 20.0);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let _dev = Device::start(port, m2.clone());
    wait_until("rewrite after the device restart", 15.0, || {
        reg(&m2, 10) == -150
    })
    .await;
    // Held: the alarm clears once a read-back finds the value.
    let all = api
        .wait_for("/api/alarms", &ro, 10.0, |v| {
            let held: Vec<_> = v
                .as_array()
                .unwrap()
                .iter()
                .filter(|a| a["key"] == "modbus.offset_output.held")
                .collect();
            held.len() >= 2 && held.iter().all(|a| a["cleared_s"].is_number())
        })
        .await;
    // Raised twice: the loss while connected, and the power cycle.
    let held = all
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["key"] == "modbus.offset_output.held")
        .count();
    assert_eq!(held, 2, "{all}");
    run.stop().await.unwrap();
    // Only the valid offset was ever written (no 0 for "no value yet").
    for m in [&m1, &m2] {
        let w = m.writes.lock().unwrap().clone();
        assert!(!w.is_empty());
        assert!(w.iter().all(|&(a, v)| a == 10 && v as i16 == -150), "{w:?}");
    }
}

/// Stop / feed-hold and heartbeat (issue 14 item 8) through Modbus: the coil follows the
/// latched stop request (set when A exceeds its limit, kept while A is back in range,
/// released by the operator's acknowledge); the heartbeat register counts up while the
/// service runs and stops when it stops.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stop_coil_follows_the_latched_request_and_heartbeat_counts() {
    let dir = tempfile::tempdir().unwrap();
    // Channel A has an upper limit of 30 °C (EP0138375: an averaged value outside its
    // limits requests a stop).
    let engine = engine_ab(1.0).replacen(
        "stale_timeout_s = 1\n",
        "stale_timeout_s = 1\nlimit_max = 30.0\n",
        1,
    );
    assert!(engine.contains("limit_max = 30.0"), "{engine}");
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let m = module_at(24.0, 20.0);
    let _dev = Device::start(port, m.clone());
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"st.db\"\n\
             [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             offset_output = {{ axis = \"Z\", address = 10, um_per_count = 0.1 }}\n\
             stop_output = {{ address = 3, table = \"coil\" }}\n\
             heartbeat = {{ address = 11, period_s = 0.1 }}\n\
             [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
             registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
        ),
    )
    .await;
    let op = run.generated.clone().unwrap().operator;
    let api = Api::new(&run);
    let coil = |m: &Module| m.coils.lock().unwrap()[3];
    wait_until("offset", 15.0, || reg(&m, 10) == -150).await;
    assert!(!coil(&m));
    // Heartbeat: counts up while running.
    let b0 = reg(&m, 11) as u16;
    wait_until("heartbeat", 10.0, || {
        (reg(&m, 11) as u16).wrapping_sub(b0) >= 3
    })
    .await;

    // A at 35 °C: stop requested → coil set.
    m.input.lock().unwrap()[0] = 350;
    wait_until("stop coil set", 10.0, || coil(&m)).await;
    // Back in range: the request stays latched, the coil stays set.
    m.input.lock().unwrap()[0] = 240;
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert!(coil(&m), "stop released without acknowledgement");
    // The operator acknowledges: released.
    let r = api
        .client
        .post(format!("{}/api/stop/ack", api.base))
        .bearer_auth(&op)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    wait_until("stop coil released", 10.0, || !coil(&m)).await;

    run.stop().await.unwrap();
    // Dead compensator: the heartbeat no longer moves.
    let b1 = reg(&m, 11);
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(reg(&m, 11), b1);
}
