//! The dashboard in a real browser: Debian's headless Chromium loads the page from the
//! service on loopback and its rendered DOM is read back (`--dump-dom`). With a token the
//! page shows the channels and the offset of this service, and a later load shows other
//! values (the simulator runs sped up); without a token, or with a wrong one, it shows the
//! refusal and no data. The time axis is wall-clock time in the browser's zone (Chromium
//! runs with TZ=Asia/Kolkata, UTC+5:30 without daylight saving, so a label in UTC or in
//! seconds since start would not match), every value carries its unit, the states are
//! explained, and the acknowledge buttons are there for an operator and absent for a
//! viewer.
//!
//! Chromium is installed by `.ci/run` (`apt-get install chromium`); if it is missing the
//! test fails and says so rather than passing without having looked at the page.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{start_with, Api};

/// Debian's chromium binary, or a failure telling how to get it.
fn chromium() -> PathBuf {
    let candidates = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .chain([PathBuf::from("/usr/bin")])
        .map(|d| d.join("chromium"));
    for c in candidates {
        if c.is_file() {
            return c;
        }
    }
    panic!(
        "chromium not found (PATH or /usr/bin): run .ci/run, it installs chromium \
         (apt-get install chromium) for this dashboard test"
    );
}

/// Loads `url` in headless Chromium with a fresh profile, lets the page's scripts run for
/// `budget_ms` of virtual time (network waits do not count), and returns the DOM.
fn dump_dom(url: &str, budget_ms: u32) -> String {
    let profile = tempfile::tempdir().unwrap();
    let err_path = profile.path().join("chromium-stderr.txt");
    let err_file = std::fs::File::create(&err_path).unwrap();
    let mut child = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!(
            "--user-data-dir={}",
            profile.path().join("profile").display()
        ))
        .arg(format!("--virtual-time-budget={budget_ms}"))
        .arg("--dump-dom")
        .arg(url)
        // A zone without daylight saving, away from UTC: the labels must be local time.
        .env("TZ", "Asia/Kolkata")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(err_file))
        .spawn()
        .expect("start chromium");
    // Read stdout on its own thread: a DOM larger than the pipe buffer would block it.
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let deadline = Instant::now() + Duration::from_secs(90);
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "chromium did not finish loading {url} within 90 s; stderr:\n{}",
                std::fs::read_to_string(&err_path).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let dom = reader.join().unwrap();
    assert!(
        status.success() && dom.contains("<html"),
        "chromium failed on {url} ({status}); stderr:\n{}",
        std::fs::read_to_string(&err_path).unwrap_or_default()
    );
    dom
}

/// The text of every element carrying `attr="…"`, as (attribute value, element text).
fn by_attr(dom: &str, attr: &str) -> Vec<(String, String)> {
    let pat = format!("{attr}=\"");
    let mut out = Vec::new();
    let mut rest = dom;
    while let Some(i) = rest.find(&pat) {
        rest = &rest[i + pat.len()..];
        let q = rest.find('"').unwrap();
        let name = rest[..q].to_string();
        let gt = rest.find('>').unwrap();
        let lt = rest[gt..].find('<').unwrap();
        out.push((name, rest[gt + 1..gt + lt].to_string()));
    }
    out
}

/// The text of the element with `id="…"`.
fn by_id(dom: &str, id: &str) -> String {
    by_attr(dom, "id")
        .into_iter()
        .find(|(k, _)| k == id)
        .map(|(_, v)| v)
        .unwrap_or_else(|| panic!("no element id={id} in the page:\n{dom}"))
}

/// The local time of day (hh:mm:ss, 24 h) in UTC+5:30 of `ms` since the Unix epoch,
/// computed here independently of the browser.
fn kolkata_hms(ms: i64) -> String {
    let local_s = ms.div_euclid(1000) + 5 * 3600 + 30 * 60;
    let d = local_s.rem_euclid(86_400);
    format!("{:02}:{:02}:{:02}", d / 3600, d / 60 % 60, d % 60)
}

fn unix_ms_now() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_millis() as i64
}

fn num(s: &str) -> f64 {
    s.trim()
        .parse()
        .unwrap_or_else(|_| panic!("{s:?} is not a number"))
}

/// What a loaded dashboard shows.
#[derive(Debug)]
struct Shown {
    time_s: f64,
    raw: Vec<(String, f64)>,
    values: Vec<(String, f64)>,
    offset_um: f64,
}

fn shown(dom: &str) -> Shown {
    let values = |attr: &str| -> Vec<(String, f64)> {
        by_attr(dom, attr)
            .into_iter()
            .map(|(k, v)| (k, num(&v)))
            .collect()
    };
    let axes = by_attr(dom, "data-axis-offset");
    assert_eq!(axes.len(), 1, "one axis expected: {axes:?}");
    Shown {
        time_s: num(&by_id(dom, "time")),
        raw: values("data-channel-raw"),
        values: values("data-channel-value"),
        offset_um: num(&axes[0].1),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dashboard_in_headless_chromium() {
    // Fail first, with the remedy, if the browser is missing.
    let _ = chromium();
    let dir = tempfile::tempdir().unwrap();
    let wall_start_ms = unix_ms_now();
    let run = start_with(
        dir.path(),
        "[machine]\nname = \"gs300-7\"\n[http]\nport = 0\n[storage]\npath = \"dash.db\"\n\
         [input]\nkind = \"simulator\"\nspeedup = 3000.0\n",
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let base = api.base.clone();

    // Let the grinder warm up so the offset is well away from zero.
    api.wait_for("/api/status", &ro, 30.0, |v| {
        v["axes"][0]["offset_um"].as_f64().unwrap().abs() > 1.0
    })
    .await;
    let (_, channels) = api.get("/api/channels", Some(&ro)).await;
    let names: Vec<String> = channels
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap().to_string())
        .collect();

    let load = |url: String| tokio::task::spawn_blocking(move || dump_dom(&url, 3000));
    let t_before = api.get("/api/status", Some(&ro)).await.1["time_s"]
        .as_f64()
        .unwrap();
    let dom1 = load(format!("{base}/?token={ro}")).await.unwrap();
    let t_after = api.get("/api/status", Some(&ro)).await.1["time_s"]
        .as_f64()
        .unwrap();
    let wall_loaded_ms = unix_ms_now();

    // The page is this service's: machine name, model source, status, and a cycle time
    // read while the browser had the page open.
    assert_eq!(by_id(&dom1, "machine"), "gs300-7");
    assert_eq!(by_id(&dom1, "model-source"), "preset:grinder");
    assert_eq!(by_id(&dom1, "status"), "running", "{dom1}");
    let s1 = shown(&dom1);
    assert!(
        s1.time_s >= t_before - 0.05 && s1.time_s <= t_after + 0.05,
        "page time {} outside the API's {t_before}…{t_after}",
        s1.time_s
    );
    // Every channel of the engine, with its raw reading in the sensor's unit (a Pt100 in
    // ohms, IEC 60751: 15…40 °C is 105.8…115.5 Ω; a °C transmitter in °C) and its
    // averaged temperature in °C.
    let shown_names: Vec<&String> = s1.values.iter().map(|(k, _)| k).collect();
    assert_eq!(shown_names, names.iter().collect::<Vec<_>>());
    let (_, model) = api.get("/api/model", Some(&ro)).await;
    let model: toml::Value = toml::from_str(model["config_toml"].as_str().unwrap()).unwrap();
    let kinds = model["channels"].as_array().unwrap();
    for ((k, r), c) in s1.raw.iter().zip(kinds) {
        match c["sensor"]["kind"].as_str().unwrap() {
            "pt100" => assert!((105.0..116.0).contains(r), "{k}: raw {r} Ω"),
            "celsius" => assert!((15.0..40.0).contains(r), "{k}: raw {r} °C"),
            other => panic!("{k}: sensor kind {other} not expected in the grinder preset"),
        }
    }
    for (k, v) in &s1.values {
        assert!((15.0..40.0).contains(v), "{k}: {v} °C");
    }
    // Each value with its unit: the raw reading in the sensor's (Ω for a Pt100, never
    // under °C), the converted value in °C.
    let raw_units = by_attr(&dom1, "data-channel-raw-unit");
    let units = by_attr(&dom1, "data-channel-unit");
    assert_eq!(raw_units.len(), names.len());
    for (((k, u), (_, vu)), c) in raw_units.iter().zip(&units).zip(kinds) {
        let want = match c["sensor"]["kind"].as_str().unwrap() {
            "pt100" => "Ω",
            _ => "°C",
        };
        assert_eq!(u, want, "{k}");
        assert_eq!(vu, "°C", "{k}");
    }
    // The time axes: wall-clock instants while this test ran (not seconds since start),
    // labelled in the browser's local time.
    let ticks = by_attr(&dom1, "data-time-tick");
    assert!(
        ticks.len() >= 8,
        "two plots with four ticks each: {ticks:?}"
    );
    for (ms, label) in &ticks {
        let ms: i64 = ms.parse().unwrap();
        assert!(
            ms >= wall_start_ms - 2000 && ms <= wall_loaded_ms + 2000,
            "tick at {ms} ms outside the test's wall time {wall_start_ms}…{wall_loaded_ms}"
        );
        assert_eq!(*label, kolkata_hms(ms), "tick {ms}");
    }
    // The states explained, the role shown, and no acknowledge button for a viewer.
    for state in ["held", "ramping", "frozen", "waiting_safe_point", "stopped"] {
        assert!(
            by_attr(&dom1, "data-legend")
                .iter()
                .any(|(k, _)| k == state),
            "legend lacks {state}"
        );
    }
    assert_eq!(by_id(&dom1, "role"), "read_only");
    assert!(!dom1.contains("<button"), "buttons for a viewer");
    assert!(s1.offset_um.abs() > 1.0, "offset shown {}", s1.offset_um);
    // The plots were drawn (one polyline per channel and two per axis).
    assert!(
        dom1.matches("<polyline").count() >= names.len() + 2,
        "plots missing"
    );

    // A few seconds later (hours of simulated time) the page shows other values.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let dom2 = load(format!("{base}/?token={ro}")).await.unwrap();
    let s2 = shown(&dom2);
    assert!(
        s2.time_s > s1.time_s + 1000.0,
        "{} → {}",
        s1.time_s,
        s2.time_s
    );
    let changed = s1
        .values
        .iter()
        .zip(&s2.values)
        .filter(|(a, b)| a.1 != b.1)
        .count();
    assert!(changed > 0, "no channel value changed: {s1:?} → {s2:?}");
    assert_ne!(s1.offset_um, s2.offset_um, "offset did not change");

    // Without a token, with an unknown one, with a valid one plus a character: the refusal,
    // and none of the data.
    for url in [
        format!("{base}/"),
        format!("{base}/?token=gcr_0000"),
        format!("{base}/?token={}x", &ro),
    ] {
        let dom = load(url.clone()).await.unwrap();
        assert!(by_id(&dom, "refused").starts_with("401"), "{url}: {dom}");
        assert!(
            !dom.contains("data-channel-value") && !dom.contains("model-source"),
            "{url} shows data: {dom}"
        );
    }

    // An alarm and a stop (a model whose validity and limits exclude the temperatures):
    // the operator's page offers both acknowledgements, the viewer's neither.
    let op = run.generated.clone().unwrap().operator;
    let (_, model) = api.get("/api/model", Some(&ro)).await;
    let narrow = model["config_toml"]
        .as_str()
        .unwrap()
        .replacen("valid_max = 80.0", "valid_max = 10.0", 1)
        // Both Pt100 channels: the first is now invalid (a fault, an alarm), the second
        // valid and above its limit (a stop request).
        .replacen("limit_max = 45.0", "limit_max = 8.0", 2);
    let put = api
        .client
        .put(format!("{base}/api/model"))
        .bearer_auth(&op)
        .body(narrow)
        .send()
        .await
        .unwrap();
    assert_eq!(put.status().as_u16(), 200);
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 20.0, |v| {
            !v.as_array().unwrap().is_empty()
        })
        .await;
    let id = alarms[0]["id"].as_i64().unwrap();
    api.wait_for("/api/status", &ro, 20.0, |v| v["stop"].is_string())
        .await;
    let dom_op = load(format!("{base}/?token={op}")).await.unwrap();
    assert_eq!(by_id(&dom_op, "role"), "operator");
    let buttons = by_attr(&dom_op, "data-ack-alarm");
    assert!(
        buttons.iter().any(|(k, _)| *k == id.to_string()),
        "no acknowledge button for alarm {id}: {buttons:?}"
    );
    let stop_url = by_attr(&dom_op, "data-ack-url")
        .into_iter()
        .map(|(u, _)| u)
        .find(|u| u == "/api/stop/ack");
    assert!(stop_url.is_some(), "no stop acknowledgement: {dom_op}");
    let dom_ro = load(format!("{base}/?token={ro}")).await.unwrap();
    assert!(
        !dom_ro.contains("<button") && !dom_ro.contains("data-ack-url"),
        "a viewer sees acknowledge buttons"
    );
    // What the alarm's button posts, with the operator's token, acknowledges it: the next
    // page shows it acknowledged and without a button.
    let url = format!("/api/alarms/{id}/ack");
    assert!(by_attr(&dom_op, "data-ack-url")
        .iter()
        .any(|(u, _)| *u == url));
    let r = api
        .client
        .post(format!("{base}{url}"))
        .bearer_auth(&op)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    api.wait_for("/api/alarms", &ro, 5.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .any(|a| a["id"] == id && a["acknowledged_by"].is_string())
    })
    .await;
    let dom_op2 = load(format!("{base}/?token={op}")).await.unwrap();
    assert!(
        !by_attr(&dom_op2, "data-ack-alarm")
            .iter()
            .any(|(k, _)| *k == id.to_string()),
        "alarm {id} still offered for acknowledgement"
    );
    assert!(dom_op2.contains("acknowledged"));
    run.stop().await.unwrap();
}

/// Headless Chromium driven over the DevTools protocol on `--remote-debugging-pipe`:
/// Chromium reads commands from its descriptor 3 and writes answers and events to
/// descriptor 4, one JSON message each, ended by a NUL byte. The shell that starts it
/// puts the ends of our stdin/stdout pipes there (`3<&0 4>&1`), so no websocket and no
/// unsafe descriptor juggling are needed.
struct Browser {
    child: std::process::Child,
    to: std::process::ChildStdin,
    from: std::sync::mpsc::Receiver<serde_json::Value>,
    next_id: u64,
    err_path: PathBuf,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn launch() -> Self {
        let profile = tempfile::tempdir().unwrap();
        let err_path = profile.path().join("chromium-stderr.txt");
        let err_file = std::fs::File::create(&err_path).unwrap();
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(r#"exec "$0" "$@" 3<&0 4>&1 </dev/null >/dev/null"#)
            .arg(chromium())
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--remote-debugging-pipe",
                "--window-size=1280,1024",
            ])
            .arg(format!(
                "--user-data-dir={}",
                profile.path().join("profile").display()
            ))
            .arg("about:blank")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(err_file))
            .spawn()
            .expect("start chromium");
        let to = child.stdin.take().unwrap();
        let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
        let (tx, from) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            use std::io::BufRead;
            let mut buf = Vec::new();
            loop {
                buf.clear();
                match out.read_until(0, &mut buf) {
                    Ok(0) | Err(_) => return,
                    Ok(_) => {
                        if buf.last() == Some(&0) {
                            buf.pop();
                        }
                        if let Ok(v) = serde_json::from_slice(&buf) {
                            if tx.send(v).is_err() {
                                return;
                            }
                        }
                    }
                }
            }
        });
        Self {
            child,
            to,
            from,
            next_id: 0,
            err_path,
            _profile: profile,
        }
    }

    /// One command (on a page's session, or the browser's), its `result`.
    fn call(
        &mut self,
        session: Option<&str>,
        method: &str,
        params: serde_json::Value,
    ) -> serde_json::Value {
        use std::io::Write;
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = serde_json::json!({ "id": id, "method": method, "params": params });
        if let Some(s) = session {
            msg["sessionId"] = s.into();
        }
        let mut bytes = msg.to_string().into_bytes();
        bytes.push(0);
        self.to.write_all(&bytes).unwrap();
        self.to.flush().unwrap();
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let v = self.from.recv_timeout(left).unwrap_or_else(|_| {
                panic!(
                    "no answer to {method} from chromium; stderr:\n{}",
                    std::fs::read_to_string(&self.err_path).unwrap_or_default()
                )
            });
            if v["id"] == id {
                assert!(v.get("error").is_none(), "{method}: {v}");
                return v["result"].clone();
            }
        }
    }

    /// A new tab on `url`, attached: its session id.
    fn open(&mut self, url: &str) -> String {
        let t = self.call(
            None,
            "Target.createTarget",
            serde_json::json!({ "url": url }),
        );
        let a = self.call(
            None,
            "Target.attachToTarget",
            serde_json::json!({ "targetId": t["targetId"], "flatten": true }),
        );
        a["sessionId"].as_str().unwrap().to_string()
    }

    /// A JavaScript expression's value in the page.
    fn eval(&mut self, session: &str, expr: &str) -> serde_json::Value {
        let r = self.call(
            Some(session),
            "Runtime.evaluate",
            serde_json::json!({ "expression": expr, "returnByValue": true }),
        );
        assert!(r.get("exceptionDetails").is_none(), "{expr}: {r}");
        r["result"]["value"].clone()
    }

    /// Polls `expr` until it is true (at most `secs`); an exception (the page not loaded
    /// yet) counts as false.
    fn wait_true(&mut self, session: &str, expr: &str, secs: f64) {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        let guarded = format!(
            "(() => {{ try {{ return ({expr}) === true; }} catch (e) {{ return false; }} }})()"
        );
        while self.eval(session, &guarded) != serde_json::json!(true) {
            assert!(Instant::now() < deadline, "never true in the page: {expr}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// A left click with the mouse at the middle of the element `selector` (scrolled into
    /// view): press and release as a user's click, hit-tested by the browser.
    fn click(&mut self, session: &str, selector: &str) {
        let sel = serde_json::to_string(selector).unwrap();
        let at = self.eval(
            session,
            &format!(
                "(() => {{ const b = document.querySelector({sel}); if (!b) return null; \
                 b.scrollIntoView({{block: 'center'}}); const r = b.getBoundingClientRect(); \
                 return [r.x + r.width / 2, r.y + r.height / 2]; }})()"
            ),
        );
        assert!(at.is_array(), "no element {selector} to click");
        for kind in ["mousePressed", "mouseReleased"] {
            self.call(
                Some(session),
                "Input.dispatchMouseEvent",
                serde_json::json!({ "type": kind, "x": at[0], "y": at[1], "button": "left",
                                    "buttons": 1, "clickCount": 1 }),
            );
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        use std::io::Write;
        // Browser.close, then our own child by its handle if it is still there.
        let _ = self
            .to
            .write_all(b"{\"id\":999999,\"method\":\"Browser.close\"}\0");
        let _ = self.to.flush();
        let deadline = Instant::now() + Duration::from_secs(3);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The acknowledge buttons clicked in a real browser: Chromium, driven over the DevTools
/// protocol, loads the operator's dashboard, a mouse click on an alarm's *acknowledge*
/// button and one on *acknowledge stop* run the page's handler, and the API shows the
/// alarm acknowledged by the operator's token and the stop acknowledgement in the audit
/// log; the viewer's page of the same moment has no button.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn acknowledge_buttons_clicked_in_chromium() {
    let _ = chromium();
    let t0 = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[machine]\nname = \"gs300-8\"\n[http]\nport = 0\n[storage]\npath = \"click.db\"\n\
         [input]\nkind = \"simulator\"\nspeedup = 3000.0\n",
    )
    .await;
    let g = run.generated.clone().unwrap();
    let (ro, op) = (g.read_only, g.operator);
    let api = Api::new(&run);
    let base = api.base.clone();

    // An alarm (one Pt100 made invalid) and a latched stop (the other above its limit).
    let (_, model) = api.get("/api/model", Some(&ro)).await;
    let narrow = model["config_toml"]
        .as_str()
        .unwrap()
        .replacen("valid_max = 80.0", "valid_max = 10.0", 1)
        .replacen("limit_max = 45.0", "limit_max = 8.0", 2);
    let put = api
        .client
        .put(format!("{base}/api/model"))
        .bearer_auth(&op)
        .body(narrow)
        .send()
        .await
        .unwrap();
    assert_eq!(put.status().as_u16(), 200);
    let alarms = api
        .wait_for("/api/alarms?unacknowledged=true", &ro, 20.0, |v| {
            !v.as_array().unwrap().is_empty()
        })
        .await;
    let id = alarms[0]["id"].as_i64().unwrap();
    api.wait_for("/api/status", &ro, 20.0, |v| v["stop"].is_string())
        .await;
    // The operator's token id as the audit log writes it (the PUT above).
    let (_, audit) = api.get("/api/audit", Some(&ro)).await;
    let op_id = audit
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["action"] == "change_model")
        .unwrap_or_else(|| panic!("no change_model row: {audit}"))["token_id"]
        .as_str()
        .unwrap()
        .to_string();
    let stop_acks = |audit: &serde_json::Value| {
        audit
            .as_array()
            .unwrap()
            .iter()
            .filter(|a| a["action"] == "acknowledge_stop" && a["token_id"] == op_id.as_str())
            .count()
    };
    assert_eq!(stop_acks(&audit), 0, "{audit}");

    let alarm_button = format!("button[data-ack-alarm=\"{id}\"]");
    let (ro_url, op_url) = (format!("{base}/?token={ro}"), format!("{base}/?token={op}"));
    let sel = serde_json::to_string(&alarm_button).unwrap();
    let (clicks, acked) = tokio::task::spawn_blocking({
        let api_base = base.clone();
        let ro = ro.clone();
        move || {
            let get = |path: &str| -> serde_json::Value {
                reqwest::blocking::Client::new()
                    .get(format!("{api_base}{path}"))
                    .bearer_auth(&ro)
                    .send()
                    .unwrap()
                    .json()
                    .unwrap()
            };
            let mut b = Browser::launch();
            // The viewer's page, rendered with the alarm and the stop: no button at all.
            let viewer = b.open(&ro_url);
            b.wait_true(
                &viewer,
                "document.getElementById('role').textContent === 'read_only' && \
                 document.querySelector('#stop .alarm') !== null && \
                 [...document.querySelectorAll('#alarms tbody tr')].some(r => \
                   r.textContent.includes('active'))",
                10.0,
            );
            assert_eq!(
                b.eval(&viewer, "document.querySelectorAll('button').length"),
                0
            );
            // The operator's page: both buttons; a mouse click on the alarm's.
            let page = b.open(&op_url);
            b.wait_true(
                &page,
                &format!(
                    "document.querySelector({sel}) !== null && \
                     document.getElementById('ack-stop') !== null"
                ),
                10.0,
            );
            let mut clicks = 0;
            let acked = loop {
                // The page redraws every 2 s; a click landing during a redraw is a
                // click on replaced markup, so at most three tries.
                clicks += 1;
                b.click(&page, &alarm_button);
                let deadline = Instant::now() + Duration::from_secs(3);
                let mut found = None;
                while found.is_none() && Instant::now() < deadline {
                    found = get("/api/alarms?limit=1000")
                        .as_array()
                        .unwrap()
                        .iter()
                        .find(|a| a["id"] == id && a["acknowledged_by"].is_string())
                        .cloned();
                    std::thread::sleep(Duration::from_millis(50));
                }
                if let Some(a) = found {
                    break a;
                }
                assert!(clicks < 3, "alarm {id} not acknowledged after 3 clicks");
            };
            // The page redraws after the POST: the alarm shows acknowledged, no button.
            b.wait_true(
                &page,
                &format!("document.querySelector({sel}) === null"),
                10.0,
            );
            // The stop's button.
            b.click(&page, "#ack-stop");
            (clicks, acked)
        }
    })
    .await
    .unwrap();
    eprintln!("alarm {id} acknowledged after {clicks} click(s): {acked}");
    assert_eq!(acked["acknowledged_by"], op_id.as_str(), "{acked}");
    let audit = api
        .wait_for("/api/audit", &ro, 5.0, |v| stop_acks(v) == 1)
        .await;
    assert!(
        audit
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["action"] == "acknowledge_alarm"
                && a["detail"] == format!("alarm {id}").as_str()
                && a["token_id"] == op_id.as_str()),
        "{audit}"
    );
    eprintln!("click test: {:.1} s", t0.elapsed().as_secs_f64());
    run.stop().await.unwrap();
}
