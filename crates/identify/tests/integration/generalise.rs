//! Does the default (`--model auto`) hold on data shaped like the real tests of issue 12?
//! Look-alike data sets are built here from a small physical model (heat sources, first-order
//! thermal lags, sensor mixtures, noise), never from the real ones:
//! - **A, repeat runs**: 5 runs of 73, 73, 73, 73 and 57 rows; 22 temperature rises ΔT (each
//!   column 0 at the run's first row, maxima ≈ 8–11 K, heavily collinear, some near
//!   duplicates); one thermal error 0 at the start rising to ≈ 13–15 µm; no time column (the
//!   sample interval is a guess).
//! - **B, production log**: 18 days of 187–622 rows, 6 absolute temperatures (ambient with a
//!   daily cycle, bed reference, spindle rear, coolant wall, transformer/bed, spindle front)
//!   and a diameter displacement (≈ 36–81 µm) whose level jumps from day to day.
//!
//! Each held-out run is never seen by any choice (outer loop here, inner validation in the
//! library). The default is compared with plain least squares on all inputs and with the
//! fixed kinds `--model static` and `--model ridge`, as the evaluators do; the
//! figures pooled over seeds 1..=n are asserted (and a fresh seed each run is held to a
//! bound against failure, see `check_fresh_seed`):
//! - B (6 inputs, within the sensor cap): default ≤ 1.02 × plain LS and ≤ 1.05 × the better
//!   of static / ridge (measured over seeds 1–8: 3.562 vs LS 3.533, static 3.550, ridge
//!   3.581 µm; 3.449 before the optimism correction of the family figures);
//! - A (22 inputs, cap 8): default ≤ 1.05 × the better of static / ridge (2.006 vs 2.220 /
//!   2.273 µm over seeds 1–8; 1.908 before the optimism correction). Plain LS on all 22
//!   inputs generalises better here (1.783 µm) and no family within the cap of 8 sensors
//!   reaches it (best alone: 2nd-order TF 1.946); the default is guarded at ≤ 1.25 × plain
//!   LS (docs/identification.md, "Look-alikes");
//! - A with a per-run sensor drift: see `repeat_runs_with_sensor_drift_default_is_not_the_worst`;
//! - the reporters' fingerprints (static / ridge well ahead of plain LS): A with re-mounted
//!   sensors ([`A_REMOUNTED`]) and B with per-day sensor offsets ([`B_DAY_OFFSETS`]), where
//!   the default must beat plain LS and follow the better fixed kind (seeds 1–8: A 3.297 vs
//!   LS 4.244, ridge 2.996; B 3.804 vs LS 3.969, static 3.770; 3.539 and 4.046 before ridge
//!   became the reference of the one-standard-error rule with leave-one-run-out). With that
//!   change A is 2.011 µm (was 2.006), B 3.564 (3.562), A with drift 3.006 (3.094).
//!   Then the coordinator's two changes (a family that halves the reference's pooled
//!   held-out MSE is kept without the consistency test; the k-step model of a forward path
//!   is the best-fitting of the k-step paths, `select::best_fitting`): A 1.963, B 3.564,
//!   A with drift 2.975, A re-mounted 3.094 (1.033 × ridge), B with offsets 3.811.
//!
//! `GEARCOMP_LOOKALIKE_FAMILIES=1` adds each family alone to the table,
//! `GEARCOMP_LOOKALIKE_DETAIL=1` prints the default's comparison per held-out run,
//! `GEARCOMP_LOOKALIKE_DT_S=60` sets the sample interval the user guesses,
//! `GEARCOMP_LOOKALIKE_DUMP=dir` writes each run as a CSV without time column (to run
//! `gearcomp fit` on), `GEARCOMP_LOOKALIKE_SENSOR_DRIFT_K=1.5` adds a per-sensor, per-run drift to A (the
//! variant where ridge beats plain LS and the default loses; docs/identification.md).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::select::Family;
use gearcomp_identify::{identify, plain_least_squares, IdentifyOptions, ModelKind, Split};

/// SplitMix64 with a Box–Muller normal: reproducible from its seed, no dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unif(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unif()
    }
    pub fn normal(&mut self) -> f64 {
        let u = self.unif().max(1e-300);
        let v = self.unif();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// First-order lag of `u` (sampled every `dt_s`, zero-order hold) with time constant `tau_s`,
/// starting from `x0`.
fn lag(u: &[f64], dt_s: f64, tau_s: f64, x0: f64) -> Vec<f64> {
    let a = (-dt_s / tau_s).exp();
    let mut x = x0;
    u.iter()
        .map(|&v| {
            let y = x;
            x = a * x + (1.0 - a) * v;
            y
        })
        .collect()
}

/// One look-alike data set: runs of rows, the inputs and the target per run.
pub struct LookAlike {
    pub names: Vec<String>,
    pub target: String,
    /// Per run: name, rows × (inputs…, target).
    pub runs: Vec<(String, Vec<Vec<f64>>)>,
}

impl LookAlike {
    /// The runs named in `keep` as one CSV with a run column and a time column at `dt_s`.
    pub fn csv(&self, keep: &[usize], dt_s: f64) -> String {
        let mut s = format!("run,time_s,{},{}\n", self.names.join(","), self.target);
        for &r in keep {
            let (name, rows) = &self.runs[r];
            for (i, row) in rows.iter().enumerate() {
                let v: Vec<String> = row.iter().map(|x| format!("{x:.4}")).collect();
                s += &format!("{name},{},{}\n", i as f64 * dt_s, v.join(","));
            }
        }
        s
    }

    pub fn table(&self, keep: &[usize], dt_s: f64) -> Table {
        let sel = Selection {
            inputs: self.names.clone(),
            targets: vec![self.target.clone()],
            run: Some("run".into()),
            ..Selection::default()
        };
        read_csv(
            &self.csv(keep, dt_s),
            "look-alike",
            &sel,
            ReadOptions::default(),
        )
        .unwrap()
    }
}

/// Shape A: repeat runs of one machine from cold. Three heat sources (spindle, axis drives,
/// hydraulics) whose power differs per run and changes once or twice within a run, plus a
/// slow ambient drift; 22 sensors = lagged mixtures of the sources (τ 10–150 min), six of
/// them near duplicates of others; the error a lagged mixture of the sources with its own
/// time constants. Rows every 5 min (true interval; the user does not know it).
pub fn shape_a(seed: u64) -> LookAlike {
    let d_k: f64 = std::env::var("GEARCOMP_LOOKALIKE_SENSOR_DRIFT_K")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    shape_a_drift(seed, d_k)
}

/// Shape A with a per-sensor, per-run drift over each run (contact, calibration) of up to
/// ±`d_k` K (0: none, the default data).
pub fn shape_a_drift(seed: u64, d_k: f64) -> LookAlike {
    shape_a_variant(
        seed,
        &AVariant {
            drift_k: d_k,
            ..AVariant::default()
        },
    )
}

/// What differs from run to run in shape A's sensors (all 0: the default data).
#[derive(Debug, Clone, Copy, Default)]
pub struct AVariant {
    /// Per-sensor, per-run drift over the run of up to ± this (K).
    pub drift_k: f64,
    /// Per-sensor, per-run gain of the sensor's response within 1 ± this (re-mounted
    /// magnetic-base sensors: contact and placement differ at each set-up).
    pub remount: f64,
    /// Slow wander of each sensor's reading (AR(1), φ = 0.97 per row, sd up to this, K):
    /// contact, cold junction, draughts; different in every run.
    pub wander_k: f64,
    /// The error's own slow wander (AR(1), φ = 0.9 per row) in µm; 0: the default 0.5 µm.
    pub err_wander_um: f64,
}

/// Shape A with the run-to-run sensor differences of `v`.
pub fn shape_a_variant(seed: u64, v: &AVariant) -> LookAlike {
    let d_k = v.drift_k;
    let mut g = Rng::new(seed);
    let lens = [73usize, 73, 73, 73, 57];
    let dt = 300.0;
    let ns = 3;
    let n_base = 16;
    // Sensor gains and time constants per source.
    let gain: Vec<Vec<f64>> = (0..n_base)
        .map(|_| {
            let main = (g.unif() * ns as f64) as usize;
            (0..ns)
                .map(|k| {
                    if k == main {
                        g.range(0.8, 1.0)
                    } else {
                        g.range(0.0, 0.15)
                    }
                })
                .collect()
        })
        .collect();
    let tau: Vec<Vec<f64>> = (0..n_base)
        .map(|_| (0..ns).map(|_| g.range(1200.0, 5400.0)).collect())
        .collect();
    // Exposure of each sensor to the two nuisance sources (most sensors none).
    let exposure: Vec<Vec<f64>> = (0..n_base)
        .map(|_| {
            (0..2)
                .map(|_| {
                    if g.unif() < 0.3 {
                        g.range(0.3, 1.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let err_gain: Vec<f64> = (0..ns).map(|_| g.range(0.2, 1.0)).collect();
    let err_tau: Vec<f64> = (0..ns).map(|_| g.range(1800.0, 7200.0)).collect();
    // Near duplicates: (copy of, gain factor).
    let dups: Vec<(usize, f64)> = (0..22 - n_base)
        .map(|_| ((g.unif() * n_base as f64) as usize, g.range(0.85, 1.15)))
        .collect();
    // The test program: per source three power levels and the two rows they change at.
    let program: Vec<([f64; 3], usize, usize)> = (0..ns)
        .map(|_| {
            let c1 = g.range(10.0, 35.0) as usize;
            let c2 = c1 + g.range(10.0, 30.0) as usize;
            (
                [g.range(0.5, 1.5), g.range(0.2, 1.6), g.range(0.0, 1.2)],
                c1,
                c2,
            )
        })
        .collect();
    let mut runs = Vec::new();
    let mut scale_t: Option<Vec<f64>> = None;
    let mut scale_e: Option<f64> = None;
    for (r, &n) in lens.iter().enumerate() {
        // Source powers: the same program every run (three levels, changed at two rows),
        // repeated within ±15 % in level and ±3 rows in timing.
        let q: Vec<Vec<f64>> = program
            .iter()
            .map(|&(l, c1, c2)| {
                let f = g.range(0.85, 1.15);
                let j1 = (c1 as f64 + g.range(-3.0, 3.0)).max(1.0) as usize;
                let j2 = (c2 as f64 + g.range(-3.0, 3.0)).max(1.0) as usize;
                (0..n)
                    .map(|i| {
                        f * if i < j1 {
                            l[0]
                        } else if i < j2 {
                            l[1]
                        } else {
                            l[2]
                        }
                    })
                    .collect()
            })
            .collect();
        let drift = g.range(-0.08, 0.08);
        // Local heat the error does not feel (coolant, a door, sun on a cover): two
        // nuisance sources per run, switched on at a random row with a random level.
        let nuis: Vec<Vec<f64>> = (0..2)
            .map(|_| {
                let on = (g.unif() * n as f64) as usize;
                let level = g.range(0.0, 0.5);
                let u: Vec<f64> = (0..n).map(|i| if i >= on { level } else { 0.0 }).collect();
                lag(&u, dt, 1800.0, 0.0)
            })
            .collect();
        let mut cols: Vec<Vec<f64>> = (0..n_base)
            .map(|s| {
                let mut v = vec![0.0; n];
                for (m, l) in nuis.iter().enumerate() {
                    for i in 0..n {
                        v[i] += exposure[s][m] * l[i];
                    }
                }
                for k in 0..ns {
                    let l = lag(&q[k], dt, tau[s][k], 0.0);
                    for i in 0..n {
                        v[i] += gain[s][k] * l[i];
                    }
                }
                for (i, x) in v.iter_mut().enumerate() {
                    *x += drift * i as f64 / 12.0;
                }
                v
            })
            .collect();
        let mut e = vec![0.0; n];
        for k in 0..ns {
            let l = lag(&q[k], dt, err_tau[k], 0.0);
            for i in 0..n {
                e[i] += err_gain[k] * l[i];
            }
        }
        // Scale once, on the first run: sensor maxima 8–11 K, error maximum 13–15 µm.
        let st = scale_t.get_or_insert_with(|| {
            cols.iter()
                .map(|c| g.range(8.0, 11.0) / c.iter().fold(1e-9_f64, |a, &b| a.max(b.abs())))
                .collect()
        });
        let se = *scale_e
            .get_or_insert_with(|| g.range(13.0, 15.0) / e.iter().fold(1e-9_f64, |a, &b| a.max(b)));
        for (c, s) in cols.iter_mut().zip(st.iter()) {
            for x in c.iter_mut() {
                *x *= s;
            }
        }
        for &(of, f) in &dups {
            let c: Vec<f64> = cols[of].iter().map(|x| x * f).collect();
            cols.push(c);
        }
        if v.remount > 0.0 {
            for c in cols.iter_mut() {
                let f = g.range(1.0 - v.remount, 1.0 + v.remount);
                for x in c.iter_mut() {
                    *x *= f;
                }
            }
        }
        // Sensor noise 0.05–0.15 K, read to 0.1 K; error noise 0.3 µm; rises from row 0.
        let noise: Vec<f64> = (0..cols.len()).map(|_| g.range(0.05, 0.15)).collect();
        let mut rows = vec![Vec::with_capacity(23); n];
        // Variant (`d_k` > 0; `GEARCOMP_LOOKALIKE_SENSOR_DRIFT_K=D` for shape A): a
        // per-sensor, per-run drift over the run (contact, calibration) of up to ±D K.
        for (c, sd) in cols.iter().zip(&noise) {
            let slope = if d_k > 0.0 {
                g.range(-d_k, d_k) / n as f64
            } else {
                0.0
            };
            let w_sd = if v.wander_k > 0.0 {
                g.range(0.0, v.wander_k)
            } else {
                0.0
            };
            let mut w = 0.0;
            let v: Vec<f64> = c
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    if w_sd > 0.0 {
                        w = 0.97 * w + w_sd * (1.0f64 - 0.97 * 0.97).sqrt() * g.normal();
                    }
                    ((x + w + slope * i as f64 + sd * g.normal()) * 10.0).round() / 10.0
                })
                .collect();
            for i in 0..n {
                rows[i].push(v[i] - v[0]);
            }
        }
        // What the sensors do not see: a run's own gain (±10 %, clamping, part
        // temperature) and a slowly wandering error (AR(1), 0.5 µm), plus 0.3 µm noise.
        let run_gain = g.range(0.9, 1.1);
        let mut wander = 0.0;
        let ew = if v.err_wander_um > 0.0 {
            v.err_wander_um
        } else {
            0.5
        };
        let ev: Vec<f64> = e
            .iter()
            .map(|x| {
                wander = 0.9 * wander + ew * (1.0f64 - 0.81).sqrt() * g.normal();
                x * se * run_gain + wander + 0.3 * g.normal()
            })
            .collect();
        for i in 0..n {
            rows[i].push(ev[i] - ev[0]);
        }
        runs.push((format!("r{}", r + 1), rows));
    }
    LookAlike {
        names: (1..=22).map(|i| format!("dT{i:02}")).collect(),
        target: "err_um".into(),
        runs,
    }
}

/// Shape B: a production log of 18 days (one run a day, 187–622 rows every 2 min). Ambient
/// with a daily cycle and a level per day; the spindle's heat follows jobs and pauses; the
/// sensors (ambient, bed reference, spindle rear, coolant wall, transformer/bed, spindle
/// front) are lagged mixtures of ambient and the spindle/drive heat; the diameter
/// displacement is a lagged mixture plus a level that jumps from day to day (re-zeroing,
/// tool change) and noise.
pub fn shape_b(seed: u64) -> LookAlike {
    shape_b_variant(seed, &BVariant::default())
}

/// What differs from day to day in shape B beyond the default data (all off: the default).
#[derive(Debug, Clone, Copy, Default)]
pub struct BVariant {
    /// Per-day, per-sensor reading offset up to ± this (K): cold-junction compensation
    /// in the cabinet, draughts, sensors re-taped after cleaning.
    pub day_bias_k: f64,
}

/// Shape B with the day-to-day differences of `v`.
pub fn shape_b_variant(seed: u64, v: &BVariant) -> LookAlike {
    let mut g = Rng::new(seed.wrapping_mul(31).wrapping_add(7));
    let dt = 120.0;
    // (gain ambient, τ ambient, gain spindle, τ spindle, gain drives, τ drives) per sensor.
    let sens = [
        (1.0, 60.0, 0.0, 600.0, 0.0, 600.0),
        (1.0, g.range(7200.0, 14400.0), 0.1, 7200.0, 0.2, 7200.0),
        (
            1.0,
            g.range(1800.0, 5400.0),
            0.9,
            g.range(1200.0, 3600.0),
            0.1,
            3600.0,
        ),
        (
            1.0,
            g.range(1800.0, 3600.0),
            0.4,
            g.range(2400.0, 6000.0),
            0.2,
            3600.0,
        ),
        (
            1.0,
            g.range(3600.0, 7200.0),
            0.1,
            3600.0,
            0.8,
            g.range(1200.0, 3600.0),
        ),
        (
            1.0,
            g.range(1200.0, 3600.0),
            1.2,
            g.range(600.0, 1800.0),
            0.1,
            3600.0,
        ),
    ];
    let e_amb = g.range(-1.5, -0.5);
    let e_tau_amb = g.range(3600.0, 10800.0);
    let e_sp = g.range(2.0, 3.5);
    let e_tau_sp = g.range(1200.0, 5400.0);
    let e_dr = g.range(0.5, 1.5);
    let e_tau_dr = g.range(1800.0, 7200.0);
    let mut runs = Vec::new();
    for d in 0..18 {
        let n = 187 + (g.unif() * 436.0) as usize;
        let amb_level = g.range(21.0, 27.0);
        let amb_amp = g.range(2.0, 4.5);
        let start_h = g.range(5.0, 9.0);
        let amb: Vec<f64> = (0..n)
            .map(|i| {
                let h = start_h + i as f64 * dt / 3600.0;
                amb_level + amb_amp * ((h - 9.0) / 24.0 * std::f64::consts::TAU).sin()
            })
            .collect();
        // Jobs: spindle heat 3–9 K-equivalent for 20–120 min, pauses 5–60 min.
        let mut sp = Vec::with_capacity(n);
        let mut dr = Vec::with_capacity(n);
        while sp.len() < n {
            let on = (g.range(10.0, 60.0)) as usize;
            let level = g.range(3.0, 9.0);
            let drive = g.range(1.0, 5.0);
            for _ in 0..on {
                sp.push(level);
                dr.push(drive);
            }
            let off = (g.range(3.0, 30.0)) as usize;
            for _ in 0..off {
                sp.push(0.0);
                dr.push(0.0);
            }
        }
        sp.truncate(n);
        dr.truncate(n);
        // Overnight cooling leaves part of yesterday's heat.
        let warm = g.range(0.0, 0.4);
        let mut cols: Vec<Vec<f64>> = sens
            .iter()
            .map(|&(ga, ta, gs, ts, gd, td)| {
                let la = lag(&amb, dt, ta, amb[0] - g.range(0.0, 1.0));
                let ls = lag(&sp, dt, ts, warm * 5.0);
                let ld = lag(&dr, dt, td, warm * 2.0);
                (0..n)
                    .map(|i| {
                        let v = ga * la[i] + gs * ls[i] + gd * ld[i] + 0.08 * g.normal();
                        (v * 10.0).round() / 10.0
                    })
                    .collect()
            })
            .collect();
        let la = lag(&amb, dt, e_tau_amb, amb[0]);
        let ls = lag(&sp, dt, e_tau_sp, warm * 5.0);
        let ld = lag(&dr, dt, e_tau_dr, warm * 2.0);
        let level = 50.0 + g.range(-5.0, 5.0);
        if v.day_bias_k > 0.0 {
            for c in cols.iter_mut() {
                let b = g.range(-v.day_bias_k, v.day_bias_k);
                for x in c.iter_mut() {
                    *x = ((*x + b) * 10.0).round() / 10.0;
                }
            }
        }
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let mut row: Vec<f64> = cols.iter().map(|c| c[i]).collect();
                row.push(level + e_amb * (la[i] - 24.0) + e_sp * ls[i] + e_dr * ld[i] + g.normal());
                row
            })
            .collect();
        runs.push((format!("d{:02}", d + 1), rows));
    }
    LookAlike {
        names: [
            "ambient_c",
            "bed_ref_c",
            "spindle_rear_c",
            "coolant_wall_c",
            "transformer_bed_c",
            "spindle_front_c",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
        target: "diameter_um".into(),
        runs,
    }
}

/// The contenders of the evaluators' table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Who {
    Auto,
    PlainLs,
    Static,
    Ridge,
    Fam(Family),
}

impl Who {
    pub fn name(self) -> String {
        match self {
            Who::Auto => "default (auto)".into(),
            Who::PlainLs => "plain LS, all inputs".into(),
            Who::Static => "--model static".into(),
            Who::Ridge => "--model ridge".into(),
            Who::Fam(f) => f.name().into(),
        }
    }
}

/// Squared test errors and rows of `who` on `test` (a run name) of `t`.
fn test_sse(t: &Table, test: &str, who: Who, base: &IdentifyOptions) -> (f64, usize) {
    let split = Split::TestRuns(vec![test.into()]);
    let rows = t
        .runs
        .as_ref()
        .unwrap()
        .iter()
        .filter(|&&k| t.run_names[k] == test)
        .count();
    let rmse = match who {
        Who::PlainLs => plain_least_squares(t, &split).unwrap()[0].1.unwrap(),
        _ => {
            let opts = IdentifyOptions {
                split,
                model: match who {
                    Who::Static => ModelKind::Static,
                    Who::Ridge => ModelKind::Ridge,
                    _ => ModelKind::Auto,
                },
                families: match who {
                    Who::Fam(f) => vec![f],
                    _ => Vec::new(),
                },
                ..base.clone()
            };
            let id = identify(t, &opts).unwrap();
            let m = &id.targets[0];
            if std::env::var("GEARCOMP_LOOKALIKE_VALTEST").is_ok() {
                // The validation figure against the held-out error (the winner's curse).
                println!(
                    "VALTEST {} {:.4} {:.4} {rows}",
                    who.name().replace(' ', "_"),
                    m.cv_rmse,
                    m.test_rmse.unwrap()
                );
            }
            if who == Who::Auto && std::env::var("GEARCOMP_LOOKALIKE_DETAIL").is_ok() {
                println!(
                    "  test {test}: kept {} (val {:.3}, test {:.3})",
                    m.family,
                    m.cv_rmse,
                    m.test_rmse.unwrap()
                );
                for c in &m.comparison {
                    println!(
                        "    {:<40} {:>2} val {:.3} {}",
                        c.family, c.sensors, c.cv_rmse, c.detail
                    );
                }
            }
            m.test_rmse.unwrap()
        }
    };
    (rmse * rmse * rows as f64, rows)
}

/// Held-out RMSE per contender for one data set: shape A leaves each run out in turn
/// (training on the other four); shape B holds out each of the last five days, training on
/// the days before it.
pub fn outer(d: &LookAlike, shape_b: bool, dt_s: f64, who: &[Who]) -> Vec<(f64, Vec<f64>)> {
    let base = IdentifyOptions::default();
    let nr = d.runs.len();
    let cases: Vec<(Vec<usize>, usize)> = if shape_b {
        (nr - 5..nr).map(|k| ((0..=k).collect(), k)).collect()
    } else {
        (0..nr).map(|k| ((0..nr).collect(), k)).collect()
    };
    let mut sse = vec![(0.0, 0usize); who.len()];
    let mut per_run = vec![Vec::new(); who.len()];
    for (keep, k) in cases {
        let t = d.table(&keep, dt_s);
        for (w, acc) in who.iter().zip(sse.iter_mut().zip(per_run.iter_mut())) {
            let (s, n) = test_sse(&t, &d.runs[k].0, *w, &base);
            acc.0 .0 += s;
            acc.0 .1 += n;
            acc.1.push((s / n as f64).sqrt());
        }
    }
    sse.iter()
        .zip(per_run)
        .map(|(&(s, n), p)| ((s / n as f64).sqrt(), p))
        .collect()
}

/// Seeds 1..=n (the pooled figures asserted); `GEARCOMP_LOOKALIKE_SEEDS=1,2,…` replaces them
/// (to rerun a fresh seed that failed, or to measure more seeds).
fn seeds(n: u64) -> Vec<u64> {
    if let Ok(s) = std::env::var("GEARCOMP_LOOKALIKE_SEEDS") {
        return s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
    }
    (1..=n).collect()
}

/// Which look-alike a table is built from.
#[derive(Debug, Clone, Copy)]
pub enum Shape {
    /// Shape A with a sensor drift of up to ± this (K); `None`: from
    /// `GEARCOMP_LOOKALIKE_SENSOR_DRIFT_K` (default 0).
    A(Option<f64>),
    /// Shape A with run-to-run sensor differences.
    AVar(AVariant),
    /// Shape B.
    B,
    /// Shape B with day-to-day sensor differences.
    BVar(BVariant),
}

impl Shape {
    fn is_b(self) -> bool {
        matches!(self, Shape::B | Shape::BVar(_))
    }
    fn make(self, seed: u64) -> LookAlike {
        match self {
            Shape::A(Some(k)) => shape_a_drift(seed, k),
            Shape::A(None) => shape_a(seed),
            Shape::AVar(v) => shape_a_variant(seed, &v),
            Shape::B => shape_b(seed),
            Shape::BVar(v) => shape_b_variant(seed, &v),
        }
    }
    fn label(self) -> &'static str {
        match self {
            Shape::A(_) => "A",
            Shape::AVar(_) => "A (re-mounted sensors)",
            Shape::B => "B",
            Shape::BVar(_) => "B (per-day sensor offsets)",
        }
    }
}

/// Shape A, repeat runs with re-mounted sensors (the reporters' fingerprint A: `--model
/// static` and `ridge` well ahead of plain LS on all inputs): at each set-up every
/// magnetic-base sensor sits a little differently (its response within ±15 %), its reading
/// wanders slowly (contact, cold junction, draughts: AR(1) up to 0.6 K), and the error has a
/// slow wander of its own of 1.5 µm that no sensor sees (clamping, part temperature).
pub const A_REMOUNTED: AVariant = AVariant {
    drift_k: 0.0,
    remount: 0.15,
    wander_k: 0.6,
    err_wander_um: 1.5,
};

/// Shape B, production days with per-day sensor offsets (the reporters' fingerprint B:
/// ridge better than plain LS, the default worse): every sensor reads off by up to ±1 K,
/// constant over a day (cold-junction compensation in the cabinet, sensors re-taped after
/// cleaning).
pub const B_DAY_OFFSETS: BVariant = BVariant { day_bias_k: 1.0 };

/// A fresh seed every run (printed with its table), unless `GEARCOMP_LOOKALIKE_SEEDS` is set.
/// One seed alone varies far more than a pool of eight (per seed the default measured 0.35 to
/// 2.6 × plain LS over seeds 9–40 of the three shapes, while the pools of 32 seeds stayed at
/// 1.01 / 1.19 / 1.02 ×), so a fresh seed is held to a bound against failure, not to the
/// pooled ratios: default ≤ 3 × plain LS on all inputs, every figure finite.
fn check_fresh_seed(shape: Shape) {
    if std::env::var("GEARCOMP_LOOKALIKE_SEEDS").is_ok() {
        return;
    }
    let fresh = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_nanos() as u64);
    let seed = 1000 + fresh % 1_000_000;
    let p = pooled(shape, &[seed], &[Who::Auto, Who::PlainLs]);
    assert!(p.iter().all(|v| v.is_finite()), "seed {seed}: {p:?}");
    assert!(
        p[0] <= 3.0 * p[1],
        "fresh seed {seed}: default {} vs plain LS {}",
        p[0],
        p[1]
    );
}

/// Pooled held-out RMSE over seeds of every contender; prints the table.
fn pooled(shape: Shape, seeds: &[u64], who: &[Who]) -> Vec<f64> {
    let shape_b = shape.is_b();
    // The sample interval the user passes (`--sample-interval-s`, a guess for A).
    let dt = std::env::var("GEARCOMP_LOOKALIKE_DT_S")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if shape_b { 120.0 } else { 300.0 });
    let mut sq = vec![0.0; who.len()];
    for &seed in seeds {
        let d = shape.make(seed);
        if let Ok(dir) = std::env::var("GEARCOMP_LOOKALIKE_DUMP") {
            // One CSV per run without a time column, as the real files come (for the CLI).
            for (name, rows) in &d.runs {
                let mut text = format!("{},{}\n", d.names.join(","), d.target);
                for r in rows {
                    let v: Vec<String> = r.iter().map(|x| format!("{x:.4}")).collect();
                    text += &format!("{}\n", v.join(","));
                }
                let shape = if shape_b { "b" } else { "a" };
                std::fs::write(format!("{dir}/{shape}{seed}_{name}.csv"), text).unwrap();
            }
        }
        let res = outer(&d, shape_b, dt, who);
        let line: Vec<String> = who
            .iter()
            .zip(&res)
            .map(|(w, (p, runs))| {
                format!(
                    "{} {:.3} [{}]",
                    w.name(),
                    p,
                    runs.iter()
                        .map(|x| format!("{x:.2}"))
                        .collect::<Vec<_>>()
                        .join(" ")
                )
            })
            .collect();
        println!("seed {seed} shape {}: {}", shape.label(), line.join(" | "));
        for (s, (p, _)) in sq.iter_mut().zip(&res) {
            *s += p * p;
        }
    }
    let pooled: Vec<f64> = sq.iter().map(|s| (s / seeds.len() as f64).sqrt()).collect();
    println!(
        "shape {} pooled over seeds {seeds:?}: {}",
        shape.label(),
        who.iter()
            .zip(&pooled)
            .map(|(w, p)| format!("{} {p:.3}", w.name()))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    pooled
}

/// Shape A (22 sensors, cap 8): the default against the fixed kinds, and with the cap at
/// every input against plain least squares on all inputs.
#[test]
fn repeat_runs_default_holds_out_of_run() {
    let mut who = vec![Who::Auto, Who::PlainLs, Who::Static, Who::Ridge];
    if std::env::var("GEARCOMP_LOOKALIKE_FAMILIES").is_ok() {
        who.extend(Family::ALL.map(Who::Fam));
    }
    check_fresh_seed(Shape::A(None));
    let p = pooled(Shape::A(None), &seeds(8), &who);
    let fixed = p[2].min(p[3]);
    assert!(
        p[0] <= 1.05 * fixed,
        "default {} vs static/ridge {fixed}",
        p[0]
    );
    assert!(p[0] <= 1.25 * p[1], "default {} vs plain LS {}", p[0], p[1]);
}

/// Shape B (6 sensors, within the cap): the default against plain least squares on all
/// inputs and the fixed kinds, holding out each of the last five days.
#[test]
fn production_days_default_holds_out_of_day() {
    let mut who = vec![Who::Auto, Who::PlainLs, Who::Static, Who::Ridge];
    if std::env::var("GEARCOMP_LOOKALIKE_FAMILIES").is_ok() {
        who.extend(Family::ALL.map(Who::Fam));
    }
    check_fresh_seed(Shape::B);
    let p = pooled(Shape::B, &seeds(8), &who);
    let fixed = p[2].min(p[3]);
    assert!(p[0] <= 1.02 * p[1], "default {} vs plain LS {}", p[0], p[1]);
    assert!(
        p[0] <= 1.05 * fixed,
        "default {} vs static/ridge {fixed}",
        p[0]
    );
}

/// Shape A with a per-sensor drift of up to ±1.5 K that differs from run to run (the
/// reporters' pattern: ridge better than plain LS). Before the optimism correction of the
/// family figures the default lost to every contender here (seeds 1–6: 3.589 µm against
/// plain LS 3.197, `--model ridge` 2.937). Measured with it over seeds 1–8: default 3.094,
/// plain LS 3.100, `--model ridge` 2.693 µm (seeds 1–6: 3.399, 3.197, 2.937); seeds 9–16:
/// 3.403, 2.978, 2.824 (per seed 0.35–1.51 × plain LS); seeds 9–40: 3.193, 3.137, 3.049.
/// With ridge as the reference of the one-standard-error rule (per-fold log ratio): seeds
/// 1–8 3.006 µm (plain LS 3.100, ridge 2.693).
/// Asserted on seeds 1–8: ≤ 1.10 × plain LS and ≤ 1.25 × `--model ridge` (a fresh seed is
/// held to `check_fresh_seed`). NOT met: 1.02 × plain LS and 1.05 × ridge on every seed
/// set; see docs/identification.md, "Look-alikes".
#[test]
fn repeat_runs_with_sensor_drift_default_is_not_the_worst() {
    let who = vec![Who::Auto, Who::PlainLs, Who::Static, Who::Ridge];
    check_fresh_seed(Shape::A(Some(1.5)));
    let p = pooled(Shape::A(Some(1.5)), &seeds(8), &who);
    assert!(p[0] <= 1.10 * p[1], "default {} vs plain LS {}", p[0], p[1]);
    assert!(p[0] <= 1.25 * p[3], "default {} vs ridge {}", p[0], p[3]);
}

/// The bound on [`A_REMOUNTED`]: 1.05 × the better fixed kind (measured 1.033 over seeds
/// 1–8 since the k-step model became the best-fitting of the k-step paths; 1.10 before).
const A_REMOUNTED_BOUND: f64 = 1.05;

/// Shape A with re-mounted sensors ([`A_REMOUNTED`], the reporters' fingerprint A: static and
/// ridge far ahead of plain LS on all 22 inputs): the default must follow them.
#[test]
fn repeat_runs_with_remounted_sensors_default_follows_the_fixed_kinds() {
    let mut who = vec![Who::Auto, Who::PlainLs, Who::Static, Who::Ridge];
    if std::env::var("GEARCOMP_LOOKALIKE_FAMILIES").is_ok() {
        who.extend(Family::ALL.map(Who::Fam));
    }
    let shape = Shape::AVar(A_REMOUNTED);
    check_fresh_seed(shape);
    let p = pooled(shape, &seeds(8), &who);
    let fixed = p[2].min(p[3]);
    assert!(p[0] < p[1], "default {} vs plain LS {}", p[0], p[1]);
    assert!(
        p[0] <= A_REMOUNTED_BOUND * fixed,
        "default {} vs static/ridge {fixed}",
        p[0]
    );
}

/// Shape B with per-day sensor offsets ([`B_DAY_OFFSETS`], the reporters' fingerprint B:
/// ridge and static better than plain LS, the default worse before this change).
#[test]
fn production_days_with_sensor_offsets_default_follows_the_fixed_kinds() {
    let mut who = vec![Who::Auto, Who::PlainLs, Who::Static, Who::Ridge];
    if std::env::var("GEARCOMP_LOOKALIKE_FAMILIES").is_ok() {
        who.extend(Family::ALL.map(Who::Fam));
    }
    let shape = Shape::BVar(B_DAY_OFFSETS);
    check_fresh_seed(shape);
    let p = pooled(shape, &seeds(8), &who);
    let fixed = p[2].min(p[3]);
    assert!(p[0] < p[1], "default {} vs plain LS {}", p[0], p[1]);
    assert!(
        p[0] <= 1.05 * fixed,
        "default {} vs static/ridge {fixed}",
        p[0]
    );
}
