//! `gearcomp dress`: design a profile roller dresser, solve the axis corrections ΔK for a
//! profile modification, and plan a worm's life, from a TOML description (JP6903407B2, worm dressing).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use gearcomp_dressing::campaign::{plan_with_options, Correction, PlanOptions, PlanRow, PlanSpec};
use gearcomp_dressing::dresser::Dresser;
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::report::{
    plan_html, plan_table, DesignSummary, PlanRowDeg, SolveSummary, TopologicalSummary,
};
use gearcomp_dressing::request::{
    check_key, current_worm, min_worn_diameter_mm, solve_request, DresserInput, Method, SolveInput,
    WormInput, DEFAULT_BUDGET_MM,
};
use gearcomp_dressing::topological_request::{solve_topological_request, TopologicalInput};
use gearcomp_dressing::worm::{Flank, Worm};
use gearcomp_report::HtmlReport;
use serde::{Deserialize, Serialize};

/// Options of `gearcomp dress`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    cmd: DressCmd,
}

#[derive(Debug, clap::Subcommand)]
enum DressCmd {
    /// Design the dresser for the new worm and show its geometry.
    Design(Common),
    /// Solve the axis corrections ΔK for the modification in [solve]; a solution whose
    /// opposite-flank cut or jacket depth exceeds [solve] budget_mm (default 0.1 mm) is
    /// refused with the producible range unless [solve] accept_penetration = true.
    Solve(Common),
    /// Plan every dressing of the worm's life from [plan].
    Plan(Common),
}

#[derive(Debug, clap::Args)]
struct Common {
    /// TOML description ([worm], [dresser], and [solve] or [plan]).
    config: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Write an HTML report (profile modification, contact line, ΔK per dressing).
    #[arg(long)]
    report: Option<PathBuf>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Config {
    worm: WormInput,
    dresser: DresserInput,
    solve: Option<SolveCfg>,
    plan: Option<PlanCfg>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SolveCfg {
    #[serde(default = "right")]
    flank: Flank,
    method: Method,
    /// Current worm diameter (default: the new worm).
    diameter_mm: Option<f64>,
    /// Profile crowning c on the worm (µm): targets (0, −c, 0) at 5/50/95 % (3-point).
    crowning_um: Option<f64>,
    /// Explicit targets [fraction of the active profile, f in µm] (3 or 4 of them).
    points: Option<Vec<[f64; 2]>>,
    /// Worm point the contact line must pass through: ν_zS as fifth unknown (eq. (14)/(19)).
    contact_point: Option<ContactPointCfg>,
    /// Topological program over the worm width ([solve.topological], JP6903407B2 eqs. (15)–(17), (22)).
    topological: Option<TopologicalInput>,
    /// Clearance budget for the opposite-flank cut and the jacket depth (mm), as in [plan].
    #[serde(default = "budget")]
    budget_mm: f64,
    /// Output a solution beyond the budget (flagged) instead of refusing it.
    #[serde(default)]
    accept_penetration: bool,
}

/// Worm point (w, b) of the contact line: w as a fraction of the active profile, b in mm.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactPointCfg {
    w_fraction: f64,
    b_mm: f64,
}

fn right() -> Flank {
    Flank::Right
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanCfg {
    #[serde(default = "right")]
    flank: Flank,
    diameters_mm: Vec<f64>,
    #[serde(default = "three_point")]
    correction: Correction,
    #[serde(default)]
    crowning_um: f64,
    #[serde(default = "budget")]
    budget_mm: f64,
    /// Choose each dressing's worm profile angle so the profile stretching is zero (claim 2).
    #[serde(default)]
    zero_stretch: bool,
    /// Half-width of that profile-angle search (degrees).
    #[serde(default = "alpha_search")]
    alpha_search_deg: f64,
}

fn alpha_search() -> f64 {
    10.0
}

fn three_point() -> Correction {
    Correction::ThreePoint
}
fn budget() -> f64 {
    DEFAULT_BUDGET_MM
}

/// Runs `gearcomp dress`.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.cmd {
        DressCmd::Design(c) => run_design(&c),
        DressCmd::Solve(c) => run_solve(&c),
        DressCmd::Plan(c) => run_plan(&c),
    }
}

fn load(path: &Path) -> anyhow::Result<(Config, Worm, Dresser)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let cfg: Config =
        toml::from_str(&text).with_context(|| format!("invalid TOML in {}", path.display()))?;
    // Both build functions name the TOML key and its unit in their errors.
    let worm = cfg.worm.build()?;
    let dresser = cfg.dresser.build(&worm)?;
    Ok((cfg, worm, dresser))
}

fn run_design(c: &Common) -> anyhow::Result<()> {
    let (_, worm, dresser) = load(&c.config)?;
    let out = DesignSummary::new(worm, dresser)?;
    if c.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print!("{}", out.text());
    }
    if let Some(path) = &c.report {
        out.html()?.write(path)?;
    }
    Ok(())
}

fn run_solve(c: &Common) -> anyhow::Result<()> {
    let (cfg, worm, dresser) = load(&c.config)?;
    let Some(sc) = cfg.solve else {
        bail!(
            "{}: a [solve] table is needed for `dress solve`",
            c.config.display()
        );
    };
    let input = SolveInput {
        flank: sc.flank,
        method: sc.method,
        diameter_mm: sc.diameter_mm,
        crowning_um: sc.crowning_um,
        points: sc.points.clone(),
        budget_mm: sc.budget_mm,
        accept_penetration: sc.accept_penetration,
    };
    // The worm diameter is checked first, before the other [solve] keys.
    let worm_now = current_worm(&worm, sc.diameter_mm)?;
    if let Some(tc) = &sc.topological {
        let setup = DressingSetup::new(worm_now, dresser);
        let o = solve_topological_request(&input, tc, sc.contact_point.is_some(), &worm, &setup)?;
        let out = TopologicalSummary::new(&o, sc.method, tc.b_range_mm, &setup)?;
        return print_and_report(c, &out, out.text(), || out.html());
    }
    let outcome = solve_request(&worm, &dresser, &input)?;
    let point = sc.contact_point.as_ref().map(|p| (p.w_fraction, p.b_mm));
    let out = SolveSummary::new(&outcome, sc.method, sc.flank, point)?;
    print_and_report(c, &out, out.text(), || out.html())
}

/// Prints `out` as JSON (`--json`) or `text`, and writes the report of `--report`.
fn print_and_report<T: Serialize>(
    c: &Common,
    out: &T,
    text: String,
    html: impl FnOnce() -> gearcomp_report::Result<HtmlReport>,
) -> anyhow::Result<()> {
    if c.json {
        println!("{}", serde_json::to_string_pretty(out)?);
    } else {
        print!("{text}");
    }
    if let Some(path) = &c.report {
        html()?.write(path)?;
    }
    Ok(())
}

fn run_plan(c: &Common) -> anyhow::Result<()> {
    let (cfg, worm, dresser) = load(&c.config)?;
    let Some(pc) = cfg.plan else {
        bail!(
            "{}: a [plan] table is needed for `dress plan`",
            c.config.display()
        );
    };
    let (spec, options) = plan_spec(pc, &worm)?;
    let rows: Vec<PlanRow> = plan_with_options(&worm, &dresser, &spec, &options)?;
    let json: Vec<PlanRowDeg<'_>> = rows.iter().map(PlanRowDeg::new).collect();
    print_and_report(c, &json, plan_table(&rows), || plan_html(&rows))
}

/// The `[plan]` table checked key by key (units and ranges in the messages), as the plan's
/// specification and options.
fn plan_spec(pc: PlanCfg, worm: &Worm) -> anyhow::Result<(PlanSpec, PlanOptions)> {
    check_key("[plan] crowning_um", pc.crowning_um, -50.0, 50.0, "µm")?;
    check_key("[plan] budget_mm", pc.budget_mm, 0.0, 5.0, "mm")?;
    if pc.diameters_mm.is_empty() || pc.diameters_mm.len() > 1000 {
        bail!(
            "[plan] diameters_mm: has {} diameters, allowed 1 ..= 1000 (mm)",
            pc.diameters_mm.len()
        );
    }
    let d_lo = (min_worn_diameter_mm(worm) * 1e4).ceil() / 1e4;
    for (i, d) in pc.diameters_mm.iter().enumerate() {
        check_key(
            &format!("[plan] diameters_mm[{i}]"),
            *d,
            d_lo,
            worm.d_s0_mm,
            "mm",
        )?;
    }
    let spec = PlanSpec {
        flank: pc.flank,
        diameters_mm: pc.diameters_mm,
        correction: pc.correction,
        crowning_mm: pc.crowning_um * 1e-3,
        budget_mm: pc.budget_mm,
    };
    if !pc.alpha_search_deg.is_finite() || !(0.01..=20.0).contains(&pc.alpha_search_deg) {
        bail!(
            "[plan] alpha_search_deg = {} is outside the allowed range 0.01 ..= 20",
            pc.alpha_search_deg
        );
    }
    let options = PlanOptions {
        zero_stretch: pc.zero_stretch,
        alpha_search_rad: pc.alpha_search_deg.to_radians(),
    };
    Ok((spec, options))
}
