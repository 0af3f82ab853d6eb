//! The HTTP API (JSON) and the dashboard page, served by axum on the service's runtime.
//!
//! Every route needs a token (`Authorization: Bearer <token>`, or `?token=` for the page
//! itself); acknowledging an alarm, acknowledging a stop and changing the model need the
//! operator role and are written to the audit log.
//!
//! In axum's idiom: a handler names the role it needs as an extractor ([`Viewer`] or
//! [`Operator`]), so the token is checked before the handler (and before a body is read),
//! and every refusal or failure is an [`ApiError`], which is its own response.

use std::path::PathBuf;
use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::{FromRequestParts, Path as UrlPath, Query, State};
use axum::http::request::Parts;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use gearcomp_thermal::{Engine, EngineConfig};
use serde::Deserialize;
use serde_json::json;

use crate::auth::Tokens;
use crate::clock::Clock;
use crate::config::Role;
use crate::cycle::{InputMsg, Live};
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
    /// A request body must arrive whole within this time (`http.body_read_timeout_s`).
    pub body_read_timeout: Duration,
}

type Shared = Arc<AppState>;

/// How often a running service reads the record's tokens again (issued or revoked by
/// `gearcomp serve --issue-token` / `--revoke-token` while it runs).
pub const TOKEN_RELOAD: Duration = Duration::from_secs(1);

async fn reload_tokens(state: std::sync::Weak<AppState>) {
    let mut tick = tokio::time::interval(TOKEN_RELOAD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        let Some(st) = state.upgrade() else { return };
        // The store blocks (SQLite file, PostgreSQL client): off the async workers. A
        // failed read keeps the tokens as they were.
        let _ = tokio::task::spawn_blocking(move || st.tokens.reload(&*st.store)).await;
    }
}

/// The router with every route. Within a tokio runtime it also starts the task that
/// keeps the tokens current (it ends with the router's state).
pub fn router(state: Shared) -> Router {
    if tokio::runtime::Handle::try_current().is_ok() {
        tokio::spawn(reload_tokens(Arc::downgrade(&state)));
    }
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
        .fallback(unknown_path)
        .method_not_allowed_fallback(wrong_method)
        .with_state(state)
}

/// A path the API does not have: 404 with the API's JSON error, naming it and the paths.
async fn unknown_path(uri: axum::http::Uri) -> ApiError {
    err(
        StatusCode::NOT_FOUND,
        format!(
            "no such path {}: expected one of {}",
            crate::error::shown(uri.path()),
            API_PATHS.join(", ")
        ),
    )
}

/// A method a path does not take: 405 with the API's JSON error.
async fn wrong_method(method: axum::http::Method, uri: axum::http::Uri) -> ApiError {
    err(
        StatusCode::METHOD_NOT_ALLOWED,
        format!(
            "{method} is not a method of {}: expected one of {}",
            crate::error::shown(uri.path()),
            API_PATHS.join(", ")
        ),
    )
}

/// The paths of the API and the dashboard, for the 404 message.
const API_PATHS: [&str; 11] = [
    "/ (dashboard)",
    "/dashboard.js",
    "GET /api/status",
    "GET /api/channels",
    "GET /api/offsets",
    "GET /api/alarms",
    "POST /api/alarms/{id}/ack",
    "POST /api/stop/ack",
    "GET /api/history",
    "GET|PUT /api/model",
    "GET /api/audit",
];

/// Every refusal and failure of the API: a status and a message, answered as
/// `{"error": "<message>"}`.
#[derive(Debug)]
pub struct ApiError {
    /// The HTTP status.
    pub status: StatusCode,
    /// What went wrong, naming the parameter, the value and what was expected.
    pub message: String,
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.status, Json(json!({ "error": self.message }))).into_response()
    }
}

impl From<crate::error::ServiceError> for ApiError {
    fn from(e: crate::error::ServiceError) -> Self {
        err(StatusCode::INTERNAL_SERVER_ERROR, e.to_string())
    }
}

/// What a handler returns.
type ApiResult<T = Response> = Result<T, ApiError>;

/// An API error; a long value the caller sent is shown by its start and length
/// ([`crate::error::shorten_message`]).
fn err(code: StatusCode, msg: impl Into<String>) -> ApiError {
    ApiError {
        status: code,
        message: crate::error::shorten_message(&msg.into()),
    }
}

/// A caller who presented a valid token.
pub struct Caller {
    role: Role,
    token_id: String,
}

/// Extractor: a caller with any valid token (read-only or operator); 401 otherwise.
pub struct Viewer(pub Caller);

/// Extractor: a caller with an operator token; 401 without a valid token, 403 for a
/// read-only one.
pub struct Operator(pub Caller);

impl FromRequestParts<Shared> for Viewer {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, st: &Shared) -> ApiResult<Self> {
        let peer = parts.extensions.get::<Peer>();
        authorize(st, &parts.headers, None, peer, Role::ReadOnly).map(Viewer)
    }
}

impl FromRequestParts<Shared> for Operator {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, st: &Shared) -> ApiResult<Self> {
        let peer = parts.extensions.get::<Peer>();
        authorize(st, &parts.headers, None, peer, Role::Operator).map(Operator)
    }
}

/// The query string of an API request; a parameter that does not parse is refused as the
/// API's other errors are (JSON, 400), naming the parameter, why and what it takes (axum's
/// own rejection was plain text without the range: "limit: invalid digit found in string").
pub struct ApiQuery<T>(pub T);

impl<T: serde::de::DeserializeOwned> FromRequestParts<Shared> for ApiQuery<T> {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, st: &Shared) -> ApiResult<Self> {
        match Query::<T>::from_request_parts(parts, st).await {
            Ok(Query(q)) => Ok(ApiQuery(q)),
            Err(e) => Err(err(StatusCode::BAD_REQUEST, query_message(&e.body_text()))),
        }
    }
}

/// The query parameters of the API and what each takes.
const QUERY_PARAMETERS: [(&str, &str); 9] = [
    ("from_s", "a service time in s"),
    ("to_s", "a service time in s"),
    ("last_s", "a wall-clock span in s"),
    (
        "limit",
        "a whole number of rows 0…4294967295 (at most 100000 are returned)",
    ),
    ("max_points", "a whole number 1…2000"),
    ("channel", "a channel name"),
    ("kind", "raw or average"),
    ("active", "true or false"),
    ("unacknowledged", "true or false"),
];

/// The message for a query string that did not parse (`text` as axum gives it).
fn query_message(text: &str) -> String {
    let detail = text
        .strip_prefix("Failed to deserialize query string: ")
        .unwrap_or(text);
    let named = |f: &str| QUERY_PARAMETERS.iter().find(|(k, _)| *k == f);
    let param = match detail.split_once(": ") {
        Some((f, why)) => named(f).map(|p| (p, why)),
        None => None,
    }
    .or_else(|| {
        QUERY_PARAMETERS
            .iter()
            .find(|(k, _)| detail.contains(&format!("`{k}`")))
            .map(|p| (p, detail))
    });
    match param {
        Some(((name, expected), why)) => {
            format!("invalid query parameter {name} ({why}): expected {expected}, given once")
        }
        None => format!("invalid query string ({detail})"),
    }
}

/// The alarm id of a request path (`/api/alarms/{id}/ack`); one that is not a number is
/// refused naming it and what it takes (axum's rejection was plain text).
pub struct AlarmId(pub i64);

impl FromRequestParts<Shared> for AlarmId {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, st: &Shared) -> ApiResult<Self> {
        match UrlPath::<String>::from_request_parts(parts, st).await {
            Ok(UrlPath(text)) => text.parse::<i64>().map(AlarmId).map_err(|_| {
                err(
                    StatusCode::BAD_REQUEST,
                    format!(
                        "invalid alarm id = {}: expected the alarm's whole number, as GET \
                         /api/alarms lists it",
                        crate::error::shown(&text)
                    ),
                )
            }),
            Err(e) => Err(err(StatusCode::BAD_REQUEST, e.body_text())),
        }
    }
}

/// The caller's role: from the token when one is presented (unknown: 401), else from a
/// client certificate named in `http.tls.client_roles`; with `certificates_only` from the
/// certificate alone. 403 when the role is below `need`.
fn authorize(
    st: &AppState,
    headers: &HeaderMap,
    query_token: Option<&str>,
    peer: Option<&Peer>,
    need: Role,
) -> ApiResult<Caller> {
    let bearer = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(str::trim);
    // An empty token (the dashboard opened without ?token=) is no token.
    let token = bearer
        .filter(|t| !t.is_empty())
        .or(query_token.filter(|t| !t.is_empty()));
    let certificates_only = peer.is_some_and(|p| p.certificates_only);
    let (role, id) = match (token, peer.and_then(|p| p.role.as_ref())) {
        (Some(token), _) if !certificates_only => {
            let Some(role) = st.tokens.role_of(token) else {
                return Err(err(StatusCode::UNAUTHORIZED, "unknown token"));
            };
            (role, Tokens::token_id(token))
        }
        (_, Some((name, role))) => (*role, format!("cert:{name}")),
        (_, None) => {
            let cert = match peer.and_then(|p| p.shown.as_deref()) {
                Some(n) => format!(
                    "the client certificate {n:?} is named in no http.tls.client_roles entry"
                ),
                None => "no client certificate".to_string(),
            };
            return Err(err(
                StatusCode::UNAUTHORIZED,
                if certificates_only {
                    format!("this server accepts client certificates only (http.tls.certificates_only); {cert}")
                } else if peer.is_some() {
                    format!("missing token: send Authorization: Bearer <token>, or a client certificate named in http.tls.client_roles ({cert})")
                } else {
                    "missing token: send Authorization: Bearer <token>".to_string()
                },
            ));
        }
    };
    if role < need {
        return Err(err(
            StatusCode::FORBIDDEN,
            format!(
                "this action needs the {} role; the {} is {}",
                need.name(),
                if id.starts_with("cert:") {
                    "client certificate"
                } else {
                    "token"
                },
                role.name()
            ),
        ));
    }
    Ok(Caller { role, token_id: id })
}

#[derive(Debug, Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

async fn page(
    State(st): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
    peer: Option<axum::Extension<Peer>>,
) -> Response {
    let peer = peer.as_ref().map(|p| &p.0);
    match authorize(&st, &headers, q.token.as_deref(), peer, Role::ReadOnly) {
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
) -> ApiResult<T> {
    // Store queries block (SQLite file, or a PostgreSQL client with its own runtime).
    let store = st.store.clone();
    tokio::task::spawn_blocking(move || f(&*store))
        .await
        .map_err(|e| err(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?
        .map_err(ApiError::from)
}

fn live(st: &AppState) -> Live {
    match st.live.lock() {
        Ok(l) => l.clone(),
        Err(p) => p.into_inner().clone(),
    }
}

/// What each axis and engine status means, as `/api/status` (`legend`), the dashboard and
/// docs/service.md show it.
pub const STATUS_LEGEND: &[(&str, &str)] = &[
    (
        "starting",
        "not every channel of the law has an averaged value yet; offset 0",
    ),
    (
        "updated",
        "the running compensation followed the law (it moved by at least the dead band D)",
    ),
    (
        "held",
        "the law is within the dead band D of the running compensation, which is kept",
    ),
    (
        "clamped",
        "the law exceeded max_offset_um; the compensation is limited to it",
    ),
    (
        "ramping",
        "the applied offset moves to the compensation at the rate limit (max_step_um per cycle)",
    ),
    (
        "waiting_safe_point",
        "a change waits for the next safe point (safe_points_only)",
    ),
    (
        "frozen",
        "a channel of the law is faulty or a position is missing: compensation frozen at its last good value",
    ),
    (
        "stopped",
        "a limit was violated: stop requested, no correction until an operator acknowledges it",
    ),
    ("running", "engine: every input good"),
    ("alarm", "engine: at least one alarm this cycle; the affected axes are frozen"),
    (
        "stop_requested",
        "engine: a limit was violated; the stop is latched until acknowledged",
    ),
];

/// The unit of a channel's raw reading and of its converted value.
pub fn channel_units(sensor: &gearcomp_thermal::SensorKind) -> (&'static str, &'static str) {
    use gearcomp_thermal::SensorKind as K;
    match sensor {
        K::Celsius {} => ("°C", "°C"),
        K::Pt100 {} | K::Pt1000 {} | K::NtcBeta { .. } | K::NtcSteinhartHart { .. } => ("Ω", "°C"),
        K::Displacement { .. } => ("raw unit (value = gain·raw + offset)", "µm"),
    }
}

async fn status(State(st): State<Shared>, Viewer(who): Viewer) -> Response {
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
        // A service time t happened at unix_s − (time_s − t) / speedup (wall clock, s since
        // the Unix epoch); exact within this run.
        "wall_clock": {
            "unix_s": storage::unix_now_s(),
            "time_s": st.clock.now_s(),
            "speedup": st.clock.speedup(),
        },
        "role": who.role.name(),
        "legend": STATUS_LEGEND.iter().map(|(k, v)| (*k, *v)).collect::<std::collections::BTreeMap<_, _>>(),
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
        // Scan complete → offset in the output cell (upper bounds of log buckets, ≤ 19 %
        // above the exact quantile); null before the first scan-triggered step.
        "latency": {
            "scans": l.latency.count(),
            "p50_s": l.latency.quantile_s(0.5),
            "p99_s": l.latency.quantile_s(0.99),
        },
    }))
    .into_response()
}

async fn channels(State(st): State<Shared>, _: Viewer) -> Response {
    let sensors: Vec<gearcomp_thermal::SensorKind> = match st.model.lock() {
        Ok(m) => m.config.channels.iter().map(|c| c.sensor).collect(),
        Err(p) => p
            .into_inner()
            .config
            .channels
            .iter()
            .map(|c| c.sensor)
            .collect(),
    };
    let rows: Vec<serde_json::Value> = live(&st)
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let (raw_unit, unit) = sensors.get(i).map_or(("", ""), channel_units);
            let mut v = json!(c);
            v["raw_unit"] = json!(raw_unit);
            v["unit"] = json!(unit);
            v
        })
        .collect();
    Json(rows).into_response()
}

#[derive(Debug, Deserialize)]
struct RangeQuery {
    from_s: Option<f64>,
    to_s: Option<f64>,
    limit: Option<u32>,
    channel: Option<String>,
    kind: Option<String>,
    active: Option<bool>,
    unacknowledged: Option<bool>,
    last_s: Option<f64>,
    max_points: Option<u32>,
}

/// Longest span `last_s` may ask for, s (100 years: a longer one spans no more of any
/// record, and one near f64::MAX left no time resolution for `max_points`' spans).
pub const MAX_LAST_S: f64 = 3.2e9;

/// Most points `max_points` may ask for.
pub const MAX_POINTS: u32 = 2000;

fn range(st: &AppState, q: &RangeQuery) -> ApiResult<Range> {
    let mut r = Range {
        from_s: q.from_s.unwrap_or(f64::MIN),
        to_s: q.to_s.unwrap_or(f64::MAX),
        limit: q.limit.unwrap_or(1000).min(100_000),
    };
    for (key, v) in [("from_s", q.from_s), ("to_s", q.to_s)] {
        if let Some(v) = v.filter(|v| !v.is_finite()) {
            return Err(err(
                StatusCode::BAD_REQUEST,
                format!("invalid {key} = {v}: expected a finite service time in s"),
            ));
        }
    }
    if let Some(last_s) = q.last_s {
        // The last `last_s` seconds of wall-clock time, up to now.
        if !(last_s.is_finite() && last_s > 0.0 && last_s <= MAX_LAST_S) {
            return Err(err(
                StatusCode::BAD_REQUEST,
                format!(
                    "invalid last_s = {}: expected a wall-clock span 0 < last_s ≤ \
                     {MAX_LAST_S} s (100 years)",
                    crate::error::number(last_s)
                ),
            ));
        }
        if q.from_s.is_some() || q.to_s.is_some() {
            return Err(err(
                StatusCode::BAD_REQUEST,
                "last_s with from_s or to_s: expected either last_s or from_s/to_s",
            ));
        }
        r.to_s = st.clock.now_s();
        r.from_s = r.to_s - last_s * st.clock.speedup();
    }
    if r.from_s.is_nan() || r.to_s.is_nan() || r.from_s > r.to_s {
        return Err(err(
            StatusCode::BAD_REQUEST,
            format!(
                "invalid range from_s = {} to_s = {}: expected from_s ≤ to_s",
                crate::error::number(r.from_s),
                crate::error::number(r.to_s)
            ),
        ));
    }
    if let Some(n) = q.max_points {
        if !(1..=MAX_POINTS).contains(&n) {
            return Err(err(
                StatusCode::BAD_REQUEST,
                format!("invalid max_points = {n}: expected 1…{MAX_POINTS}"),
            ));
        }
        if r.from_s == f64::MIN || r.to_s == f64::MAX {
            return Err(err(
                StatusCode::BAD_REQUEST,
                "max_points without a range: expected last_s, or from_s and to_s",
            ));
        }
    }
    Ok(r)
}

/// A series over all of `r` in at most `n` points (`per` rows each, e.g. one per axis):
/// when the range holds more rows than that, the newest `per` rows of each of `n` equal
/// time spans of the range (so a 24 h view covers all 24 h, not its last rows); otherwise
/// every row. Oldest first, times increasing.
fn thinned<T>(
    r: Range,
    n: u32,
    per: u32,
    time_s: fn(&T) -> f64,
    mut query: impl FnMut(Range) -> crate::error::Result<Vec<T>>,
) -> crate::error::Result<Vec<T>> {
    let per = per.max(1);
    let all = query(Range {
        limit: n.saturating_mul(per),
        ..r
    })?;
    if all.len() < n.saturating_mul(per) as usize {
        return Ok(all);
    }
    let width = (r.to_s - r.from_s) / f64::from(n);
    let mut out: Vec<T> = Vec::with_capacity(all.len());
    let mut last = f64::NEG_INFINITY;
    for i in 0..n {
        let from_s = r.from_s + width * f64::from(i);
        let to_s = if i + 1 == n {
            r.to_s
        } else {
            r.from_s + width * f64::from(i + 1)
        };
        let rows = query(Range {
            from_s,
            to_s,
            limit: per,
        })?;
        // Spans share their bounds (BETWEEN): a row on a bound is kept once.
        let newest = rows.iter().map(time_s).fold(last, f64::max);
        out.extend(rows.into_iter().filter(|x| time_s(x) > last));
        last = newest;
    }
    Ok(out)
}

async fn offsets(
    State(st): State<Shared>,
    _: Viewer,
    ApiQuery(q): ApiQuery<RangeQuery>,
) -> ApiResult {
    let r = range(&st, &q)?;
    let axes = live(&st).axes.len() as u32;
    let rows = match q.max_points {
        None => db(&st, move |c| c.offset_history(r)).await?,
        Some(n) => {
            db(&st, move |c| {
                thinned(
                    r,
                    n,
                    axes,
                    |x: &storage::OffsetRow| x.time_s,
                    |r| c.offset_history(r),
                )
            })
            .await?
        }
    };
    Ok(Json(json!({ "current": live(&st).axes, "history": rows })).into_response())
}

async fn history(
    State(st): State<Shared>,
    _: Viewer,
    ApiQuery(q): ApiQuery<RangeQuery>,
) -> ApiResult {
    let r = range(&st, &q)?;
    let kind = match q.kind.as_deref().unwrap_or("average") {
        "raw" => SeriesKind::Raw,
        "average" => SeriesKind::Average,
        other => {
            return Err(err(
                StatusCode::BAD_REQUEST,
                format!("invalid kind = {other:?}: expected raw or average"),
            ))
        }
    };
    let names: Vec<String> = live(&st).channels.iter().map(|c| c.name.clone()).collect();
    let Some(name) = q.channel.clone() else {
        return Err(err(
            StatusCode::BAD_REQUEST,
            format!("missing channel: expected one of {}", names.join(", ")),
        ));
    };
    let Some(idx) = names.iter().position(|n| *n == name) else {
        return Err(err(
            StatusCode::NOT_FOUND,
            format!(
                "invalid channel = {name:?}: expected one of {}",
                names.join(", ")
            ),
        ));
    };
    let points = match q.max_points {
        None => db(&st, move |c| c.channel_history(idx as u16, kind, r)).await?,
        Some(n) => {
            db(&st, move |c| {
                thinned(
                    r,
                    n,
                    1,
                    |p: &storage::Point| p.time_s,
                    |r| c.channel_history(idx as u16, kind, r),
                )
            })
            .await?
        }
    };
    Ok(Json(json!({ "channel": name, "points": points })).into_response())
}

async fn alarms(
    State(st): State<Shared>,
    _: Viewer,
    ApiQuery(q): ApiQuery<RangeQuery>,
) -> ApiResult {
    // `active=true`: alarms not cleared; `unacknowledged=true`: not cleared or not yet
    // acknowledged (what an operator still has to look at).
    let active = q.active.unwrap_or(false);
    let unacked = q.unacknowledged.unwrap_or(false);
    let limit = q.limit.unwrap_or(200).min(10_000);
    let mut rows = db(&st, move |c| c.alarms(active || unacked, limit)).await?;
    if active {
        rows.retain(|r| r.cleared_s.is_none());
    }
    // An active input alarm with repeats carries its count (see crate::alarms); every
    // other row counts once.
    let counts = live(&st).input_alarm_counts;
    let rows: Vec<serde_json::Value> = rows
        .into_iter()
        .map(|r| {
            let count = match r.cleared_s {
                None => counts.get(&r.key).copied().unwrap_or(1),
                Some(_) => 1,
            };
            let mut v = json!(r);
            v["count"] = json!(count);
            v
        })
        .collect();
    Ok(Json(rows).into_response())
}

fn log(st: &AppState, r: Record) -> ApiResult<()> {
    st.records
        .try_send(r)
        .map_err(|_| err(StatusCode::SERVICE_UNAVAILABLE, "the store is busy; retry"))
}

fn audit(st: &AppState, who: &Caller, action: &'static str, detail: String) -> ApiResult<()> {
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
    Operator(who): Operator,
    AlarmId(id): AlarmId,
) -> ApiResult {
    if !db(&st, move |c| c.alarm_exists(id)).await? {
        return Err(err(
            StatusCode::NOT_FOUND,
            format!("no alarm with id = {id}"),
        ));
    }
    log(
        &st,
        Record::AlarmAcknowledged {
            id,
            by: who.token_id.clone(),
        },
    )?;
    audit(&st, &who, "acknowledge_alarm", format!("alarm {id}"))?;
    Ok(Json(json!({ "acknowledged": id })).into_response())
}

async fn ack_stop(State(st): State<Shared>, Operator(who): Operator) -> ApiResult {
    if st.cycle.try_send(InputMsg::AckStop).is_err() {
        return Err(err(
            StatusCode::SERVICE_UNAVAILABLE,
            "the cycle is busy; retry",
        ));
    }
    audit(&st, &who, "acknowledge_stop", String::new())?;
    Ok(Json(json!({ "acknowledged": "stop" })).into_response())
}

async fn get_model(State(st): State<Shared>, _: Viewer) -> Response {
    let m = match st.model.lock() {
        Ok(m) => m.clone(),
        Err(p) => p.into_inner().clone(),
    };
    let toml = m.config.to_toml_string().unwrap_or_default();
    let models: Vec<String> = m.config.models.values().map(|f| f.name.clone()).collect();
    Json(json!({ "source": m.source, "config_toml": toml, "model_files": models })).into_response()
}

/// Largest engine configuration accepted by `PUT /api/model`, bytes.
pub const MAX_MODEL_BYTES: usize = 1024 * 1024;

async fn put_model(
    State(st): State<Shared>,
    // The token is checked (by the extractor) before a byte of the body is read: an
    // unauthenticated request gets 401 whatever it sends, and only an operator's body is
    // read (up to the limit).
    Operator(who): Operator,
    body: axum::body::Body,
) -> ApiResult {
    let limit = st.body_read_timeout;
    let Ok(body) = tokio::time::timeout(limit, axum::body::to_bytes(body, MAX_MODEL_BYTES)).await
    else {
        return Ok(body_too_slow(limit));
    };
    let body: Bytes = body.map_err(|_| {
        err(
            StatusCode::PAYLOAD_TOO_LARGE,
            format!(
                "body over {MAX_MODEL_BYTES} bytes (or cut off); expected an engine \
                     configuration (TOML) of at most {MAX_MODEL_BYTES} bytes"
            ),
        )
    })?;
    let text = std::str::from_utf8(&body)
        .map_err(|e| {
            err(
                StatusCode::BAD_REQUEST,
                format!("body is not UTF-8 TOML: {e}"),
            )
        })?
        .to_string();
    let current = match st.model.lock() {
        Ok(m) => m.config.clone(),
        Err(p) => p.into_inner().config.clone(),
    };
    let engine_err = |e: gearcomp_thermal::ThermalError| {
        err(
            StatusCode::BAD_REQUEST,
            format!("engine configuration: {e}"),
        )
    };
    let mut cfg = EngineConfig::from_toml_str(&text).map_err(engine_err)?;
    // The record's channel layout is fixed for a database; a model change keeps it.
    let old: Vec<&str> = current.channels.iter().map(|c| c.name.as_str()).collect();
    let new: Vec<&str> = cfg.channels.iter().map(|c| c.name.as_str()).collect();
    if old != new {
        return Err(err(
            StatusCode::BAD_REQUEST,
            format!("invalid channels = {new:?}: expected the channels in use, in order: {old:?}"),
        ));
    }
    let old_axes: Vec<&str> = current.axes.iter().map(|a| a.name.as_str()).collect();
    let new_axes: Vec<&str> = cfg.axes.iter().map(|a| a.name.as_str()).collect();
    if old_axes != new_axes {
        return Err(err(
            StatusCode::BAD_REQUEST,
            format!(
                "invalid axes = {new_axes:?}: expected the axes in use, in order: {old_axes:?}"
            ),
        ));
    }
    cfg.models = current.models.clone();
    let engine = Engine::new(&cfg).map_err(engine_err)?;
    if st
        .cycle
        .try_send(InputMsg::SwapEngine(
            Box::new(engine),
            Box::new(cfg.clone()),
        ))
        .is_err()
    {
        return Err(err(
            StatusCode::SERVICE_UNAVAILABLE,
            "the cycle is busy; retry",
        ));
    }
    let source = format!("api:{}", who.token_id);
    if let Ok(mut m) = st.model.lock() {
        *m = ModelInfo {
            source: source.clone(),
            config: cfg,
        };
    }
    log(
        &st,
        Record::Model {
            source,
            config_toml: text.clone(),
        },
    )?;
    audit(&st, &who, "change_model", format!("{} bytes", text.len()))?;
    Ok(Json(json!({ "model": "changed" })).into_response())
}

/// 408 for a body that did not arrive whole in time; the connection is closed with it
/// (the rest of the body is never read).
fn body_too_slow(limit: Duration) -> Response {
    let mut r = err(
        StatusCode::REQUEST_TIMEOUT,
        format!(
            "body not received whole within http.body_read_timeout_s = {} s; expected the \
             whole body within that time",
            crate::error::number(limit.as_secs_f64())
        ),
    )
    .into_response();
    r.headers_mut().insert(
        axum::http::header::CONNECTION,
        axum::http::HeaderValue::from_static("close"),
    );
    r
}

async fn audit_log(State(st): State<Shared>, _: Viewer) -> ApiResult {
    let rows = db(&st, |c| c.audit_log(500)).await?;
    Ok(Json(rows).into_response())
}

/// What the HTTP server enforces per connection (see `[http]` in docs/service.md): the
/// limits, and how an HTTPS client's certificate maps to a role.
#[derive(Debug, Clone)]
pub struct ServerLimits {
    /// Most connections open at once; a connection beyond is closed at once.
    pub max_connections: usize,
    /// A connection must deliver a request's headers (and, with HTTPS, finish its
    /// handshake) within this time, also between the requests of a kept-alive connection.
    pub header_read_timeout: Duration,
    /// Client-certificate login (`[http.tls] client_ca_file`); the certificate itself is
    /// verified by the acceptor of [`tls_acceptor`].
    pub clients: Option<Arc<ClientLogin>>,
}

impl ServerLimits {
    /// The limits of an `[http]` section.
    pub fn of(h: &crate::config::HttpSection) -> Self {
        Self {
            max_connections: h.max_connections as usize,
            header_read_timeout: Duration::from_secs_f64(h.header_read_timeout_s),
            clients: h
                .tls
                .as_ref()
                .filter(|t| t.client_ca_file.is_some())
                .map(|t| {
                    Arc::new(ClientLogin {
                        roles: t.client_roles.clone(),
                        certificates_only: t.certificates_only,
                    })
                }),
        }
    }
}

/// Client-certificate login (`http.tls.client_ca_file`, `client_roles`,
/// `certificates_only`).
#[derive(Debug)]
pub struct ClientLogin {
    /// Certificate names and their roles.
    pub roles: Vec<crate::config::ClientRole>,
    /// Tokens refused; a mapped certificate is the only way in.
    pub certificates_only: bool,
}

/// What the TLS handshake of a connection established about the client (a request
/// extension on connections of a server with client-certificate login).
#[derive(Debug, Clone)]
pub struct Peer {
    /// The certificate's name that matched `client_roles` and its role; None without a
    /// certificate or with one named nowhere.
    pub role: Option<(String, Role)>,
    /// The certificate's CN or DNS name for messages (None without a certificate).
    pub shown: Option<String>,
    /// Tokens refused on this server.
    pub certificates_only: bool,
}

impl Peer {
    /// The peer of a finished handshake: its end-entity certificate's names looked up in
    /// `login` (rustls has verified the chain to the plant CA).
    pub fn of(
        login: &ClientLogin,
        certs: Option<&[rustls::pki_types::CertificateDer<'_>]>,
    ) -> Self {
        let names = certs
            .and_then(|c| c.first())
            .map(|c| crate::auth::certificate_names(c).unwrap_or_default());
        Self {
            role: names.as_ref().and_then(|n| n.role(&login.roles)),
            shown: names.map(|n| n.shown()),
            certificates_only: login.certificates_only,
        }
    }
}

/// The HTTPS acceptor of `[http.tls]` (rustls, ring provider): the certificate chain and
/// key are read and checked at start, and the plant CA of `client_ca_file`; the error
/// names the key and the file.
pub fn tls_acceptor(t: &crate::config::HttpTls) -> crate::error::Result<tokio_rustls::TlsAcceptor> {
    use crate::error::invalid;
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::{CertificateDer, PrivateKeyDer};
    let certs: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(&t.cert_file)
        .and_then(|it| it.collect::<std::result::Result<Vec<_>, _>>())
        .map_err(|e| {
            invalid(
                "http.tls.cert_file",
                format!("{} ({e})", t.cert_file.display()),
                "a readable PEM file with the server's certificate chain",
            )
        })?;
    if certs.is_empty() {
        return Err(invalid(
            "http.tls.cert_file",
            t.cert_file.display(),
            "a PEM file with at least one CERTIFICATE block",
        ));
    }
    let key = PrivateKeyDer::from_pem_file(&t.key_file).map_err(|e| {
        invalid(
            "http.tls.key_file",
            format!("{} ({e})", t.key_file.display()),
            "a readable PEM file with the private key (PKCS#8, PKCS#1 or SEC1)",
        )
    })?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let builder = rustls::ServerConfig::builder_with_provider(provider.clone())
        .with_safe_default_protocol_versions()
        .map_err(|e| invalid("http.tls", e, "TLS 1.2 or 1.3 with the ring provider"))?;
    let builder = match &t.client_ca_file {
        None => builder.with_no_client_auth(),
        Some(ca_file) => {
            let ca: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(ca_file)
                .and_then(|it| it.collect::<std::result::Result<Vec<_>, _>>())
                .map_err(|e| {
                    invalid(
                        "http.tls.client_ca_file",
                        format!("{} ({e})", ca_file.display()),
                        "a readable PEM file with the plant CA's certificate",
                    )
                })?;
            let mut roots = rustls::RootCertStore::empty();
            for c in ca {
                roots.add(c).map_err(|e| {
                    invalid(
                        "http.tls.client_ca_file",
                        format!("{} ({e})", ca_file.display()),
                        "CA certificates rustls accepts",
                    )
                })?;
            }
            if roots.is_empty() {
                return Err(invalid(
                    "http.tls.client_ca_file",
                    ca_file.display(),
                    "a PEM file with at least one CERTIFICATE block",
                ));
            }
            let verifier = rustls::server::WebPkiClientVerifier::builder_with_provider(
                Arc::new(roots),
                provider,
            );
            // Without certificates_only a client may come without a certificate (and log in
            // with a token); a certificate it does present must chain to the plant CA.
            let verifier = if t.certificates_only {
                verifier
            } else {
                verifier.allow_unauthenticated()
            };
            let verifier = verifier.build().map_err(|e| {
                invalid(
                    "http.tls.client_ca_file",
                    format!("{} ({e})", ca_file.display()),
                    "a CA certificate usable to verify client certificates",
                )
            })?;
            builder.with_client_cert_verifier(verifier)
        }
    };
    let cfg = builder.with_single_cert(certs, key).map_err(|e| {
        invalid(
            "http.tls.key_file",
            format!("{} ({e})", t.key_file.display()),
            "the private key of the certificate in http.tls.cert_file",
        )
    })?;
    Ok(tokio_rustls::TlsAcceptor::from(Arc::new(cfg)))
}

/// Serves `app` on `listener` until `stop` fires (or its sender is dropped), then lets the
/// open requests finish (at most 10 s).
///
/// Unlike `axum::serve` this bounds what a client can hold: at most
/// `limits.max_connections` connections, and a connection that does not deliver its
/// request headers within `limits.header_read_timeout` is closed (hyper's HTTP/1
/// header-read timer; for HTTPS the handshake has the same bound). When every slot is
/// taken, a new connection takes the slot of the one that has waited longest without a
/// request being served (idle, half-open, or still sending headers or its TLS handshake);
/// only when every connection has a request in progress is the new one closed at once. So
/// idle connections, however many, never keep a client out, and a request being served is
/// never cut.
pub async fn serve(
    listener: tokio::net::TcpListener,
    app: Router,
    limits: ServerLimits,
    tls: Option<tokio_rustls::TlsAcceptor>,
    mut stop: tokio::sync::oneshot::Receiver<()>,
) {
    let permits = Arc::new(tokio::sync::Semaphore::new(limits.max_connections));
    let slots = Arc::new(Slots::default());
    let (closing_tx, closing_rx) = tokio::sync::watch::channel(false);
    loop {
        let tcp = tokio::select! {
            r = listener.accept() => match r {
                Ok((tcp, _)) => tcp,
                // Out of descriptors or a connection reset before accept: wait briefly,
                // never spin.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            _ = &mut stop => break,
        };
        let permit = match permits.clone().try_acquire_owned() {
            Ok(p) => p,
            Err(_) => {
                // Every slot taken: the longest-idle connection gives its slot up (its
                // task ends at once); with none idle the new connection is closed.
                if !slots.evict_oldest_idle() {
                    drop(tcp);
                    continue;
                }
                let wait =
                    tokio::time::timeout(Duration::from_secs(1), permits.clone().acquire_owned());
                match wait.await {
                    Ok(Ok(p)) => p,
                    _ => {
                        drop(tcp);
                        continue;
                    }
                }
            }
        };
        let _ = tcp.set_nodelay(true);
        let app = app.clone();
        let tls = tls.clone();
        let closing = closing_rx.clone();
        let header_timeout = limits.header_read_timeout;
        let clients = limits.clients.clone();
        let (slot, registered) = slots.open();
        tokio::spawn(async move {
            // Dropped when the task ends: the connection leaves the slots, then the slot is
            // free.
            let _permit = permit;
            let _registered = registered;
            let busy = slot.clone();
            let conn = async move {
                match tls {
                    None => serve_connection(tcp, app, header_timeout, closing, busy).await,
                    Some(acc) => {
                        let hs = tokio::time::timeout(header_timeout, acc.accept(tcp));
                        if let Ok(Ok(stream)) = hs.await {
                            // Client-certificate login: every request of this connection
                            // carries what the handshake established.
                            let app = match &clients {
                                Some(login) => app.layer(axum::Extension(Peer::of(
                                    login,
                                    stream.get_ref().1.peer_certificates(),
                                ))),
                                None => app,
                            };
                            serve_connection(stream, app, header_timeout, closing, busy).await;
                        }
                    }
                }
            };
            let mut conn = std::pin::pin!(conn);
            loop {
                tokio::select! {
                    _ = conn.as_mut() => break,
                    // Asked to give the slot up: only while no request is being served (one
                    // may have started since the accept loop looked).
                    _ = slot.evict.notified() => {
                        if slot.busy.load(std::sync::atomic::Ordering::Acquire) == 0 {
                            break;
                        }
                    }
                }
            }
        });
    }
    drop(listener);
    let _ = closing_tx.send(true);
    // Every connection returns its permit when it ends.
    let all = u32::try_from(limits.max_connections).unwrap_or(u32::MAX);
    let _ = tokio::time::timeout(Duration::from_secs(10), permits.acquire_many(all)).await;
}

/// One open connection: how many of its requests are being served, and the signal to
/// give its slot up.
#[derive(Default)]
struct Slot {
    busy: std::sync::atomic::AtomicUsize,
    evict: tokio::sync::Notify,
}

/// The open connections, oldest first (by the order they were accepted in).
#[derive(Default)]
struct Slots {
    open: Mutex<std::collections::BTreeMap<u64, Arc<Slot>>>,
    next: std::sync::atomic::AtomicU64,
}

impl Slots {
    /// Registers a new connection; it is removed when the returned guard drops.
    fn open(self: &Arc<Self>) -> (Arc<Slot>, Registered) {
        let id = self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let slot = Arc::new(Slot::default());
        self.lock().insert(id, slot.clone());
        (
            slot,
            Registered {
                slots: self.clone(),
                id,
            },
        )
    }

    /// Asks the oldest connection with no request being served to close; false if every
    /// connection is serving one.
    fn evict_oldest_idle(&self) -> bool {
        let open = self.lock();
        let idle = open
            .values()
            .find(|s| s.busy.load(std::sync::atomic::Ordering::Acquire) == 0);
        match idle {
            Some(s) => {
                s.evict.notify_one();
                true
            }
            None => false,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, std::collections::BTreeMap<u64, Arc<Slot>>> {
        // The map stays consistent whatever a panicking holder did (inserts and removes).
        self.open.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Removes its connection from [`Slots`] when the connection's task ends.
struct Registered {
    slots: Arc<Slots>,
    id: u64,
}

impl Drop for Registered {
    fn drop(&mut self) {
        self.slots.lock().remove(&self.id);
    }
}

/// Counts a request of a connection as being served while it lives.
struct Serving(Arc<Slot>);

impl Serving {
    fn new(slot: &Arc<Slot>) -> Self {
        slot.busy.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
        Self(slot.clone())
    }
}

impl Drop for Serving {
    fn drop(&mut self) {
        self.0
            .busy
            .fetch_sub(1, std::sync::atomic::Ordering::AcqRel);
    }
}

async fn serve_connection<I>(
    io: I,
    app: Router,
    header_read_timeout: Duration,
    mut closing: tokio::sync::watch::Receiver<bool>,
    slot: Arc<Slot>,
) where
    I: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin + Send + 'static,
{
    let svc = hyper_util::service::TowerToHyperService::new(app);
    // Each request counts as served from its headers until its response is produced.
    let svc = hyper::service::service_fn(move |req| {
        let serving = Serving::new(&slot);
        let answer = hyper::service::Service::call(&svc, req);
        async move {
            let r = answer.await;
            drop(serving);
            r
        }
    });
    let mut builder = hyper::server::conn::http1::Builder::new();
    builder
        .timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(header_read_timeout)
        .keep_alive(true);
    let conn = builder.serve_connection(hyper_util::rt::TokioIo::new(io), svc);
    let mut conn = std::pin::pin!(conn);
    tokio::select! {
        _ = conn.as_mut() => {}
        _ = closed(&mut closing) => {
            conn.as_mut().graceful_shutdown();
            let _ = conn.await;
        }
    }
}

/// Resolves once the server is closing (or its signal is gone).
async fn closed(closing: &mut tokio::sync::watch::Receiver<bool>) {
    loop {
        if *closing.borrow_and_update() {
            return;
        }
        if closing.changed().await.is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    /// `thinned` over a synthetic series against a direct construction: the newest row of
    /// every non-empty span of the range, oldest first.
    #[test]
    fn thinned_series_covers_the_whole_range() {
        // 1000 rows at irregular times 0…~2500 s, one exactly on a span bound.
        let times: Vec<f64> = (0..1000)
            .map(|i| f64::from(i) * 2.5 + f64::from(i % 3) * 0.1)
            .collect();
        let query = |r: Range| -> crate::error::Result<Vec<f64>> {
            let mut v: Vec<f64> = times
                .iter()
                .copied()
                .filter(|t| *t >= r.from_s && *t <= r.to_s)
                .collect();
            let keep = v.len().saturating_sub(r.limit as usize);
            Ok(v.split_off(keep))
        };
        let r = Range {
            from_s: 0.0,
            to_s: 2500.0,
            limit: 0,
        };
        let got = thinned(r, 10, 1, |t| *t, query).unwrap();
        // Spans of 250 s: [0,250], [250,500], …; the newest time of each.
        let mut want = Vec::new();
        for i in 0..10 {
            let (lo, hi) = (250.0 * f64::from(i), 250.0 * f64::from(i + 1));
            if let Some(t) = times
                .iter()
                .copied()
                .filter(|t| *t >= lo && *t <= hi)
                .reduce(f64::max)
            {
                if want.last().is_none_or(|l: &f64| t > *l) {
                    want.push(t);
                }
            }
        }
        assert_eq!(got, want);
        assert_eq!(got.len(), 10);
        assert!(*got.last().unwrap() >= 2497.0, "{got:?}");
        // A range holding fewer rows than asked for comes back whole.
        let small = Range {
            from_s: 100.0,
            to_s: 120.0,
            limit: 0,
        };
        let got = thinned(small, 10, 1, |t| *t, query).unwrap();
        let want: Vec<f64> = times
            .iter()
            .copied()
            .filter(|t| (100.0..=120.0).contains(t))
            .collect();
        assert_eq!(got, want);
    }

    #[test]
    fn every_axis_status_has_a_legend() {
        for s in [
            "starting",
            "updated",
            "held",
            "clamped",
            "ramping",
            "waiting_safe_point",
            "frozen",
            "stopped",
            "running",
            "alarm",
            "stop_requested",
        ] {
            assert!(STATUS_LEGEND.iter().any(|(k, _)| *k == s), "{s}");
        }
    }
}
