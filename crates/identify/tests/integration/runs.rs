//! Real test data as it comes: runs in one file (time restarting), one file per run, logs
//! without a time column, gaps; every model state restarts at a run's first sample;
//! constant or duplicated sensors are dropped with a note; bad splits are refused.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_core::model::{LinearModel, Term, Transform};
use gearcomp_identify::data::{read_csv, read_runs, ReadOptions, Selection};
use gearcomp_identify::{identify, predict, IdentifyOptions, ModelKind, Split};

fn sel(run: Option<&str>) -> Selection {
    Selection {
        targets: vec!["y_um".into()],
        run: run.map(str::to_string),
        ..Selection::default()
    }
}

/// One run's rows: time from 0, two temperatures, a target with a lagged term.
fn run_rows(k: usize, n: usize, dt: f64) -> Vec<(f64, f64, f64, f64)> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            let a = 20.0 + (k as f64) + 3.0 * (t / (900.0 + 100.0 * k as f64)).sin();
            let b = 22.0 + 2.0 * (t / 1700.0 + k as f64).cos();
            (t, a, b, 1.5 * a - 0.5 * b)
        })
        .collect()
}

fn csv(rows: &[(f64, f64, f64, f64)], run: Option<&str>) -> String {
    let mut s = String::from(if run.is_some() {
        "run,time_s,a_c,b_c,y_um\n"
    } else {
        "time_s,a_c,b_c,y_um\n"
    });
    for r in rows {
        if let Some(run) = run {
            s += &format!("{run},");
        }
        s += &format!("{},{},{},{}\n", r.0, r.1, r.2, r.3);
    }
    s
}

fn lag_model() -> LinearModel {
    LinearModel {
        intercept: 0.5,
        terms: vec![
            Term {
                channel: "a_c".into(),
                coefficient: 2.0,
                transform: Transform::FirstOrderLag { tau_s: 600.0 },
            },
            Term {
                channel: "b_c".into(),
                coefficient: -1.0,
                transform: Transform::Rate { tau_s: 300.0 },
            },
            Term {
                channel: "b_c".into(),
                coefficient: 0.25,
                transform: Transform::Delay { delay_s: 120.0 },
            },
        ],
    }
}

#[test]
fn every_state_restarts_at_each_run_in_one_file_and_in_several_files() {
    let runs: Vec<Vec<(f64, f64, f64, f64)>> = (0..3).map(|k| run_rows(k, 80, 30.0)).collect();
    // One file, run column, time restarting at 0 in each run.
    let mut one = String::from("run,time_s,a_c,b_c,y_um\n");
    for (k, r) in runs.iter().enumerate() {
        one += csv(r, Some(&format!("{}", k + 1)))
            .lines()
            .skip(1)
            .map(|l| format!("{l}\n"))
            .collect::<String>()
            .as_str();
    }
    let t1 = read_csv(&one, "runs.csv", &sel(Some("run")), ReadOptions::default()).unwrap();
    assert_eq!(t1.run_names, vec!["1", "2", "3"]);
    assert_eq!(t1.segments, vec![0, 80, 160]);
    // Several files, one run each.
    let texts: Vec<String> = runs.iter().map(|r| csv(r, None)).collect();
    let names = ["a.csv", "b.csv", "c.csv"];
    let files: Vec<(&str, &str)> = texts
        .iter()
        .zip(names)
        .map(|(t, n)| (t.as_str(), n))
        .collect();
    let t2 = read_runs(&files, &sel(None), ReadOptions::default()).unwrap();
    assert_eq!(t2.run_names, vec!["a", "b", "c"]);
    assert_eq!(t2.segments, vec![0, 80, 160]);
    // Independent construction: each run read and evaluated on its own.
    let m = lag_model();
    let mut expect = Vec::new();
    for t in &texts {
        let ti = read_csv(t, "one", &sel(None), ReadOptions::default()).unwrap();
        expect.extend(predict(&ti, &m).unwrap());
    }
    for t in [&t1, &t2] {
        let p = predict(t, &m).unwrap();
        assert_eq!(p.len(), expect.len());
        for (a, b) in p.iter().zip(&expect) {
            assert_eq!(a, b, "state leaked across runs");
        }
    }
}

#[test]
fn sample_interval_and_gaps() {
    let rows = run_rows(0, 40, 60.0);
    let mut text = String::from("a_c,b_c,y_um\n");
    for (i, r) in rows.iter().enumerate() {
        if i == 5 {
            text += "oops,1,2\n";
        } else {
            text += &format!("{},{},{}\n", r.1, r.2, r.3);
        }
    }
    let opts = ReadOptions {
        sample_interval_s: Some(60.0),
        skip_bad_rows: true,
        ..ReadOptions::default()
    };
    let t = read_csv(&text, "log", &sel(None), opts).unwrap();
    // The bad row still occupies its sample instant.
    assert_eq!(t.time_s[4], 240.0);
    assert_eq!(t.time_s[5], 360.0);
    assert_eq!(t.time_s.len(), 39);
    // A file with a time column and a sample interval is ambiguous: refused.
    let e = read_csv(&csv(&rows, None), "log", &sel(None), opts).unwrap_err();
    assert!(e.to_string().contains("--sample-interval-s"), "{e}");
    // No time column and no interval: the message says what to do.
    let e = read_csv(&text, "log", &sel(None), ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("--sample-interval-s"), "{e}");
    let e = read_csv(
        &text,
        "log",
        &sel(None),
        ReadOptions {
            sample_interval_s: Some(0.0),
            ..ReadOptions::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("> 0 s"), "{e}");
    // A gap inside a run splits it: the lag restarts after it.
    let mut g = rows.clone();
    for r in g.iter_mut().skip(20) {
        r.0 += 3600.0;
    }
    let t = read_csv(&csv(&g, None), "gap", &sel(None), ReadOptions::default()).unwrap();
    assert_eq!(t.segments, vec![0, 20]);
    let m = lag_model();
    let p = predict(&t, &m).unwrap();
    let tail = read_csv(
        &csv(&g[20..], None),
        "tail",
        &sel(None),
        ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(p[20..], predict(&tail, &m).unwrap()[..]);
}

#[test]
fn bad_splits_are_refused_with_the_runs_named() {
    let mut text = String::from("run,time_s,a_c,b_c,y_um\n");
    for k in 0..3 {
        text += csv(&run_rows(k, 60, 30.0), Some(&format!("r{k}")))
            .lines()
            .skip(1)
            .map(|l| format!("{l}\n"))
            .collect::<String>()
            .as_str();
    }
    let t = read_csv(&text, "runs", &sel(Some("run")), ReadOptions::default()).unwrap();
    let opts = |split| IdentifyOptions {
        split,
        model: ModelKind::Static,
        classes: Some(2),
        ..IdentifyOptions::default()
    };
    let e = identify(&t, &opts(Split::TestRuns(vec!["r7".into()]))).unwrap_err();
    assert!(
        e.to_string().contains("--test-runs = r7") && e.to_string().contains("r0, r1, r2"),
        "{e}"
    );
    let e = identify(&t, &opts(Split::TimeBefore(3600.0))).unwrap_err();
    assert!(e.to_string().contains("--test-runs"), "{e}");
    identify(&t, &opts(Split::TestRuns(vec!["r2".into()]))).unwrap();
    let one = read_csv(
        &csv(&run_rows(0, 60, 30.0), None),
        "one",
        &sel(None),
        ReadOptions::default(),
    )
    .unwrap();
    let e = identify(&one, &opts(Split::TimeBefore(1800.0 * 3600.0))).unwrap_err();
    assert!(e.to_string().contains("--train-before-h = 1800 h"), "{e}");
    let e = identify(&one, &opts(Split::TestRuns(vec!["1".into()]))).unwrap_err();
    assert!(e.to_string().contains("--run-column"), "{e}");
}

#[test]
fn constant_and_duplicated_sensors_are_dropped_with_a_note() {
    let rows = run_rows(0, 120, 30.0);
    let mut text = String::from("time_s,a_c,b_c,k_c,a2_c,y_um\n");
    for r in &rows {
        text += &format!(
            "{},{},{},21.5,{},{}\n",
            r.0,
            r.1,
            r.2,
            1.8 * r.1 + 32.0,
            r.3
        );
    }
    let t = read_csv(&text, "d", &sel(None), ReadOptions::default()).unwrap();
    for model in [
        ModelKind::Static,
        ModelKind::Ridge,
        ModelKind::Dynamic,
        ModelKind::Auto,
    ] {
        let id = identify(
            &t,
            &IdentifyOptions {
                model,
                split: Split::None,
                classes: if model == ModelKind::Auto {
                    None
                } else {
                    Some(2)
                },
                ..IdentifyOptions::default()
            },
        )
        .unwrap();
        assert_eq!(id.input_names, vec!["a_c", "b_c"], "{model:?}");
        assert!(
            id.notes[0].contains("k_c dropped: constant"),
            "{:?}",
            id.notes
        );
        assert!(
            id.notes[1].contains("a2_c dropped: duplicates a_c"),
            "{:?}",
            id.notes
        );
        let m = &id.targets[0];
        assert!(m.fold_rmse.iter().all(|v| v.is_finite()), "{model:?}");
        let tol = if model == ModelKind::Ridge { 0.1 } else { 1e-6 };
        assert!(m.cv_rmse.is_finite() && m.train_rmse < tol, "{model:?}");
    }
}

/// `Identification::to_model_file`: axes named as asked (the target's name otherwise), the
/// fitted models and envelopes under those names, provenance RMSE equal to the fit's, and a
/// file that survives its own TOML round trip; a wrong number of axis names is refused.
#[test]
fn model_file_of_an_identification() {
    use gearcomp_core::model::ModelFile;
    use gearcomp_identify::Origin;
    let mut rows = run_rows(0, 300, 60.0);
    rows.extend(
        run_rows(1, 300, 60.0)
            .into_iter()
            .map(|r| (r.0 + 18_000.0, r.1, r.2, r.3)),
    );
    let t = read_csv(&csv(&rows, None), "two", &sel(None), ReadOptions::default()).unwrap();
    let id = identify(
        &t,
        &IdentifyOptions {
            split: Split::TimeBefore(18_000.0),
            ..IdentifyOptions::default()
        },
    )
    .unwrap();
    let origin = Origin {
        name: "m",
        data: "two.csv",
        rows: t.time_s.len(),
        created_by: "test",
        restart_after_s: t.gap_after_s,
    };
    let f = id.to_model_file(&origin, &["X".into()], None).unwrap();
    assert_eq!(f.axes.len(), 1);
    assert_eq!(f.axes[0].axis, "X");
    assert_eq!(f.axes[0].target, "y_um");
    assert_eq!(f.axes[0].machine, id.targets[0].model);
    assert_eq!(f.envelopes.len(), 1);
    assert_eq!(f.envelopes[0].axis, "X");
    let p = f.provenance.as_ref().unwrap();
    assert_eq!(p.train_rmse_um, vec![id.targets[0].train_rmse]);
    assert_eq!(p.test_rmse_um, vec![id.targets[0].test_rmse.unwrap()]);
    assert_eq!(f.description, "identified from two.csv (600 rows)");
    let back = ModelFile::from_toml_str(&f.to_toml_string().unwrap()).unwrap();
    assert_eq!(back.axes, f.axes);
    let unnamed = id.to_model_file(&origin, &[], None).unwrap();
    assert_eq!(unnamed.axes[0].axis, "y_um");
    let e = id
        .to_model_file(&origin, &["X".into(), "Z".into()], None)
        .unwrap_err();
    assert!(e.to_string().contains("axis"), "{e}");
}

/// When no candidate model can be validated (here every input is constant within each
/// training run, so every leave-one-run-out fold trains on a singular design), the error
/// says so, naming the target, its training rows, the validation and what to change.
#[test]
fn nothing_validated_is_named_with_what_to_change() {
    let mut text = String::from("run,time_s,a_c,b_c,y_um\n");
    for run in 1..=3 {
        for i in 0..10 {
            let a = 20.0 + run as f64;
            let b = 25.0 - 2.0 * run as f64 + if run == 3 { 0.1 * i as f64 } else { 0.0 };
            text += &format!("r{run},{},{a},{b},{}\n", i * 60, 2.0 * a + i as f64);
        }
    }
    let t = read_csv(&text, "log.csv", &sel(Some("run")), ReadOptions::default()).unwrap();
    let o = IdentifyOptions {
        split: Split::TestRuns(vec!["r3".into()]),
        ..IdentifyOptions::default()
    };
    let e = identify(&t, &o).unwrap_err().to_string();
    assert!(
        e.starts_with("no candidate model of y_um could be validated on its 20 training row(s) (leave-one-run-out")
            && e.contains("--no-test"),
        "{e}"
    );
}

/// One file per run, exported with the columns in another order (and an extra column) in
/// some files: each file's columns are read by name into the first file's order, the same
/// table as the files written alike. A file lacking a column, or holding another, is still
/// refused naming both files' columns.
#[test]
fn files_with_their_columns_in_another_order_read_by_name() {
    let cols = ["time_s", "a_c", "b_c", "c_c", "y_um", "z_um"];
    // Rows: time, three temperatures, two targets; file k's values differ.
    let rows = |k: usize| -> Vec<[f64; 6]> {
        (0..20)
            .map(|i| {
                let t = 60.0 * i as f64;
                let (a, b, c) = (
                    20.0 + k as f64 + 0.1 * i as f64,
                    22.0 - 0.05 * i as f64,
                    19.0 + (i % 3) as f64,
                );
                [t, a, b, c, 1.5 * a - b, c - 0.5 * a]
            })
            .collect()
    };
    let write = |k: usize, order: &[usize], extra: bool| -> String {
        let mut head: Vec<&str> = order.iter().map(|&j| cols[j]).collect();
        if extra {
            head.insert(1, "note");
        }
        let mut s = head.join(",") + "\n";
        for r in rows(k) {
            let mut cells: Vec<String> = order.iter().map(|&j| r[j].to_string()).collect();
            if extra {
                cells.insert(1, "x".into());
            }
            s += &(cells.join(",") + "\n");
        }
        s
    };
    let sel = Selection {
        targets: vec!["*_um".into()],
        ..Selection::default()
    };
    let same = [0, 1, 2, 3, 4, 5];
    let alike: Vec<String> = (0..3).map(|k| write(k, &same, false)).collect();
    let names = ["r0.csv", "r1.csv", "r2.csv"];
    let files =
        |texts: &[String]| -> Vec<(String, &str)> { texts.iter().cloned().zip(names).collect() };
    let read = |texts: &[String]| {
        let f = files(texts);
        let refs: Vec<(&str, &str)> = f.iter().map(|(t, n)| (t.as_str(), *n)).collect();
        read_runs(&refs, &sel, ReadOptions::default())
    };
    let want = read(&alike).unwrap();
    // Every permutation of the five value columns for the second and third file (the
    // time column moved too in some).
    let mut perms = vec![vec![1usize, 2, 3, 4, 5]];
    for _ in 0..4 {
        let next: Vec<Vec<usize>> = perms
            .iter()
            .flat_map(|p| {
                (0..p.len()).map(move |i| {
                    let mut q = p.clone();
                    q.swap(0, i);
                    q.rotate_left(1);
                    q
                })
            })
            .collect();
        perms = next;
        perms.sort();
        perms.dedup();
    }
    for (n, p) in perms.iter().enumerate() {
        let mut order = p.clone();
        order.insert(n % 6, 0);
        let texts = vec![
            alike[0].clone(),
            write(1, &order, n % 2 == 0),
            write(2, &order.iter().rev().copied().collect::<Vec<_>>(), false),
        ];
        let got = read(&texts).unwrap();
        assert_eq!(got.input_names, want.input_names);
        assert_eq!(got.target_names, want.target_names);
        assert_eq!(
            (&got.time_s, &got.inputs, &got.targets),
            (&want.time_s, &want.inputs, &want.targets),
            "{order:?}"
        );
    }
    // A file without c_c: refused, both files' columns named.
    let e = read(&[
        alike[0].clone(),
        write(1, &[0, 1, 2, 4, 5], false),
        alike[2].clone(),
    ])
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("columns of r1.csv")
            && e.contains("inputs a_c b_c / targets y_um z_um")
            && e.contains("the columns of r0.csv: inputs a_c b_c c_c"),
        "{e}"
    );
}

/// Runs logged row by row in one file (two or three machines, a random interleaving that
/// keeps each run's rows in their order): each run's rows are taken together, so the table
/// (times, values, runs, segments) and the lag model's predictions are those of the same
/// log with each run's rows together; every row keeps its line; a note names the first row
/// that came back. Under time stamps each run counts from its own first stamp; under
/// `--missing split` a row left out still splits its own run.
#[test]
fn runs_logged_row_by_row_are_taken_together() {
    use gearcomp_identify::data::{DataIssue, MissingCells};
    for seed in [1u64, 2, 3, 4, 5, std::process::id() as u64] {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let n_runs = 2 + (seed % 2) as usize;
        let runs: Vec<Vec<(f64, f64, f64, f64)>> =
            (0..n_runs).map(|k| run_rows(k, 40 + 7 * k, 30.0)).collect();
        let stamps = seed % 3 == 0;
        let hole = (seed % 2 == 1).then_some((1usize, 17usize));
        let cell = |k: usize, i: usize| -> String {
            let (t, a, b, y) = runs[k][i];
            let time = if stamps {
                // Run k from its own day; each run's times count from its first stamp.
                let s = t as i64;
                format!("2024-03-{:02} 08:{:02}:{:02}", 1 + k, s / 60, s % 60)
            } else {
                t.to_string()
            };
            let a = if hole == Some((k, i)) {
                String::new()
            } else {
                a.to_string()
            };
            format!("{},{time},{a},{b},{y}\n", ["m1", "m2", "m3"][k])
        };
        // The interleaving: at each row a random run with rows left.
        let mut at = vec![0usize; n_runs];
        let mut mixed = String::from("run,time_s,a_c,b_c,y_um\n");
        let mut mixed_lines: Vec<Vec<u64>> = vec![Vec::new(); n_runs];
        let mut line = 1u64;
        while at.iter().zip(&runs).any(|(&i, r)| i < r.len()) {
            let left: Vec<usize> = (0..n_runs).filter(|&k| at[k] < runs[k].len()).collect();
            let k = left[(next() % left.len() as u64) as usize];
            mixed += &cell(k, at[k]);
            line += 1;
            mixed_lines[k].push(line);
            at[k] += 1;
        }
        // The runs in the order they first appear, each run's rows together.
        let mut first: Vec<usize> = (0..n_runs).collect();
        first.sort_by_key(|&k| mixed_lines[k][0]);
        let together: String = std::iter::once("run,time_s,a_c,b_c,y_um\n".to_string())
            .chain(
                first
                    .iter()
                    .flat_map(|&k| (0..runs[k].len()).map(move |i| (k, i)))
                    .map(|(k, i)| cell(k, i)),
            )
            .collect();
        let opts = ReadOptions {
            missing: MissingCells::Split,
            ..ReadOptions::default()
        };
        let want = read_csv(&together, "log.csv", &sel(Some("run")), opts).unwrap();
        let got = read_csv(&mixed, "log.csv", &sel(Some("run")), opts).unwrap();
        assert_eq!(got.time_s, want.time_s, "seed {seed}");
        assert_eq!(
            (&got.inputs, &got.targets),
            (&want.inputs, &want.targets),
            "seed {seed}"
        );
        assert_eq!((&got.runs, &got.run_names), (&want.runs, &want.run_names));
        assert_eq!(got.segments, want.segments, "seed {seed}");
        // Each row keeps its line in the file (the hole's row is left out).
        let lines: Vec<u64> = first
            .iter()
            .flat_map(|&k| {
                let skip = hole.filter(|h| h.0 == k).map(|h| h.1);
                mixed_lines[k]
                    .iter()
                    .enumerate()
                    .filter(move |(i, _)| Some(*i) != skip)
                    .map(|(_, &l)| l)
            })
            .collect();
        assert_eq!(got.lines, lines, "seed {seed}");
        let note = got
            .issues
            .iter()
            .find(|i| matches!(i, DataIssue::RunsTogether { .. }))
            .map(ToString::to_string)
            .unwrap_or_default();
        assert!(
            note.contains("comes back after another run's rows"),
            "{:?}",
            got.issues
        );
        let m = lag_model();
        assert_eq!(predict(&got, &m).unwrap(), predict(&want, &m).unwrap());
    }
}
