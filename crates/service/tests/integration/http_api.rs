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
    // ... without a jump: the applied offset never moved by more than the rate limit of
    // the engine (0.5 µm) plus the bumpless rate (0.5 µm) per cycle, although the new
    // engine started from 0 (a drop of |before| > 1.5 µm had it been applied directly).
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
    assert!(max_step <= 1.0 + 1e-9, "largest step {max_step} µm");

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
