//! Full identification on FL_THERMAL (clustering, selection, fit, validation), against the
//! cost of only reading the data, measured in the same run; and the per-sample model
//! evaluation (allocation-free `TransformState` stepping) against a plain dot product.
//!
//! The `read_path` group times what the whole-process comparison with numpy
//! (`static_vs_numpy.py`) spends before and during the static identification.
//!
//! Budget: issue 12 asks for ≤ 1 s for the full default `fit` on FL_THERMAL (every family
//! and the validation included); figures are reported as ratios to the CSV read.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use gearcomp_core::model::Transform;
use gearcomp_identify::data::{read_csv, ReadOptions, Selection};
use gearcomp_identify::transform::TransformState;
use gearcomp_identify::{identify, IdentifyOptions};

fn bench(c: &mut Criterion) {
    let text = gearcomp_datasets::fl_thermal_csv();
    let sel = Selection {
        targets: vec!["ch*_um".into()],
        ..Selection::default()
    };
    let table = read_csv(text, "fl_thermal", &sel, ReadOptions::default()).unwrap();
    let opts = IdentifyOptions::default();
    let mut g = c.benchmark_group("fl_thermal");
    g.sample_size(10);
    g.bench_function("baseline_read_csv-16sensors-11115rows", |b| {
        b.iter(|| read_csv(black_box(text), "fl", &sel, ReadOptions::default()).unwrap())
    });
    // The default (issue 12): every family, rolling-origin validation, envelopes.
    g.bench_function("identify_default_auto-16sensors-5targets-11115rows", |b| {
        b.iter(|| identify(black_box(&table), &opts).unwrap())
    });
    let dynamic = IdentifyOptions {
        model: gearcomp_identify::ModelKind::Dynamic,
        ..IdentifyOptions::default()
    };
    g.bench_function("identify_dynamic-16sensors-5targets-11115rows", |b| {
        b.iter(|| identify(black_box(&table), &dynamic).unwrap())
    });
    g.finish();

    // The read path of the whole-process benchmark (static_vs_numpy.py): inflating the
    // embedded gzip (members on every core) and parsing the clean log (pieces on every
    // core), against the row-by-row reader of the same text (a quoted header name sends
    // it through the csv crate), measured in the same run.
    let static_sel = Selection {
        targets: vec!["ch1_um".into(), "ch3_um".into(), "ch5_um".into()],
        ..Selection::default()
    };
    let quoted = text.replacen("time_s", "\"time_s\"", 1);
    let mut r = c.benchmark_group("read_path");
    r.sample_size(20);
    r.bench_function("baseline_row_by_row_csv_crate-16in-3tg-11115rows", |b| {
        b.iter(|| {
            read_csv(
                black_box(&quoted),
                "fl",
                &static_sel,
                ReadOptions::default(),
            )
            .unwrap()
        })
    });
    r.bench_function("read_csv_clean-16in-3tg-11115rows", |b| {
        b.iter(|| read_csv(black_box(text), "fl", &static_sel, ReadOptions::default()).unwrap())
    });
    // What `fit` does: the embedded text (no decompression: gearcomp-datasets) parsed by
    // `read_csv_clean` above, and a `--data` log file read in 256 KB chunks and parsed as
    // they come, against reading the whole text first (in one process the freed buffers are
    // reused, so the page faults a fresh process pays for a 4.4 MB text do not show here:
    // see static_vs_numpy.py).
    let path = std::env::temp_dir().join(format!("gearcomp-bench-{}.csv", std::process::id()));
    std::fs::write(&path, text).unwrap();
    r.bench_function("baseline_read_text_then_parse-16in-3tg-11115rows", |b| {
        b.iter(|| {
            let t = std::fs::read_to_string(&path).unwrap();
            read_csv(&t, "fl", &static_sel, ReadOptions::default()).unwrap()
        })
    });
    r.bench_function(
        "read_file_in_chunks_while_parsing-16in-3tg-11115rows",
        |b| {
            b.iter(|| {
                gearcomp_identify::data::read_csv_file(
                    &path,
                    "fl",
                    &static_sel,
                    ReadOptions::default(),
                )
                .unwrap()
                .unwrap()
            })
        },
    );
    let _ = std::fs::remove_file(&path);
    let static_opts = IdentifyOptions {
        model: gearcomp_identify::ModelKind::Static,
        classes: Some(6),
        ..IdentifyOptions::default()
    };
    let static_table = read_csv(text, "fl", &static_sel, ReadOptions::default()).unwrap();
    r.bench_function("identify_static_6_classes_and_plain_ls-3tg", |b| {
        b.iter(|| {
            let id = identify(black_box(&static_table), &static_opts).unwrap();
            let base =
                gearcomp_identify::plain_least_squares(&static_table, &static_opts.split).unwrap();
            (id, base)
        })
    });
    // The same two as `fit` runs them: the floor on a second core beside the identification.
    r.bench_function(
        "identify_static_6_classes_with_floor_on_all_cores-3tg",
        |b| {
            b.iter(|| {
                gearcomp_identify::pipeline::identify_with_floor(
                    black_box(&static_table),
                    &static_opts,
                )
                .unwrap()
            })
        },
    );
    r.finish();

    // Per-cycle evaluation of an 8-sensor value + rate model: 16 terms.
    let coeffs: Vec<f64> = (0..16).map(|i| 0.1 * i as f64).collect();
    let mut states: Vec<TransformState> = (0..16)
        .map(|i| {
            if i % 2 == 0 {
                TransformState::new(Transform::Value)
            } else {
                TransformState::new(Transform::Rate { tau_s: 900.0 })
            }
        })
        .collect();
    let temps: Vec<f64> = (0..16).map(|i| 20.0 + i as f64).collect();
    let mut t_s = 0.0;
    let mut p = c.benchmark_group("per_sample");
    p.bench_function("baseline_dot_product-16terms", |b| {
        b.iter(|| {
            black_box(&coeffs)
                .iter()
                .zip(black_box(&temps))
                .map(|(a, x)| a * x)
                .sum::<f64>()
        })
    });
    p.bench_function("model_step-16terms", |b| {
        b.iter(|| {
            t_s += 15.0;
            let mut y = 0.0;
            for ((s, a), x) in states.iter_mut().zip(&coeffs).zip(black_box(&temps)) {
                y += a * s.step(t_s, *x);
            }
            y
        })
    });
    p.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
