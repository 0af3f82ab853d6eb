//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../common/mod.rs"]
mod common;
#[cfg(feature = "postgres")]
mod postgres_common;

mod alarm_flood;
mod chaos;
mod dashboard_browser;
mod envelope;
mod http_api;
mod http_client_certs;
mod http_limits;
mod modbus;
mod modbus_fuzz;
mod modbus_output;
mod modbus_pulses;
mod modbus_silent;
mod mqtt;
mod mqtt_fuzz;
mod mqtt_limits;
mod mqtt_outputs;
mod mqtt_reconnect;
mod opcua;
mod opcua_asyncua;
mod opcua_fuzz;
mod opcua_pulses;
mod opcua_secure;
mod postgres;
mod postgres_kill;
mod postgres_spill;
mod postgres_tls;
mod replay;
mod replay_ack;
mod replay_positions;
mod replay_props;
mod restart;
mod storage;
