//! The compensation service behind `gearcomp serve`: live sensor readings in (built-in
//! simulator, CSV replay, MQTT, Modbus TCP, OPC UA), the thermal engine of gearcomp-thermal
//! stepping in a dedicated cycle thread, offsets out (MQTT, Modbus register, OPC UA node),
//! every raw sample, averaged value, offset and alarm kept in SQLite (WAL) or PostgreSQL
//! (optionally over TLS, with a local spill file through outages), and an HTTP(S) API with a
//! dashboard. One process can serve several machines.
//!
//! * [`config`]: `machine.toml` ([`ServiceConfig`]), unknown keys refused.
//! * [`backoff`]: the reconnect back-off every client and the PostgreSQL store share.
//! * [`cycle`]: the cycle thread, bumpless transfer on model changes.
//! * [`clock`]: the service clock (sped-up time continuing the record; its wall-clock anchor).
//! * [`storage`]: the backend-neutral record (`Store`), SQLite and PostgreSQL, batched
//!   commits, CSV export for `gearcomp fit`.
//! * [`auth`]: tokens (generated at first start, stored hashed), read-only / operator.
//! * [`http`]: REST API and the dashboard page.
//! * [`sources`]: simulator, CSV replay, MQTT, Modbus TCP and OPC UA adapters.
//! * [`service`]: [`serve`] and [`serve_many`] put it together and stop it cleanly.
//!
//! Conventions are listed in `docs/service.md`.

pub mod alarms;
pub mod auth;
pub mod backoff;
pub mod clock;
pub mod config;
pub mod cycle;
pub mod error;
pub mod http;
pub mod latency;
pub mod service;
pub mod sources;
pub mod storage;

pub use config::{MachineEntry, ServiceConfig};
pub use error::{Result, ServiceError};
pub use service::{serve, serve_many, Overrides};
