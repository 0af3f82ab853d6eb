//! What the store (`mod.rs`) and the writer share: the connection settings and the
//! machine's key. It imports only [`super::connect`], which imports no room, so no room
//! needs to import `mod.rs`.

use postgres::Client;

use super::connect::Connection;
use crate::error::Result;

/// Connection settings and the machine's key, shared by the readers and the writer.
#[derive(Clone)]
pub(super) struct Target {
    pub(super) conn: Connection,
    pub(super) describe: String,
    pub(super) machine: String,
    pub(super) machine_id: i32,
    /// Which shared writer the machine joins: the settings its session depends on (kept
    /// in memory only; it may hold the password's variable name, never shown).
    pub(super) hub_key: String,
}

impl Target {
    pub(super) fn connect(&self) -> Result<Client> {
        self.conn.connect()
    }
}
