//! `gearcomp fit`: thermal model identification from measured data (issue 4, seed 003).
//!
//! Data in (CSV; the embedded FL_THERMAL test by default), model file and report out.

use std::path::PathBuf;

use anyhow::Context as _;
use gearcomp_core::model::{
    AxisModel, ModelFile, Provenance, ReferenceRadius, ShrinkGear, ShrinkMethod, MODEL_FORMAT,
};
use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::dendrogram::dendrogram_svg;
use gearcomp_identify::identify::{
    identify, plain_least_squares, Grouping, IdentifyOptions, ModelKind, RepresentativeBy, Split,
};
use gearcomp_identify::workpiece::{combined_offsets_um, shrink_offset_um, workpiece_shrink};
use gearcomp_report::{Chart, HtmlReport, Series};

/// Model kind (`--model`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum ModelArg {
    /// Value + filtered rate per sensor; sensors, τ and class count by cross-validation.
    Dynamic,
    /// Seed 003 as written: every class representative, current values, least squares.
    Static,
    /// As static, fitted by ridge regression (α by cross-validation).
    Ridge,
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
    /// CSV log with a header row: time column (s), temperature columns, target columns.
    /// Default: the embedded FL_THERMAL data set.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Target columns (names or glob patterns such as "ch*_um"), e.g. measured drift in µm.
    #[arg(long, num_args = 1.., default_value = "*_um")]
    pub target: Vec<String>,
    /// Input (temperature) columns: names or glob patterns. Default: every "*_c" column.
    #[arg(long, num_args = 1.., default_value = "*_c")]
    pub inputs: Vec<String>,
    /// Name of the time column (seconds, strictly increasing).
    #[arg(long, default_value = "time_s")]
    pub time_column: String,
    /// Column holding a run number: enables k-fold by run and --test-runs.
    #[arg(long)]
    pub run_column: Option<String>,
    /// Train on rows with time < this many hours; test on the rest.
    #[arg(long, default_value_t = 24.0, conflicts_with_all = ["test_runs", "no_test"])]
    pub train_before_h: f64,
    /// Test on these run numbers (comma separated), train on the other runs.
    #[arg(long, value_delimiter = ',', requires = "run_column")]
    pub test_runs: Vec<f64>,
    /// Train on all rows (no test error is reported).
    #[arg(long)]
    pub no_test: bool,
    /// Model kind.
    #[arg(long, value_enum, default_value = "dynamic")]
    pub model: ModelArg,
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
    /// Largest number of sensors per target (dynamic model).
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

fn load(path: &Option<PathBuf>, sel: &Selection, skip: bool) -> anyhow::Result<(Table, String)> {
    let opts = ReadOptions {
        skip_bad_rows: skip,
        ..ReadOptions::default()
    };
    let (text, name) = match path {
        Some(p) => (
            std::fs::read_to_string(p).with_context(|| format!("read {}", p.display()))?,
            p.display().to_string(),
        ),
        None => (
            gearcomp_datasets::fl_thermal_csv()
                .context("decompress the embedded FL_THERMAL data")?,
            "FL_THERMAL (embedded)".to_string(),
        ),
    };
    Ok((read_csv(&text, &name, sel, opts)?, name))
}

fn thin(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    let step = points.len().div_ceil(max.max(1)).max(1);
    points.into_iter().step_by(step).collect()
}

/// Runs `gearcomp fit`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sel = Selection {
        time: args.time_column.clone(),
        inputs: args.inputs.clone(),
        targets: args.target.clone(),
        run: args.run_column.clone(),
    };
    let (table, data_name) = load(&args.data, &sel, args.skip_bad_rows)?;
    let split = if args.no_test {
        Split::None
    } else if !args.test_runs.is_empty() {
        Split::TestRuns(args.test_runs.clone())
    } else {
        if !(args.train_before_h.is_finite() && args.train_before_h > 0.0) {
            anyhow::bail!(
                "invalid --train-before-h = {}: expected hours > 0",
                args.train_before_h
            );
        }
        Split::TimeBefore(args.train_before_h * 3600.0)
    };
    let opts = IdentifyOptions {
        model: match args.model {
            ModelArg::Dynamic => ModelKind::Dynamic,
            ModelArg::Static => ModelKind::Static,
            ModelArg::Ridge => ModelKind::Ridge,
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
    };
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

    // Workpiece shrink model (seed 003 eqs. (3)–(8)), attached to the first axis.
    let mut workpiece = None;
    if let Some(path) = &args.workpiece_data {
        let wsel = Selection {
            time: args.time_column.clone(),
            inputs: args.inputs.clone(),
            targets: vec![args.workpiece_target.clone().unwrap_or_default()],
            run: None,
        };
        let (wt, _) = load(&Some(path.clone()), &wsel, args.skip_bad_rows)?;
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
        workpiece = Some((w, wid.targets[0].clone()));
    }

    let axes: Vec<AxisModel> = id
        .targets
        .iter()
        .enumerate()
        .map(|(j, m)| AxisModel {
            axis: args
                .axis
                .get(j)
                .cloned()
                .unwrap_or_else(|| m.target.clone()),
            target: m.target.clone(),
            machine: m.model.clone(),
            workpiece: if j == 0 {
                workpiece.as_ref().map(|w| w.0.clone())
            } else {
                None
            },
        })
        .collect();
    let file = ModelFile {
        format: MODEL_FORMAT.into(),
        name: args.name.clone(),
        description: format!("identified from {data_name} ({} rows)", table.time_s.len()),
        axes,
        provenance: Some(Provenance {
            data: data_name.clone(),
            created_by: format!("gearcomp fit {}", env!("CARGO_PKG_VERSION")),
            method: id.method.clone(),
            train_rmse_um: id.targets.iter().map(|m| m.train_rmse).collect(),
            test_rmse_um: id
                .targets
                .iter()
                .map(|m| m.test_rmse.unwrap_or(f64::NAN))
                .filter(|v| v.is_finite())
                .collect(),
        }),
    };
    file.validate()?;

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
    for i in table.issues.iter().take(20) {
        let _ = writeln!(out, "  note: {i}");
    }
    if table.issues.len() > 20 {
        let _ = writeln!(out, "  note: … {} more", table.issues.len() - 20);
    }
    let _ = writeln!(out, "method: {}", id.method);
    let mut rows = Vec::new();
    for (m, b) in id.targets.iter().zip(&base) {
        let sensors: Vec<&str> = m
            .sensors
            .iter()
            .map(|&s| table.input_names[s].as_str())
            .collect();
        let _ = writeln!(
            out,
            "\n{}: {} classes, {} sensor(s): {}{}{}",
            m.target,
            m.classes.len(),
            sensors.len(),
            sensors.join(", "),
            m.tau_s
                .map_or(String::new(), |t| format!("; rate τ = {t} s")),
            m.ridge_alpha
                .map_or(String::new(), |a| format!("; ridge α = {a}"))
        );
        let fmt_opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let _ = writeln!(
            out,
            "  RMSE µm: train {:.3}, test {}, cross-validation {:.3} (folds: {}); R² = {:.4}",
            m.train_rmse,
            fmt_opt(m.test_rmse),
            m.cv_rmse,
            m.fold_rmse
                .iter()
                .map(|v| format!("{v:.3}"))
                .collect::<Vec<_>>()
                .join(", "),
            m.fit.r2
        );
        let _ = writeln!(
            out,
            "  plain least squares on all {} inputs: train {:.3}, test {} µm",
            table.inputs.len(),
            b.0,
            fmt_opt(b.1)
        );
        let _ = writeln!(
            out,
            "  {:<34} {:>16} {:>14}",
            "term", "coefficient", "std. error"
        );
        let _ = writeln!(
            out,
            "  {:<34} {:>16.6} {:>14.6}",
            "intercept",
            m.fit.coefficients[0],
            m.fit.std_errors.first().copied().unwrap_or(f64::NAN)
        );
        for (k, name) in m.regressors.iter().enumerate() {
            let _ = writeln!(
                out,
                "  {:<34} {:>16.6e} {:>14.4e}",
                name,
                m.fit.coefficients[k + 1],
                m.fit.std_errors.get(k + 1).copied().unwrap_or(f64::NAN)
            );
        }
        rows.push(vec![
            m.target.clone(),
            sensors.join(" "),
            m.tau_s.map_or("-".into(), |t| format!("{t}")),
            format!("{:.3}", m.train_rmse),
            fmt_opt(m.test_rmse),
            format!("{:.3}", m.cv_rmse),
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
    {
        use std::io::Write as _;
        stdout.write_all(out.as_bytes())?;
    }

    if let Some(p) = &args.out {
        file.save(p)
            .with_context(|| format!("write model file {}", p.display()))?;
        std::io::Write::write_all(
            &mut stdout,
            format!("\nmodel file: {}\n", p.display()).as_bytes(),
        )?;
    }
    if let Some(p) = &args.report {
        let mut r = HtmlReport::new(format!("gearcomp fit: {}", args.name));
        r.paragraph(&format!("Data: {data_name}. {}", id.method));
        r.heading("Summary (RMSE in the target unit, µm)");
        r.table(
            &[
                "target",
                "chosen sensors",
                "rate τ / s",
                "train",
                "test",
                "cross-validation",
                "plain LS test (all inputs)",
            ],
            &rows,
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
        let cut = {
            let merges = &id.dendrogram.merges;
            let k = first.classes.len();
            let done = table.inputs.len().saturating_sub(k);
            merges
                .get(done)
                .map(|m| m.level)
                .or_else(|| merges.last().map(|m| m.level))
        };
        r.raw_svg(&dendrogram_svg(
            &id.dendrogram,
            &table.input_names,
            cut,
            &first.sensors,
        ));
        r.paragraph(&format!(
            "Dashed line: the cut giving {} classes for {}; red: its chosen sensors.",
            first.classes.len(),
            first.target
        ));
        for (j, m) in id.targets.iter().enumerate() {
            r.heading(&m.target);
            let cls: Vec<String> = m
                .classes
                .iter()
                .map(|c| {
                    format!(
                        "{{{}}}",
                        c.iter()
                            .map(|&i| table.input_names[i].as_str())
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
                    .map(|&s| table.input_names[s].as_str())
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
                .with(Series::line("predicted", pred)),
            )?;
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
            let offs = combined_offsets_um(&table, &file.axes[0]).ok();
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
        std::io::Write::write_all(&mut stdout, format!("report: {}\n", p.display()).as_bytes())?;
    }
    Ok(())
}
