//! The HTTP API against the running service on loopback: token roles, history ranges,
//! alarm acknowledgement and model change (audited), bumpless transfer.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use common::{start_with, Api};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn roles_history_alarms_and_model_change() {
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\n[storage]\npath = \"api.db\"\n[input]\nkind = \"simulator\"\nspeedup = 3000.0\n",
    )
    .await;
    let g = run.generated.clone().unwrap();
    let (op, ro) = (g.operator.as_str(), g.read_only.as_str());
    let api = Api::new(&run);

    // 401 without or with an unknown token, 200 with either role.
    assert_eq!(api.get("/api/status", None).await.0, 401);
    assert_eq!(api.get("/api/status", Some("gco_forged")).await.0, 401);
    assert_eq!(api.get("/api/status", Some(ro)).await.0, 200);
    assert_eq!(api.get("/api/status", Some(op)).await.0, 200);
    // The page itself takes the token in the query (a browser cannot set the header).
    let page = api
        .client
        .get(format!("{}/", api.base))
        .send()
        .await
        .unwrap();
    assert_eq!(page.status().as_u16(), 401);
    let page = api
        .client
        .get(format!("{}/?token={ro}", api.base))
        .send()
        .await
        .unwrap();
    assert_eq!(page.status().as_u16(), 200);
    assert!(page.text().await.unwrap().contains("Predicted drift"));

    // Wait until the grinder has drifted so the offset is well away from zero.
    let st = api
        .wait_for("/api/status", ro, 20.0, |v| {
            v["axes"][0]["offset_um"].as_f64().unwrap().abs() > 1.5
        })
        .await;
    let t_now = st["time_s"].as_f64().unwrap();

    // History with a time range: every point inside it, Pt100 raw values in ohms. The
    // record is committed in batches (every 0.25 s of wall time) and the simulator runs far
    // faster than real time, so the range may reach the store a moment after the status.
    let (from, to) = (t_now / 4.0, t_now / 2.0);
    let h = api
        .wait_for(
            &format!("/api/history?channel=bed_top_c&kind=raw&from_s={from}&to_s={to}"),
            ro,
            10.0,
            |v| v["points"].as_array().is_some_and(|a| !a.is_empty()),
        )
        .await;
    let pts = h["points"].as_array().unwrap();
    for p in pts {
        let t = p["time_s"].as_f64().unwrap();
        assert!(t >= from && t <= to, "{t}");
        // IEC 60751: R(18…25 °C) = 107.0…109.7 Ω.
        let r = p["value"].as_f64().unwrap();
        assert!((106.0..111.0).contains(&r), "{r}");
    }
    // A history range in wall-clock seconds (`last_s`, here all of the sped-up record),
    // thinned to `max_points` spread over the whole range: from the record's first quarter
    // up to now.
    // The wall time since start (service time / speed-up) plus a fifth: the range starts
    // just before the record.
    let last_s = t_now / 3000.0 * 1.2;
    let thin = api
        .get(
            &format!("/api/history?channel=bed_top_c&kind=raw&last_s={last_s}&max_points=50"),
            Some(ro),
        )
        .await
        .1;
    let ts: Vec<f64> = thin["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["time_s"].as_f64().unwrap())
        .collect();
    assert!(ts.len() <= 50 && ts.len() >= 30, "{} points", ts.len());
    assert!(ts.windows(2).all(|w| w[0] < w[1]), "{ts:?}");
    assert!(
        ts[0] < t_now / 4.0 && *ts.last().unwrap() > t_now / 2.0,
        "{t_now}: {ts:?}"
    );
    for bad in [
        "/api/history?channel=bed_top_c&last_s=-1",
        "/api/history?channel=bed_top_c&last_s=60&from_s=0",
        "/api/history?channel=bed_top_c&last_s=60&max_points=0",
        "/api/history?channel=bed_top_c&max_points=10",
        "/api/offsets?last_s=60&max_points=100000",
    ] {
        let (code, v) = api.get(bad, Some(ro)).await;
        assert_eq!(code, 400, "{bad}: {v}");
        assert!(
            v["error"].as_str().unwrap().contains("expected"),
            "{bad}: {v}"
        );
    }
    // Query parameters that do not parse, a non-finite time, a span beyond any record and
    // a path the API does not have: JSON errors naming the parameter (or path), why and
    // what it takes (plain text without the range before; `last_s=1e308` answered 200
    // with an empty history).
    for (path, code, want) in [
        (
            "/api/offsets?limit=-1",
            400,
            "invalid query parameter limit (invalid digit found in string): expected a whole number of rows",
        ),
        ("/api/alarms?active=maybe", 400, "invalid query parameter active ("),
        (
            "/api/offsets?limit=1&limit=2",
            400,
            "invalid query parameter limit (duplicate field",
        ),
        (
            "/api/offsets?from_s=NaN",
            400,
            "invalid from_s = NaN: expected a finite service time in s",
        ),
        (
            "/api/offsets?last_s=1e308&max_points=10",
            400,
            "invalid last_s = 1e308: expected a wall-clock span 0 < last_s ≤ 3200000000 s",
        ),
        ("/api/nope", 404, "no such path /api/nope: expected one of"),
    ] {
        let (got, v) = api.get(path, Some(ro)).await;
        assert_eq!(got, code, "{path}: {v}");
        assert!(
            v["error"].as_str().is_some_and(|e| e.contains(want)),
            "{path}: {v}"
        );
    }
    let offs = api
        .get(
            &format!("/api/offsets?last_s={last_s}&max_points=20"),
            Some(ro),
        )
        .await
        .1;
    let n = offs["history"].as_array().unwrap().len();
    assert!((1..=20).contains(&n), "{n}");

    // Units of every channel: a Pt100's raw reading in Ω, its value in °C.
    let (_, chans) = api.get("/api/channels", Some(ro)).await;
    let bed = chans
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "bed_top_c")
        .unwrap();
    assert_eq!(bed["raw_unit"], "Ω");
    assert_eq!(bed["unit"], "°C");
    // The status says who asks, what the states mean, and how service time maps to the
    // wall clock (unix_s − (time_s − t)/speedup, with the configured speed-up).
    let (_, st_ro) = api.get("/api/status", Some(ro)).await;
    let (_, st_op) = api.get("/api/status", Some(op)).await;
    assert_eq!(st_ro["role"], "read_only");
    assert_eq!(st_op["role"], "operator");
    for k in ["held", "ramping", "frozen", "clamped", "waiting_safe_point"] {
        assert!(
            st_ro["legend"][k].as_str().is_some_and(|t| t.len() > 10),
            "{k}"
        );
    }
    let wc = &st_ro["wall_clock"];
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    assert!((wc["unix_s"].as_f64().unwrap() - now).abs() < 5.0, "{wc}");
    assert_eq!(wc["speedup"].as_f64().unwrap(), 3000.0);
    assert!(wc["time_s"].as_f64().unwrap() >= st_ro["time_s"].as_f64().unwrap());

    assert_eq!(api.get("/api/history?channel=nope", Some(ro)).await.0, 404);
    assert_eq!(
        api.get("/api/history?channel=bed_top_c&from_s=5&to_s=1", Some(ro))
            .await
            .0,
        400
    );

    // Model change: read-only refused, operator accepted and logged. Kz doubled.
    let (cfg_code, model) = api.get("/api/model", Some(ro)).await;
    assert_eq!(cfg_code, 200);
    let toml = model["config_toml"].as_str().unwrap().to_string();
    assert!(toml.contains("kz_um_per_c = -3.75"), "{toml}");
    let doubled = toml.replace("kz_um_per_c = -3.75", "kz_um_per_c = -7.5");
    let put = |tok: &str, body: String| {
        api.client
            .put(format!("{}/api/model", api.base))
            .bearer_auth(tok)
            .body(body)
            .send()
    };
    assert_eq!(
        put(ro, doubled.clone()).await.unwrap().status().as_u16(),
        403
    );
    let bad = put(op, toml.replace("[[axes]]", "[[axes]]\nbogus = 1"))
        .await
        .unwrap();
    assert_eq!(bad.status().as_u16(), 400);
    assert!(bad.text().await.unwrap().contains("bogus"));
    let before = api.get("/api/status", Some(ro)).await.1["axes"][0]["offset_um"]
        .as_f64()
        .unwrap();
    let ok = put(op, doubled).await.unwrap();
    assert_eq!(ok.status().as_u16(), 200);
    // The new law takes over (−7.5·(A − B) is about twice the old offset) ...
    let took_over = api
        .wait_for("/api/status", ro, 20.0, |v| {
            let a = &v["axes"][0];
            a["offset_um"].as_f64().unwrap().abs() > 1.8 * before.abs()
                && a["engine_offset_um"] == a["offset_um"]
        })
        .await;
    let t1 = took_over["time_s"].as_f64().unwrap();
    let offs = api
        .wait_for("/api/offsets?limit=100000", ro, 5.0, |v| {
            v["history"]
                .as_array()
                .unwrap()
                .last()
                .is_some_and(|r| r["time_s"].as_f64().unwrap() >= t1)
        })
        .await;
    // ... without a jump: the applied offset never moved by more than the axis's rate
    // limit (0.5 µm) per cycle, although the new engine started from 0 (a drop of
    // |before| > 1.5 µm had it been applied directly) and ramped at that rate itself (the
    // earlier decaying bias added both: up to 1.0 µm per cycle).
    let ys: Vec<f64> = offs["history"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|r| r["offset_um"].as_f64())
        .collect();
    assert!(ys.len() > 10, "{}", ys.len());
    let max_step = ys
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(max_step <= 0.5 + 1e-9, "largest step {max_step} µm");

    // An alarm: a model whose validity range excludes the bed temperature.
    let (_, model) = api.get("/api/model", Some(ro)).await;
    let narrow = model["config_toml"]
        .as_str()
        .unwrap()
        .replacen("valid_max = 80.0", "valid_max = 10.0", 1)
        .replacen("limit_max = 45.0", "limit_max = 8.0", 1);
    let r = put(op, narrow).await.unwrap();
    assert_eq!(r.status().as_u16(), 200, "{}", r.text().await.unwrap());
    let alarms = api
        .wait_for("/api/alarms?active=true", ro, 20.0, |v| {
            v.as_array().unwrap().iter().any(|a| {
                a["key"] == "channel.bed_top_c.short_circuit"
                    || a["key"] == "channel.bed_top_c.open_circuit"
            })
        })
        .await;
    let alarm = alarms
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["key"].as_str().unwrap().starts_with("channel.bed_top_c"))
        .unwrap();
    assert!(
        alarm["message"].as_str().unwrap().contains("valid -20…10"),
        "{alarm}"
    );
    let id = alarm["id"].as_i64().unwrap();
    let ack = |tok: &str| {
        api.client
            .post(format!("{}/api/alarms/{id}/ack", api.base))
            .bearer_auth(tok)
            .send()
    };
    assert_eq!(ack(ro).await.unwrap().status().as_u16(), 403);
    assert_eq!(ack(op).await.unwrap().status().as_u16(), 200);
    let not_a_number = api
        .client
        .post(format!("{}/api/alarms/abc/ack", api.base))
        .bearer_auth(op)
        .send()
        .await
        .unwrap();
    assert_eq!(not_a_number.status().as_u16(), 400);
    let v: serde_json::Value = not_a_number.json().await.unwrap();
    assert!(
        v["error"].as_str().is_some_and(
            |e| e.contains("invalid alarm id = abc: expected the alarm's whole number")
        ),
        "{v}"
    );
    // Operator actions are committed with the next batch (≤ commit_interval_s).
    api.wait_for("/api/alarms", ro, 5.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .any(|a| a["id"] == id && a["acknowledged_by"].is_string())
    })
    .await;
    let audit = api
        .wait_for("/api/audit", ro, 5.0, |v| v.as_array().unwrap().len() == 3)
        .await;
    let actions: Vec<&str> = audit
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["action"].as_str().unwrap())
        .collect();
    assert_eq!(
        actions,
        vec!["acknowledge_alarm", "change_model", "change_model"]
    );
    assert!(audit
        .as_array()
        .unwrap()
        .iter()
        .all(|a| a["role"] == "operator"));
    let n = run.stop().await.unwrap();
    assert!(n > 0);
}
