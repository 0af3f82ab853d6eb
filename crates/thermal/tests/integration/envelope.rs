//! Issue 12 item 4: the engine warns when the live inputs of an identified model leave the
//! model file's training envelope (per-channel range, Mahalanobis bound on the regressors),
//! and the compensation goes on. References: points just inside/outside a hand-built
//! envelope with d² written out by hand; a brute-force d² = (x − x̄)ᵀ S⁻¹ (x − x̄) from the
//! sample covariance of random training points; FL_THERMAL's 5000 rpm test period.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_core::model::{ChannelRange, Envelope, ModelFile};
use gearcomp_thermal::engine::{Excursion, ENVELOPE_CLEAR_HOLD_S};
use gearcomp_thermal::replay::replay_csv;
use gearcomp_thermal::{
    Alarm, AxisStatus, Engine, EngineConfig, EngineStatus, Inputs, Output, Reading,
};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

/// A model y = 1 + Σ 0.5·value(c_k) on `names`, with `env` (if any) on axis "X".
fn model(names: &[&str], env: Option<Envelope>) -> ModelFile {
    let mut t = String::from(
        "format = \"gearcomp-thermal-model/1\"\nname = \"env\"\n[[axes]]\naxis = \"X\"\n[axes.machine]\nintercept = 1.0\n",
    );
    for n in names {
        t.push_str(&format!(
            "[[axes.machine.terms]]\nchannel = \"{n}\"\ncoefficient = 0.5\n"
        ));
    }
    let mut m = ModelFile::from_toml_str(&t).unwrap();
    m.envelopes.extend(env);
    m.validate().unwrap();
    m
}

/// Celsius channels, N = 1, no filter: each channel's averaged value is its reading.
fn engine(names: &[&str], env: Option<Envelope>) -> Engine {
    let mut t = String::new();
    for n in names {
        t.push_str(&format!(
            "[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -100.0\nvalid_max = 1000.0\nstale_timeout_s = 1e6\n"
        ));
    }
    t.push_str(
        "[[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 1e4\nmax_step_um = 1e4\n\
         [[axes.terms]]\nkind = \"model\"\nfile = \"m.toml\"\naxis = \"X\"\n",
    );
    let mut cfg = EngineConfig::from_toml_str(&t).unwrap();
    cfg.insert_model("m.toml", model(names, env));
    Engine::new(&cfg).unwrap()
}

fn step(e: &mut Engine, t: f64, values: &[f64]) -> Output {
    let r: Vec<Reading> = values
        .iter()
        .map(|&v| Reading { raw: v, stamp_s: t })
        .collect();
    e.step(&Inputs {
        time_s: t,
        readings: &r,
        trigger: true,
        safe_point: true,
        positions_mm: &[],
    })
}

/// W = [[2, 0], [1, 0.5]], x̄ = (20, 21), max d² = 4: d² = (2a)² + (a + 0.5·b)² by hand,
/// a = x₁ − 20, b = x₂ − 21. Ranges 10…30 °C and 12…32 °C.
fn hand_envelope() -> Envelope {
    Envelope {
        axis: "X".into(),
        ranges: vec![
            ChannelRange {
                channel: "a".into(),
                min: 10.0,
                max: 30.0,
            },
            ChannelRange {
                channel: "b".into(),
                min: 12.0,
                max: 32.0,
            },
        ],
        feature_mean: vec![20.0, 21.0],
        whitening: vec![2.0, 0.0, 1.0, 0.5],
        max_d2: 4.0,
        rows: 101,
    }
}

fn hand_d2(x1: f64, x2: f64) -> f64 {
    let (a, b) = (x1 - 20.0, x2 - 21.0);
    (2.0 * a).powi(2) + (a + 0.5 * b).powi(2)
}

#[test]
fn hand_built_envelope_points_just_inside_and_outside() {
    // Along the direction (u, v) = (0.3, 1): d² = t²·q, q = (0.6)² + (0.3 + 0.5)² = 1.0,
    // so the bound d² = 4 is at t = 2: (20.6, 23).
    let q: f64 = 0.6f64.powi(2) + 0.8f64.powi(2);
    let t_bound = (4.0 / q).sqrt();
    for (scale, outside) in [
        (1.0 - 1e-6, false),
        (1.0 + 1e-6, true),
        (0.5, false),
        (3.0, true),
    ] {
        let (x1, x2) = (20.0 + 0.3 * t_bound * scale, 21.0 + t_bound * scale);
        let mut e = engine(&["a", "b"], Some(hand_envelope()));
        let o = step(&mut e, 0.0, &[x1, x2]);
        assert_eq!(o.warning.is_some(), outside, "scale {scale}: {o:?}");
        if let Some(Alarm::Envelope {
            axis,
            excursion:
                Excursion::Leverage {
                    leverage,
                    bound,
                    d2,
                    max_d2,
                },
        }) = o.warning
        {
            assert_eq!(axis, 0);
            let want = hand_d2(x1, x2);
            assert!((d2 - want).abs() < 1e-12 * want, "{d2} vs {want}");
            assert_eq!(max_d2, 4.0);
            assert!((leverage - (1.0 / 101.0 + want / 100.0)).abs() < 1e-15);
            assert!((bound - (1.0 / 101.0 + 4.0 / 100.0)).abs() < 1e-15);
        }
        // A warning: compensation goes on, nothing frozen, no alarm, no stop.
        assert_eq!(o.status, EngineStatus::Running);
        assert_eq!(o.alarm, None);
        assert_eq!(o.stop, None);
        assert_eq!(o.axes()[0].status, AxisStatus::Updated);
        assert_eq!(o.axes()[0].offset_um, 1.0 + 0.5 * x1 + 0.5 * x2);
    }
    // Ranges: b = 32.01 °C is outside (with a = 20.1, d² is not the reason checked first);
    // 31.99 is inside the range (and then outside the Mahalanobis bound only).
    let mut e = engine(&["a", "b"], Some(hand_envelope()));
    let o = step(&mut e, 0.0, &[20.1, 32.01]);
    assert_eq!(
        o.warning,
        Some(Alarm::Envelope {
            axis: 0,
            excursion: Excursion::Range {
                channel: 1,
                value: 32.01,
                min: 12.0,
                max: 32.0,
                celsius: true
            }
        })
    );
    let mut e = engine(&["a", "b"], Some(hand_envelope()));
    let o = step(&mut e, 0.0, &[9.99, 21.0]);
    assert!(matches!(
        o.warning,
        Some(Alarm::Envelope {
            excursion: Excursion::Range { channel: 0, .. },
            ..
        })
    ));
    // Ranges only (no Mahalanobis bound): far from the mean but inside the ranges: no warning.
    let mut env = hand_envelope();
    env.feature_mean.clear();
    env.whitening.clear();
    let mut e = engine(&["a", "b"], Some(env));
    assert_eq!(step(&mut e, 0.0, &[29.9, 12.1]).warning, None);
}

/// The same offsets with and without an envelope while the warning is raised: a warning
/// freezes nothing; it clears only after the hold time inside the shrunk envelope, and
/// inputs wandering across the boundary give one warning, not one per instant.
#[test]
fn warning_does_not_freeze_and_clears_after_hold_with_hysteresis() {
    let mut with = engine(&["a", "b"], Some(hand_envelope()));
    let mut without = engine(&["a", "b"], None);
    let mut edges = 0;
    let mut was = false;
    let mut last_on = f64::NAN;
    // 0…999 s: inside; 1000…1999 s: a wanders ±0.05 °C across its maximum 30 °C; from 2000 s
    // back at the mean (deep inside).
    for k in 0..4000 {
        let t = k as f64;
        let a = if (1000..2000).contains(&k) {
            30.0 + 0.05 * (t * 0.7).sin()
        } else {
            20.0
        };
        let b = 21.0 - 0.5 * (a - 20.0) * 2.0; // keep d² small: a + 0.5·b term cancels
        let b = if (1000..2000).contains(&k) { b } else { 21.0 };
        let o1 = step(&mut with, t, &[a, b]);
        let o2 = step(&mut without, t, &[a, b]);
        assert_eq!(o1.axes(), o2.axes(), "t = {t}");
        assert_eq!(o1.status, o2.status);
        let on = o1.warning.is_some();
        if on && !was {
            edges += 1;
        }
        if on {
            last_on = t;
        }
        was = on;
    }
    assert_eq!(edges, 1, "one warning for the whole wandering");
    // The last reading outside is a little before 2000 s; inside from 2000 s: cleared
    // exactly ENVELOPE_CLEAR_HOLD_S later.
    assert_eq!(last_on, 2000.0 + ENVELOPE_CLEAR_HOLD_S - 1.0);
}

#[test]
fn warning_state_survives_save_and_restore() {
    let mut a = engine(&["a", "b"], Some(hand_envelope()));
    let mut b_engine: Option<Engine> = None;
    for k in 0..1500 {
        let t = k as f64;
        let x = if (100..300).contains(&k) {
            [31.0, 21.0]
        } else {
            [20.0, 21.0]
        };
        let oa = step(&mut a, t, &x);
        if k == 310 {
            assert!(oa.warning.is_some());
            let mut buf = Vec::new();
            a.save_state(&mut buf);
            let mut e = engine(&["a", "b"], Some(hand_envelope()));
            e.restore_state(&buf).unwrap();
            b_engine = Some(e);
        } else if let Some(e) = b_engine.as_mut() {
            assert_eq!(
                format!("{oa:?}"),
                format!("{:?}", step(e, t, &x)),
                "t = {t}"
            );
        }
    }
}

/// d² = (x − x̄)ᵀ S⁻¹ (x − x̄), S the sample covariance (explicit sums, LU inverse).
fn brute_d2(train: &[Vec<f64>], x: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
    let n = train.len();
    let p = x.len();
    let mean: Vec<f64> = (0..p)
        .map(|j| train.iter().map(|r| r[j]).sum::<f64>() / n as f64)
        .collect();
    let mut s = DMatrix::zeros(p, p);
    for r in train {
        for i in 0..p {
            for j in 0..p {
                s[(i, j)] += (r[i] - mean[i]) * (r[j] - mean[j]) / (n as f64 - 1.0);
            }
        }
    }
    (mean, s.try_inverse().unwrap())
}

fn quad(mean: &[f64], s_inv: &DMatrix<f64>, x: &[f64]) -> f64 {
    let d = DVector::from_iterator(x.len(), x.iter().zip(mean).map(|(a, m)| a - m));
    (d.transpose() * s_inv * &d)[(0, 0)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random training clouds (p = 1…4 channels, correlated), the envelope stored as the
    /// identification stores it (W = √(n − 1)·R⁻ᵀ from the QR of the centred rows), random
    /// live points: the engine warns exactly where the brute-force check says so.
    #[test]
    fn engine_warning_matches_brute_force(
        p in 1usize..=4,
        n in 12usize..40,
        seed in proptest::collection::vec(-1.0f64..1.0, 4 * 40 + 16 + 4 * 8),
    ) {
        let names: Vec<String> = (0..p).map(|k| format!("c{k}")).collect();
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        let mix = |k: usize, z: &[f64]| -> f64 {
            20.0 + (0..p).map(|j| seed[160 + (k * 4 + j) % 16] * z[j] * 3.0).sum::<f64>() + 2.0 * z[k]
        };
        let train: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let z = &seed[i * 4..i * 4 + 4];
                (0..p).map(|k| mix(k, z)).collect()
            })
            .collect();
        let (mean, s_inv) = brute_d2(&train, &vec![0.0; p]);
        let max_d2 = train.iter().map(|r| quad(&mean, &s_inv, r)).fold(0.0, f64::max);
        let xc = DMatrix::from_fn(n, p, |i, j| train[i][j] - mean[j]);
        let r = xc.qr().r();
        let w = r.solve_upper_triangular(&DMatrix::identity(p, p)).unwrap().transpose()
            * ((n - 1) as f64).sqrt();
        let ranges: Vec<ChannelRange> = (0..p)
            .map(|k| ChannelRange {
                channel: names[k].clone(),
                min: train.iter().map(|r| r[k]).fold(f64::INFINITY, f64::min),
                max: train.iter().map(|r| r[k]).fold(f64::NEG_INFINITY, f64::max),
            })
            .collect();
        let env = Envelope {
            axis: "X".into(),
            ranges: ranges.clone(),
            feature_mean: mean.clone(),
            whitening: (0..p * p).map(|k| w[(k / p, k % p)]).collect(),
            max_d2,
            rows: n as u64,
        };
        for q in 0..8 {
            let z = &seed[176 + q * 4..176 + q * 4 + 4];
            let x: Vec<f64> = (0..p).map(|k| mix(k, z) + 1.5 * z[(k + 1) % 4]).collect();
            let d2 = quad(&mean, &s_inv, &x);
            let first_out = (0..p).find(|&k| x[k] < ranges[k].min || x[k] > ranges[k].max);
            // Skip points on a boundary within rounding.
            if (d2 - max_d2).abs() < 1e-6 * max_d2
                || (0..p).any(|k| (x[k] - ranges[k].min).abs() < 1e-9 || (x[k] - ranges[k].max).abs() < 1e-9)
            {
                continue;
            }
            let mut e = engine(&refs, Some(env.clone()));
            let o = step(&mut e, 0.0, &x);
            match (first_out, o.warning) {
                (Some(k), Some(Alarm::Envelope { excursion: Excursion::Range { channel, value, .. }, .. })) => {
                    prop_assert_eq!(channel as usize, k);
                    prop_assert_eq!(value, x[k]);
                }
                (None, Some(Alarm::Envelope { excursion: Excursion::Leverage { d2: got, .. }, .. })) => {
                    prop_assert!(d2 > max_d2, "{} ≤ {}", d2, max_d2);
                    prop_assert!((got - d2).abs() < 1e-7 * d2.max(1.0), "{} vs {}", got, d2);
                }
                (None, None) => prop_assert!(d2 <= max_d2, "{} > {} not warned", d2, max_d2),
                (want, got) => prop_assert!(false, "range {:?} but engine {:?}", want, got),
            }
            // The training rows themselves never warn.
            if q == 0 {
                for row in &train {
                    let mut e = engine(&refs, Some(env.clone()));
                    prop_assert_eq!(step(&mut e, 0.0, row).warning, None);
                }
            }
        }
    }
}

/// FL_THERMAL: a static model of ch1 on five temperatures fitted here on the first 24 h
/// (least squares by QR), its envelope computed here by brute force (ranges, S⁻¹ of the
/// sample covariance; W = Cholesky factor of S⁻¹). Replayed through the engine: no warning on
/// the training rows, a warning on the 5000 rpm test period (24 h … 28 h).
#[test]
fn fl_thermal_warns_in_the_5000_rpm_period_and_not_on_training_rows() {
    let text = gearcomp_datasets::fl_thermal_csv();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').map(str::trim).collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .collect();
    let names = ["t1_c", "t3_c", "t5_c", "t8_c", "t12_c"];
    let cols: Vec<usize> = names.iter().map(|n| col(n)).collect();
    let (ti, yi) = (col("time_s"), col("ch1_um"));
    let train: Vec<Vec<f64>> = rows
        .iter()
        .filter(|r| r[ti] < 86_400.0)
        .map(|r| cols.iter().map(|&c| r[c]).collect())
        .collect();
    let y: Vec<f64> = rows
        .iter()
        .filter(|r| r[ti] < 86_400.0)
        .map(|r| r[yi])
        .collect();
    let n = train.len();
    let p = names.len();
    let a = DMatrix::from_fn(n, p + 1, |i, j| if j == 0 { 1.0 } else { train[i][j - 1] });
    let qr = a.qr();
    let coef = qr
        .r()
        .solve_upper_triangular(&(qr.q().transpose() * DVector::from_vec(y)))
        .unwrap();
    let (mean, s_inv) = brute_d2(&train, &[0.0; 5]);
    let max_d2 = train
        .iter()
        .map(|r| quad(&mean, &s_inv, r))
        .fold(0.0, f64::max);
    let l = s_inv.clone().cholesky().unwrap().l(); // S⁻¹ = L·Lᵀ: d² = ‖Lᵀ·dx‖²
    let w = l.transpose();
    let mut t = String::from(
        "format = \"gearcomp-thermal-model/1\"\nname = \"fl ch1\"\n[[axes]]\naxis = \"X\"\n",
    );
    t.push_str(&format!("[axes.machine]\nintercept = {:e}\n", coef[0]));
    for (k, nm) in names.iter().enumerate() {
        t.push_str(&format!(
            "[[axes.machine.terms]]\nchannel = \"{nm}\"\ncoefficient = {:e}\n",
            coef[k + 1]
        ));
    }
    let mut m = ModelFile::from_toml_str(&t).unwrap();
    m.envelopes.push(Envelope {
        axis: "X".into(),
        ranges: (0..p)
            .map(|k| ChannelRange {
                channel: names[k].into(),
                min: train.iter().map(|r| r[k]).fold(f64::INFINITY, f64::min),
                max: train.iter().map(|r| r[k]).fold(f64::NEG_INFINITY, f64::max),
            })
            .collect(),
        feature_mean: mean,
        whitening: (0..p * p).map(|k| w[(k / p, k % p)]).collect(),
        max_d2,
        rows: n as u64,
    });
    m.validate().unwrap();
    // Every FL_THERMAL temperature as a channel (the log's columns), only five in the model.
    let mut c = String::new();
    for k in 1..=16 {
        c.push_str(&format!(
            "[[channels]]\nname = \"t{k}_c\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 60.0\n"
        ));
    }
    c.push_str("[[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 200.0\n[[axes.terms]]\nkind = \"model\"\nfile = \"m.toml\"\naxis = \"X\"\n");
    let mut cfg = EngineConfig::from_toml_str(&c).unwrap();
    cfg.insert_model("m.toml", m);
    let mut e = Engine::new(&cfg).unwrap();
    let replay = replay_csv(&mut e, text).unwrap();
    assert!(replay.bad_rows.is_empty());
    let (mut train_warn, mut hot, mut hot_warn, mut later_warn, mut later) = (0, 0, 0, 0, 0);
    for r in &replay.rows {
        let h = r.time_s / 3600.0;
        let w = !r.warning.is_empty();
        if h < 24.0 {
            train_warn += usize::from(w);
        } else if h < 28.0 {
            hot += 1;
            hot_warn += usize::from(w);
        } else {
            later += 1;
            later_warn += usize::from(w);
        }
        assert_ne!(r.status, EngineStatus::Alarm, "{r:?}");
        assert!(r.alarm.is_empty());
    }
    let first = replay.rows.iter().find(|r| !r.warning.is_empty()).unwrap();
    println!(
        "FL_THERMAL envelope warning: training rows {train_warn}, 5000 rpm period {hot_warn}/{hot}, after {later_warn}/{later}; first at {:.3} h: {}",
        first.time_s / 3600.0,
        first.warning
    );
    assert_eq!(train_warn, 0);
    assert!(hot_warn * 10 >= hot * 9, "{hot_warn}/{hot}");
    assert!(
        first
            .warning
            .contains("axis X: warning, model extrapolating"),
        "{}",
        first.warning
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The warning's hysteresis and hold, as four properties of any input sequence (one
    /// channel, range 10…30 °C, so the shrunk range is 10.4…29.6 °C; random steps of 1 … 300 s
    /// and values wandering across both boundaries): an input outside raises it; it is
    /// never raised without one; it clears only at the end of a run of inputs inside the
    /// shrunk range lasting at least 600 s; and such a run always clears it.
    #[test]
    fn hysteresis_and_hold_hold_for_any_sequence(
        steps in proptest::collection::vec((1u32..300, -1.0f64..1.0), 50..300),
    ) {
        let env = Envelope {
            axis: "X".into(),
            ranges: vec![ChannelRange { channel: "a".into(), min: 10.0, max: 30.0 }],
            feature_mean: vec![],
            whitening: vec![],
            max_d2: 0.0,
            rows: 50,
        };
        let mut e = engine(&["a"], Some(env));
        let (mut t, mut v) = (0.0, 20.0);
        let mut was_on = false;
        let mut run_start: Option<f64> = None;
        for (dt, dv) in steps {
            t += f64::from(dt);
            // A walk biased towards the upper boundary region, reflected into 8…32 °C.
            v = (v + 3.0 * dv + 0.4).clamp(8.0, 32.0);
            if v >= 32.0 {
                v = 27.0;
            }
            let on = step(&mut e, t, &[v]).warning.is_some();
            let outside = !(10.0..=30.0).contains(&v);
            let inside_shrunk = (10.4..=29.6).contains(&v);
            run_start = if inside_shrunk { run_start.or(Some(t)) } else { None };
            let long_run = run_start.is_some_and(|s| t - s >= ENVELOPE_CLEAR_HOLD_S);
            prop_assert!(!outside || on, "outside at {t} s ({v} °C) without a warning");
            prop_assert!(was_on || outside || !on, "raised at {t} s without an excursion");
            let cleared = was_on && !on;
            prop_assert!(!cleared || long_run, "cleared at {t} s after a short run");
            prop_assert!(!(long_run && on), "still on at {t} s after {:?}", run_start);
            was_on = on;
        }
    }
}
