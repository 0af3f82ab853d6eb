//! The dashboard in a real browser: Debian's headless Chromium loads the page from the
//! service on loopback and its rendered DOM is read back (`--dump-dom`). With a token the
//! page shows the channels and the offset of this service, and a later load shows other
//! values (the simulator runs sped up); without a token, or with a wrong one, it shows the
//! refusal and no data.
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
    run.stop().await.unwrap();
}
