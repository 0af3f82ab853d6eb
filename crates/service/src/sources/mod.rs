//! Input adapters: each turns a protocol's readings into [`crate::cycle::InputMsg`]s.

#[cfg(feature = "modbus")]
pub mod modbus;
#[cfg(feature = "mqtt")]
pub mod mqtt;
pub mod sim;
