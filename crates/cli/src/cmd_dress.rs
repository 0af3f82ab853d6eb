//! `gearcomp dress`: design a profile roller dresser, solve the axis corrections ΔK for a
//! profile modification, and plan a worm's life, from a TOML description (JP6903407B2, worm dressing).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use gearcomp_dressing::campaign::{plan_with_options, PlanRow};
use gearcomp_dressing::config::DressConfig;
use gearcomp_dressing::dresser::Dresser;
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::report::{
    plan_html, plan_table, DesignSummary, PlanRowDeg, SolveSummary, TopologicalSummary,
};
use gearcomp_dressing::request::{current_worm, solve_request};
use gearcomp_dressing::topological_request::solve_topological_request;
use gearcomp_dressing::worm::Worm;
use gearcomp_report::HtmlReport;
use serde::Serialize;

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

/// Runs `gearcomp dress`.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.cmd {
        DressCmd::Design(c) => run_design(&c),
        DressCmd::Solve(c) => run_solve(&c),
        DressCmd::Plan(c) => run_plan(&c),
    }
}

fn load(path: &Path) -> anyhow::Result<(DressConfig, Worm, Dresser)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let cfg = DressConfig::from_toml_str(&text)
        .with_context(|| format!("invalid TOML in {}", path.display()))?;
    // The build names the TOML key and its unit in its errors.
    let (worm, dresser) = cfg.build()?;
    Ok((cfg, worm, dresser))
}

fn run_design(c: &Common) -> anyhow::Result<()> {
    let (_, worm, dresser) = load(&c.config)?;
    let out = DesignSummary::new(worm, dresser)?;
    print_and_report(c, &out, out.text(), || out.html())
}

fn run_solve(c: &Common) -> anyhow::Result<()> {
    let (cfg, worm, dresser) = load(&c.config)?;
    let Some(sc) = cfg.solve else {
        bail!(
            "{}: a [solve] table is needed for `dress solve`",
            c.config.display()
        );
    };
    let input = sc.input();
    // The worm diameter is checked first, before the other [solve] keys.
    let worm_now = current_worm(&worm, sc.diameter_mm)?;
    if let Some(tc) = &sc.topological {
        let setup = DressingSetup::new(worm_now, dresser);
        let o = solve_topological_request(&input, tc, sc.contact_point.is_some(), &worm, &setup)?;
        let out = TopologicalSummary::new(&o, sc.method, tc.b_range_mm, &setup)?;
        return print_and_report(c, &out, out.text(), || out.html());
    }
    let outcome = solve_request(&worm, &dresser, &input)?;
    let out = SolveSummary::new(&outcome, sc.method, sc.flank, sc.contact_point())?;
    print_and_report(c, &out, out.text(), || out.html())
}

/// Writes the report of `--report` first (so nothing is printed when it cannot be written,
/// as in `gearcomp grind`), then prints `out` as JSON (`--json`) or `text`.
fn print_and_report<T: Serialize>(
    c: &Common,
    out: &T,
    text: String,
    html: impl FnOnce() -> gearcomp_report::Result<HtmlReport>,
) -> anyhow::Result<()> {
    if let Some(path) = &c.report {
        html()
            .and_then(|r| r.write(path))
            .with_context(|| format!("writing report {}", path.display()))?;
    }
    let printed = if c.json {
        serde_json::to_string_pretty(out)? + "\n"
    } else {
        text
    };
    print!("{printed}");
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
    let (spec, options) = pc.spec(&worm)?;
    let rows: Vec<PlanRow> = plan_with_options(&worm, &dresser, &spec, &options)?;
    let json: Vec<PlanRowDeg<'_>> = rows.iter().map(PlanRowDeg::new).collect();
    print_and_report(c, &json, plan_table(&rows), || plan_html(&rows))
}
