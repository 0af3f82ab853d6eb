//! `gearcomp fit`: thermal model identification from measured data (issue 4, CN105397560).
//!
//! Data in (CSV; the embedded FL_THERMAL test by default), model file and report out.

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use gearcomp_core::model::{ReferenceRadius, ShrinkGear, ShrinkMethod, WorkpieceShrink};
use gearcomp_identify::data::{read_runs, MissingCells, ReadOptions, Selection, Table};
use gearcomp_identify::dialect::parse_delimiter;
use gearcomp_identify::report::FitReport;
use gearcomp_identify::select::Family;
use gearcomp_identify::spreadsheet::{is_workbook, read_paths_with_targets, SheetChoice};
use gearcomp_identify::target_unit::{LengthUnit, TargetUnit};
use gearcomp_identify::time_unit::{TimeUnit, TimeUnitChoice};
use gearcomp_identify::workpiece::workpiece_shrink;
use gearcomp_identify::{
    identify, pipeline::identify_with_floor, Grouping, IdentifyOptions, ModelKind, Origin,
    RepresentativeBy, Split, TargetModel,
};

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
    /// CN105397560's class representatives, least squares or ridge (class count and α by
    /// validation, within the sensor cap).
    Classes,
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
            FamilyArg::Classes => Family::Classes,
            FamilyArg::Differences => Family::Differences,
            FamilyArg::Delay => Family::Delay,
            FamilyArg::LeadLag => Family::LeadLag,
            FamilyArg::Tf1 => Family::Tf1,
            FamilyArg::Tf2 => Family::Tf2,
        }
    }
}

/// The unit of the target columns (`--target-unit`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum TargetUnitArg {
    /// From the log's units row under the header, else the column name (z_mm, Weg [mm]),
    /// else µm.
    Auto,
    /// Micrometres.
    Um,
    /// Millimetres.
    Mm,
    /// Nanometres.
    Nm,
    /// Metres.
    M,
    /// Inches.
    Inch,
}

/// The unit of a numeric time column (`--time-unit`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum TimeUnitArg {
    /// From the log's units row under the header, else the column name (time_min,
    /// Zeit [h]), else seconds.
    Auto,
    /// Seconds.
    S,
    /// Milliseconds.
    Ms,
    /// Minutes.
    Min,
    /// Hours.
    H,
}

/// The order of day and month in slash dates (`--date-order`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum DateOrderArg {
    /// From each file's dates: its first date with a number above 12 says which is the day
    /// for every row; a file whose dates all read either way (03/01/2026) is refused.
    Auto,
    /// Day first: 25/11/2026 (most of Europe).
    Dmy,
    /// Month first: 11/25/2026 (the United States).
    Mdy,
}

impl DateOrderArg {
    fn order(self) -> Option<gearcomp_identify::dialect::DateOrder> {
        use gearcomp_identify::dialect::DateOrder;
        match self {
            DateOrderArg::Auto => None,
            DateOrderArg::Dmy => Some(DateOrder::DayFirst),
            DateOrderArg::Mdy => Some(DateOrder::MonthFirst),
        }
    }
}

impl From<TimeUnitArg> for TimeUnitChoice {
    fn from(u: TimeUnitArg) -> Self {
        match u {
            TimeUnitArg::Auto => TimeUnitChoice::Auto,
            TimeUnitArg::S => TimeUnitChoice::Given(TimeUnit::S),
            TimeUnitArg::Ms => TimeUnitChoice::Given(TimeUnit::Ms),
            TimeUnitArg::Min => TimeUnitChoice::Given(TimeUnit::Min),
            TimeUnitArg::H => TimeUnitChoice::Given(TimeUnit::H),
        }
    }
}

impl From<TargetUnitArg> for TargetUnit {
    fn from(u: TargetUnitArg) -> Self {
        match u {
            TargetUnitArg::Auto => TargetUnit::Auto,
            TargetUnitArg::Um => TargetUnit::Given(LengthUnit::Um),
            TargetUnitArg::Mm => TargetUnit::Given(LengthUnit::Mm),
            TargetUnitArg::Nm => TargetUnit::Given(LengthUnit::Nm),
            TargetUnitArg::M => TargetUnit::Given(LengthUnit::M),
            TargetUnitArg::Inch => TargetUnit::Given(LengthUnit::Inch),
        }
    }
}

/// Rows with an empty or NaN cell in a used input column (`--missing`); an empty target cell
/// is a row without a measurement, read in either case.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum MissingArg {
    /// Such a row is a bad row: the fit stops (or drops it with --skip-bad-rows).
    Error,
    /// Such a row is left out and listed, and the run is split there (filters restart).
    Split,
    /// The cell holds the input's last value in its run (channels logged at different
    /// rates); rows before an input's first value in a run are left out and listed.
    Hold,
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
    /// CSV log(s) with a header row: time column (s), temperature columns, target columns;
    /// or workbooks (.xlsx .xlsm .xlsb .xls .ods), read as the same values written as CSV.
    /// Several files are several runs (one per file, named after the file).
    /// Default: the embedded FL_THERMAL data set.
    #[arg(long, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// Workbook sheet(s) to read, by name or 1-based number; several are several runs, each
    /// named after its sheet. Default: the workbook's only sheet with data.
    #[arg(long, num_args = 1..)]
    pub sheet: Vec<String>,
    /// Every sheet with data of each workbook (or every --sheet) is a run named after it.
    #[arg(long)]
    pub sheets_as_runs: bool,
    /// The first row is data, not a header (CSV and workbooks): columns are named c1 … cN
    /// by position (column A = c1), e.g. --time-column c1 --inputs 'c*' --target c23
    /// (the time and target columns are never inputs).
    #[arg(long)]
    pub no_header: bool,
    /// Workbook(s) holding the target columns of the --data workbooks, one per --data file,
    /// row for row (each sheet's target sheet: the one of the same name, else the one at
    /// the same place).
    #[arg(long, num_args = 1.., requires = "data")]
    pub target_data: Vec<PathBuf>,
    /// The log has no time column: rows are this many seconds apart (restarting per run).
    #[arg(long)]
    pub sample_interval_s: Option<f64>,
    /// Target columns (names or glob patterns such as "ch*_um"), e.g. measured drift in µm.
    /// When the default "*_um" matches none, the columns whose unit (in brackets or in the
    /// units row) is µm or nm, with a note.
    #[arg(long, num_args = 1.., default_value = "*_um")]
    pub target: Vec<String>,
    /// Input (temperature) columns: names or glob patterns. Default: every "*_c" column;
    /// when it matches none, the columns whose unit (in brackets or in the units row) is °C
    /// or K, with a note.
    #[arg(long, num_args = 1.., default_value = "*_c")]
    pub inputs: Vec<String>,
    /// Name of the time column: seconds (or another unit, see --time-unit), or time stamps
    /// (ISO 8601 or dd.mm.yyyy hh:mm:ss),
    /// increasing within each run; DATE+TIME names a date and a time-of-day column.
    #[arg(long, default_value = "time_s")]
    pub time_column: String,
    /// Column naming the run of each row (time restarts in each run): validation by
    /// leave-one-run-out and --test-runs.
    #[arg(long)]
    pub run_column: Option<String>,
    /// Every stretch between time gaps is a run of its own (e.g. the days of a production
    /// log whose nights are gaps): runs are named 1 … N in time order (a --run-column run
    /// cut by gaps: NAME/1 … NAME/k), validated leave-one-run-out, named in --test-runs.
    #[arg(long)]
    pub runs_at_gaps: bool,
    /// A numeric time that falls starts a new run instead of a bad row (several runs logged
    /// one after the other in one file, the time restarting in each, without a run column):
    /// runs 1 … N in file order (in a --run-column run NAME: NAME, NAME/2 …; in a file of
    /// several: FILE, FILE/2 …), validated leave-one-run-out, named in --test-runs.
    #[arg(long)]
    pub runs_at_restarts: bool,
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
    /// Fit on bin means over this many seconds (within each run segment, never across the
    /// train/test split). Default: none, unless the dynamic families' search would exceed
    /// its budget on every row of a long high-rate log; then the shortest step that fits,
    /// up to a tenth of the shortest --tau-s / --delay-s, with a note.
    #[arg(long)]
    pub resample_s: Option<f64>,
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
    /// Cross-validation folds (2 … 100): runs (with --run-column) or contiguous time blocks.
    #[arg(long, default_value_t = 3)]
    pub folds: usize,
    /// Candidate ridge α values (ridge model).
    #[arg(long, value_delimiter = ',', default_value = "0.0001,0.001,0.01,0.1")]
    pub ridge_alpha: Vec<f64>,
    /// Drop bad rows (they are still listed) instead of stopping at them.
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Field delimiter of the CSV log(s): "," ";" or "tab". Default: detected from the header.
    #[arg(long)]
    pub delimiter: Option<String>,
    /// Numbers use a decimal comma (20,125). Default: detected on the data of ';' or tab logs.
    #[arg(long)]
    pub decimal_comma: bool,
    /// Rows with an empty or NaN cell in a used input column (sensor dropouts). An empty or
    /// NaN target cell is a row without a measurement (a probe every few minutes): kept, it
    /// drives the filters and lags but is neither fitted nor scored.
    #[arg(long, value_enum, default_value = "error")]
    pub missing: MissingArg,
    /// Values a data logger writes for a missing sample, numbers (e.g. -9999 32767) or texts
    /// (e.g. "#N/A" OVF; write --missing-code=--- for a text that starts with a dash), read
    /// as empty cells: an input's then follow --missing, a target's are rows without a
    /// measurement. Without it, a common code far outside its column's other values is
    /// refused, and so is a text.
    #[arg(long, num_args = 1.., allow_negative_numbers = true)]
    pub missing_code: Vec<String>,
    /// Fit values that stand far apart from their column's others as written. Without it, a
    /// few values (at most 1 % of a column) separated from all the others by a gap of more
    /// than 15 times their span are refused as a sensor fault (an open Pt100 at 850 °C, an
    /// overflow written as 3276.7, a probe off its surface).
    #[arg(long)]
    pub keep_far_values: bool,
    /// Unit of the target columns; the model's offsets are µm, so another unit is converted
    /// on reading, with a note. auto: the log's units row, else the column name (z_mm,
    /// Weg [mm]), else µm; a units-row cell that is no length unit is refused.
    #[arg(long, value_enum, default_value = "auto")]
    pub target_unit: TargetUnitArg,
    /// Unit of a numeric time column; every time constant, delay and split is in seconds,
    /// so another unit is converted on reading, with a note. auto: the log's units row, else
    /// the column name (time_min, Zeit [h]), else s; a units-row cell that is no time unit is
    /// refused. Time stamps (dates and times of day) have no unit.
    #[arg(long, value_enum, default_value = "auto")]
    pub time_unit: TimeUnitArg,
    /// Order of day and month in slash-date time stamps (03/01/2026 08:00:00 [AM|PM]).
    #[arg(long, value_enum, default_value = "auto")]
    pub date_order: DateOrderArg,
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

/// The reading options of the command line.
fn read_options(args: &Args) -> anyhow::Result<ReadOptions> {
    Ok(ReadOptions {
        skip_bad_rows: args.skip_bad_rows,
        sample_interval_s: args.sample_interval_s,
        delimiter: args.delimiter.as_deref().map(parse_delimiter).transpose()?,
        decimal_comma: args.decimal_comma.then_some(true),
        missing: match args.missing {
            MissingArg::Error => MissingCells::Error,
            MissingArg::Split => MissingCells::Split,
            MissingArg::Hold => MissingCells::Hold,
        },
        no_header: args.no_header,
        target_unit: Some(args.target_unit.into()),
        time_unit: Some(args.time_unit.into()),
        missing_codes: gearcomp_identify::missing_code::MissingCodes::parse(&args.missing_code)?,
        runs_at_restarts: args.runs_at_restarts,
        keep_far_values: args.keep_far_values,
        date_order: args.date_order.order(),
        ..ReadOptions::default()
    })
}

fn load(
    paths: &[PathBuf],
    sel: &Selection,
    opts: ReadOptions,
    sheets: &SheetChoice,
    targets: &[PathBuf],
) -> anyhow::Result<(Table, String)> {
    let books = paths.iter().any(|p| is_workbook(p));
    if books || !sheets.sheets.is_empty() || sheets.all || !targets.is_empty() {
        let name = paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ");
        let table = read_paths_with_targets(paths, targets, sel, opts, sheets)?;
        return Ok((table, name));
    }
    if paths.is_empty() {
        // The embedded text (no decompression at run time: gearcomp-datasets).
        let name = "FL_THERMAL (embedded)";
        let text = gearcomp_datasets::fl_thermal_csv();
        return Ok((read_runs(&[(text, name)], sel, opts)?, name.to_string()));
    }
    if let Some(read) = read_streamed(paths, sel, opts) {
        return read;
    }
    let name = paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let table = gearcomp_identify::encoding::read_log_files(paths, sel, opts)?;
    Ok((table, name))
}

/// One plain log, read in chunks and parsed as it comes when it is clean (no copy of the
/// whole text in memory); None for anything else, which `load` reads as text, as before.
fn read_streamed(
    paths: &[PathBuf],
    sel: &Selection,
    opts: ReadOptions,
) -> Option<anyhow::Result<(Table, String)>> {
    let [p] = paths else {
        return None;
    };
    let name = p.display().to_string();
    let table = gearcomp_identify::data::read_csv_file(p, &name, sel, opts)?;
    Some(table.map(|t| (t, name)).map_err(Into::into))
}

/// `--runs-at-gaps` (every stretch between time gaps made a run) and the train/test split,
/// with the notes saying what was chosen.
fn runs_and_split(args: &Args, table: &mut Table) -> anyhow::Result<(Split, Option<String>)> {
    let gap_note = args.runs_at_gaps.then(|| {
        let before = table.run_count();
        let n = table.make_segments_runs();
        if n > before {
            format!("--runs-at-gaps: {n} runs between the time gaps")
        } else {
            "--runs-at-gaps: no time gap cuts a run; the runs are as read".to_string()
        }
    });
    let (split, split_note) = split_of(args, table)?;
    let note = match (gap_note, split_note) {
        (Some(g), Some(s)) => Some(format!("{g}; {s}")),
        (g, s) => g.or(s),
    };
    Ok((split, note))
}

/// `--resample-s`, or the default's step for a log too long to search at its own rate
/// (`gearcomp_identify::resample`): the table of bin means and the note saying so (after
/// `note`, the split's).
fn resample(
    args: &Args,
    table: Table,
    split: &Split,
    opts: &IdentifyOptions,
    note: Option<String>,
) -> anyhow::Result<(Table, Option<String>)> {
    match gearcomp_identify::resample::for_fit(&table, split, opts, args.resample_s)? {
        None => Ok((table, note)),
        Some((r, this)) => Ok((
            r,
            Some(note.map_or(this.clone(), |n| format!("{n}; {this}"))),
        )),
    }
}

/// The train/test split the options ask for, and a note when it was chosen by default.
fn split_of(args: &Args, table: &Table) -> anyhow::Result<(Split, Option<String>)> {
    Ok(if args.no_test {
        (Split::None, None)
    } else if !args.test_runs.is_empty() {
        (Split::TestRuns(args.test_runs.clone()), None)
    } else if let Some(h) = args.train_before_h {
        if !(h.is_finite() && h > 0.0) {
            anyhow::bail!("invalid --train-before-h = {h}: expected hours > 0");
        }
        (Split::TimeBefore(h * 3600.0), None)
    } else {
        gearcomp_identify::pipeline::default_split(table)
    })
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
        // The workpiece target is a temperature, read as written.
        ReadOptions {
            target_unit: None,
            ..read_options(args)?
        },
        &SheetChoice::default(),
        &[],
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

/// The model file's name chooses its format: refused before the fit, not after it.
fn check_out(args: &Args) -> anyhow::Result<()> {
    if let Some(p) = &args.out {
        gearcomp_core::model::ModelFile::check_path(p).context("--out")?;
    }
    Ok(())
}

/// Runs `gearcomp fit`: read, identify, write the model file, the summary and the report.
pub fn run(args: Args) -> anyhow::Result<()> {
    check_out(&args)?;
    let sel = Selection {
        time: args.time_column.clone(),
        inputs: args.inputs.clone(),
        targets: args.target.clone(),
        run: args.run_column.clone(),
    };
    let sheets = SheetChoice {
        sheets: args.sheet.clone(),
        all: args.sheets_as_runs,
    };
    let (mut table, data_name) = load(
        &args.data,
        &sel,
        read_options(&args)?,
        &sheets,
        &args.target_data,
    )?;
    let (split, split_note) = runs_and_split(&args, &mut table)?;
    let opts = options(&args, &split);
    opts.check()?;
    let (table, split_note) = resample(&args, table, &split, &opts, split_note)?;
    let (id, base) = identify_with_floor(&table, &opts)?;
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
        restart_after_s: table.gap_after_s,
    };
    let file = id.to_model_file(&origin, &args.axis, workpiece.as_ref().map(|w| w.0.clone()))?;

    let fit = FitReport {
        data_name: &data_name,
        table: &table,
        id: &id,
        plain_ls: &base,
        split: &split,
        split_note: split_note.as_deref(),
        file: &file,
        workpiece: workpiece.as_ref().map(|(w, m)| (w, m)),
    };
    output(&args, &fit)
}

/// Prints the summary (or the JSON document) and writes the model file and the report.
fn output(args: &Args, fit: &FitReport) -> anyhow::Result<()> {
    let summary = fit.summary_text()?;
    let mut stdout = std::io::stdout().lock();
    if args.json {
        let mut text = serde_json::to_string_pretty(&fit.to_json()?)?;
        text.push('\n');
        stdout.write_all(text.as_bytes())?;
    } else {
        stdout.write_all(summary.as_bytes())?;
    }
    if let Some(p) = &args.out {
        fit.file
            .save(p)
            .with_context(|| format!("write model file {}", p.display()))?;
        if !args.json {
            writeln!(stdout, "\nmodel file: {}", p.display())?;
        }
    }
    if let Some(p) = &args.report {
        fit.html_report(&args.name)?
            .write(p)
            .with_context(|| format!("write report {}", p.display()))?;
        if !args.json {
            writeln!(stdout, "report: {}", p.display())?;
        }
    }
    Ok(())
}
