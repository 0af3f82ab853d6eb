//! The plant schema: versioned in `gearcomp_schema`, migrations run once each under a
//! transaction-level advisory lock so machines starting together do not race.

use postgres::Client;

use crate::error::{invalid, Result};
use crate::storage::unix_now_s;

/// Schema version this build writes.
pub const SCHEMA_VERSION: i32 = 2;

/// Advisory-lock class of gearcomp (first key of the two-key lock functions).
pub(super) const LOCK_CLASS: i32 = 0x6763_6f6d; // "gcom"

/// Migrations, index = version − 1. Each runs once, in the transaction that records it.
pub(super) const MIGRATIONS: [&str; 2] = [
    "
CREATE TABLE machines (id SERIAL PRIMARY KEY, name TEXT NOT NULL UNIQUE,
    last_batch BIGINT NOT NULL DEFAULT 0, created_unix_s DOUBLE PRECISION NOT NULL);
CREATE TABLE channels (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE axes (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE targets (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE samples (machine_id INTEGER NOT NULL, id BIGINT NOT NULL,
    time_s DOUBLE PRECISION NOT NULL, channel INTEGER NOT NULL, raw DOUBLE PRECISION,
    PRIMARY KEY (machine_id, id));
CREATE INDEX samples_time ON samples (machine_id, channel, time_s);
CREATE TABLE averages (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL,
    channel INTEGER NOT NULL, value DOUBLE PRECISION);
CREATE INDEX averages_time ON averages (machine_id, time_s);
CREATE TABLE offsets (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL, axis INTEGER NOT NULL,
    offset_um DOUBLE PRECISION, target_um DOUBLE PRECISION, law_um DOUBLE PRECISION,
    status TEXT NOT NULL);
CREATE INDEX offsets_time ON offsets (machine_id, time_s);
CREATE TABLE target_values (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL,
    target INTEGER NOT NULL, value DOUBLE PRECISION);
CREATE INDEX target_values_time ON target_values (machine_id, time_s);
CREATE TABLE alarms (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL, key TEXT NOT NULL,
    message TEXT NOT NULL, cleared_s DOUBLE PRECISION, acknowledged_by TEXT,
    acknowledged_unix_s DOUBLE PRECISION);
CREATE INDEX alarms_machine ON alarms (machine_id, id);
CREATE TABLE tokens (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, role TEXT NOT NULL, sha256 TEXT NOT NULL,
    created_unix_s DOUBLE PRECISION NOT NULL, UNIQUE (machine_id, sha256));
CREATE TABLE audit (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, unix_s DOUBLE PRECISION NOT NULL, token_id TEXT NOT NULL,
    role TEXT NOT NULL, action TEXT NOT NULL, detail TEXT NOT NULL);
CREATE TABLE models (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, unix_s DOUBLE PRECISION NOT NULL, source TEXT NOT NULL,
    config_toml TEXT NOT NULL);
",
    "
CREATE TABLE resume_state (machine_id INTEGER PRIMARY KEY REFERENCES machines(id),
    time_s DOUBLE PRECISION NOT NULL, state TEXT NOT NULL);
",
];

/// Creates or upgrades the schema (idempotent; safe when several services start at once).
pub fn migrate(client: &mut Client) -> Result<()> {
    let mut tx = client.transaction()?;
    tx.execute("SELECT pg_advisory_xact_lock($1, 0)", &[&LOCK_CLASS])?;
    tx.batch_execute(
        "CREATE TABLE IF NOT EXISTS gearcomp_schema (version INTEGER PRIMARY KEY, \
         applied_unix_s DOUBLE PRECISION NOT NULL)",
    )?;
    let row = tx.query_one("SELECT COALESCE(MAX(version), 0) FROM gearcomp_schema", &[])?;
    let have: i32 = row.try_get(0)?;
    if have > SCHEMA_VERSION {
        return Err(invalid(
            "gearcomp_schema.version",
            have,
            format!("≤ {SCHEMA_VERSION} (the database was written by a newer gearcomp)"),
        ));
    }
    for v in have + 1..=SCHEMA_VERSION {
        if let Some(sql) = MIGRATIONS.get((v - 1) as usize) {
            tx.batch_execute(sql)?;
        }
        tx.execute(
            "INSERT INTO gearcomp_schema (version, applied_unix_s) VALUES ($1, $2)",
            &[&v, &unix_now_s()],
        )?;
    }
    tx.commit()?;
    Ok(())
}
