//! Selection that mirrors deployment, checked on multi-run data built here: the default
//! (`ModelKind::Auto`) is assessed by an outer leave-one-run-out loop (each held-out run
//! is never seen by any choice) against plain least squares on all inputs.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::{identify, plain_least_squares, IdentifyOptions, Split};
use gearcomp_thermal::presets::hobbing;
use gearcomp_thermal::Simulator;

/// Five 8 h runs of the hobbing simulator, each with its own spindle speed, duty cycle,
/// ambient and shift start; one row per minute; the run named in a column.
fn hobbing_runs() -> String {
    let base = hobbing().machine;
    let names: Vec<String> = base.sensors.iter().map(|s| s.name.clone()).collect();
    let mut text = format!("run,time_s,{},drift_um\n", names.join(","));
    let cases = [
        (1000.0, 240.0, 40.0, 20.0, 6.0),
        (600.0, 120.0, 120.0, 18.0, 14.0),
        (1400.0, 300.0, 20.0, 23.0, 22.0),
        (800.0, 180.0, 60.0, 21.0, 6.0),
        (1200.0, 240.0, 100.0, 19.0, 10.0),
    ];
    for (k, &(rpm, cut, load, amb, start)) in cases.iter().enumerate() {
        let mut spec = base.clone();
        spec.spindle_rpm = rpm;
        spec.cut_s = cut;
        spec.load_s = load;
        spec.ambient_mean_c = amb;
        spec.shift_start_h = start;
        let mut sim = Simulator::new(spec, 7 + k as u64).unwrap();
        let steps = sim.steps_for_hours(8.0);
        for i in 0..steps {
            let s = sim.advance();
            if i % 6 == 0 {
                let v: Vec<String> = s.value.iter().map(|v| format!("{v}")).collect();
                text += &format!("{k},{},{},{}\n", s.time_s, v.join(","), s.measured_drift_um);
            }
        }
    }
    text
}

/// Outer leave-one-run-out: pooled test RMSE of the default and of plain LS on all inputs.
fn outer_loro(t: &Table, opts: &IdentifyOptions) -> (Vec<f64>, Vec<f64>) {
    let nt = t.targets.len();
    let (mut auto_sse, mut ls_sse, mut n) = (vec![0.0; nt], vec![0.0; nt], 0usize);
    for r in &t.run_names {
        let split = Split::TestRuns(vec![r.clone()]);
        let rows = t
            .runs
            .as_ref()
            .unwrap()
            .iter()
            .filter(|&&k| t.run_names[k] == *r)
            .count();
        let id = identify(
            t,
            &IdentifyOptions {
                split: split.clone(),
                ..opts.clone()
            },
        )
        .unwrap();
        let ls = plain_least_squares(t, &split).unwrap();
        if std::env::var("GEARCOMP_MULTIRUN_DETAIL").is_ok() {
            for m in &id.targets {
                println!(
                    "  test {r}: kept {} (val {:.3}, test {:.3}; plain LS {:.3})",
                    m.family,
                    m.cv_rmse,
                    m.test_rmse.unwrap(),
                    ls[0].1.unwrap()
                );
                for c in &m.comparison {
                    println!(
                        "    {:<40} {:>2} val {:.3} {}",
                        c.family, c.sensors, c.cv_rmse, c.detail
                    );
                }
            }
        }
        for j in 0..nt {
            auto_sse[j] += id.targets[j].test_rmse.unwrap().powi(2) * rows as f64;
            ls_sse[j] += ls[j].1.unwrap().powi(2) * rows as f64;
        }
        n += rows;
    }
    let f = |v: Vec<f64>| v.iter().map(|s| (s / n as f64).sqrt()).collect::<Vec<_>>();
    (f(auto_sse), f(ls_sse))
}

#[test]
fn hobbing_runs_default_beats_plain_least_squares_out_of_run() {
    let text = hobbing_runs();
    let sel = Selection {
        targets: vec!["drift_um".into()],
        run: Some("run".into()),
        ..Selection::default()
    };
    let t = read_csv(&text, "hobbing runs", &sel, ReadOptions::default()).unwrap();
    assert_eq!(t.run_names.len(), 5);
    let (auto, ls) = outer_loro(&t, &IdentifyOptions::default());
    println!("hobbing outer LORO: default {auto:?}, plain LS {ls:?}");
    // The column core lags the column (τ ≈ 9 h): a lag model must do strictly better
    // (measured 0.668 vs 0.693 µm with the k-step path the candidates share, and with the
    // best-fitting one; 0.675 with the
    // optimism of the family figures alone; 0.552 before
    // it, 0.532 before the one-standard-error rule against plain LS and the classes family,
    // 0.511 before the stacked families), and never more than 2 % worse.
    assert!(auto[0] <= 1.02 * ls[0], "{auto:?} vs {ls:?}");
    assert!(auto[0] < ls[0], "{auto:?} vs {ls:?}");
}

#[test]
fn fl_thermal_pseudo_runs_default_is_never_much_worse_than_plain_least_squares() {
    let text = gearcomp_datasets::fl_thermal_csv();
    // Cut into 8 h pseudo-runs (a run column added here); `GEARCOMP_MULTIRUN_HOURS=h`
    // measures another cut (the assertions below are those of the 8 h cut).
    let hours: f64 = std::env::var("GEARCOMP_MULTIRUN_HOURS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(8.0);
    let mut out = String::new();
    for (i, l) in text.lines().enumerate() {
        if i == 0 {
            out += &format!("run,{l}\n");
        } else {
            let t: f64 = l.split(',').next().unwrap().parse().unwrap();
            out += &format!("{},{l}\n", (t / (hours * 3600.0)).floor() as usize);
        }
    }
    let sel = Selection {
        targets: vec!["ch1_um".into(), "ch3_um".into(), "ch5_um".into()],
        run: Some("run".into()),
        ..Selection::default()
    };
    let t = read_csv(&out, "FL_THERMAL pseudo-runs", &sel, ReadOptions::default()).unwrap();
    assert_eq!(
        t.run_names.len(),
        (166_710.0 / (hours * 3600.0)).floor() as usize + 1
    );
    let (auto, ls) = outer_loro(&t, &IdentifyOptions::default());
    println!("FL_THERMAL outer LORO: default {auto:?}, plain LS {ls:?}");
    // Measured (nested selection, stacked families, classes family, optimism of the family
    // figures, ridge as the one-standard-error reference with leave-one-run-out, a halved
    // error kept outright, the k-step path the candidates share): ch1 2.529 vs 6.886, ch3
    // 2.956 vs 6.049, ch5 5.128 vs 6.426 µm (2.417, 2.944, 5.130 with the best-fitting
    // k-step path; ch1 6.668 with the ridge reference alone: lead-lag did
    // not beat ridge by one standard error in every split; 2.547 before it; before the
    // optimism 2.547, 3.117, 4.616; before the classes family 2.502, 3.117,
    // 4.532; without the stack 2.547, 3.193, 5.228;
    // docs/identification.md). Never more than 2 % worse than plain LS on all 16
    // inputs (the default reads at most 8), and strictly better: every channel lags.
    for j in 0..3 {
        assert!(auto[j] <= 1.02 * ls[j], "{j}: {auto:?} vs {ls:?}");
        assert!(auto[j] < ls[j], "{j}: {auto:?} vs {ls:?}");
    }
}

/// Every family's model, written as the model file the engine loads, runs in the
/// compensation engine (gearcomp-thermal) with the prediction the fit reports: the law
/// value per cycle equals `predict` on each run (the engine restarted per run).
#[test]
#[allow(clippy::needless_range_loop)]
fn every_family_runs_in_the_engine_as_fitted() {
    use gearcomp_identify::select::Family;
    let text = hobbing_runs();
    let sel = Selection {
        targets: vec!["drift_um".into()],
        run: Some("run".into()),
        ..Selection::default()
    };
    let t = read_csv(&text, "hobbing runs", &sel, ReadOptions::default()).unwrap();
    // Every family alone, then the default (every family and their stack), then a stack
    // that is kept here (ridge and the 1st-order TF; with the optimism of the family
    // figures the full default keeps lead-lag on this split).
    let mut stacked = false;
    for fams in Family::ALL.map(|f| vec![f]).into_iter().chain([
        Vec::new(),
        vec![Family::Stacked, Family::Ridge, Family::Tf1],
    ]) {
        let id = identify_families_testing_run_4(&t, &fams);
        let m = &id.targets[0];
        let name = m.family.clone();
        stacked |= name.starts_with(Family::Stacked.name());
        engine_runs_as_fitted(&t, m, &name, t.segment_ranges());
    }
    // The stack is kept on the last set: its combined terms run in the engine too.
    assert!(stacked, "no run kept the stacked families");
}

/// `identify` with `families` (empty: the default), run 4 held out for test.
fn identify_families_testing_run_4(
    t: &Table,
    families: &[gearcomp_identify::select::Family],
) -> gearcomp_identify::Identification {
    identify(
        t,
        &IdentifyOptions {
            families: families.to_vec(),
            split: Split::TestRuns(vec!["4".into()]),
            ..IdentifyOptions::default()
        },
    )
    .unwrap()
}

/// The model of `m`, through the model-file text (with the table's `restart_after_s`),
/// run in the compensation engine from a fresh engine at each of `ranges` (row ranges in
/// which time increases): its law value per cycle equals `predict` to 1e-9.
fn engine_runs_as_fitted(
    t: &Table,
    m: &gearcomp_identify::TargetModel,
    name: &str,
    ranges: Vec<(usize, usize)>,
) {
    use gearcomp_identify::predict;
    use gearcomp_thermal::config::{TimeFilterConfig, Trigger};
    use gearcomp_thermal::presets::HOBBING_MODEL_KEY;
    use gearcomp_thermal::{Engine, Inputs, Reading};
    let file = gearcomp_core::model::ModelFile {
        format: gearcomp_core::model::MODEL_FORMAT.into(),
        name: "fit".into(),
        description: String::new(),
        restart_after_s: t.gap_after_s,
        axes: vec![gearcomp_core::model::AxisModel {
            axis: "X".into(),
            target: m.target.clone(),
            machine: m.model.clone(),
            workpiece: None,
        }],
        provenance: None,
        envelopes: Vec::new(),
    };
    let file =
        gearcomp_core::model::ModelFile::from_toml_str(&file.to_toml_string().unwrap()).unwrap();
    let mut cfg = hobbing().config;
    cfg.sampling.samples_per_average = 1;
    cfg.sampling.time_filter = TimeFilterConfig::None {};
    cfg.sampling.trigger = Trigger::Clock { period_s: 60.0 };
    cfg.insert_model(HOBBING_MODEL_KEY, file.clone());
    let predicted = predict(t, &file.axes[0].machine).unwrap();
    let mut compared = 0;
    for (s, e) in ranges {
        let mut eng = Engine::new(&cfg).unwrap();
        for i in s..e {
            let readings: Vec<Reading> = t
                .inputs
                .iter()
                .map(|x| Reading {
                    raw: x[i],
                    stamp_s: t.time_s[i],
                })
                .collect();
            let out = eng.step(&Inputs {
                time_s: t.time_s[i],
                readings: &readings,
                trigger: false,
                safe_point: true,
                positions_mm: &[0.0],
            });
            let law = out.axes()[0].law_um;
            if law.is_finite() {
                let p = predicted[i];
                assert!(
                    (law - p).abs() <= 1e-9 * (1.0 + p.abs()),
                    "{name}: row {i}: engine {law} vs fit {p}"
                );
                compared += 1;
            }
        }
    }
    assert!(compared > t.time_s.len() * 9 / 10, "{name}: {compared}");
}

/// Gaps inside the runs (16 min of rows left out at one or two places per run, against a
/// 1 min step): the fit restarts every lag, rate and delay state there, and so does one
/// engine run over the whole run by itself (the model file's `restart_after_s`, 3 × the
/// median step): the law equals the fit's prediction on every row. Before, the engine
/// carried its states over the gap and missed the fit by up to 4.4 µm.
#[test]
fn the_engine_restarts_its_states_at_the_gaps_the_fit_restarted_them() {
    use gearcomp_identify::select::Family;
    let text = hobbing_runs();
    let mut gapped = String::new();
    for (i, l) in text.lines().enumerate() {
        // Rows 200–215 and, in odd runs, 350–365 of each 480-row run.
        let k = i.saturating_sub(1) % 480;
        let run = i.saturating_sub(1) / 480;
        if i > 0 && ((200..216).contains(&k) || (run % 2 == 1 && (350..366).contains(&k))) {
            continue;
        }
        gapped += l;
        gapped.push('\n');
    }
    let sel = Selection {
        targets: vec!["drift_um".into()],
        run: Some("run".into()),
        ..Selection::default()
    };
    let t = read_csv(
        &gapped,
        "hobbing runs with gaps",
        &sel,
        ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(t.run_names.len(), 5);
    assert_eq!(t.segments.len(), 5 + 5 + 2, "{:?}", t.segments);
    assert_eq!(t.gap_after_s, Some(180.0));
    // One range per run: time restarts in each, so each needs its own engine.
    let runs = t.runs.clone().unwrap();
    let mut ranges = Vec::new();
    let mut s = 0;
    for i in 1..=runs.len() {
        if i == runs.len() || runs[i] != runs[i - 1] {
            ranges.push((s, i));
            s = i;
        }
    }
    for fams in [
        vec![Family::LeadLag],
        vec![Family::Tf1],
        vec![Family::Tf2],
        vec![Family::Delay],
        Vec::new(),
    ] {
        let id = identify_families_testing_run_4(&t, &fams);
        let m = &id.targets[0];
        engine_runs_as_fitted(&t, m, &m.family, ranges.clone());
    }
}
