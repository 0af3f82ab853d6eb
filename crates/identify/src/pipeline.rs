//! The identification pipeline: correlation → fuzzy-equivalence classes → one representative
//! per class → forward selection by k-fold-by-run cross-validation → least-squares fit →
//! validation on held-out data → a `gearcomp_core::model::LinearModel` per target.

use crate::cluster::{self, Dendrogram};
use crate::data::Table;
use crate::error::{invalid, IdentifyError, Result};
use crate::fit::{
    predict, Grouping, Identification, IdentifyOptions, ModelKind, RepresentativeBy, Split,
    TargetModel,
};
use crate::fit::{representative_scores, rmse_where, select_rows, TrainRows};
use crate::par::{join, par_map};
use crate::regress::{self, augmented_r, r_factor, stack};
use crate::transform::transform_segments;
use gearcomp_core::model::{LinearModel, Term, Transform};
use nalgebra::{DMatrix, DVector};

/// Train mask of a split.
pub fn train_mask(table: &Table, split: &Split) -> Result<Vec<bool>> {
    let mask: Vec<bool> = match split {
        Split::TimeBefore(s) => {
            // Runs on one clock (time stamps, or the days of a log cut at its gaps) split
            // by time as one log does; runs whose time restarts cannot.
            if table.run_count() > 1 && table.time_s.windows(2).any(|w| w[1] <= w[0]) {
                return Err(invalid(
                    "--train-before-h",
                    s / 3600.0,
                    &format!(
                        "no time split on data of {} runs whose time restarts in each run: name the test runs with --test-runs (runs: {})",
                        table.run_count(),
                        table.run_names.join(", ")
                    ),
                ));
            }
            let t0 = table.time_s.first().copied().unwrap_or(0.0);
            let t1 = table.time_s.last().copied().unwrap_or(0.0);
            if !(s.is_finite() && *s > t0 && *s <= t1) {
                return Err(invalid(
                    "--train-before-h",
                    format!("{} h", s / 3600.0),
                    &format!(
                        "a time inside the data, {} h < t ≤ {} h (leave test rows after it, or use --no-test)",
                        t0 / 3600.0,
                        t1 / 3600.0
                    ),
                ));
            }
            table.time_s.iter().map(|t| t < s).collect()
        }
        Split::TestRuns(runs) => {
            let r = table.runs.as_ref().ok_or_else(|| {
                invalid(
                    "--test-runs",
                    runs.join(","),
                    "data with runs (--run-column, or several --data files)",
                )
            })?;
            let mut test = vec![false; table.run_names.len()];
            for name in runs {
                let k = table.run_index(name).ok_or_else(|| {
                    invalid(
                        "--test-runs",
                        name,
                        &format!("one of the runs {}", table.run_names.join(", ")),
                    )
                })?;
                test[k] = true;
            }
            r.iter().map(|&k| !test[k]).collect()
        }
        Split::None => vec![true; table.time_s.len()],
    };
    // Only rows with every target measured are fitted and scored (`Table::measured`).
    let measured = table.measured();
    let sparse = measured.iter().any(|&m| !m);
    let mask: Vec<bool> = mask.iter().zip(&measured).map(|(&a, &b)| a && b).collect();
    let n = mask.iter().filter(|&&m| m).count();
    if n < 10 && sparse {
        let one_at_a_time = if table.targets.len() > 1 {
            format!(
                " (the targets are measured on different rows: fit them one at a time, --target {} then --target {})",
                table.target_names[0], table.target_names[1]
            )
        } else {
            String::new()
        };
        return Err(invalid(
            "training rows",
            format!("{n} with every target measured"),
            &format!("at least 10 training rows on which every target has a value{one_at_a_time}"),
        ));
    }
    if n < 10 {
        // Name the option that left too few training rows (issue 12 shapes: "training rows
        // of the split: 0 row(s)" did not say that --test-runs named every run).
        return Err(match split {
            Split::TestRuns(runs) => invalid(
                "--test-runs",
                runs.join(","),
                &format!(
                    "runs that leave at least 10 training rows in the other runs ({n} left; runs: {})",
                    table.run_names.join(", ")
                ),
            ),
            Split::TimeBefore(s) => invalid(
                "--train-before-h",
                format!("{} h", s / 3600.0),
                &format!("a time with at least 10 training rows before it ({n} before it)"),
            ),
            Split::None => IdentifyError::TooFewRows {
                what: "training rows".into(),
                rows: n,
                needed: 10,
            },
        });
    }
    Ok(mask)
}

/// Longest log span (h) that the default split trains on its first 24 h, as the FL_THERMAL
/// protocol does (train on the first 24 h of the 46 h test).
pub const DEFAULT_SPLIT_SPAN_H: f64 = 72.0;

/// The default train/test split (`fit` without `--no-test`, `--test-runs` or
/// `--train-before-h`) and the note saying what it chose, when it is not the plain 24 h:
/// - several runs: the last run tests;
/// - one run of at most 24 h: every row trains (no test error);
/// - one run of at most [`DEFAULT_SPLIT_SPAN_H`]: the first 24 h from the first row train,
///   the rest tests (the FL_THERMAL protocol);
/// - a longer run (a production log of many days): its first two thirds, in whole hours,
///   train and the last third tests, where 24 h would train on the first day alone.
pub fn default_split(table: &Table) -> (Split, Option<String>) {
    if table.run_count() > 1 {
        let last = table.run_names.last().cloned().unwrap_or_default();
        let note =
            format!("test run: {last} (the last run; choose with --test-runs, or --no-test)");
        return (Split::TestRuns(vec![last]), Some(note));
    }
    let (t0, t1) = match (table.time_s.first(), table.time_s.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => return (Split::None, None),
    };
    let span_h = (t1 - t0) / 3600.0;
    if span_h <= 24.0 {
        let note = "the data ends before the default 24 h split: every row trains, no test error (give --train-before-h to hold out a test period)";
        return (Split::None, Some(note.into()));
    }
    if span_h <= DEFAULT_SPLIT_SPAN_H {
        return (Split::TimeBefore(t0 + 24.0 * 3600.0), None);
    }
    let h = (t0 / 3600.0 + 2.0 * span_h / 3.0).round();
    (
        Split::TimeBefore(h * 3600.0),
        Some(format!(
            "the log spans {span_h:.1} h: the default trains on its first two thirds (before {h} h) and tests on the rest (the first 24 h only up to a {DEFAULT_SPLIT_SPAN_H} h log; choose with --train-before-h)"
        )),
    )
}

/// The fixed kinds' validation in words: `k`-fold cross-validation by run or by contiguous
/// time block ([`folds`]).
fn fold_validation(table: &Table, train: &[bool], k: usize) -> String {
    let by = if table.training_runs(train).is_some() {
        "run"
    } else {
        "contiguous time block"
    };
    format!("{k}-fold cross-validation by {by}")
}

/// Validation fold of each training row: by run (runs dealt round-robin into `folds`
/// groups in order of appearance) when at least two runs train, otherwise (no runs, or
/// the other runs held out for test) `folds` contiguous blocks of equal time span.
///
/// # Formula
/// block = min(⌊(t − t₀)/((t₁ − t₀)/K)⌋, K − 1) over the training period [t₀, t₁]
pub fn folds(table: &Table, train: &[bool], k: usize) -> Result<Vec<Option<usize>>> {
    if k < 2 {
        return Err(invalid("folds", k, "at least 2 folds"));
    }
    if let (Some(runs), Some(seen)) = (&table.runs, table.training_runs(train)) {
        return Ok(runs
            .iter()
            .zip(train)
            .map(|(r, &m)| m.then(|| seen.iter().position(|s| s == r).unwrap_or(0) % k))
            .collect());
    }
    let times: Vec<f64> = table
        .time_s
        .iter()
        .zip(train)
        .filter(|(_, &m)| m)
        .map(|(t, _)| *t)
        .collect();
    let t0 = times.iter().copied().fold(f64::INFINITY, f64::min);
    let t1 = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let span = (t1 - t0) / k as f64;
    Ok(table
        .time_s
        .iter()
        .zip(train)
        .map(|(t, &m)| m.then(|| (((t - t0) / span).floor().max(0.0) as usize).min(k - 1)))
        .collect())
}

/// Cross-validation by QR reduction: per fold, the R factors of [1 X Y] on the training
/// and held-out rows. Since ‖Q·R·v‖ = ‖R·v‖, every sub-model's least-squares fit and its
/// held-out error follow from these small matrices, exactly (no normal equations).
struct CvEngine {
    train_r: Vec<DMatrix<f64>>,
    val_r: Vec<DMatrix<f64>>,
    /// The R factor of [1 X Y] on every training row (the folds' blocks stacked): the final
    /// fit and the floor from it (every training row is in one fold's block).
    all_r: DMatrix<f64>,
    n_features: usize,
    n_val: usize,
}

impl CvEngine {
    fn new(features: &[&[f64]], targets: &[&[f64]], fold: &[Option<usize>], k: usize) -> Self {
        let m = 1 + features.len() + targets.len();
        // The folds' blocks, then their training factors, on every core.
        let fold_ids: Vec<usize> = (0..k).collect();
        let blocks: Vec<DMatrix<f64>> = par_map(&fold_ids, |&f| {
            let rows: Vec<usize> = (0..fold.len()).filter(|&i| fold[i] == Some(f)).collect();
            augmented_r(&rows, features, targets)
        });
        let n_val = fold.iter().filter(|g| g.is_some_and(|g| g < k)).count();
        let train_r = par_map(&fold_ids, |&f| {
            let others: Vec<&DMatrix<f64>> =
                (0..k).filter(|&g| g != f).map(|g| &blocks[g]).collect();
            r_factor(stack(&others, m))
        });
        let all_r = r_factor(stack(&blocks.iter().collect::<Vec<_>>(), m));
        Self {
            train_r,
            val_r: blocks,
            all_r,
            n_features: features.len(),
            n_val,
        }
    }

    /// Per-fold held-out SSE of the model on `features` (indices) for `target`.
    fn fold_sse(&self, features: &[usize], target: usize) -> Option<Vec<f64>> {
        let mut cols = Vec::with_capacity(features.len() + 1);
        cols.push(0usize);
        cols.extend(features.iter().map(|f| f + 1));
        let ycol = 1 + self.n_features + target;
        let mut out = Vec::with_capacity(self.train_r.len());
        for (tr, va) in self.train_r.iter().zip(&self.val_r) {
            if tr.nrows() < cols.len() {
                return None;
            }
            let a = tr.select_columns(&cols);
            let b = tr.column(ycol).into_owned();
            let qr = a.qr();
            let r = qr.r();
            let max_p = (0..cols.len()).map(|j| r[(j, j)].abs()).fold(0.0, f64::max);
            if (0..cols.len()).any(|j| !crate::regress::exceeds(r[(j, j)].abs(), 1e-11 * max_p)) {
                return None;
            }
            let mut qtb = b;
            qr.q_tr_mul(&mut qtb);
            let beta = r.solve_upper_triangular(&qtb.rows(0, cols.len()).into_owned())?;
            let e: DVector<f64> = va.column(ycol) - va.select_columns(&cols) * beta;
            out.push(e.norm_squared());
        }
        Some(out)
    }

    fn rmse(&self, features: &[usize], target: usize) -> Option<f64> {
        let s = self.fold_sse(features, target)?;
        Some((s.iter().sum::<f64>() / self.n_val as f64).sqrt())
    }
}

struct Choice {
    cv: f64,
    tau: Option<f64>,
    alpha: Option<f64>,
    sensors: Vec<usize>,
    classes: Vec<Vec<usize>>,
    reps: Vec<usize>,
}

fn better(a: &Option<Choice>, cv: f64, len: usize) -> bool {
    match a {
        None => true,
        Some(c) => cv < c.cv || (cv == c.cv && len < c.sensors.len()),
    }
}

/// Identifies one model per target of `table`.
///
/// # Source
/// CN105397560, steps 1)–6) and eq. (9) (docs/identification.md, "CN105397560 as
/// implemented") [RECONSTRUCTED]; the
/// dynamic Value + Rate model and its cross-validated selection are this project's
/// (docs/identification.md) [PROJECT CONVENTION].
pub fn identify(table: &Table, opts: &IdentifyOptions) -> Result<Identification> {
    opts.check()?;
    match measured_groups(table) {
        Some(groups) => identify_groups(table, opts, &groups),
        None => identify_one(table, opts),
    }
}

/// The targets of `table` grouped by the rows they are measured on (the same rows with a
/// value), each group in target order, the groups in order of their first target; `None`
/// when every target is measured on the same rows (one group).
pub fn measured_groups(table: &Table) -> Option<Vec<Vec<usize>>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for j in 0..table.targets.len() {
        let same = |k: usize| {
            table.targets[j]
                .iter()
                .zip(&table.targets[k])
                .all(|(a, b)| a.is_nan() == b.is_nan())
        };
        match groups.iter_mut().find(|g| same(g[0])) {
            Some(g) => g.push(j),
            None => groups.push(vec![j]),
        }
    }
    (groups.len() > 1).then_some(groups)
}

/// The rows that train some target under `split`: [`train_mask`], or with targets measured
/// on different rows ([`measured_groups`]) the union of each group's training rows, as
/// [`identify`] trains them.
///
/// # Errors
/// A bad split, or too few training rows for a group, as [`train_mask`] names them.
pub fn train_rows_of_any_target(table: &Table, split: &Split) -> Result<Vec<bool>> {
    let Some(groups) = measured_groups(table) else {
        return train_mask(table, split);
    };
    let mut any = vec![false; table.time_s.len()];
    for g in &groups {
        for (a, b) in any
            .iter_mut()
            .zip(train_mask(&with_targets(table, g), split)?)
        {
            *a |= b;
        }
    }
    Ok(any)
}

/// `table` with only the targets `group`.
fn with_targets(table: &Table, group: &[usize]) -> Table {
    Table {
        target_names: group
            .iter()
            .map(|&j| table.target_names[j].clone())
            .collect(),
        targets: group.iter().map(|&j| table.targets[j].clone()).collect(),
        ..table.clone()
    }
}

/// Targets measured on different rows: each group of targets measured on the same rows
/// ([`measured_groups`]) is identified on its own rows, and the models are joined in
/// target order, each with its own training and test rows ([`TargetModel::own_rows`]);
/// the identification's `train` and `test` are their unions, its correlation, classes,
/// folds and method the first group's. When the groups drop different inputs (an input
/// constant on one group's rows only), the targets are identified together on the rows
/// where all are measured, as before.
fn identify_groups(
    table: &Table,
    opts: &IdentifyOptions,
    groups: &[Vec<usize>],
) -> Result<Identification> {
    let mut parts = Vec::with_capacity(groups.len());
    for g in groups {
        parts.push(identify_one(&with_targets(table, g), opts)?);
    }
    if parts
        .windows(2)
        .any(|w| w[0].input_names != w[1].input_names)
    {
        return identify_one(table, opts);
    }
    let n = table.time_s.len();
    let mut slots: Vec<Option<TargetModel>> = vec![None; table.targets.len()];
    let mut train = vec![false; n];
    let mut test = vec![false; n];
    let mut notes: Vec<String> = Vec::new();
    let mut counts = Vec::new();
    for (g, part) in groups.iter().zip(&mut parts) {
        for (i, (&a, &b)) in part.train.iter().zip(&part.test).enumerate() {
            train[i] |= a;
            test[i] |= b;
        }
        for note in &part.notes {
            if !notes.contains(note) {
                notes.push(note.clone());
            }
        }
        let rows = part.train.iter().filter(|&&m| m).count();
        for (&j, mut m) in g.iter().zip(std::mem::take(&mut part.targets)) {
            counts.push(format!("{} {rows}", table.target_names[j]));
            m.own_rows = Some((part.train.clone(), part.test.clone()));
            slots[j] = Some(m);
        }
    }
    notes.push(format!(
        "targets measured on different rows: each is identified, validated and tested on its own rows (training rows: {})",
        counts.join(", ")
    ));
    let mut first = parts.swap_remove(0);
    // Each group's floor is on its own rows: the caller computes the floor per group.
    first.floor = None;
    first.targets = slots.into_iter().flatten().collect();
    first.train = train;
    first.test = test;
    first.notes = notes;
    Ok(first)
}

fn identify_one(table: &Table, opts: &IdentifyOptions) -> Result<Identification> {
    let mut id = identify_models(table, opts)?;
    // Each target's envelope on its own core (the targets are independent).
    let envelopes = par_map(&id.targets, |m| {
        crate::envelope::training_envelope_and_rows(
            table,
            &id.train,
            &m.target,
            &m.model,
            crate::envelope::FitKind::of(m),
            m.cv_rmse,
        )
    });
    for (m, e) in id.targets.iter_mut().zip(envelopes) {
        let (env, outside, half) = e?;
        m.envelope = Some(env);
        m.outside = outside;
        m.interval_um = half;
    }
    Ok(id)
}

/// [`plain_least_squares`] on all inputs: (train RMSE, test RMSE) per target.
pub type Floor = Vec<(f64, Option<f64>)>;

/// [`identify`] and [`plain_least_squares`] (the floor the report compares with) at once,
/// the floor on a second core; the same results as the two calls one after the other
/// (the split is `opts.split`; an error of `identify` comes first).
pub fn identify_with_floor(
    table: &Table,
    opts: &IdentifyOptions,
) -> Result<(Identification, Floor)> {
    // The fixed kinds compute the floor on the way (`Identification::floor`), from the
    // factor their validation already made: no second thread, no second factorisation.
    if opts.model != ModelKind::Auto && measured_groups(table).is_none() {
        let mut id = identify(table, opts)?;
        let floor = match id.floor.take() {
            Some(f) => f,
            None => plain_least_squares(table, &opts.split)?,
        };
        return Ok((id, floor));
    }
    let (id, floor) = std::thread::scope(|s| {
        let floor = s.spawn(|| plain_least_squares(table, &opts.split));
        let id = identify(table, opts);
        (id, join(floor))
    });
    Ok((id?, floor?))
}

fn identify_models(table: &Table, opts: &IdentifyOptions) -> Result<Identification> {
    if table.targets.is_empty() {
        return Err(invalid("targets", "none", "at least one target column"));
    }
    let train = train_mask(table, &opts.split)?;
    check_magnitudes(table)?;
    let (reduced, mut notes) = drop_degenerate_inputs(table, &train);
    notes.extend(constant_targets_note(table, &train));
    notes.extend(split_runs_note(table));
    notes.extend(table.measured_note());
    let table = &reduced;
    let c = table.inputs.len();
    if c == 0 {
        return Err(invalid(
            "inputs",
            "every input constant or duplicated on the training rows",
            "at least one input that varies",
        ));
    }
    if opts.model == ModelKind::Auto {
        let (bounded, notes) = bound_dynamic_search(table, &train, opts, notes);
        return crate::select::identify_auto(table, train, notes, &bounded);
    }
    if c < 2 {
        return Err(invalid("inputs", c, "at least 2 input columns"));
    }
    if opts.max_sensors == 0 {
        return Err(invalid("max_sensors", 0, "at least 1"));
    }
    for &tau in &opts.taus_s {
        if !(tau.is_finite() && tau > 0.0) {
            return Err(invalid("tau_s", tau, "time constants > 0 s"));
        }
    }
    if opts.model == ModelKind::Dynamic && opts.taus_s.is_empty() {
        return Err(invalid("tau_s", "[]", "at least one time constant"));
    }
    if let Some(k) = opts.classes {
        if k == 0 || k > c {
            return Err(invalid("classes", k, &format!("1 ≤ classes ≤ {c} inputs")));
        }
    }
    let fold = folds(table, &train, opts.folds)?;
    let rows = TrainRows::new(&train);
    let k_folds = opts.folds;
    let tr_inputs: Vec<std::borrow::Cow<[f64]>> = table.inputs.iter().map(|x| rows.of(x)).collect();
    let tr_refs: Vec<&[f64]> = tr_inputs.iter().map(|v| &v[..]).collect();
    // The inputs' correlations and, with Pearson representatives, each input's |r| with each
    // target from one matrix over the inputs and the targets (the same bits as the inputs'
    // matrix and `pearson` per pair); any constant column falls back to them, which name it.
    let tr_targets: Vec<std::borrow::Cow<[f64]>> =
        table.targets.iter().map(|y| rows.of(y)).collect();
    let joint = (opts.representative == RepresentativeBy::Pearson)
        .then(|| {
            let all: Vec<&[f64]> = tr_refs
                .iter()
                .copied()
                .chain(tr_targets.iter().map(|v| &v[..]))
                .collect();
            cluster::correlation_matrix_if_varying(&all)
        })
        .flatten();
    let corr = match &joint {
        Some(m) => m.view((0, 0), (c, c)).into_owned(),
        None => cluster::correlation_matrix(&tr_refs, &table.input_names)?,
    };
    let absr = corr.map(f64::abs);
    let dendrogram = Dendrogram::single_linkage(&absr);
    // A candidate count of c or more classes is every input its own class (the count c);
    // none is dropped (`--class-counts 3` with 3 inputs fitted 2 classes before).
    let counts: Vec<usize> = match opts.classes {
        Some(k) => vec![k],
        None => {
            let mut v: Vec<usize> = Vec::with_capacity(opts.class_counts.len().max(1));
            for k in opts.class_counts.iter().map(|&k| k.min(c)) {
                if !v.contains(&k) {
                    v.push(k);
                }
            }
            if v.is_empty() {
                v.push(c);
            }
            v
        }
    };
    let class_sets: Vec<(usize, Vec<Vec<usize>>)> = counts
        .iter()
        .map(|&k| {
            let cl = match opts.grouping {
                Grouping::FuzzyEquivalence => dendrogram.classes(k)?,
                Grouping::FuzzyCMeans => cluster::fuzzy_c_means(&tr_refs, k, 2.0, 1e-9, 2000)?.1,
            };
            Ok((k, cl))
        })
        .collect::<Result<_>>()?;
    let target_refs: Vec<&[f64]> = table.targets.iter().map(|v| v.as_slice()).collect();
    let in_refs: Vec<&[f64]> = table.inputs.iter().map(|v| v.as_slice()).collect();

    // Candidate regressors per τ: value and rate of every input (dynamic), or values only.
    let taus: Vec<Option<f64>> = match opts.model {
        ModelKind::Dynamic => opts.taus_s.iter().map(|&t| Some(t)).collect(),
        _ => vec![None],
    };
    // Values are the input columns themselves (borrowed); rates are computed.
    let mut features: Vec<Vec<std::borrow::Cow<[f64]>>> = Vec::with_capacity(taus.len());
    let segs = table.segment_ranges();
    for tau in &taus {
        let mut f = Vec::with_capacity(2 * c);
        for x in &table.inputs {
            f.push(std::borrow::Cow::Borrowed(x.as_slice()));
            if let Some(tau_s) = tau {
                f.push(std::borrow::Cow::Owned(transform_segments(
                    &table.time_s,
                    x,
                    Transform::Rate { tau_s: *tau_s },
                    &segs,
                )?));
            }
        }
        features.push(f);
    }
    let per_sensor = if opts.model == ModelKind::Dynamic {
        2
    } else {
        1
    };
    let engines: Vec<CvEngine> = features
        .iter()
        .map(|f| {
            let refs: Vec<&[f64]> = f.iter().map(|v| &v[..]).collect();
            CvEngine::new(&refs, &target_refs, &fold, k_folds)
        })
        .collect();
    let cols_of = |sensors: &[usize]| -> Vec<usize> {
        sensors
            .iter()
            .flat_map(|&s| (0..per_sensor).map(move |q| per_sensor * s + q))
            .collect()
    };

    // Each target's selection and final fit on its own core (the targets are independent).
    let target_index: Vec<usize> = (0..table.targets.len()).collect();
    let out = par_map(&target_index, |&j| -> Result<TargetModel> {
        let y = &table.targets[j];
        let ytr = &tr_targets[j];
        let score = match &joint {
            Some(m) => (0..c).map(|i| m[(i, c + j)].abs()).collect(),
            None => representative_scores(table, &tr_refs, ytr, j, opts.representative)?,
        };
        let mut best: Option<Choice> = None;
        for (_, classes) in &class_sets {
            let reps = cluster::representatives(classes, &score);
            match opts.model {
                ModelKind::Dynamic => {
                    for (ti, eng) in engines.iter().enumerate() {
                        let mut sel: Vec<usize> = Vec::new();
                        for _ in 0..opts.max_sensors.min(reps.len()) {
                            let mut step: Option<(f64, usize)> = None;
                            for &cand in reps.iter().filter(|r| !sel.contains(r)) {
                                let mut s = sel.clone();
                                s.push(cand);
                                if let Some(v) = eng.rmse(&cols_of(&s), j) {
                                    if step.is_none_or(|(b, _)| v < b) {
                                        step = Some((v, cand));
                                    }
                                }
                            }
                            let Some((v, cand)) = step else { break };
                            sel.push(cand);
                            if better(&best, v, sel.len()) {
                                best = Some(Choice {
                                    cv: v,
                                    tau: taus[ti],
                                    alpha: None,
                                    sensors: sel.clone(),
                                    classes: classes.clone(),
                                    reps: reps.clone(),
                                });
                            }
                        }
                    }
                }
                ModelKind::Static => {
                    if let Some(v) = engines[0].rmse(&cols_of(&reps), j) {
                        if better(&best, v, reps.len()) {
                            best = Some(Choice {
                                cv: v,
                                tau: None,
                                alpha: None,
                                sensors: reps.clone(),
                                classes: classes.clone(),
                                reps: reps.clone(),
                            });
                        }
                    }
                }
                ModelKind::Auto => {}
                ModelKind::Ridge => {
                    for &alpha in &opts.ridge_alphas {
                        let v = ridge_cv(&in_refs, &reps, y, &fold, k_folds, alpha)?;
                        if better(&best, v, reps.len()) {
                            best = Some(Choice {
                                cv: v,
                                tau: None,
                                alpha: Some(alpha),
                                sensors: reps.clone(),
                                classes: classes.clone(),
                                reps: reps.clone(),
                            });
                        }
                    }
                }
            }
        }
        let choice = best.ok_or_else(|| IdentifyError::NothingValidated {
            target: table.target_names[j].clone(),
            training_rows: rows.mask.iter().filter(|&&m| m).count(),
            validation: fold_validation(table, &train, k_folds),
        })?;
        finish(
            table, &rows, &fold, k_folds, j, &features, &taus, per_sensor, choice, score, &engines,
        )
    })
    .into_iter()
    .collect::<Result<Vec<_>>>()?;
    let method = format!(
        "{} model; classes by {}; representative by {}; {}",
        match opts.model {
            ModelKind::Dynamic => "dynamic (value + filtered rate per sensor, forward selection)",
            ModelKind::Static => "static (CN105397560: all class representatives, OLS)",
            ModelKind::Ridge => "static ridge (all class representatives)",
            ModelKind::Auto => "every family compared",
        },
        match opts.grouping {
            Grouping::FuzzyEquivalence => "fuzzy equivalence (max–min closure, λ-cut)",
            Grouping::FuzzyCMeans => "fuzzy c-means (m = 2)",
        },
        match opts.representative {
            RepresentativeBy::Pearson => "max |Pearson r| with the target",
            RepresentativeBy::GreyRelational => "max grey relational grade (ρ = 0.5)",
        },
        fold_validation(table, &train, k_folds),
    );
    let test = table.test_mask(&train);
    let floor = engines
        .first()
        .and_then(|eng| engine_floor(table, &train, eng, per_sensor));
    Ok(Identification {
        correlation: corr,
        dendrogram,
        train,
        test,
        fold,
        targets: out,
        method,
        input_names: table.input_names.clone(),
        notes,
        floor,
    })
}

/// [`plain_least_squares`] of `table` (its inputs already the ones `drop_degenerate_inputs`
/// keeps, `train` its training rows) from a validation engine whose features hold every
/// input's value at columns 1 + `per_sensor`·s: the coefficients from the engine's factor
/// of every training row, the residuals of every row as [`residuals_of`] computes them.
/// `None` where plain least squares needs its own factorisation (too few rows, collinear
/// inputs: the minimum-norm solution).
fn engine_floor(
    table: &Table,
    train: &[bool],
    eng: &CvEngine,
    per_sensor: usize,
) -> Option<Vec<(f64, Option<f64>)>> {
    let c = table.inputs.len();
    let n_train = train.iter().filter(|&&m| m).count();
    if n_train < c + 2 {
        return None;
    }
    let mut cols = vec![0usize];
    cols.extend((0..c).map(|s| 1 + per_sensor * s));
    table
        .targets
        .iter()
        .enumerate()
        .map(|(j, y)| {
            let (b, _) = regress::lstsq_of_r(&eng.all_r, &cols, 1 + eng.n_features + j)?;
            let e = residuals_of_coefficients(&b, &table.inputs, y);
            Some((
                rmse_where(&e, train, true).unwrap_or(f64::NAN),
                rmse_where(&e, train, false),
            ))
        })
        .collect()
}

/// Largest magnitude of an input or target value the fit takes: its squares and sums over
/// any table stay finite (a target of 1e301 gave infinite errors and a model file of
/// coefficients near 1e300).
pub const MAX_MAGNITUDE: f64 = 1e100;

/// Refuses a column holding a value beyond [`MAX_MAGNITUDE`], naming it and the value.
fn check_magnitudes(table: &Table) -> Result<()> {
    let columns = table
        .input_names
        .iter()
        .zip(&table.inputs)
        .chain(table.target_names.iter().zip(&table.targets));
    for (name, x) in columns {
        if let Some(v) = x.iter().find(|v| v.abs() > MAX_MAGNITUDE) {
            return Err(invalid(
                &format!("column {name}"),
                format!("{v:e}"),
                &format!(
                    "values of magnitude ≤ {MAX_MAGNITUDE:e} (in its unit: µm for a target, °C for a temperature)"
                ),
            ));
        }
    }
    Ok(())
}

/// A note naming the targets whose measured training values are all equal (a stuck or
/// disconnected probe, a displacement channel never connected): their model is that
/// constant, which compensates nothing.
fn constant_targets_note(table: &Table, train: &[bool]) -> Option<String> {
    let stuck: Vec<String> = table
        .target_names
        .iter()
        .zip(&table.targets)
        .filter_map(|(name, y)| {
            let mut v = y
                .iter()
                .zip(train)
                .filter(|(v, &m)| m && v.is_finite())
                .map(|(v, _)| *v);
            let first = v.next()?;
            v.all(|x| x == first).then(|| format!("{name} ({first})"))
        })
        .collect();
    (!stuck.is_empty()).then(|| {
        format!(
            "target {} constant on every training row: a stuck or disconnected probe? its model is that constant and compensates nothing",
            stuck.join(", ")
        )
    })
}

/// Drops inputs that are constant on the training rows or duplicate an earlier input
/// (|r| = 1 within 1e-12: the same signal, possibly scaled or offset); returns the reduced
/// table and one note per dropped input naming it and why.
pub fn drop_degenerate_inputs<'a>(
    table: &'a Table,
    train: &[bool],
) -> (std::borrow::Cow<'a, Table>, Vec<String>) {
    let mut keep: Vec<usize> = Vec::new();
    let mut notes = Vec::new();
    let rows = TrainRows::new(train);
    let cols: Vec<std::borrow::Cow<[f64]>> = table.inputs.iter().map(|x| rows.of(x)).collect();
    let stats: Vec<(f64, f64)> = cols
        .iter()
        .map(|x| {
            let n = x.len().max(1) as f64;
            let m = x.iter().sum::<f64>() / n;
            let sd = (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt();
            (m, sd)
        })
        .collect();
    for (i, x) in cols.iter().enumerate() {
        let (m, sd) = stats[i];
        let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
            (a.0.min(v), a.1.max(v))
        });
        if !crate::regress::exceeds(hi - lo, 1e-12 * (1.0 + m.abs())) {
            notes.push(format!(
                "input {} dropped: constant ({lo}) on the training rows",
                table.input_names[i]
            ));
            continue;
        }
        let dup = keep.iter().copied().find(|&k| {
            let (mk, sk) = stats[k];
            // Four running sums first: they differ from the one running sum below by at
            // most 2·n·ε·Σ|a·b| ≤ 2·n·ε·n·sd·sk (Cauchy–Schwarz), i.e. |r| by 2·n·ε, far
            // below 1e-6 for any table: |r| < 1 − 1e-6 there means no duplicate, and the
            // decision is the one of the single running sum (computed when it matters).
            let mut acc = [0.0f64; 4];
            let (xa, xb) = (x.chunks_exact(4), cols[k].chunks_exact(4));
            let (ra, rb) = (xa.remainder(), xb.remainder());
            for (a, b) in xa.zip(xb) {
                for q in 0..4 {
                    acc[q] += (a[q] - m) * (b[q] - mk);
                }
            }
            let tail: f64 = ra.iter().zip(rb).map(|(a, b)| (a - m) * (b - mk)).sum();
            let quick = (acc[0] + acc[1] + acc[2] + acc[3] + tail) / (x.len() as f64 * sd * sk);
            if quick.abs() < 1.0 - 1e-6 {
                return false;
            }
            let r = x
                .iter()
                .zip(cols[k].iter())
                .map(|(a, b)| (a - m) * (b - mk))
                .sum::<f64>()
                / (x.len() as f64 * sd * sk);
            r.abs() >= 1.0 - 1e-12
        });
        if let Some(k) = dup {
            notes.push(format!(
                "input {} dropped: duplicates {} (|r| = 1 on the training rows)",
                table.input_names[i], table.input_names[k]
            ));
            continue;
        }
        keep.push(i);
    }
    if keep.len() == table.inputs.len() {
        return (std::borrow::Cow::Borrowed(table), notes);
    }
    let mut t = table.clone();
    t.input_names = keep.iter().map(|&i| table.input_names[i].clone()).collect();
    t.inputs = keep.iter().map(|&i| table.inputs[i].clone()).collect();
    (std::borrow::Cow::Owned(t), notes)
}

fn ridge_cv(
    inputs: &[&[f64]],
    sensors: &[usize],
    y: &[f64],
    fold: &[Option<usize>],
    k: usize,
    alpha: f64,
) -> Result<f64> {
    let per = ridge_fold_rmse(inputs, sensors, y, fold, k, alpha)?;
    let (mut sse, mut n) = (0.0, 0usize);
    for (f, r) in per.iter().enumerate() {
        let m = fold.iter().filter(|g| **g == Some(f)).count();
        sse += r * r * m as f64;
        n += m;
    }
    Ok((sse / n.max(1) as f64).sqrt())
}

/// Held-out RMSE of each fold of a ridge model (folds without rows give 0).
fn ridge_fold_rmse(
    inputs: &[&[f64]],
    sensors: &[usize],
    y: &[f64],
    fold: &[Option<usize>],
    k: usize,
    alpha: f64,
) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(k);
    let names: Vec<String> = sensors.iter().map(|s| format!("input {s}")).collect();
    for f in 0..k {
        let tr: Vec<bool> = fold.iter().map(|g| g.is_some_and(|g| g != f)).collect();
        let va: Vec<usize> = (0..fold.len()).filter(|&i| fold[i] == Some(f)).collect();
        let cols: Vec<Vec<f64>> = sensors
            .iter()
            .map(|&s| select_rows(inputs[s], &tr))
            .collect();
        let refs: Vec<&[f64]> = cols.iter().map(|v| v.as_slice()).collect();
        let fit = regress::ridge(&refs, &select_rows(y, &tr), alpha, &names)?;
        let mut sse = 0.0;
        for &i in &va {
            let row: Vec<f64> = sensors.iter().map(|&s| inputs[s][i]).collect();
            let e = y[i] - fit.predict(&row);
            sse += e * e;
        }
        out.push((sse / va.len().max(1) as f64).sqrt());
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn finish(
    table: &Table,
    rows: &TrainRows,
    fold: &[Option<usize>],
    k_folds: usize,
    j: usize,
    features: &[Vec<std::borrow::Cow<[f64]>>],
    taus: &[Option<f64>],
    per_sensor: usize,
    ch: Choice,
    score: Vec<f64>,
    engines: &[CvEngine],
) -> Result<TargetModel> {
    let ti = taus.iter().position(|t| *t == ch.tau).unwrap_or(0);
    let feats = &features[ti];
    let mut cols: Vec<std::borrow::Cow<[f64]>> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut kinds: Vec<(usize, Transform)> = Vec::new();
    for &s in &ch.sensors {
        let name = &table.input_names[s];
        cols.push(rows.of(&feats[per_sensor * s]));
        names.push(name.clone());
        kinds.push((s, Transform::Value));
        if let Some(tau_s) = ch.tau {
            cols.push(rows.of(&feats[per_sensor * s + 1]));
            names.push(format!("rate({name}, τ = {tau_s} s)"));
            kinds.push((s, Transform::Rate { tau_s }));
        }
    }
    let refs: Vec<&[f64]> = cols.iter().map(|v| &v[..]).collect();
    let ytr = rows.of(&table.targets[j]);
    let eng = &engines[ti];
    let fit = match ch.alpha {
        Some(a) => regress::ridge(&refs, &ytr, a, &names)?,
        // Least squares from the engine's factor of every training row (the columns of
        // [1 X Y] that hold these regressors and this target): no factorisation of the rows.
        None => {
            let mut rcols = vec![0usize];
            for &s in &ch.sensors {
                rcols.extend((0..per_sensor).map(|q| 1 + per_sensor * s + q));
            }
            regress::ols_of_r(
                &eng.all_r,
                &rcols,
                1 + eng.n_features + j,
                &refs,
                &ytr,
                &names,
            )?
        }
    };
    let model = LinearModel {
        intercept: fit.coefficients[0],
        terms: kinds
            .iter()
            .zip(&fit.coefficients[1..])
            .map(|(&(s, transform), &coefficient)| Term {
                channel: table.input_names[s].clone(),
                coefficient,
                transform,
            })
            .collect(),
    };
    model.validate(&format!("model of {}", table.target_names[j]))?;
    let predicted = predict(table, &model)?;
    let e: Vec<f64> = table.targets[j]
        .iter()
        .zip(&predicted)
        .map(|(y, p)| y - p)
        .collect();
    let fold_rmse = if ch.alpha.is_none() {
        let fcols: Vec<usize> = ch
            .sensors
            .iter()
            .flat_map(|&s| (0..per_sensor).map(move |q| per_sensor * s + q))
            .collect();
        let sse = engines[ti].fold_sse(&fcols, j).unwrap_or_default();
        sse.iter()
            .enumerate()
            .map(|(f, s)| {
                let n = fold.iter().filter(|g| **g == Some(f)).count().max(1);
                (s / n as f64).sqrt()
            })
            .collect()
    } else {
        let in_refs: Vec<&[f64]> = table.inputs.iter().map(|v| v.as_slice()).collect();
        ridge_fold_rmse(
            &in_refs,
            &ch.sensors,
            &table.targets[j],
            fold,
            k_folds,
            ch.alpha.unwrap_or(0.0),
        )?
    };
    Ok(TargetModel {
        target: table.target_names[j].clone(),
        classes: ch.classes,
        representatives: ch.reps,
        target_score: score,
        sensors: ch.sensors,
        tau_s: ch.tau,
        ridge_alpha: ch.alpha,
        pcr_components: None,
        cv_rmse: ch.cv,
        fold_rmse,
        regressors: names,
        fit,
        model,
        predicted,
        family: match (ch.alpha, ch.tau) {
            (Some(_), _) => "ridge".into(),
            (None, Some(_)) => "lead-lag (value + rate, shared τ)".into(),
            (None, None) => "static least squares".into(),
        },
        comparison: Vec::new(),
        envelope: None,
        outside: Vec::new(),
        interval_um: Vec::new(),
        train_rmse: rmse_where(&e, rows.mask, true).unwrap_or(f64::NAN),
        test_rmse: rmse_where(&e, rows.mask, false),
        own_rows: None,
    })
}

/// Plain least squares on all inputs (the floor to beat): (train RMSE, test RMSE) per target.
pub fn plain_least_squares(table: &Table, split: &Split) -> Result<Vec<(f64, Option<f64>)>> {
    let Some(groups) = measured_groups(table) else {
        return plain_least_squares_one(table, split);
    };
    // Each group of targets on its own rows, as `identify` does.
    let mut out = vec![(f64::NAN, None); table.targets.len()];
    for g in &groups {
        for (&j, floor) in g
            .iter()
            .zip(plain_least_squares_one(&with_targets(table, g), split)?)
        {
            out[j] = floor;
        }
    }
    Ok(out)
}

fn plain_least_squares_one(table: &Table, split: &Split) -> Result<Vec<(f64, Option<f64>)>> {
    let train = train_mask(table, split)?;
    let (table, _) = drop_degenerate_inputs(table, &train);
    let rows = TrainRows::new(&train);
    let table = &table;
    let cols: Vec<std::borrow::Cow<[f64]>> = table.inputs.iter().map(|x| rows.of(x)).collect();
    let refs: Vec<&[f64]> = cols.iter().map(|v| &v[..]).collect();
    let ys: Vec<std::borrow::Cow<[f64]>> = table.targets.iter().map(|y| rows.of(y)).collect();
    let ys: Vec<&[f64]> = ys.iter().map(|v| &v[..]).collect();
    let fits: Vec<regress::LinearFit> = match regress::ols_many(&refs, &ys, &table.input_names) {
        Ok(f) => f,
        // Fewer training rows than inputs + 2, or collinear inputs (c = a + b): the
        // minimum-norm least-squares solution (numpy's lstsq), so that the floor exists on
        // every valid shape instead of aborting the fit.
        Err(IdentifyError::TooFewRows { .. } | IdentifyError::RankDeficient { .. }) => {
            min_norm_least_squares(&refs, &ys)
        }
        Err(e) => return Err(e),
    };
    table
        .targets
        .iter()
        .zip(fits)
        .map(|(y, fit)| {
            let e = residuals_of(&fit, &table.inputs, y);
            Ok((
                rmse_where(&e, &train, true).unwrap_or(f64::NAN),
                rmse_where(&e, &train, false),
            ))
        })
        .collect()
}

/// y − `fit.predict(row)` of every row of `columns`, bit for bit: the same products added
/// in the same order as `LinearFit::predict` (Σ b_j·x_j from −0.0 as `Iterator::sum`,
/// then b0 + Σ), one column at a time over all rows instead of row by row.
fn residuals_of(fit: &regress::LinearFit, columns: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    residuals_of_coefficients(&fit.coefficients, columns, y)
}

/// [`residuals_of`] for the coefficients (intercept first).
fn residuals_of_coefficients(coefficients: &[f64], columns: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let mut s = vec![-0.0f64; n];
    for (&b, x) in coefficients[1..].iter().zip(columns) {
        for (si, &xi) in s.iter_mut().zip(&x[..n]) {
            *si += b * xi;
        }
    }
    let b0 = coefficients[0];
    y.iter().zip(&s).map(|(&y, &s)| y - (b0 + s)).collect()
}

/// A note when a run's rows are not together in a table (a run whose rows come back after
/// another run's): every block of a run is a segment, so each filter, lag and delay
/// restarts at each block. The CSV reader takes each run's rows together (with its own
/// note), so this concerns tables built otherwise.
fn split_runs_note(table: &Table) -> Option<String> {
    let runs = table.runs.as_ref()?;
    let mut seen = vec![false; table.run_names.len()];
    let mut blocks = 0usize;
    let mut first: Option<(usize, u64)> = None;
    for (i, &r) in runs.iter().enumerate() {
        if i > 0 && runs[i - 1] == r {
            continue;
        }
        blocks += 1;
        if seen.get(r).copied().unwrap_or(false) {
            first.get_or_insert((r, table.lines.get(i).copied().unwrap_or(0)));
        } else if let Some(s) = seen.get_mut(r) {
            *s = true;
        }
    }
    let (r, line) = first?;
    Some(format!(
        "runs not together: run {} comes back at line {line} after another run's rows ({blocks} \
         blocks for {} runs); each block is a segment, so every filter, lag and delay restarts \
         at each block; keep each run's rows together (sort the log by run) for dynamic models",
        table.run_names.get(r).map_or("?", String::as_str),
        table.run_names.len()
    ))
}

/// Largest training rows × (candidate regressor columns)² for which the default
/// (`--family` not given) searches the dynamic families (pure delay, lead-lag, 1st- and
/// 2nd-order transfer functions): their candidate columns (value, one lag per τ, one delay
/// per d, for every sensor) enter the validation's QR factors, whose cost grows with this
/// product (100 sensors × 13 columns on 8 640 training rows, 1.5·10¹⁰: 24 s; 30 sensors on
/// 8 640 rows, 1.3·10⁹: 2 s, on this 2-core machine). Above it the default compares the
/// static families only and says so in a note; `--family` naming them searches them anyway.
pub const DYNAMIC_SEARCH_BUDGET: f64 = 3e9;

/// The default's families bounded by [`DYNAMIC_SEARCH_BUDGET`] (unchanged when the user
/// named families or the search fits the budget), with the note saying so.
fn bound_dynamic_search<'o>(
    table: &Table,
    train: &[bool],
    opts: &'o IdentifyOptions,
    mut notes: Vec<String>,
) -> (std::borrow::Cow<'o, IdentifyOptions>, Vec<String>) {
    use crate::fit::Family;
    if !opts.families.is_empty() {
        return (std::borrow::Cow::Borrowed(opts), notes);
    }
    let c = table.inputs.len();
    let n = train.iter().filter(|&&m| m).count();
    let cols = c * (1 + opts.taus_s.len() + opts.delays_s.len());
    let cost = n as f64 * (cols as f64).powi(2);
    if cost <= DYNAMIC_SEARCH_BUDGET {
        return (std::borrow::Cow::Borrowed(opts), notes);
    }
    let dynamic = [Family::Delay, Family::LeadLag, Family::Tf1, Family::Tf2];
    let mut bounded = opts.clone();
    bounded.families = Family::ALL
        .iter()
        .copied()
        .filter(|f| !dynamic.contains(f))
        .chain(std::iter::once(Family::Stacked))
        .collect();
    notes.push(format!(
        "search bounded: {c} inputs × {} candidate columns each on {n} training rows exceed the \
         default's budget (rows × columns² = {cost:.2e} > {DYNAMIC_SEARCH_BUDGET:.0e}), so the \
         dynamic families ({}) were not searched; name them with --family to search them \
         (slow), or give fewer --inputs, --tau-s or --delay-s",
        1 + opts.taus_s.len() + opts.delays_s.len(),
        dynamic.map(Family::name).join(", ")
    ));
    (std::borrow::Cow::Owned(bounded), notes)
}

/// Minimum-norm least squares of each y on [1 X] (SVD, singular values below
/// max(n, p + 1)·ε·σ₁ treated as zero): the solution of numpy's `lstsq`. Only the
/// coefficients are meaningful (standard errors empty, r² and RMSE of the fitted rows).
fn min_norm_least_squares(columns: &[&[f64]], ys: &[&[f64]]) -> Vec<regress::LinearFit> {
    let n = ys.first().map_or(0, |y| y.len());
    let p = columns.len() + 1;
    let a = DMatrix::from_fn(n, p, |i, j| if j == 0 { 1.0 } else { columns[j - 1][i] });
    let svd = gearcomp_linalg::Svd::new(&a).ok();
    // The singular values come in decreasing order.
    let s1 = svd
        .as_ref()
        .and_then(|s| s.singular_values.get(0).copied())
        .unwrap_or(0.0);
    let eps = s1 * n.max(p) as f64 * f64::EPSILON;
    ys.iter()
        .map(|y| {
            let yv = DVector::from_column_slice(y);
            let b = svd.as_ref().map_or_else(
                || vec![0.0; p],
                |s| s.solve(&yv, eps).iter().copied().collect(),
            );
            let fitted = &a * DVector::from_column_slice(&b);
            let residuals: Vec<f64> = (0..n).map(|i| y[i] - fitted[i]).collect();
            let sse: f64 = residuals.iter().map(|e| e * e).sum();
            let mean = y.iter().sum::<f64>() / n.max(1) as f64;
            let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
            regress::LinearFit {
                coefficients: b,
                std_errors: Vec::new(),
                r2: if sst > 0.0 { 1.0 - sse / sst } else { 1.0 },
                rmse: (sse / n.max(1) as f64).sqrt(),
                sse,
                residuals,
            }
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The fixed kinds' floor, taken from their validation engine's factor, is plain least
    /// squares on all inputs solved afresh ([`plain_least_squares`]): train and test RMSE to
    /// 1e-9 relative, for the static, ridge and dynamic kinds on random tables (drifting
    /// correlated inputs, a constant and a duplicated one dropped on the way, two targets);
    /// with collinear inputs the engine gives none and the minimum-norm floor stays.
    #[test]
    fn fixed_kinds_floor_is_plain_least_squares() {
        let mut u = crate::test_uniform(41);
        let mut next = move || u() * 2.0 - 1.0;
        for case in 0..9 {
            let n = 300 + 37 * case;
            let c = 3 + case % 5;
            let mut walk = 0.0;
            let drift: Vec<f64> = (0..n)
                .map(|_| {
                    walk += 0.05 * next();
                    walk
                })
                .collect();
            let mut inputs: Vec<Vec<f64>> = (0..c)
                .map(|j| {
                    let g = 1.0 + 0.3 * j as f64;
                    drift
                        .iter()
                        .map(|d| 22.0 + j as f64 + g * d + 0.2 * next())
                        .collect()
                })
                .collect();
            inputs.push(vec![21.5; n]);
            inputs.push(inputs[0].clone());
            if case == 8 {
                // Collinear: a sum of two others (no duplicate, rank deficient).
                let s: Vec<f64> = inputs[1]
                    .iter()
                    .zip(&inputs[2])
                    .map(|(a, b)| a + b)
                    .collect();
                inputs.push(s);
            }
            let names: Vec<String> = (0..inputs.len()).map(|j| format!("t{j}_c")).collect();
            let targets: Vec<Vec<f64>> = (0..2)
                .map(|k| {
                    (0..n)
                        .map(|i| 5.0 * k as f64 + 3.0 * inputs[0][i] - 2.0 * inputs[1][i] + next())
                        .collect()
                })
                .collect();
            let table = Table {
                time_s: (0..n).map(|i| 60.0 * i as f64).collect(),
                input_names: names,
                inputs,
                target_names: vec!["a_um".into(), "b_um".into()],
                targets,
                segments: vec![0],
                ..Table::default()
            };
            let split = Split::TimeBefore(60.0 * (n * 2 / 3) as f64);
            let want = plain_least_squares(&table, &split).unwrap();
            for model in [ModelKind::Static, ModelKind::Ridge, ModelKind::Dynamic] {
                let opts = IdentifyOptions {
                    model,
                    split: split.clone(),
                    classes: Some(2),
                    ..IdentifyOptions::default()
                };
                let id = identify(&table, &opts).unwrap();
                match (&id.floor, case) {
                    (None, 8) => {}
                    (Some(got), _) if case != 8 => {
                        for ((a, at), (b, bt)) in want.iter().zip(got) {
                            let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + x.abs());
                            assert!(close(*a, *b), "case {case} {model:?}: {a} vs {b}");
                            assert!(close(at.unwrap(), bt.unwrap()), "case {case} {model:?}");
                        }
                    }
                    (f, _) => panic!("case {case} {model:?}: floor {f:?}"),
                }
                let (_, floor) = identify_with_floor(&table, &opts).unwrap();
                let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + x.abs());
                for ((a, at), (b, bt)) in want.iter().zip(&floor) {
                    assert!(
                        close(*a, *b) && close(at.unwrap(), bt.unwrap()),
                        "case {case}"
                    );
                }
            }
        }
    }

    /// The floor's residuals, column by column over all rows, are y − `LinearFit::predict`
    /// of each row, bit for bit.
    #[test]
    fn floor_residuals_are_predict_row_by_row() {
        let mut u = crate::test_uniform(3);
        let mut next = move || u() * 40.0 - 20.0;
        for c in 0..6 {
            let n = 50 + 7 * c;
            let cols: Vec<Vec<f64>> = (0..c).map(|_| (0..n).map(|_| next()).collect()).collect();
            let y: Vec<f64> = (0..n).map(|_| next()).collect();
            let fit = regress::LinearFit {
                coefficients: (0..=c).map(|_| next()).collect(),
                std_errors: Vec::new(),
                r2: 0.0,
                rmse: 0.0,
                sse: 0.0,
                residuals: Vec::new(),
            };
            let e = residuals_of(&fit, &cols, &y);
            for i in 0..n {
                let row: Vec<f64> = cols.iter().map(|x| x[i]).collect();
                assert_eq!(
                    e[i].to_bits(),
                    (y[i] - fit.predict(&row)).to_bits(),
                    "{c} {i}"
                );
            }
        }
    }

    /// The duplicate-input check against the definition written here (Pearson r by one
    /// running sum over the training rows, |r| ≥ 1 − 1e-12): exact affine copies, copies
    /// with noise of 1e-3 … 1e-9 of the signal (|r| from 1 − 1e-6 down to about
    /// 1 − 1e-18), odd row counts (the four-lane sum's remainder) and a mask of two blocks.
    #[test]
    fn duplicate_inputs_match_the_single_sum_definition() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for n in [7usize, 64, 1001, 5763] {
            let base: Vec<f64> = (0..n).map(|i| (i as f64 * 0.01).sin() + next()).collect();
            let noise: Vec<f64> = (0..n).map(|_| next()).collect();
            let mut inputs = vec![base.clone()];
            let mut names = vec!["base_c".to_string()];
            for (k, eps) in [0.0, 1e-3, 1e-5, 1e-6, 1e-7, 1e-9].iter().enumerate() {
                inputs.push(
                    base.iter()
                        .zip(&noise)
                        .map(|(b, z)| 3.5 * b - 2.0 + eps * z)
                        .collect(),
                );
                names.push(format!("c{k}_c"));
            }
            for mask_kind in 0..2 {
                let train: Vec<bool> = (0..n)
                    .map(|i| mask_kind == 0 || i < n / 3 || i >= 2 * n / 3)
                    .collect();
                let table = Table {
                    time_s: (0..n).map(|i| i as f64).collect(),
                    input_names: names.clone(),
                    inputs: inputs.clone(),
                    target_names: vec!["y_um".into()],
                    targets: vec![base.clone()],
                    ..Table::default()
                };
                let (_, notes) = drop_degenerate_inputs(&table, &train);
                // The definition: r of each copy with `base`, one running sum.
                let sel = |v: &[f64]| -> Vec<f64> {
                    v.iter()
                        .zip(&train)
                        .filter(|p| *p.1)
                        .map(|p| *p.0)
                        .collect()
                };
                let b = sel(&base);
                let stat = |v: &[f64]| {
                    let m = v.iter().sum::<f64>() / v.len() as f64;
                    let sd =
                        (v.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / v.len() as f64).sqrt();
                    (m, sd)
                };
                let (mb, sb) = stat(&b);
                let want: Vec<String> = names[1..]
                    .iter()
                    .zip(&inputs[1..])
                    .filter(|(_, v)| {
                        let c = sel(v);
                        let (mc, sc) = stat(&c);
                        let r = c
                            .iter()
                            .zip(&b)
                            .map(|(p, q)| (p - mc) * (q - mb))
                            .sum::<f64>()
                            / (c.len() as f64 * sc * sb);
                        r.abs() >= 1.0 - 1e-12
                    })
                    .map(|(name, _)| format!("input {name} dropped: duplicates base_c"))
                    .collect();
                let got: Vec<String> = notes
                    .iter()
                    .map(|s| s.split(" (").next().unwrap().to_string())
                    .collect();
                assert_eq!(got, want, "n = {n}, mask {mask_kind}");
                // The exact copy is always dropped, the 1e-3 copy never.
                assert!(want[0].contains("c0_c"));
                assert!(!want.iter().any(|w| w.contains("c1_c")));
            }
        }
    }

    /// The default split: the last run with runs; every row up to 24 h; 24 h after the
    /// first row up to a 72 h log (also on an absolute time axis); the first two thirds in
    /// whole hours beyond, with a note.
    #[test]
    fn default_split_is_24_h_or_two_thirds_of_a_long_log() {
        let of = |h: &[f64]| {
            let t = Table {
                time_s: h.iter().map(|x| x * 3600.0).collect(),
                ..Table::default()
            };
            default_split(&t)
        };
        let (s, note) = of(&[0.0, 20.0]);
        assert_eq!(s, Split::None);
        assert!(note.unwrap().contains("every row trains"));
        assert_eq!(of(&[0.0, 46.0]), (Split::TimeBefore(86_400.0), None));
        assert_eq!(of(&[0.0, 72.0]), (Split::TimeBefore(86_400.0), None));
        assert_eq!(
            of(&[1000.0, 1046.0]),
            (Split::TimeBefore(1024.0 * 3600.0), None)
        );
        let (s, note) = of(&[0.0, 100.0]);
        assert_eq!(s, Split::TimeBefore(67.0 * 3600.0));
        let note = note.unwrap();
        assert!(
            note.contains("spans 100.0 h") && note.contains("before 67 h"),
            "{note}"
        );
        assert_eq!(of(&[500.0, 932.0]).0, Split::TimeBefore(788.0 * 3600.0));
        assert_eq!(of(&[]), (Split::None, None));
        let runs = Table {
            time_s: vec![0.0, 1.0, 0.0, 1.0],
            runs: Some(vec![0, 0, 1, 1]),
            run_names: vec!["a".into(), "b".into()],
            ..Table::default()
        };
        assert_eq!(default_split(&runs).0, Split::TestRuns(vec!["b".into()]));
    }
}
