//! What an identification takes and gives: the options, the model families compared, the
//! identified models and the model file they make, and the row helpers (row selection by a
//! mask, RMSE over a mask, a model's prediction over a table) that both the fixed model
//! kinds ([`crate::pipeline`]) and the family comparison ([`crate::select`]) use. It imports
//! neither of them, so they and [`crate::envelope`] import from here and not from each other.

use crate::cluster::Dendrogram;
use crate::data::Table;
use crate::error::{invalid, IdentifyError, Result};
use crate::regress::LinearFit;
use crate::transform::transform_segments;
use gearcomp_core::model::{
    AxisModel, LinearModel, ModelFile, Provenance, Transform, WorkpieceShrink, MODEL_FORMAT,
};
use nalgebra::DMatrix;
use std::borrow::Cow;

/// The kind of model fitted per target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ModelKind {
    /// Value + filtered rate (lead–lag) per sensor, sensors chosen by forward selection
    /// among the class representatives, τ and class count by cross-validation.
    Dynamic,
    /// CN105397560 as written: every class representative, current values, OLS.
    Static,
    /// As `Static`, fitted by ridge regression with α chosen by cross-validation.
    Ridge,
    /// Every family of [`Family`] compared by the deployment validation
    /// (leave-one-run-out, or rolling origin on one run); the best is kept.
    #[default]
    Auto,
}

/// How the inputs are grouped into classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Grouping {
    /// Fuzzy-equivalence (max–min closure, λ-cut), i.e. single linkage on |r| (CN105397560).
    #[default]
    FuzzyEquivalence,
    /// Fuzzy c-means on the range-normalised series (the open-source workbench).
    FuzzyCMeans,
}

/// How the representative of a class is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RepresentativeBy {
    /// Largest |Pearson r| with the target (CN105397560).
    #[default]
    Pearson,
    /// Largest grey relational grade with the target, ρ = 0.5 (the workbench).
    GreyRelational,
}

/// Which rows train the model; the others test it.
#[derive(Debug, Clone, PartialEq)]
pub enum Split {
    /// Rows with time < the given seconds train.
    TimeBefore(f64),
    /// Rows of the named runs test (names as in `Table::run_names`, or the same number);
    /// the others train.
    TestRuns(Vec<String>),
    /// All rows train; no test error.
    None,
}

/// Options of [`identify`].
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyOptions {
    /// Model kind.
    pub model: ModelKind,
    /// Class formation.
    pub grouping: Grouping,
    /// Representative criterion.
    pub representative: RepresentativeBy,
    /// A fixed class count; `None` chooses among `class_counts` by cross-validation.
    pub classes: Option<usize>,
    /// Candidate class counts (those ≥ the number of inputs are dropped).
    pub class_counts: Vec<usize>,
    /// Candidate rate filter time constants in s (dynamic model).
    pub taus_s: Vec<f64>,
    /// At most this many sensors per target (dynamic model).
    pub max_sensors: usize,
    /// Number of cross-validation folds (runs, or contiguous time blocks without runs).
    pub folds: usize,
    /// Candidate ridge α (ridge model).
    pub ridge_alphas: Vec<f64>,
    /// Train/test split.
    pub split: Split,
    /// Candidate pure delays in s (delay family of [`ModelKind::Auto`]).
    pub delays_s: Vec<f64>,
    /// Families compared by [`ModelKind::Auto`] (empty: all).
    pub families: Vec<Family>,
}

/// The most validation folds `--folds` takes. Each rolling-origin fold costs a fit per
/// candidate (about 0.17 s and 1 MB for every family on FL_THERMAL), so a mistyped count
/// (`--folds 1000000`) would run for days and exhaust memory; a hundred folds is far more
/// than a validation of a thermal test needs.
pub const MAX_FOLDS: usize = 100;

impl IdentifyOptions {
    /// Refuses candidate grids a fit cannot use, naming the command-line option, the value
    /// and the expected range (issue 12: `--ridge-alpha -1` and `--class-counts 0` were
    /// silently dropped, a grid of only such values silently ran without that family).
    pub fn check(&self) -> Result<()> {
        if let Some(a) = self
            .ridge_alphas
            .iter()
            .find(|a| !(a.is_finite() && **a >= 0.0))
        {
            return Err(invalid("--ridge-alpha", a, "α ≥ 0 (finite)"));
        }
        if let Some(k) = self.class_counts.iter().find(|&&k| k == 0) {
            return Err(invalid("--class-counts", k, "class counts ≥ 1"));
        }
        if self.classes == Some(0) {
            return Err(invalid("--classes", 0, "a class count ≥ 1"));
        }
        if let Some(t) = self.taus_s.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(invalid("--tau-s", t, "time constants > 0 s"));
        }
        if let Some(d) = self.delays_s.iter().find(|d| !(d.is_finite() && **d > 0.0)) {
            return Err(invalid("--delay-s", d, "delays > 0 s"));
        }
        if self.max_sensors == 0 {
            return Err(invalid("--max-sensors", 0, "at least 1 sensor"));
        }
        if !(2..=MAX_FOLDS).contains(&self.folds) {
            return Err(invalid(
                "--folds",
                self.folds,
                &format!("2 ..= {MAX_FOLDS} validation folds"),
            ));
        }
        // The default compares the class counts of --class-counts: a fixed count would be
        // ignored without a word (`--classes 1000` with 3 inputs was accepted).
        if let (ModelKind::Auto, Some(k)) = (self.model, self.classes) {
            return Err(invalid(
                "--classes",
                k,
                "a fixed class count only with --model static | ridge | dynamic (the default compares --class-counts)",
            ));
        }
        // The families are those of the default's comparison: with a fixed kind they would
        // be ignored without a word.
        if self.model != ModelKind::Auto && !self.families.is_empty() {
            let named: Vec<&str> = self.families.iter().map(|f| f.name()).collect();
            return Err(invalid(
                "--family",
                named.join(", "),
                "families only with --model auto (the default); a fixed --model fits its own kind",
            ));
        }
        Ok(())
    }
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            model: ModelKind::Auto,
            grouping: Grouping::FuzzyEquivalence,
            representative: RepresentativeBy::Pearson,
            classes: None,
            class_counts: vec![6, 8, 10, 12],
            taus_s: vec![300.0, 600.0, 900.0, 1200.0, 1800.0, 2400.0, 3600.0, 7200.0],
            max_sensors: 8,
            folds: 3,
            ridge_alphas: vec![1e-4, 1e-3, 1e-2, 1e-1],
            split: Split::TimeBefore(86_400.0),
            delays_s: vec![300.0, 900.0, 1800.0, 3600.0],
            families: Vec::new(),
        }
    }
}

/// The identified model of one target.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetModel {
    /// Target column name.
    pub target: String,
    /// Classes of the inputs (indices into the table's inputs) at the chosen count.
    pub classes: Vec<Vec<usize>>,
    /// Representative of each class.
    pub representatives: Vec<usize>,
    /// |r| (or grey grade) of each input with the target, on the training rows.
    pub target_score: Vec<f64>,
    /// The sensors the model reads, in selection order.
    pub sensors: Vec<usize>,
    /// Rate filter time constant in s (dynamic model).
    pub tau_s: Option<f64>,
    /// Ridge α (ridge model).
    pub ridge_alpha: Option<f64>,
    /// Leading principal components kept (principal-component regression).
    pub pcr_components: Option<usize>,
    /// Pooled cross-validation RMSE (µm, target unit) on the training rows.
    pub cv_rmse: f64,
    /// RMSE of each validation fold.
    pub fold_rmse: Vec<f64>,
    /// Regressor names, in coefficient order after the intercept.
    pub regressors: Vec<String>,
    /// The least-squares fit on all training rows.
    pub fit: LinearFit,
    /// The model as written to the model file.
    pub model: LinearModel,
    /// Model prediction at every row (evaluated from `model` with the engine's semantics).
    pub predicted: Vec<f64>,
    /// Model family (e.g. "static least squares"), for reports.
    pub family: String,
    /// Every family compared by the deployment validation (empty for a fixed kind).
    pub comparison: Vec<FamilyScore>,
    /// Training envelope of the model's inputs (axis = the target name).
    pub envelope: Option<gearcomp_core::model::Envelope>,
    /// Per row: inputs outside the training envelope.
    pub outside: Vec<bool>,
    /// Per row: 95 % prediction-interval half-width (target unit).
    pub interval_um: Vec<f64>,
    /// RMSE on the training rows.
    pub train_rmse: f64,
    /// RMSE on the test rows (None without a test set).
    pub test_rmse: Option<f64>,
    /// This target's own training and test rows, when the targets of one fit are measured
    /// on different rows and each group of them was identified on its own rows
    /// ([`crate::identify`]); `None`: the identification's `train` and `test`.
    pub own_rows: Option<(Vec<bool>, Vec<bool>)>,
}

/// The whole identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// Pearson correlation of the inputs on the training rows.
    pub correlation: DMatrix<f64>,
    /// Dendrogram of |r| (fuzzy-equivalence / single linkage).
    pub dendrogram: Dendrogram,
    /// Whether each row trains.
    pub train: Vec<bool>,
    /// Whether each row is a test row: not training, and every target measured on it
    /// ([`crate::data::Table::measured`]).
    pub test: Vec<bool>,
    /// Validation fold of each row (training rows only).
    pub fold: Vec<Option<usize>>,
    /// One model per target.
    pub targets: Vec<TargetModel>,
    /// One-line description of the method, for reports and provenance.
    pub method: String,
    /// The inputs used (after dropping constant or duplicated ones); `sensors` and
    /// `classes` index this list.
    pub input_names: Vec<String>,
    /// Notes about the inputs (dropped sensors, with the reason).
    pub notes: Vec<String>,
    /// Plain least squares on all inputs, (train RMSE, test RMSE) per target, when the
    /// identification computed it on the way (the fixed kinds: from their validation
    /// engine's factor of every training row); `None` otherwise
    /// ([`crate::pipeline::identify_with_floor`] then computes it).
    pub floor: Option<Vec<(f64, Option<f64>)>>,
}

/// Where an identification came from, for the model file's provenance.
#[derive(Debug, Clone, PartialEq)]
pub struct Origin<'a> {
    /// Model name.
    pub name: &'a str,
    /// Data description (file names or the embedded data set).
    pub data: &'a str,
    /// Rows read.
    pub rows: usize,
    /// Tool and version that fitted it.
    pub created_by: &'a str,
    /// The data's gap step ([`crate::data::Table::gap_after_s`]), the model file's
    /// `restart_after_s`.
    pub restart_after_s: Option<f64>,
}

impl Identification {
    /// The model file the engine loads: one axis per target (named `axes[j]`, the target's
    /// name when not given), `workpiece` attached to the first axis, provenance (data,
    /// method, train and test RMSE) and each target's training envelope under its axis name;
    /// validated.
    pub fn to_model_file(
        &self,
        origin: &Origin,
        axes: &[String],
        workpiece: Option<WorkpieceShrink>,
    ) -> Result<ModelFile> {
        if !axes.is_empty() && axes.len() != self.targets.len() {
            return Err(invalid(
                "axis",
                axes.join(" "),
                &format!("one axis name per target ({})", self.targets.len()),
            ));
        }
        let mut workpiece = workpiece;
        let axes: Vec<AxisModel> = self
            .targets
            .iter()
            .enumerate()
            .map(|(j, m)| AxisModel {
                axis: axes.get(j).cloned().unwrap_or_else(|| m.target.clone()),
                target: m.target.clone(),
                machine: m.model.clone(),
                workpiece: workpiece.take(),
            })
            .collect();
        let envelopes = self
            .targets
            .iter()
            .zip(&axes)
            .filter_map(|(m, a)| {
                m.envelope.clone().map(|mut e| {
                    e.axis = a.axis.clone();
                    e
                })
            })
            .collect();
        let file = ModelFile {
            format: MODEL_FORMAT.into(),
            name: origin.name.to_string(),
            description: format!("identified from {} ({} rows)", origin.data, origin.rows),
            restart_after_s: origin.restart_after_s,
            axes,
            provenance: Some(Provenance {
                data: origin.data.to_string(),
                created_by: origin.created_by.to_string(),
                method: self.method.clone(),
                train_rmse_um: self.targets.iter().map(|m| m.train_rmse).collect(),
                test_rmse_um: self
                    .targets
                    .iter()
                    .filter_map(|m| m.test_rmse)
                    .filter(|v| v.is_finite())
                    .collect(),
            }),
            envelopes,
        };
        file.validate()?;
        Ok(file)
    }
}

pub(crate) fn rmse_where(e: &[f64], mask: &[bool], want: bool) -> Option<f64> {
    // A residual is NaN exactly where the target was not measured (`Table::measured`;
    // the inputs are finite on every row): such rows are not scored.
    let (s, n) = e
        .iter()
        .zip(mask)
        .filter(|(v, &m)| m == want && v.is_finite())
        .fold((0.0, 0usize), |(s, n), (v, _)| (s + v * v, n + 1));
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// A model family of the automatic comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Current values, ordinary least squares, sensors by forward selection.
    Static,
    /// Current values, ridge (α by validation), on the static family's sensor order.
    Ridge,
    /// Current values, principal-component regression (components by validation).
    Pcr,
    /// Value + first-order lag per sensor, one τ shared by all sensors.
    LeadLag,
    /// First-order transfer function per sensor: value + lag, τ chosen per sensor.
    Tf1,
    /// Second-order transfer function per sensor: value + two lags, τ pair per sensor.
    Tf2,
    /// Pure delay per sensor (delay chosen per sensor, 0 included).
    Delay,
    /// Static least squares on single sensors and sensor differences A − B.
    Differences,
    /// CN105397560 as written inside the comparison: fuzzy-equivalence classes of the
    /// inputs, one representative per class, least squares or ridge on the representatives;
    /// the class count (within the sensor cap) and α by validation, the classes and
    /// representatives formed on each fold's training rows.
    Classes,
    /// Convex combination of the other families' best models, weights fitted on their
    /// out-of-fold predictions ([`stack`]); not in [`Family::ALL`]: compared by
    /// default, or when named beside the families it combines.
    Stacked,
}

impl Family {
    /// Every family, in order of simplicity (ties keep the earlier).
    pub const ALL: [Family; 9] = [
        Family::Static,
        Family::Ridge,
        Family::Pcr,
        Family::Classes,
        Family::Differences,
        Family::Delay,
        Family::LeadLag,
        Family::Tf1,
        Family::Tf2,
    ];

    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Family::Static => "static least squares",
            Family::Ridge => "ridge",
            Family::Pcr => "principal-component regression",
            Family::LeadLag => "lead-lag (value + lag, shared τ)",
            Family::Tf1 => "1st-order transfer function",
            Family::Tf2 => "2nd-order transfer function",
            Family::Delay => "pure delay",
            Family::Differences => "sensor differences (A − B)",
            Family::Classes => "class representatives (CN105397560)",
            Family::Stacked => "stacked families (convex weights)",
        }
    }
}

/// One family's result in the comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyScore {
    /// Family name.
    pub family: String,
    /// Number of sensors of the family's best model.
    pub sensors: usize,
    /// Pooled validation RMSE (target unit).
    pub cv_rmse: f64,
    /// Validation RMSE per fold.
    pub fold_rmse: Vec<f64>,
    /// Hyper-parameters chosen (τ, α, components, delays) or why the family is out.
    pub detail: String,
    /// Whether the family may be kept (false: e.g. over the sensor cap).
    pub eligible: bool,
    /// Whether this family's model was kept.
    pub kept: bool,
}

/// The values of `x` at the rows where `mask` is true.
pub(crate) fn select_rows(x: &[f64], mask: &[bool]) -> Vec<f64> {
    x.iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(v, _)| *v)
        .collect()
}

/// The index of the input column `name` of `table` (an error naming the columns there are).
pub(crate) fn input_index(table: &Table, name: &str) -> Result<usize> {
    table
        .input_names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| IdentifyError::ColumnNotFound {
            pattern: name.to_string(),
            available: table.input_names.join(", "),
        })
}

/// The regressor series of each term of `model` over the table (the engine's transform
/// semantics, as [`crate::envelope::regressors`]), a value term's borrowed from its input
/// column (the value transform is the identity: the same numbers without a copy); any other
/// term, or a table whose series or segments [`transform_segments`] refuses, as
/// `regressors` computes it (the same error).
pub(crate) fn regressor_series<'t>(
    table: &'t Table,
    model: &LinearModel,
) -> Result<Vec<Cow<'t, [f64]>>> {
    let segs = table.segment_ranges();
    let n = table.time_s.len();
    let mut next = 0usize;
    let segments_ok = segs.iter().all(|&(s, e)| {
        let ok = s == next && e <= n && e > s;
        next = e;
        ok
    }) && next == n;
    model
        .terms
        .iter()
        .map(|t| {
            let u = &table.inputs[input_index(table, &t.channel)?];
            if t.transform == Transform::Value && segments_ok && u.len() == n {
                Ok(Cow::Borrowed(u.as_slice()))
            } else {
                transform_segments(&table.time_s, u, t.transform, &segs).map(Cow::Owned)
            }
        })
        .collect()
}

/// Evaluates a linear model over the whole table with the engine's transform semantics.
pub fn predict(table: &Table, model: &LinearModel) -> Result<Vec<f64>> {
    let mut out = vec![model.intercept; table.time_s.len()];
    // A value term's series is its input column itself (no copy; the same numbers).
    let series = regressor_series(table, model)?;
    for (t, x) in model.terms.iter().zip(&series) {
        for (o, v) in out.iter_mut().zip(x.iter()) {
            *o += t.coefficient * v;
        }
    }
    Ok(out)
}

/// The training rows of a mask, to take from series: a slice of a series when they are one
/// contiguous block (a time split, the usual case), else a copy (the same values in the same
/// order either way). The block is found once per mask.
pub(crate) struct TrainRows<'m> {
    pub(crate) mask: &'m [bool],
    block: Option<(usize, usize)>,
}

impl<'m> TrainRows<'m> {
    pub(crate) fn new(mask: &'m [bool]) -> Self {
        let start = mask.iter().position(|&t| t).unwrap_or(mask.len());
        let end = mask[start..]
            .iter()
            .position(|&t| !t)
            .map_or(mask.len(), |p| start + p);
        let block = (!mask[end..].contains(&true)).then_some((start, end));
        Self { mask, block }
    }

    /// The training rows of `x` (a series as long as the mask).
    pub(crate) fn of<'a>(&self, x: &'a [f64]) -> std::borrow::Cow<'a, [f64]> {
        match self.block {
            Some((a, b)) if x.len() == self.mask.len() => std::borrow::Cow::Borrowed(&x[a..b]),
            _ => std::borrow::Cow::Owned(select_rows(x, self.mask)),
        }
    }
}

/// How well each input (its training rows in `inputs`) represents target `j` (training rows
/// `y`): |Pearson r| or the grey relational grade (ρ = 0.5), CN105397560's choice of a class
/// representative; the static kind and the class-representatives family both rank by it.
pub(crate) fn representative_scores(
    table: &Table,
    inputs: &[&[f64]],
    y: &[f64],
    j: usize,
    by: RepresentativeBy,
) -> Result<Vec<f64>> {
    match by {
        RepresentativeBy::Pearson => inputs
            .iter()
            .enumerate()
            .map(|(i, x)| {
                crate::cluster::pearson(
                    x,
                    y,
                    &format!(
                        "correlation({}, {})",
                        table.input_names[i], table.target_names[j]
                    ),
                )
                .map(f64::abs)
            })
            .collect(),
        RepresentativeBy::GreyRelational => crate::cluster::grey_relational_grades(y, inputs, 0.5),
    }
}
