//! The Modbus input against a hostile temperature module (a tokio-modbus server on loopback)
//! that answers register reads from a random script: good readings, valid frames with
//! another count of words than asked (0, 2 or 3), exception codes, and the broken-sensor
//! words 0x7FFF / 0x8000 outside the plausible range. Asserted on the record, for a fixed
//! seed and a fresh one:
//!
//! - the service and its input live on: after the script, good readings bring the offset to
//!   the law by hand, Cz = −3.75·(A − B) = −3.75·(24 − 20) = −15 µm;
//! - no step: consecutive stored offsets differ by at most the axis's rate limit (0.5 µm);
//! - nothing dropped silently: every answer with a wrong word count or an implausible word
//!   is one stored not-a-number sample (the channel faults, its axis freezes) with the
//!   register's alarm; every exception raises the register's alarm.
//!
//! Defect found (session 11): a valid frame of 0 or 2 words for a 1-word read hit the
//! `debug_assert` inside tokio-modbus's `read_input_registers` (the adapter's task panicked:
//! the input was dead for the rest of the run) and, in a release build, the poll skipped the
//! register without a sample or an alarm.
#![cfg(feature = "modbus")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::collections::VecDeque;
use std::future;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{fixed_then_fresh, free_port, start_with, step_beyond, stored_offsets, Api};
use proptest::prelude::*;
use tokio_modbus::prelude::*;
use tokio_modbus::server::tcp::{accept_tcp_connection, Server};

/// One answer of the module to one register read.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Answer {
    /// The register's word: tenths of °C.
    Good(u16),
    /// A valid frame with this many words (never 1).
    Words(usize),
    /// An exception response.
    Exception(u8),
    /// A broken-sensor word outside the plausible range (0x7FFF or 0x8000).
    Implausible(u16),
}

fn answer() -> impl Strategy<Value = Answer> {
    prop_oneof![
        5 => (200u16..300).prop_map(Answer::Good),
        1 => prop_oneof![Just(0usize), Just(2), Just(3)].prop_map(Answer::Words),
        1 => prop_oneof![Just(1u8), Just(2), Just(4), Just(6)].prop_map(Answer::Exception),
        1 => prop_oneof![Just(0x7FFFu16), Just(0x8000)].prop_map(Answer::Implausible),
    ]
}

/// The module: each read of register 0 (A) or 1 (B) takes the next answer of the script;
/// after it, A = 24.0 °C and B = 20.0 °C. Every answer given is logged with its address.
#[derive(Clone, Default)]
struct Hostile {
    script: Arc<Mutex<VecDeque<Answer>>>,
    given: Arc<Mutex<Vec<(u16, Answer)>>>,
}

impl tokio_modbus::server::Service for Hostile {
    type Request = Request<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = future::Ready<Result<Response, ExceptionCode>>;

    fn call(&self, req: Self::Request) -> Self::Future {
        let Request::ReadInputRegisters(a, 1) = req else {
            return future::ready(Err(ExceptionCode::IllegalFunction));
        };
        let next = self.script.lock().unwrap().pop_front();
        let ans = next.unwrap_or(Answer::Good(if a == 0 { 240 } else { 200 }));
        if next.is_some() {
            self.given.lock().unwrap().push((a, ans));
        }
        future::ready(match ans {
            Answer::Good(w) | Answer::Implausible(w) => Ok(Response::ReadInputRegisters(vec![w])),
            Answer::Words(n) => Ok(Response::ReadInputRegisters(vec![230; n])),
            Answer::Exception(c) => Err(match c {
                1 => ExceptionCode::IllegalFunction,
                2 => ExceptionCode::IllegalDataAddress,
                4 => ExceptionCode::ServerDeviceFailure,
                _ => ExceptionCode::ServerDeviceBusy,
            }),
        })
    }
}

async fn serve(port: u16, m: Hostile) {
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

/// Cz = −3.75·(A − B) on Z, at most 0.5 µm per cycle, channels stale after 1 s.
fn engine() -> String {
    let ch = |n: &str| {
        format!(
            "[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\n\
             valid_max = 80.0\nstale_timeout_s = 1.0\n"
        )
    };
    format!(
        "{}{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 100.0\n\
         max_step_um = 0.5\n[[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\n\
         kz_um_per_c = -3.75\n",
        ch("A"),
        ch("B")
    )
}

fn run_case(script: Vec<Answer>) -> Result<(), TestCaseError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("engine.toml"), engine()).unwrap();
        let port = free_port();
        let module = Hostile::default();
        *module.script.lock().unwrap() = script.iter().copied().collect();
        tokio::spawn(serve(port, module.clone()));
        let run = start_with(
            dir.path(),
            &format!(
                "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
                 [storage]\npath = \"f.db\"\n\
                 [input]\nkind = \"modbus\"\npoll_period_s = 0.02\n\
                 reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
                 [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
                 registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, \
                 {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
            ),
        )
        .await;
        let ro = run.generated.clone().unwrap().read_only;
        let api = Api::new(&run);
        // The script played out, then the law on the good readings: −15 µm.
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let (_, st) = api.get("/api/status", Some(&ro)).await;
            let played = module.script.lock().unwrap().is_empty();
            if played && st["axes"][0]["offset_um"].as_f64() == Some(-15.0) {
                break;
            }
            prop_assert!(
                Instant::now() < deadline,
                "input dead or offset off the law: {st}\nscript left: {}",
                module.script.lock().unwrap().len()
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let db = run.db.clone();
        run.stop().await.unwrap();

        let given = module.given.lock().unwrap().clone();
        prop_assert_eq!(given.len(), script.len());
        let conn = gearcomp_service::storage::open_read(&db).unwrap();
        let step = step_beyond(&stored_offsets(&db), 0.5);
        prop_assert!(
            step.is_none(),
            "offset (row, value, before) {:?}: a step beyond the rate limit",
            step
        );
        for (addr, ch) in [(0u16, 0i64), (1, 1)] {
            let bad = given
                .iter()
                .filter(|(a, x)| {
                    *a == addr && matches!(x, Answer::Words(_) | Answer::Implausible(_))
                })
                .count() as i64;
            let nan: i64 = conn
                .query_row(
                    "SELECT COUNT(*) FROM samples WHERE channel = ?1 AND raw IS NULL",
                    [ch],
                    |r| r.get(0),
                )
                .unwrap();
            prop_assert_eq!(nan, bad, "register {}: not-a-number samples", addr);
            let refused = given
                .iter()
                .any(|(a, x)| *a == addr && !matches!(x, Answer::Good(_)));
            let alarms: i64 = conn
                .query_row(
                    "SELECT COUNT(*) FROM alarms WHERE key = ?1",
                    [format!("modbus.0.register.{addr}")],
                    |r| r.get(0),
                )
                .unwrap();
            prop_assert_eq!(alarms > 0, refused, "register {}: alarms {}", addr, alarms);
        }
        let conn_alarms: i64 = conn
            .query_row(
                "SELECT COUNT(*) FROM alarms WHERE key LIKE 'modbus.0.connection%' AND time_s > \
                 (SELECT MIN(time_s) FROM samples)",
                [],
                |r| r.get(0),
            )
            .unwrap();
        prop_assert_eq!(conn_alarms, 0, "the connection dropped on a bad answer");
        Ok(())
    })
}

#[test]
fn hostile_register_answers_never_kill_the_input_nor_step_the_offset() {
    let strat = proptest::collection::vec(answer(), 10..60);
    fixed_then_fresh(&strat, 0x5e11_0003, 2, 2, run_case);
}
