//! The compensation service behind `gearcomp serve`: live sensor readings in (built-in
//! simulator, MQTT, Modbus TCP), the thermal engine of gearcomp-thermal stepping in a
//! dedicated cycle thread, offsets out (MQTT, Modbus register), every raw sample,
//! averaged value, offset and alarm kept in SQLite (WAL), and an HTTP API with a dashboard.
//!
//! * [`config`]: `machine.toml` ([`ServiceConfig`]), unknown keys refused.
//! * [`cycle`]: the cycle thread, the service clock, bumpless transfer on model changes.
//! * [`storage`]: the SQLite record, batched commits, CSV export for `gearcomp fit`.
//! * [`auth`]: tokens (generated at first start, stored hashed), read-only / operator.
//! * [`http`]: REST API and the dashboard page.
//! * [`sources`]: simulator, MQTT and Modbus adapters.
//! * [`service`]: [`serve`] puts it together and stops it cleanly.
//!
//! Conventions are listed in `docs/service.md`.

pub mod alarms;
pub mod auth;
pub mod config;
pub mod cycle;
pub mod error;
pub mod http;
pub mod service;
pub mod sources;
pub mod storage;

pub use config::{MachineEntry, ServiceConfig};
pub use error::{Result, ServiceError};
pub use service::{serve, serve_many, Overrides};
