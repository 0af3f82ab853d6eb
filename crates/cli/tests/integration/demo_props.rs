//! `gearcomp demo` over random valid and invalid options, through the binary.
//!
//! Valid: any preset, shift length and noise seed. References: the claim of JPH0761598B2 that
//! the surface grinder's thermal error is held within 5 µm by Cz = Kz·(A − B) (the grinder
//! preset), EP0138375's shaper whose uncompensated size error is of the order of 0.076 mm and
//! whose compensation is only as fine as its boundary constant D = 5.08 µm and pulse 2.54 µm,
//! and, for every preset, that compensation never makes the worst error larger once the
//! machine has had an hour to warm up. Every printed number must be finite.
//!
//! Invalid: a shift length outside 0 < h ≤ 336, an unknown preset, or a model file that is
//! not one: the message names the option and the range or the file. Fixed seed plus fresh.

use crate::common::{all_finite, gearcomp, prop_runners, temp_dir};
use proptest::prelude::*;

#[test]
fn demo_holds_the_seeds_claims_for_random_shifts() {
    let strategy = (
        prop::sample::select(vec!["grinder", "shaper", "hobbing"]),
        1.0f64..24.0,
        any::<u64>(),
    );
    for (i, mut runner) in prop_runners(6, 0xde30_0001).into_iter().enumerate() {
        runner
            .run(&strategy, |(preset, hours, seed)| {
                let dir = temp_dir("demo-props", &format!("valid{i}"));
                let out = dir.join("r.html");
                let (h, s) = (format!("{hours}"), format!("{seed}"));
                let o = gearcomp(&[
                    "demo",
                    "--preset",
                    preset,
                    "--hours",
                    &h,
                    "--seed",
                    &s,
                    "--json",
                    "--out",
                    out.to_str().unwrap(),
                ]);
                let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
                prop_assert!(o.status.success(), "{preset} {h} h seed {s}: {stderr}");
                let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
                prop_assert!(all_finite(&v), "{v}");
                let comp = v["compensated"]["max_abs_um"].as_f64().unwrap();
                let uncomp = v["uncompensated"]["max_abs_um"].as_f64().unwrap();
                prop_assert!(comp <= uncomp, "{preset} {h} h seed {s}: {comp} > {uncomp}");
                match preset {
                    // JPH0761598B2: within 5 µm with Cz = Kz·(A − B).
                    "grinder" => prop_assert!(comp <= 5.0, "{v}"),
                    // EP0138375: D = 5.08 µm plus half a 2.54 µm pulse plus what the machine
                    // moves between two corrections; the preset documents 7.7 µm on 8 h.
                    "shaper" => prop_assert!(comp <= 10.0, "{v}"),
                    _ => prop_assert!(comp <= 5.0, "{v}"),
                }
                prop_assert!(std::fs::metadata(&out).unwrap().len() > 1000);
                std::fs::remove_dir_all(&dir).ok();
                Ok(())
            })
            .unwrap();
    }
}

#[test]
fn demo_names_the_option_of_random_bad_input() {
    let strategy = prop_oneof![
        prop_oneof![-1e6f64..=0.0, 336.0001f64..1e9]
            .prop_map(|h| (vec!["--hours".to_owned(), format!("{h}")], "--hours")),
        Just((vec!["--hours".to_owned(), "nan".to_owned()], "--hours")),
        "[a-z]{1,8}"
            .prop_filter("not a preset", |p| !["grinder", "shaper", "hobbing"]
                .contains(&p.as_str()))
            .prop_map(|p| (vec!["--preset".to_owned(), p], "preset")),
    ];
    for (i, mut runner) in prop_runners(8, 0xde30_0001).into_iter().enumerate() {
        runner
            .run(&strategy, |(args, key)| {
                let dir = temp_dir("demo-props", &format!("bad{i}"));
                let out = dir.join("r.html");
                let mut all: Vec<&str> = vec!["demo"];
                all.extend(args.iter().map(String::as_str));
                all.extend(["--out", out.to_str().unwrap()]);
                let o = gearcomp(&all);
                let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
                prop_assert!(!o.status.success(), "{args:?} accepted");
                prop_assert!(stderr.contains(key), "{args:?}: {stderr}");
                prop_assert!(!stderr.contains("panicked"), "{stderr}");
                prop_assert!(!out.exists(), "report written for {args:?}");
                std::fs::remove_dir_all(&dir).ok();
                Ok(())
            })
            .unwrap();
    }
    // A model file that is not one: the file is named.
    let dir = temp_dir("demo-props", "badmodel");
    let model = dir.join("model.toml");
    std::fs::write(&model, "this is = not a model").unwrap();
    let o = gearcomp(&[
        "demo",
        "--model",
        model.to_str().unwrap(),
        "--out",
        dir.join("r.html").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("model.toml"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
