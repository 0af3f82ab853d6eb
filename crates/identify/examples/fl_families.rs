//! FL_THERMAL, trained on the first 24 h: the default model of ch1, ch3, ch5 and, per
//! family, its validation RMSE and (read afterwards, never used for a choice) its test RMSE,
//! the table of docs/identification.md. `FOLDS=n` sets the rolling-origin folds (3).
//!
//! `cargo run --release -p gearcomp-identify --example fl_families`
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, ReadOptions, Selection};
use gearcomp_identify::select::Family;
use gearcomp_identify::{identify, plain_least_squares, IdentifyOptions, Split};

fn main() {
    let text = gearcomp_datasets::fl_thermal_csv();
    let sel = Selection {
        targets: vec!["ch1_um".into(), "ch3_um".into(), "ch5_um".into()],
        ..Selection::default()
    };
    let t = read_csv(text, "fl_thermal", &sel, ReadOptions::default()).unwrap();
    let base = plain_least_squares(&t, &Split::TimeBefore(86_400.0)).unwrap();
    let folds = std::env::var("FOLDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let opts = IdentifyOptions {
        folds,
        ..IdentifyOptions::default()
    };
    let id = identify(&t, &opts).unwrap();
    for (j, m) in id.targets.iter().enumerate() {
        println!(
            "{}: {} ({} sensors): validation {:.3}, test {:.3} µm (plain LS on all inputs {:.3})",
            m.target,
            m.family,
            m.sensors.len(),
            m.cv_rmse,
            m.test_rmse.unwrap_or(f64::NAN),
            base[j].1.unwrap_or(f64::NAN)
        );
        for c in &m.comparison {
            println!(
                "    {:40} val {:.3} {:?} {} {}",
                c.family,
                c.cv_rmse,
                c.fold_rmse
                    .iter()
                    .map(|v| format!("{v:.2}"))
                    .collect::<Vec<_>>(),
                c.sensors,
                c.detail
            );
        }
    }
    println!("family: validation / test per target (µm)");
    for fam in Family::ALL {
        let id = identify(
            &t,
            &IdentifyOptions {
                families: vec![fam],
                ..opts.clone()
            },
        )
        .unwrap();
        let v: Vec<String> = id
            .targets
            .iter()
            .map(|m| format!("{:.3} / {:.3}", m.cv_rmse, m.test_rmse.unwrap_or(f64::NAN)))
            .collect();
        println!("  {:40} {}", fam.name(), v.join("   "));
    }
}
