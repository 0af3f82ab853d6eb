//! Input adapters: each turns a protocol's readings into [`crate::cycle::InputMsg`]s.

#[cfg(feature = "modbus")]
pub mod modbus;
#[cfg(feature = "mqtt")]
pub mod mqtt;
#[cfg(feature = "opcua")]
pub mod opcua;
#[cfg(feature = "opcua")]
pub mod opcua_config;
pub mod replay;
pub mod replay_config;
pub mod sim;
