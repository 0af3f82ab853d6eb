//! `gearcomp serve`: the compensation service (see `docs/service.md`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use gearcomp_service::{serve_many, MachineEntry, Overrides, ServiceConfig};

/// Runs the compensation service: sensors in, the engine in its cycle, offsets out, every
/// sample kept, HTTP API and dashboard.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "With no configuration it runs the embedded default: the simulated \
grinder of the thermal presets, the record in ./gearcomp.db, the dashboard on \
http://127.0.0.1:8080 (tokens printed at first start).\n\
Examples:\n  gearcomp serve --speedup 60\n  gearcomp serve --config machine.toml\n  \
gearcomp serve --config shaper1.toml --config grinder2.toml   (two machines, one process)\n  \
gearcomp serve --db gearcomp.db --export-csv log.csv   (then: gearcomp fit --data log.csv --target measured_drift_um)"
)]
pub struct Args {
    /// Service configuration (TOML); unknown keys are refused. Repeat it to serve several
    /// machines in one process (each with its own name, record and HTTP port).
    #[arg(long)]
    pub config: Vec<PathBuf>,
    /// Database file (overrides storage.path).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// HTTP port (overrides http.port; 0 picks a free port, printed on stdout).
    #[arg(long)]
    pub port: Option<u16>,
    /// Service-clock seconds per wall-clock second, 0.001…1e6: the simulator's speed, or the
    /// CSV replay's (log seconds per second); ignored by live inputs (real time).
    #[arg(long)]
    pub speedup: Option<f64>,
    /// Stop cleanly after this many wall-clock seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Export the record as a CSV for `gearcomp fit` and exit.
    #[arg(long, value_name = "CSV")]
    pub export_csv: Option<PathBuf>,
    /// Print the SHA-256 of a token (for `[[auth.tokens]] sha256 = ...`) and exit.
    #[arg(long, value_name = "TOKEN")]
    pub hash_token: Option<String>,
    /// Issue a new token (operator or read_only) into the record of --config/--db, written
    /// once to the new owner-only file --token-file, and exit. A running service accepts
    /// it within a second.
    #[arg(long, value_name = "ROLE", requires = "token_file")]
    pub issue_token: Option<String>,
    /// The file --issue-token writes the token to (created 0600; never overwritten).
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// Revoke the record's token with this id (8 hex digits, as --list-tokens and the
    /// audit log show) and exit. A running service refuses it within a second.
    #[arg(long, value_name = "ID")]
    pub revoke_token: Option<String>,
    /// List the record's tokens (id and role, never the token) and exit.
    #[arg(long)]
    pub list_tokens: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(t) = &args.hash_token {
        println!("{}", gearcomp_service::auth::hash_token(t));
        return Ok(());
    }
    let machines = load_machines(&args.config)?;
    if args.export_csv.is_some() && machines.len() > 1 {
        anyhow::bail!(
            "invalid --export-csv with {} --config: expected one machine's configuration",
            machines.len()
        );
    }
    let cfg = &machines[0].config;
    if args.issue_token.is_some() || args.revoke_token.is_some() || args.list_tokens {
        if machines.len() > 1 {
            anyhow::bail!(
                "invalid token command with {} --config: expected one machine's configuration",
                machines.len()
            );
        }
        return token_commands(&args, cfg);
    }
    if let Some(out) = &args.export_csv {
        return export_csv(out, args.db.as_ref(), cfg);
    }
    serve_many(
        machines,
        Overrides {
            duration_s: args.duration_s,
            speedup: args.speedup,
            port: args.port,
            db: args.db,
        },
    )?;
    Ok(())
}

/// The machines of the `--config` files, or the embedded default without one.
fn load_machines(config: &[PathBuf]) -> anyhow::Result<Vec<MachineEntry>> {
    Ok(match config {
        [] => vec![MachineEntry {
            source: "(default)".into(),
            config: ServiceConfig::default(),
        }],
        paths => paths
            .iter()
            .map(|p| {
                Ok(MachineEntry {
                    source: p.display().to_string(),
                    config: ServiceConfig::load(p)?,
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?,
    })
}

/// `--issue-token`, `--revoke-token`, `--list-tokens` on the record of `cfg` (or `--db`).
fn token_commands(args: &Args, cfg: &ServiceConfig) -> anyhow::Result<()> {
    let mut cfg = cfg.clone();
    if let Some(db) = &args.db {
        cfg.storage.path = db.clone();
    }
    let store = gearcomp_service::storage::open_store(&cfg)?;
    use gearcomp_service::auth;
    auth::secure_record(&cfg, None)?;
    if let Some(role) = &args.issue_token {
        let role = gearcomp_service::config::Role::from_name(role).ok_or_else(|| {
            anyhow::anyhow!("invalid --issue-token = {role:?}: expected operator or read_only")
        })?;
        let file = args.token_file.clone().unwrap_or_default();
        let id = auth::issue_token(&*store, role, &file)?;
        println!(
            "issued {} token {id} in {}; written to {} (owner-only)",
            role.name(),
            store.describe(),
            file.display()
        );
    }
    if let Some(id) = &args.revoke_token {
        let n = auth::revoke_token(&*store, id)?;
        println!("revoked {n} token(s) with id {id} in {}", store.describe());
    }
    if args.list_tokens {
        for (id, role) in auth::list_tokens(&*store)? {
            println!("{id} {}", role.name());
        }
    }
    Ok(())
}

/// `--export-csv`: the machine's rows of the PostgreSQL database of `cfg` (without `--db`),
/// else the SQLite record `--db` or `storage.path`.
fn export_csv(out: &Path, db: Option<&PathBuf>, cfg: &ServiceConfig) -> anyhow::Result<()> {
    if let (None, gearcomp_service::config::StorageBackend::Postgres) = (db, cfg.storage.backend) {
        // The record is this machine's rows in the PostgreSQL database of the config.
        let store = gearcomp_service::storage::open_store(cfg)?;
        let rows = gearcomp_service::storage::export_csv_from(&*store, out)
            .with_context(|| format!("export {} to {}", store.describe(), out.display()))?;
        println!("wrote {} ({rows} rows)", out.display());
        return Ok(());
    }
    let db = db.cloned().unwrap_or_else(|| cfg.storage.path.clone());
    if !db.exists() {
        anyhow::bail!(
            "invalid --db = {}: expected an existing record",
            db.display()
        );
    }
    let rows = gearcomp_service::storage::export_csv(&db, out)
        .with_context(|| format!("export {} to {}", db.display(), out.display()))?;
    println!("wrote {} ({rows} rows)", out.display());
    Ok(())
}
