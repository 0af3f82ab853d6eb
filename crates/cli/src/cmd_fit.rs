//! `gearcomp fit`: thermal model identification from measured data (issue 4, CN105397560).
//!
//! Data in (CSV; the embedded FL_THERMAL test by default), model file and report out.

use std::path::PathBuf;

use anyhow::Context as _;
use gearcomp_core::model::{ModelFile, ReferenceRadius, ShrinkGear, ShrinkMethod, WorkpieceShrink};
use gearcomp_identify::data::{read_runs, ReadOptions, Selection, Table};
use gearcomp_identify::dendrogram::dendrogram_svg;
use gearcomp_identify::identify::{
    identify, plain_least_squares, Grouping, Identification, IdentifyOptions, ModelKind, Origin,
    RepresentativeBy, Split, TargetModel,
};
use gearcomp_identify::select::Family;
use gearcomp_identify::workpiece::{combined_offsets_um, shrink_offset_um, workpiece_shrink};
use gearcomp_report::{Chart, HtmlReport, Series};

/// Model kind (`--model`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum ModelArg {
    /// Every family compared by leave-one-run-out (runs) or rolling-origin (one run)
    /// validation on the training rows; the best is kept.
    Auto,
    /// Value + filtered rate per sensor; sensors, τ and class count by cross-validation.
    Dynamic,
    /// CN105397560 as written: every class representative, current values, least squares.
    Static,
    /// As static, fitted by ridge regression (α by cross-validation).
    Ridge,
}

/// Model family of `--model auto` (`--family`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum FamilyArg {
    /// Current values, least squares, sensors by forward selection.
    Static,
    /// Current values, ridge (α by validation).
    Ridge,
    /// Current values, principal-component regression.
    Pcr,
    /// Sensors and sensor differences A − B, least squares.
    Differences,
    /// A pure delay per sensor.
    Delay,
    /// Value + first-order lag per sensor, one shared τ.
    LeadLag,
    /// First-order transfer function per sensor (value + lag, τ per sensor).
    Tf1,
    /// Second-order transfer function per sensor (value + two lags).
    Tf2,
}

impl From<FamilyArg> for Family {
    fn from(f: FamilyArg) -> Self {
        match f {
            FamilyArg::Static => Family::Static,
            FamilyArg::Ridge => Family::Ridge,
            FamilyArg::Pcr => Family::Pcr,
            FamilyArg::Differences => Family::Differences,
            FamilyArg::Delay => Family::Delay,
            FamilyArg::LeadLag => Family::LeadLag,
            FamilyArg::Tf1 => Family::Tf1,
            FamilyArg::Tf2 => Family::Tf2,
        }
    }
}

/// Class formation (`--grouping`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum GroupingArg {
    /// Fuzzy equivalence: max–min transitive closure and λ-cut (= single linkage on |r|).
    FuzzyEquivalence,
    /// Fuzzy c-means (m = 2) on the range-normalised series.
    Fcm,
}

/// Representative criterion (`--representative`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum RepresentativeArg {
    /// Largest |Pearson r| with the target.
    Pearson,
    /// Largest grey relational grade with the target (ρ = 0.5).
    Grey,
}

/// Shrink reference radius (`--shrink-reference`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum ReferenceArg {
    /// Reference (pitch) circle.
    Pitch,
    /// Tip circle (needs --tip-diameter-mm).
    Tip,
}

/// Shrink formula (`--shrink-method`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum ShrinkMethodArg {
    /// Exact involute form.
    Exact,
    /// First-order form r·λ·ΔT.
    FirstOrder,
}

/// Options of `gearcomp fit`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Example: gearcomp fit --target ch1_um ch3_um ch5_um --out model.toml --report fit.html\n\
Without --data the embedded FL_THERMAL test (46 h, 16 temperatures, 5 probes) is used, trained on the first 24 h."
)]
pub struct Args {
    /// CSV log(s) with a header row: time column (s), temperature columns, target columns.
    /// Several files are several runs (one per file, named after the file).
    /// Default: the embedded FL_THERMAL data set.
    #[arg(long, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// The log has no time column: rows are this many seconds apart (restarting per run).
    #[arg(long)]
    pub sample_interval_s: Option<f64>,
    /// Target columns (names or glob patterns such as "ch*_um"), e.g. measured drift in µm.
    #[arg(long, num_args = 1.., default_value = "*_um")]
    pub target: Vec<String>,
    /// Input (temperature) columns: names or glob patterns. Default: every "*_c" column.
    #[arg(long, num_args = 1.., default_value = "*_c")]
    pub inputs: Vec<String>,
    /// Name of the time column (seconds, strictly increasing).
    #[arg(long, default_value = "time_s")]
    pub time_column: String,
    /// Column naming the run of each row (time restarts in each run): validation by
    /// leave-one-run-out and --test-runs.
    #[arg(long)]
    pub run_column: Option<String>,
    /// Train on rows with time < this many hours; test on the rest (one run only;
    /// default 24 h on one run; with several runs the last run tests by default).
    #[arg(long, conflicts_with_all = ["test_runs", "no_test"])]
    pub train_before_h: Option<f64>,
    /// Test on these runs (comma separated names or numbers), train on the other runs.
    #[arg(long, value_delimiter = ',', conflicts_with = "no_test")]
    pub test_runs: Vec<String>,
    /// Train on all rows (no test error is reported).
    #[arg(long)]
    pub no_test: bool,
    /// Model kind.
    #[arg(long, value_enum, default_value = "auto")]
    pub model: ModelArg,
    /// Print the result as JSON (family, sensors, coefficients, folds, errors).
    #[arg(long)]
    pub json: bool,
    /// How sensors are grouped into classes.
    #[arg(long, value_enum, default_value = "fuzzy-equivalence")]
    pub grouping: GroupingArg,
    /// How the representative of each class is chosen.
    #[arg(long, value_enum, default_value = "pearson")]
    pub representative: RepresentativeArg,
    /// Fixed number of classes; default: chosen from --class-counts by cross-validation.
    #[arg(long)]
    pub classes: Option<usize>,
    /// Candidate class counts for the cross-validated choice.
    #[arg(long, value_delimiter = ',', default_value = "6,8,10,12")]
    pub class_counts: Vec<usize>,
    /// Candidate rate-filter time constants τ in seconds (dynamic model).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "300,600,900,1200,1800,2400,3600,7200"
    )]
    pub tau_s: Vec<f64>,
    /// Candidate pure delays in seconds (delay family of --model auto).
    #[arg(long, value_delimiter = ',', default_value = "300,900,1800,3600")]
    pub delay_s: Vec<f64>,
    /// Families compared by --model auto (comma separated; default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub family: Vec<FamilyArg>,
    /// Largest number of sensors per target (every family).
    #[arg(long, default_value_t = 8)]
    pub max_sensors: usize,
    /// Cross-validation folds: runs (with --run-column) or contiguous time blocks.
    #[arg(long, default_value_t = 3)]
    pub folds: usize,
    /// Candidate ridge α values (ridge model).
    #[arg(long, value_delimiter = ',', default_value = "0.0001,0.001,0.01,0.1")]
    pub ridge_alpha: Vec<f64>,
    /// Drop bad rows (they are still listed) instead of stopping at them.
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Axis name of each target's model, in target order (default: the target's name).
    #[arg(long, num_args = 1..)]
    pub axis: Vec<String>,
    /// Write the thermal model file here (.toml, or .json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the HTML report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Model name stored in the file.
    #[arg(long, default_value = "identified thermal model")]
    pub name: String,
    /// Workpiece (dry hobbing): CSV with the inputs and the measured workpiece temperature.
    #[arg(long, requires_all = ["workpiece_target", "module_mm", "teeth"])]
    pub workpiece_data: Option<PathBuf>,
    /// Workpiece temperature column Ta (°C) in --workpiece-data.
    #[arg(long)]
    pub workpiece_target: Option<String>,
    /// Classes (= sensors) of the workpiece temperature model Ta = a0 + Σ ai·ti.
    #[arg(long, default_value_t = 3)]
    pub workpiece_classes: usize,
    /// Normal module m_n in mm of the gear being cut.
    #[arg(long)]
    pub module_mm: Option<f64>,
    /// Normal pressure angle α_n in degrees.
    #[arg(long, default_value_t = 20.0)]
    pub pressure_angle_deg: f64,
    /// Number of teeth z.
    #[arg(long)]
    pub teeth: Option<u32>,
    /// Helix angle β in degrees (0 = spur).
    #[arg(long, default_value_t = 0.0)]
    pub helix_angle_deg: f64,
    /// Tip diameter d_a in mm (needed for --shrink-reference tip).
    #[arg(long)]
    pub tip_diameter_mm: Option<f64>,
    /// Linear expansion coefficient λ of the workpiece in 1/K.
    #[arg(long, default_value_t = 11.5e-6)]
    pub expansion_per_k: f64,
    /// Design (measuring-room) temperature Tb in °C.
    #[arg(long, default_value_t = 20.0)]
    pub design_temp_c: f64,
    /// Radius at which the cooled tooth thickness is made right.
    #[arg(long, value_enum, default_value = "pitch")]
    pub shrink_reference: ReferenceArg,
    /// Exact or first-order shrink formula.
    #[arg(long, value_enum, default_value = "exact")]
    pub shrink_method: ShrinkMethodArg,
}

fn load(
    paths: &[PathBuf],
    sel: &Selection,
    skip: bool,
    sample_interval_s: Option<f64>,
) -> anyhow::Result<(Table, String)> {
    let opts = ReadOptions {
        skip_bad_rows: skip,
        sample_interval_s,
        ..ReadOptions::default()
    };
    let files: Vec<(String, String)> = if paths.is_empty() {
        vec![(
            gearcomp_datasets::fl_thermal_csv()
                .context("decompress the embedded FL_THERMAL data")?,
            "FL_THERMAL (embedded)".to_string(),
        )]
    } else {
        paths
            .iter()
            .map(|p| {
                Ok((
                    std::fs::read_to_string(p).with_context(|| format!("read {}", p.display()))?,
                    p.display().to_string(),
                ))
            })
            .collect::<anyhow::Result<_>>()?
    };
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(t, n)| (t.as_str(), n.as_str()))
        .collect();
    let name = files
        .iter()
        .map(|f| f.1.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    Ok((read_runs(&refs, sel, opts)?, name))
}

/// A figure for printing: "-" instead of NaN or infinity.
fn num(v: f64, prec: usize) -> String {
    if v.is_finite() {
        format!("{v:.prec$}")
    } else {
        "-".into()
    }
}

/// A coefficient-like figure in exponent form, "-" when not finite.
fn num_e(v: f64, prec: usize) -> String {
    if v.is_finite() {
        format!("{v:.prec$e}")
    } else {
        "-".into()
    }
}

fn thin(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    let step = points.len().div_ceil(max.max(1)).max(1);
    points.into_iter().step_by(step).collect()
}

/// Test rows, test rows outside the training envelope, mean 95 % interval half-width.
fn extrapolation(
    train: &[bool],
    m: &gearcomp_identify::identify::TargetModel,
) -> (usize, usize, f64) {
    let mut n = 0;
    let mut out = 0;
    for (i, &tr) in train.iter().enumerate() {
        if !tr {
            n += 1;
            out += usize::from(m.outside.get(i).copied().unwrap_or(false));
        }
    }
    let half = if m.interval_um.is_empty() {
        f64::NAN
    } else {
        m.interval_um.iter().sum::<f64>() / m.interval_um.len() as f64
    };
    (n, out, half)
}

/// A number for JSON: null when not finite.
fn jnum(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::json!(v)
    } else {
        serde_json::Value::Null
    }
}

/// `fit --json`: per target the chosen family, sensors, model terms, validation folds,
/// the family comparison, train and test error.
fn fit_json(
    id: &gearcomp_identify::identify::Identification,
    base: &[(f64, Option<f64>)],
    data_name: &str,
    table: &Table,
    file: &ModelFile,
) -> anyhow::Result<serde_json::Value> {
    let n_train = id.train.iter().filter(|&&m| m).count();
    let targets: Vec<serde_json::Value> = id
        .targets
        .iter()
        .zip(base)
        .map(|(m, b)| {
            serde_json::json!({
                "target": m.target,
                "family": m.family,
                "sensors": m.sensors.iter().map(|&s| id.input_names[s].clone()).collect::<Vec<_>>(),
                "intercept": jnum(m.model.intercept),
                "terms": serde_json::to_value(&m.model.terms).unwrap_or_default(),
                "validation_rmse_um": jnum(m.cv_rmse),
                "validation_folds_um": m.fold_rmse.iter().map(|v| jnum(*v)).collect::<Vec<_>>(),
                "train_rmse_um": jnum(m.train_rmse),
                "test_rmse_um": m.test_rmse.map_or(serde_json::Value::Null, jnum),
                "test_rows_outside_envelope": extrapolation(&id.train, m).1,
                "mean_interval_half_width_um": jnum(extrapolation(&id.train, m).2),
                "plain_ls_all_inputs": {
                    "train_rmse_um": jnum(b.0),
                    "test_rmse_um": b.1.map_or(serde_json::Value::Null, jnum),
                },
                "comparison": m.comparison.iter().map(|c| serde_json::json!({
                    "family": c.family,
                    "sensors": c.sensors,
                    "validation_rmse_um": jnum(c.cv_rmse),
                    "validation_folds_um": c.fold_rmse.iter().map(|v| jnum(*v)).collect::<Vec<_>>(),
                    "detail": c.detail,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    Ok(serde_json::json!({
        "data": data_name,
        "rows": table.time_s.len(),
        "training_rows": n_train,
        "test_rows": table.time_s.len() - n_train,
        "runs": table.run_names,
        "inputs": id.input_names,
        "notes": id.notes,
        "method": id.method,
        "targets": targets,
        "model_file": serde_json::to_value(file)?,
    }))
}

/// The train/test split the options ask for, and a note when it was chosen by default.
fn split_of(args: &Args, table: &Table) -> anyhow::Result<(Split, Option<String>)> {
    let mut split_note = None;
    let split = if args.no_test {
        Split::None
    } else if !args.test_runs.is_empty() {
        Split::TestRuns(args.test_runs.clone())
    } else if args.train_before_h.is_none() && table.run_count() > 1 {
        let last = table.run_names.last().cloned().unwrap_or_default();
        split_note = Some(format!(
            "test run: {last} (the last run; choose with --test-runs, or --no-test)"
        ));
        Split::TestRuns(vec![last])
    } else if args.train_before_h.is_none()
        && table.time_s.last().is_some_and(|&t| t <= 24.0 * 3600.0)
    {
        split_note = Some(
            "the data ends before the default 24 h split: every row trains, no test error (give --train-before-h to hold out a test period)".into(),
        );
        Split::None
    } else {
        let h = args.train_before_h.unwrap_or(24.0);
        if !(h.is_finite() && h > 0.0) {
            anyhow::bail!("invalid --train-before-h = {h}: expected hours > 0");
        }
        Split::TimeBefore(h * 3600.0)
    };
    Ok((split, split_note))
}

/// The identification options of the command line.
fn options(args: &Args, split: &Split) -> IdentifyOptions {
    IdentifyOptions {
        model: match args.model {
            ModelArg::Dynamic => ModelKind::Dynamic,
            ModelArg::Static => ModelKind::Static,
            ModelArg::Ridge => ModelKind::Ridge,
            ModelArg::Auto => ModelKind::Auto,
        },
        grouping: match args.grouping {
            GroupingArg::FuzzyEquivalence => Grouping::FuzzyEquivalence,
            GroupingArg::Fcm => Grouping::FuzzyCMeans,
        },
        representative: match args.representative {
            RepresentativeArg::Pearson => RepresentativeBy::Pearson,
            RepresentativeArg::Grey => RepresentativeBy::GreyRelational,
        },
        classes: args.classes,
        class_counts: args.class_counts.clone(),
        taus_s: args.tau_s.clone(),
        max_sensors: args.max_sensors,
        folds: args.folds,
        ridge_alphas: args.ridge_alpha.clone(),
        split: split.clone(),
        delays_s: args.delay_s.clone(),
        families: args.family.iter().map(|&f| f.into()).collect(),
    }
}

/// The workpiece shrink model (`--workpiece-data`): its temperature model (the seed's
/// static method) and the shrink of the gear; `None` without workpiece data.
fn workpiece_model(
    args: &Args,
    opts: &IdentifyOptions,
) -> anyhow::Result<Option<(WorkpieceShrink, TargetModel)>> {
    let Some(path) = &args.workpiece_data else {
        return Ok(None);
    };
    let wsel = Selection {
        time: args.time_column.clone(),
        inputs: args.inputs.clone(),
        targets: vec![args.workpiece_target.clone().unwrap_or_default()],
        run: None,
    };
    let (wt, _) = load(
        std::slice::from_ref(path),
        &wsel,
        args.skip_bad_rows,
        args.sample_interval_s,
    )?;
    let wid = identify(
        &wt,
        &IdentifyOptions {
            model: ModelKind::Static,
            classes: Some(args.workpiece_classes),
            split: Split::None,
            ..opts.clone()
        },
    )
    .context("workpiece temperature model")?;
    let gear = ShrinkGear {
        normal_module_mm: args.module_mm.unwrap_or(f64::NAN),
        pressure_angle_deg: args.pressure_angle_deg,
        teeth: args.teeth.unwrap_or(0),
        helix_angle_deg: args.helix_angle_deg,
        tip_diameter_mm: args.tip_diameter_mm,
    };
    let w = workpiece_shrink(
        wid.targets[0].model.clone(),
        gear,
        args.design_temp_c,
        args.expansion_per_k,
        match args.shrink_reference {
            ReferenceArg::Pitch => ReferenceRadius::Pitch,
            ReferenceArg::Tip => ReferenceRadius::Tip,
        },
        match args.shrink_method {
            ShrinkMethodArg::Exact => ShrinkMethod::Exact,
            ShrinkMethodArg::FirstOrder => ShrinkMethod::FirstOrder,
        },
    )?;
    Ok(Some((w, wid.targets[0].clone())))
}

/// Runs `gearcomp fit`: read, identify, write the model file, the summary and the report.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sel = Selection {
        time: args.time_column.clone(),
        inputs: args.inputs.clone(),
        targets: args.target.clone(),
        run: args.run_column.clone(),
    };
    let (table, data_name) = load(&args.data, &sel, args.skip_bad_rows, args.sample_interval_s)?;
    let (split, split_note) = split_of(&args, &table)?;
    let opts = options(&args, &split);
    let id = identify(&table, &opts)?;
    let base = plain_least_squares(&table, &split)?;
    if !args.axis.is_empty() && args.axis.len() != table.targets.len() {
        anyhow::bail!(
            "invalid --axis: {} name(s) for {} target(s) ({}); give one per target",
            args.axis.len(),
            table.targets.len(),
            table.target_names.join(", ")
        );
    }

    // Workpiece shrink model (CN105397560 eqs. (3)–(8)), attached to the first axis.
    let workpiece = workpiece_model(&args, &opts)?;

    let created_by = format!("gearcomp fit {}", env!("CARGO_PKG_VERSION"));
    let origin = Origin {
        name: &args.name,
        data: &data_name,
        rows: table.time_s.len(),
        created_by: &created_by,
    };
    let file = id.to_model_file(&origin, &args.axis, workpiece.as_ref().map(|w| w.0.clone()))?;

    // Text summary.
    let mut out = String::new();
    use std::fmt::Write as _;
    let n_train = id.train.iter().filter(|&&m| m).count();
    let _ = writeln!(
        out,
        "data: {data_name}: {} rows, {} inputs, {} target(s); {} training rows, {} test rows",
        table.time_s.len(),
        table.inputs.len(),
        table.targets.len(),
        n_train,
        table.time_s.len() - n_train
    );
    if let Some(n) = &split_note {
        let _ = writeln!(out, "  note: {n}");
    }
    if table.runs.is_some() {
        let _ = writeln!(
            out,
            "  runs: {} ({}); {} segment(s) (filters restart at each)",
            table.run_names.len(),
            table.run_names.join(", "),
            table.segment_ranges().len()
        );
    }
    for n in &id.notes {
        let _ = writeln!(out, "  note: {n}");
    }
    for i in table.issues.iter().take(20) {
        let _ = writeln!(out, "  note: {i}");
    }
    if table.issues.len() > 20 {
        let _ = writeln!(out, "  note: … {} more", table.issues.len() - 20);
    }
    let _ = writeln!(out, "method: {}", id.method);
    let names = &id.input_names;
    let fmt_opt = |v: Option<f64>| v.map_or("-".to_string(), |v| num(v, 3));
    let mut rows = Vec::new();
    for (m, b) in id.targets.iter().zip(&base) {
        let sensors: Vec<&str> = m.sensors.iter().map(|&s| names[s].as_str()).collect();
        let _ = writeln!(
            out,
            "\n{}: {}; {} sensor(s): {}{}{}",
            m.target,
            if m.classes.is_empty() {
                m.family.clone()
            } else {
                format!("{} classes", m.classes.len())
            },
            sensors.len(),
            sensors.join(", "),
            m.tau_s
                .map_or(String::new(), |t| format!("; rate τ = {t} s")),
            m.ridge_alpha
                .map_or(String::new(), |a| format!("; ridge α = {a}"))
        );
        if !m.comparison.is_empty() {
            let _ = writeln!(
                out,
                "  {:<40} {:>8} {:>12}  folds µm; choice",
                "family (validation on training rows)", "sensors", "RMSE µm"
            );
            for c in &m.comparison {
                let _ = writeln!(
                    out,
                    "  {:<40} {:>8} {:>12}  {}; {}{}",
                    c.family,
                    c.sensors,
                    num(c.cv_rmse, 3),
                    c.fold_rmse
                        .iter()
                        .map(|v| num(*v, 3))
                        .collect::<Vec<_>>()
                        .join(", "),
                    c.detail,
                    if c.family == m.family {
                        "  ← kept"
                    } else {
                        ""
                    }
                );
            }
        }
        let _ = writeln!(
            out,
            "  RMSE µm: train {}, test {}, validation {} (folds: {}); R² = {}",
            num(m.train_rmse, 3),
            fmt_opt(m.test_rmse),
            num(m.cv_rmse, 3),
            m.fold_rmse
                .iter()
                .map(|v| num(*v, 3))
                .collect::<Vec<_>>()
                .join(", "),
            num(m.fit.r2, 4)
        );
        let _ = writeln!(
            out,
            "  plain least squares on all {} inputs: train {}, test {} µm",
            names.len(),
            num(b.0, 3),
            fmt_opt(b.1)
        );
        let (n_test, n_out, mean_half) = extrapolation(&id.train, m);
        let _ = writeln!(
            out,
            "  extrapolation: {n_out} of {n_test} test rows outside the training envelope; 95 % prediction interval ± {} µm on average (validation RMSE × √(1 + leverage))",
            num(mean_half, 3)
        );
        let _ = writeln!(
            out,
            "  {:<34} {:>16} {:>14}",
            "term", "coefficient", "std. error"
        );
        let _ = writeln!(
            out,
            "  {:<34} {:>16} {:>14}",
            "intercept",
            num(m.fit.coefficients[0], 6),
            num(m.fit.std_errors.first().copied().unwrap_or(f64::NAN), 6)
        );
        for (k, name) in m.regressors.iter().enumerate() {
            let _ = writeln!(
                out,
                "  {:<34} {:>16} {:>14}",
                name,
                num_e(m.fit.coefficients[k + 1], 6),
                num_e(m.fit.std_errors.get(k + 1).copied().unwrap_or(f64::NAN), 4)
            );
        }
        rows.push(vec![
            m.target.clone(),
            m.family.clone(),
            sensors.join(" "),
            m.tau_s.map_or("-".into(), |t| format!("{t}")),
            num(m.train_rmse, 3),
            fmt_opt(m.test_rmse),
            num(m.cv_rmse, 3),
            fmt_opt(b.1),
        ]);
    }
    if let Some((w, wm)) = &workpiece {
        let chans: Vec<&str> = w
            .temperature
            .terms
            .iter()
            .map(|t| t.channel.as_str())
            .collect();
        let _ = writeln!(out, "\nworkpiece: Ta = {:.6} + Σ ai·ti on {} (train RMSE {:.3} °C); δT at Ta = Tb + 30 K: {:.4} µm",
            w.temperature.intercept, chans.join(", "), wm.train_rmse, shrink_offset_um(w, w.design_temp_c + 30.0)?);
    }
    let mut stdout = std::io::stdout().lock();
    if args.json {
        let v = fit_json(&id, &base, &data_name, &table, &file)?;
        let mut text = serde_json::to_string_pretty(&v)?;
        text.push('\n');
        std::io::Write::write_all(&mut stdout, text.as_bytes())?;
    } else {
        use std::io::Write as _;
        stdout.write_all(out.as_bytes())?;
    }

    if let Some(p) = &args.out {
        file.save(p)
            .with_context(|| format!("write model file {}", p.display()))?;
        if !args.json {
            std::io::Write::write_all(
                &mut stdout,
                format!("\nmodel file: {}\n", p.display()).as_bytes(),
            )?;
        }
    }
    if let Some(p) = &args.report {
        write_report(
            p,
            &args,
            &data_name,
            &table,
            &id,
            &rows,
            &file,
            workpiece.as_ref(),
            &split,
        )?;
        if !args.json {
            std::io::Write::write_all(
                &mut stdout,
                format!("report: {}\n", p.display()).as_bytes(),
            )?;
        }
    }
    Ok(())
}

/// The HTML report: summary table, data notes, dendrogram, per-target charts and terms,
/// the workpiece shrink, and the model file.
#[allow(clippy::too_many_arguments)]
fn write_report(
    p: &std::path::Path,
    args: &Args,
    data_name: &str,
    table: &Table,
    id: &Identification,
    rows: &[Vec<String>],
    file: &ModelFile,
    workpiece: Option<&(WorkpieceShrink, TargetModel)>,
    split: &Split,
) -> anyhow::Result<()> {
    let mut r = HtmlReport::new(format!("gearcomp fit: {}", args.name));
    r.paragraph(&format!("Data: {data_name}. {}", id.method));
    r.heading("Summary (RMSE in the target unit, µm)");
    r.table(
        &[
            "target",
            "family",
            "chosen sensors",
            "rate τ / s",
            "train",
            "test",
            "cross-validation",
            "plain LS test (all inputs)",
        ],
        rows,
    );
    if !table.issues.is_empty() {
        r.heading("Data notes");
        r.preformatted(
            &table
                .issues
                .iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join("\n"),
        );
    }
    r.heading("Sensor classes (fuzzy equivalence dendrogram, training rows)");
    let first = &id.targets[0];
    let cut = if first.classes.is_empty() {
        None
    } else {
        let merges = &id.dendrogram.merges;
        let k = first.classes.len();
        let done = id.input_names.len().saturating_sub(k);
        merges
            .get(done)
            .map(|m| m.level)
            .or_else(|| merges.last().map(|m| m.level))
    };
    r.raw_svg(&dendrogram_svg(
        &id.dendrogram,
        &id.input_names,
        cut,
        &first.sensors,
    ));
    if cut.is_some() {
        r.paragraph(&format!(
            "Dashed line: the cut giving {} classes for {}; red: its chosen sensors.",
            first.classes.len(),
            first.target
        ));
    } else {
        r.paragraph(&format!("Red: the sensors chosen for {}.", first.target));
    }
    for (j, m) in id.targets.iter().enumerate() {
        r.heading(&m.target);
        if !m.comparison.is_empty() {
            r.paragraph(&format!("Family comparison ({}), validation RMSE on the training rows in µm; the lowest eligible is kept: {}.", id.method, m.family));
            let crow: Vec<Vec<String>> = m
                .comparison
                .iter()
                .map(|c| {
                    vec![
                        c.family.clone(),
                        c.sensors.to_string(),
                        num(c.cv_rmse, 3),
                        c.fold_rmse
                            .iter()
                            .map(|v| num(*v, 3))
                            .collect::<Vec<_>>()
                            .join(", "),
                        c.detail.clone(),
                        if c.kept { "kept".into() } else { String::new() },
                    ]
                })
                .collect();
            r.table(
                &[
                    "family",
                    "sensors",
                    "validation RMSE",
                    "folds",
                    "choice",
                    "",
                ],
                &crow,
            );
        }
        let cls: Vec<String> = m
            .classes
            .iter()
            .map(|c| {
                format!(
                    "{{{}}}",
                    c.iter()
                        .map(|&i| id.input_names[i].as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
            .collect();
        r.paragraph(&format!(
            "Classes: {}. Chosen: {}.",
            cls.join(" "),
            m.sensors
                .iter()
                .map(|&s| id.input_names[s].as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
        let hours: Vec<f64> = table.time_s.iter().map(|t| t / 3600.0).collect();
        let meas = thin(
            hours
                .iter()
                .copied()
                .zip(table.targets[j].iter().copied())
                .collect(),
            2500,
        );
        let pred = thin(
            hours
                .iter()
                .copied()
                .zip(m.predicted.iter().copied())
                .collect(),
            2500,
        );
        let res = thin(
            hours
                .iter()
                .zip(table.targets[j].iter().zip(&m.predicted))
                .map(|(h, (y, p))| (*h, y - p))
                .collect(),
            2500,
        );
        let split_h = match &split {
            Split::TimeBefore(s) => format!(" (train before {:.1} h)", s / 3600.0),
            _ => String::new(),
        };
        r.chart(
            &Chart::new(
                format!("{}: measured vs predicted{split_h}", m.target),
                "time / h",
                "displacement / µm",
            )
            .with(Series::line("measured", meas))
            .with(Series::line("predicted", pred))
            .with(Series::line(
                "95 % interval (upper)",
                thin(
                    hours
                        .iter()
                        .zip(m.predicted.iter().zip(&m.interval_um))
                        .map(|(h, (p, w))| (*h, p + w))
                        .collect(),
                    2500,
                ),
            ))
            .with(Series::line(
                "95 % interval (lower)",
                thin(
                    hours
                        .iter()
                        .zip(m.predicted.iter().zip(&m.interval_um))
                        .map(|(h, (p, w))| (*h, p - w))
                        .collect(),
                    2500,
                ),
            ))
            .with(Series::points(
                "outside the training envelope (extrapolating)",
                thin(
                    hours
                        .iter()
                        .zip(m.predicted.iter().zip(&m.outside))
                        .filter(|(_, (_, &o))| o)
                        .map(|(h, (p, _))| (*h, *p))
                        .collect(),
                    1500,
                ),
            )),
        )?;
        let (n_test, n_out, mean_half) = extrapolation(&id.train, m);
        r.paragraph(&format!(
            "{n_out} of {n_test} test rows are outside the training envelope (a channel outside its training range, or the regressors farther from the training mean than any training row: Mahalanobis bound); they are marked on the chart. 95 % prediction interval: ± {} µm on average.",
            num(mean_half, 3)
        ));
        r.chart(
            &Chart::new(
                format!("{}: residual (measured − predicted)", m.target),
                "time / h",
                "residual / µm",
            )
            .with(Series::line("residual", res)),
        )?;
    }
    if let Some((w, _)) = &workpiece {
        let offs = combined_offsets_um(table, &file.axes[0]).ok();
        r.heading("Workpiece shrink (dry hobbing)");
        r.paragraph(&format!(
            "Ta model intercept {:.6} °C, {} term(s); δT at Ta = Tb + 30 K: {:.4} µm.",
            w.temperature.intercept,
            w.temperature.terms.len(),
            shrink_offset_um(w, w.design_temp_c + 30.0)?
        ));
        if offs.is_none() {
            r.paragraph("The combined offset δM + δT is not drawn: the workpiece model's channels are not all in the main data.");
        }
    }
    r.heading("Model file");
    r.preformatted(&file.to_toml_string()?);
    r.write(p)
        .with_context(|| format!("write report {}", p.display()))?;
    Ok(())
}
