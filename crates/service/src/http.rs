//! The HTTP API (JSON) and the dashboard page, served by axum on the service's runtime.
//!
//! Every route needs a token (`Authorization: Bearer <token>`, or `?token=` for the page
//! itself); acknowledging an alarm, acknowledging a stop and changing the model need the
//! operator role and are written to the audit log.

// Handlers return axum's `Response` as their error so a refusal is one `?`-free early
// return; boxing it would only add an allocation per refused request.
#![allow(clippy::result_large_err)]

use std::path::PathBuf;
use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::body::Bytes;
use axum::extract::{Path as UrlPath, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use gearcomp_thermal::{Engine, EngineConfig};
use serde::Deserialize;
use serde_json::json;

use crate::auth::Tokens;
use crate::config::Role;
use crate::cycle::{Clock, InputMsg, Live};
use crate::storage::{self, Range, Record, SeriesKind, StoreStats};

const DASHBOARD_HTML: &str = include_str!("../assets/dashboard.html");
const DASHBOARD_JS: &str = include_str!("../assets/dashboard.js");

/// The model in use, as the API shows it.
#[derive(Debug, Clone)]
pub struct ModelInfo {
    /// Where it came from (preset name, file, or the operator's token id).
    pub source: String,
    /// The engine configuration.
    pub config: EngineConfig,
}

/// Shared state of the handlers.
pub struct AppState {
    /// The database file.
    pub db: PathBuf,
    /// Machine name.
    pub machine: String,
    /// The input kind, for the status page.
    pub input: String,
    /// Live state from the cycle.
    pub live: Arc<Mutex<Live>>,
    /// Token verifier.
    pub tokens: Tokens,
    /// To the cycle (model changes, stop acknowledgement).
    pub cycle: SyncSender<InputMsg>,
    /// To the store (operator actions); the store thread is the only writer.
    pub records: SyncSender<storage::Record>,
    /// The record (SQLite or PostgreSQL); every history, alarm and audit query goes here.
    pub store: Arc<dyn storage::Store>,
    /// The model in use.
    pub model: Mutex<ModelInfo>,
    /// Store counters.
    pub stats: Arc<StoreStats>,
    /// The service clock.
    pub clock: Clock,
    /// Start instant.
    pub started: Instant,
}

type Shared = Arc<AppState>;

/// The router with every route.
pub fn router(state: Shared) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/dashboard.js", get(script))
        .route("/api/status", get(status))
        .route("/api/channels", get(channels))
        .route("/api/offsets", get(offsets))
        .route("/api/alarms", get(alarms))
        .route("/api/alarms/{id}/ack", post(ack_alarm))
        .route("/api/stop/ack", post(ack_stop))
        .route("/api/history", get(history))
        .route("/api/model", get(get_model).put(put_model))
        .route("/api/audit", get(audit_log))
        .with_state(state)
}

fn err(code: StatusCode, msg: impl Into<String>) -> Response {
    (code, Json(json!({ "error": msg.into() }))).into_response()
}

/// A caller who presented a valid token.
struct Caller {
    role: Role,
    token_id: String,
}

fn authorize(
    st: &AppState,
    headers: &HeaderMap,
    query_token: Option<&str>,
    need: Role,
) -> Result<Caller, Response> {
    let bearer = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(str::trim);
    let Some(token) = bearer.or(query_token) else {
        return Err(err(
            StatusCode::UNAUTHORIZED,
            "missing token: send Authorization: Bearer <token>",
        ));
    };
    let Some(role) = st.tokens.role_of(token) else {
        return Err(err(StatusCode::UNAUTHORIZED, "unknown token"));
    };
    if role < need {
        return Err(err(
            StatusCode::FORBIDDEN,
            format!(
                "this action needs the {} role; the token is {}",
                need.name(),
                role.name()
            ),
        ));
    }
    Ok(Caller {
        role,
        token_id: Tokens::token_id(token),
    })
}

#[derive(Debug, Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

async fn page(
    State(st): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    match authorize(&st, &headers, q.token.as_deref(), Role::ReadOnly) {
        Ok(_) => Html(DASHBOARD_HTML).into_response(),
        Err(_) => (
            StatusCode::UNAUTHORIZED,
            Html("<!doctype html><title>gearcomp</title><p id=\"refused\">401: open this page with ?token=&lt;token&gt; (printed at first start).</p>"),
        )
            .into_response(),
    }
}

async fn script() -> Response {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        DASHBOARD_JS,
    )
        .into_response()
}

async fn db<T: Send + 'static>(
    st: &AppState,
    f: impl FnOnce(&dyn storage::Store) -> crate::error::Result<T> + Send + 'static,
) -> Result<T, Response> {
    // Store queries block (SQLite file, or a PostgreSQL client with its own runtime).
    let store = st.store.clone();
    tokio::task::spawn_blocking(move || f(&*store))
        .await
        .map_err(|e| err(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?
        .map_err(|e| err(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))
}

fn live(st: &AppState) -> Live {
    match st.live.lock() {
        Ok(l) => l.clone(),
        Err(p) => p.into_inner().clone(),
    }
}

async fn status(State(st): State<Shared>, headers: HeaderMap) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let l = live(&st);
    let source = st
        .model
        .lock()
        .map(|m| m.source.clone())
        .unwrap_or_default();
    use std::sync::atomic::Ordering;
    Json(json!({
        "machine": st.machine,
        "input": st.input,
        "model_source": source,
        "time_s": l.time_s,
        "clock_origin_s": st.clock.origin_s(),
        "speedup": st.clock.speedup(),
        "uptime_s": st.started.elapsed().as_secs_f64(),
        "status": l.status,
        "cycles": l.cycles,
        "samples_received": l.samples,
        "committed_samples": st.stats.committed_samples.load(Ordering::Acquire),
        "last_sample_id": st.stats.last_sample_id.load(Ordering::Acquire),
        "commits": st.stats.commits.load(Ordering::Relaxed),
        "storage": {
            "backend": st.store.backend(),
            "record": st.store.describe(),
            "reachable": !st.stats.unreachable.load(Ordering::Acquire),
            "buffered_records": st.stats.buffered_records.load(Ordering::Acquire),
            "dropped_records": st.stats.dropped_records.load(Ordering::Acquire),
            "spilled_records": st.stats.spilled_records.load(Ordering::Acquire),
        },
        "stop": l.stop,
        "axes": l.axes,
    }))
    .into_response()
}

async fn channels(State(st): State<Shared>, headers: HeaderMap) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    Json(live(&st).channels).into_response()
}

#[derive(Debug, Deserialize)]
struct RangeQuery {
    from_s: Option<f64>,
    to_s: Option<f64>,
    limit: Option<u32>,
    channel: Option<String>,
    kind: Option<String>,
    active: Option<bool>,
}

fn range(q: &RangeQuery) -> Result<Range, Response> {
    let r = Range {
        from_s: q.from_s.unwrap_or(f64::MIN),
        to_s: q.to_s.unwrap_or(f64::MAX),
        limit: q.limit.unwrap_or(1000).min(100_000),
    };
    if r.from_s.is_nan() || r.to_s.is_nan() || r.from_s > r.to_s {
        return Err(err(
            StatusCode::BAD_REQUEST,
            format!(
                "invalid range from_s = {} to_s = {}: expected from_s ≤ to_s",
                r.from_s, r.to_s
            ),
        ));
    }
    Ok(r)
}

async fn offsets(
    State(st): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<RangeQuery>,
) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let r = match range(&q) {
        Ok(r) => r,
        Err(e) => return e,
    };
    match db(&st, move |c| c.offset_history(r)).await {
        Ok(rows) => Json(json!({ "current": live(&st).axes, "history": rows })).into_response(),
        Err(e) => e,
    }
}

async fn history(
    State(st): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<RangeQuery>,
) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let r = match range(&q) {
        Ok(r) => r,
        Err(e) => return e,
    };
    let kind = match q.kind.as_deref().unwrap_or("average") {
        "raw" => SeriesKind::Raw,
        "average" => SeriesKind::Average,
        other => {
            return err(
                StatusCode::BAD_REQUEST,
                format!("invalid kind = {other:?}: expected raw or average"),
            )
        }
    };
    let names: Vec<String> = live(&st).channels.iter().map(|c| c.name.clone()).collect();
    let Some(name) = q.channel.clone() else {
        return err(
            StatusCode::BAD_REQUEST,
            format!("missing channel: expected one of {}", names.join(", ")),
        );
    };
    let Some(idx) = names.iter().position(|n| *n == name) else {
        return err(
            StatusCode::NOT_FOUND,
            format!(
                "invalid channel = {name:?}: expected one of {}",
                names.join(", ")
            ),
        );
    };
    match db(&st, move |c| c.channel_history(idx as u16, kind, r)).await {
        Ok(points) => Json(json!({ "channel": name, "points": points })).into_response(),
        Err(e) => e,
    }
}

async fn alarms(
    State(st): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<RangeQuery>,
) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let active = q.active.unwrap_or(false);
    let limit = q.limit.unwrap_or(200).min(10_000);
    match db(&st, move |c| c.alarms(active, limit)).await {
        Ok(rows) => Json(rows).into_response(),
        Err(e) => e,
    }
}

fn log(st: &AppState, r: Record) -> Result<(), Response> {
    st.records
        .try_send(r)
        .map_err(|_| err(StatusCode::SERVICE_UNAVAILABLE, "the store is busy; retry"))
}

fn audit(
    st: &AppState,
    who: &Caller,
    action: &'static str,
    detail: String,
) -> Result<(), Response> {
    log(
        st,
        Record::Audit {
            token_id: who.token_id.clone(),
            role: who.role.name(),
            action,
            detail,
        },
    )
}

async fn ack_alarm(
    State(st): State<Shared>,
    headers: HeaderMap,
    UrlPath(id): UrlPath<i64>,
) -> Response {
    let who = match authorize(&st, &headers, None, Role::Operator) {
        Ok(w) => w,
        Err(r) => return r,
    };
    let exists = db(&st, move |c| c.alarm_exists(id)).await;
    match exists {
        Ok(true) => {}
        Ok(false) => return err(StatusCode::NOT_FOUND, format!("no alarm with id = {id}")),
        Err(e) => return e,
    }
    if let Err(e) = log(
        &st,
        Record::AlarmAcknowledged {
            id,
            by: who.token_id.clone(),
        },
    ) {
        return e;
    }
    if let Err(e) = audit(&st, &who, "acknowledge_alarm", format!("alarm {id}")) {
        return e;
    }
    Json(json!({ "acknowledged": id })).into_response()
}

async fn ack_stop(State(st): State<Shared>, headers: HeaderMap) -> Response {
    let who = match authorize(&st, &headers, None, Role::Operator) {
        Ok(w) => w,
        Err(r) => return r,
    };
    if st.cycle.try_send(InputMsg::AckStop).is_err() {
        return err(StatusCode::SERVICE_UNAVAILABLE, "the cycle is busy; retry");
    }
    if let Err(e) = audit(&st, &who, "acknowledge_stop", String::new()) {
        return e;
    }
    Json(json!({ "acknowledged": "stop" })).into_response()
}

async fn get_model(State(st): State<Shared>, headers: HeaderMap) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let m = match st.model.lock() {
        Ok(m) => m.clone(),
        Err(p) => p.into_inner().clone(),
    };
    let toml = m.config.to_toml_string().unwrap_or_default();
    let models: Vec<String> = m.config.models.values().map(|f| f.name.clone()).collect();
    Json(json!({ "source": m.source, "config_toml": toml, "model_files": models })).into_response()
}

async fn put_model(State(st): State<Shared>, headers: HeaderMap, body: Bytes) -> Response {
    let who = match authorize(&st, &headers, None, Role::Operator) {
        Ok(w) => w,
        Err(r) => return r,
    };
    let text = match std::str::from_utf8(&body) {
        Ok(t) => t.to_string(),
        Err(e) => {
            return err(
                StatusCode::BAD_REQUEST,
                format!("body is not UTF-8 TOML: {e}"),
            )
        }
    };
    let current = match st.model.lock() {
        Ok(m) => m.config.clone(),
        Err(p) => p.into_inner().config.clone(),
    };
    let mut cfg = match EngineConfig::from_toml_str(&text) {
        Ok(c) => c,
        Err(e) => {
            return err(
                StatusCode::BAD_REQUEST,
                format!("engine configuration: {e}"),
            )
        }
    };
    // The record's channel layout is fixed for a database; a model change keeps it.
    let old: Vec<&str> = current.channels.iter().map(|c| c.name.as_str()).collect();
    let new: Vec<&str> = cfg.channels.iter().map(|c| c.name.as_str()).collect();
    if old != new {
        return err(
            StatusCode::BAD_REQUEST,
            format!("invalid channels = {new:?}: expected the channels in use, in order: {old:?}"),
        );
    }
    let old_axes: Vec<&str> = current.axes.iter().map(|a| a.name.as_str()).collect();
    let new_axes: Vec<&str> = cfg.axes.iter().map(|a| a.name.as_str()).collect();
    if old_axes != new_axes {
        return err(
            StatusCode::BAD_REQUEST,
            format!(
                "invalid axes = {new_axes:?}: expected the axes in use, in order: {old_axes:?}"
            ),
        );
    }
    cfg.models = current.models.clone();
    let engine = match Engine::new(&cfg) {
        Ok(e) => e,
        Err(e) => {
            return err(
                StatusCode::BAD_REQUEST,
                format!("engine configuration: {e}"),
            )
        }
    };
    if st
        .cycle
        .try_send(InputMsg::SwapEngine(
            Box::new(engine),
            Box::new(cfg.clone()),
        ))
        .is_err()
    {
        return err(StatusCode::SERVICE_UNAVAILABLE, "the cycle is busy; retry");
    }
    let source = format!("api:{}", who.token_id);
    if let Ok(mut m) = st.model.lock() {
        *m = ModelInfo {
            source: source.clone(),
            config: cfg,
        };
    }
    let logged = log(
        &st,
        Record::Model {
            source,
            config_toml: text.clone(),
        },
    )
    .and_then(|()| audit(&st, &who, "change_model", format!("{} bytes", text.len())));
    match logged {
        Ok(()) => Json(json!({ "model": "changed" })).into_response(),
        Err(e) => e,
    }
}

async fn audit_log(State(st): State<Shared>, headers: HeaderMap) -> Response {
    if let Err(r) = authorize(&st, &headers, None, Role::ReadOnly) {
        return r;
    }
    let res = db(&st, |c| c.audit_log(500)).await;
    match res {
        Ok(rows) => Json(rows).into_response(),
        Err(e) => e,
    }
}
