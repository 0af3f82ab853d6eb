//! `gearcomp dress`: design a profile roller dresser, solve the axis corrections ΔK for a
//! profile modification, and plan a worm's life, from a TOML description (JP6903407B2, worm dressing).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use gearcomp_dressing::campaign::{plan_with_options, Correction, PlanOptions, PlanRow, PlanSpec};
use gearcomp_dressing::dresser::Dresser;
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::request::{
    check_key, current_worm, min_worn_diameter_mm, solve_request, DresserInput, Method, SolveInput,
    WormInput, DEFAULT_BUDGET_MM,
};
use gearcomp_dressing::simulation::{contact_line, fit_contact_line};
use gearcomp_dressing::solve::axial_position_for_contact_point;
use gearcomp_dressing::topological_request::{solve_topological_request, TopologicalInput};
use gearcomp_dressing::topology::CorrectionSchedule;
use gearcomp_dressing::worm::{Flank, Worm};
use gearcomp_report::{Chart, HtmlReport, Series};
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

#[derive(Debug, Serialize)]
struct DesignOut {
    base_radius_mm: f64,
    base_helix_angle_deg: f64,
    lead_mm: f64,
    tip_radius_mm: f64,
    root_radius_mm: f64,
    nominal_centre_distance_mm: f64,
    nominal_crossing_angle_deg: f64,
    fillet_radius_mm: f64,
    active_profile_mm: (f64, f64),
    tip_dresser_radius_mm: f64,
    contact_line_direction_deg: f64,
    /// Dresser axial profile (z_A mm, R_A mm).
    profile: Vec<(f64, f64)>,
}

fn run_design(c: &Common) -> anyhow::Result<()> {
    let (_, worm, dresser) = load(&c.config)?;
    let setup = DressingSetup::new(worm, dresser);
    let fl = Flank::Right;
    let (w_nf, w_na) = setup.active_profile(fl)?;
    let k0 = AxisCorrection::default();
    let side = setup.dresser.side(fl);
    let u_end = setup.dresser.u_max();
    let profile: Vec<(f64, f64)> = (0..=200)
        .map(|i| {
            let z = -u_end + 2.0 * u_end * f64::from(i) / 200.0;
            (z, setup.dresser.profile(z).0)
        })
        .collect();
    let ws: Vec<f64> = (0..=10)
        .map(|i| w_nf + (w_na - w_nf) * f64::from(i) / 10.0)
        .collect();
    let line = contact_line(&setup, fl, &ws, &k0)?;
    let (rho, _, _) = fit_contact_line(&line);
    let out = DesignOut {
        base_radius_mm: worm.r_b_mm,
        base_helix_angle_deg: worm.beta_b_rad.to_degrees(),
        lead_mm: worm.p_mm * 2.0 * std::f64::consts::PI,
        tip_radius_mm: worm.r_a_mm,
        root_radius_mm: worm.r_f_mm,
        nominal_centre_distance_mm: setup.nominal.d_mm,
        nominal_crossing_angle_deg: setup.nominal.gamma_rad.to_degrees(),
        fillet_radius_mm: side.fillet_radius_mm,
        active_profile_mm: (w_nf, w_na),
        tip_dresser_radius_mm: setup.association(fl, w_na, &k0)?,
        contact_line_direction_deg: rho.to_degrees(),
        profile,
    };
    if c.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "worm: r_b {:.5} mm, beta_b {:.5} deg, lead {:.5} mm, r_a {:.3} mm, r_f {:.3} mm",
            out.base_radius_mm,
            out.base_helix_angle_deg,
            out.lead_mm,
            out.tip_radius_mm,
            out.root_radius_mm
        );
        println!(
            "uncorrected setting: d0 {:.4} mm, gamma0 {:.5} deg",
            out.nominal_centre_distance_mm, out.nominal_crossing_angle_deg
        );
        println!(
            "dresser: fillet radius {:.4} mm, dresses the tip with radius {:.5} mm",
            out.fillet_radius_mm, out.tip_dresser_radius_mm
        );
        println!(
            "active profile w = [{:.5}, {:.5}] mm; contact line direction rho_FS {:.3} deg",
            w_nf, w_na, out.contact_line_direction_deg
        );
    }
    if let Some(path) = &c.report {
        let mut r = HtmlReport::new("gearcomp dress design");
        r.paragraph(&format!(
            "Dresser d_A = {} mm designed for the worm z_S = {}, d_S0 = {} mm.",
            setup.dresser.spec.d_a_mm, worm.z_s, worm.d_s0_mm
        ));
        r.chart(
            &Chart::new("Dresser axial profile", "z_A [mm]", "R_A [mm]")
                .with(Series::line("profile", out.profile.clone())),
        )?;
        r.chart(
            &Chart::new("Contact line worm-dresser (eq. 9)", "w [mm]", "b [mm]")
                .with(Series::points("contact line", line)),
        )?;
        r.write(path)?;
    }
    Ok(())
}

#[derive(Debug, Serialize)]
struct SolveOut {
    method: String,
    flank: Flank,
    worm_diameter_mm: f64,
    iterations: usize,
    condition: f64,
    dphi_s_rad: f64,
    dgamma_deg: f64,
    dd_mm: f64,
    dnu_ya_mm: f64,
    axes_bsp2: AxesOut,
    /// (w mm, f_nFS µm) over the active profile.
    profile_um: Vec<(f64, f64)>,
    stretch_percent: f64,
    opposite_flank_cut_um: f64,
    jacket_depth_um: f64,
    /// The clearance budget both are compared with (µm), `[solve] budget_mm`.
    budget_um: f64,
    /// Opposite-flank cut beyond the budget (only with `accept_penetration = true`).
    penetration: bool,
    /// Jacket deeper than the budget below the root (only with `accept_penetration = true`).
    undercut: bool,
    contact_line: Vec<(f64, f64)>,
    /// ν_zS as fifth unknown: present when [solve] has a contact_point.
    #[serde(skip_serializing_if = "Option::is_none")]
    contact_point: Option<ContactPointOut>,
}

#[derive(Debug, Serialize)]
struct ContactPointOut {
    w_mm: f64,
    b_mm: f64,
    /// Worm axial position at which the contact line passes (w, b).
    nu_zs_mm: f64,
    /// Machine (5) at that position.
    axes_bsp2: AxesOut,
    /// The contact line there, (w mm, b mm).
    contact_line: Vec<(f64, f64)>,
}

#[derive(Debug, Serialize)]
struct AxesOut {
    b1_deg: f64,
    v1_mm: f64,
    a1_deg: f64,
    x1_mm: f64,
    z1_mm: f64,
}

fn axes_for(setup: &DressingSetup, dk: &AxisCorrection) -> anyhow::Result<AxesOut> {
    axes_at(setup, dk, 0.0)
}

fn axes_at(setup: &DressingSetup, dk: &AxisCorrection, nu_zs_mm: f64) -> anyhow::Result<AxesOut> {
    let a = setup.machine_axes_at(dk, nu_zs_mm)?;
    Ok(AxesOut {
        b1_deg: a.b1_rad.to_degrees(),
        v1_mm: a.v1_mm,
        a1_deg: a.a1_rad.to_degrees(),
        x1_mm: a.x1_mm,
        z1_mm: a.z1_mm,
    })
}

fn run_solve(c: &Common) -> anyhow::Result<()> {
    let (cfg, worm, dresser) = load(&c.config)?;
    let Some(sc) = cfg.solve else {
        bail!(
            "{}: a [solve] table is needed for `dress solve`",
            c.config.display()
        );
    };
    let worm_now = current_worm(&worm, sc.diameter_mm)?;
    let setup = DressingSetup::new(worm_now, dresser.clone());
    if let Some(tc) = &sc.topological {
        return run_solve_topological(c, &sc, tc, &worm, &setup);
    }
    let fl = sc.flank;
    let input = SolveInput {
        flank: fl,
        method: sc.method,
        diameter_mm: sc.diameter_mm,
        crowning_um: sc.crowning_um,
        points: sc.points.clone(),
        budget_mm: sc.budget_mm,
        accept_penetration: sc.accept_penetration,
    };
    let outcome = solve_request(&worm, &dresser, &input)?;
    let setup = outcome.setup;
    let (w_nf, w_na) = outcome.active_mm;
    let at = |q: f64| w_nf + q * (w_na - w_nf);
    let sol = outcome.solution;
    let checks = outcome.checks;
    let dk = sol.dk;
    let ws: Vec<f64> = (0..=20).map(|i| at(f64::from(i) / 20.0)).collect();
    let line0 = contact_line(&setup, fl, &ws, &dk)?;
    let contact_point = match &sc.contact_point {
        None => None,
        Some(cp) => {
            if !(0.0..=1.0).contains(&cp.w_fraction) {
                bail!(
                    "[solve] contact_point.w_fraction = {} is outside the allowed range 0 ..= 1",
                    cp.w_fraction
                );
            }
            if !cp.b_mm.is_finite() || cp.b_mm.abs() > 1e4 {
                bail!(
                    "[solve] contact_point.b_mm = {} is outside the allowed range -10000 ..= 10000",
                    cp.b_mm
                );
            }
            let w0 = at(cp.w_fraction);
            // Fifth unknown: with ΔK constant the contact line only translates with ν_zS.
            let nu = axial_position_for_contact_point(&setup, fl, w0, cp.b_mm, &dk)?;
            Some(ContactPointOut {
                w_mm: w0,
                b_mm: cp.b_mm,
                nu_zs_mm: nu,
                axes_bsp2: axes_at(&setup, &dk, nu)?,
                contact_line: line0.iter().map(|(w, b)| (*w, b - nu)).collect(),
            })
        }
    };
    let prof = setup.profile(fl, &ws, &dk)?;
    // P_FS against the new worm dressed uncorrected (docs/dressing.md).
    let stretch = outcome.stretch;
    let out = SolveOut {
        method: format!("{:?}", sc.method),
        flank: fl,
        worm_diameter_mm: setup.worm.d_s_mm,
        iterations: sol.iterations,
        condition: sol.cond,
        dphi_s_rad: dk.dphi_s_rad,
        dgamma_deg: dk.dgamma_rad.to_degrees(),
        dd_mm: dk.dd_mm,
        dnu_ya_mm: dk.dnu_ya_mm,
        axes_bsp2: axes_for(&setup, &dk)?,
        profile_um: ws
            .iter()
            .zip(prof.iter())
            .map(|(w, f)| (*w, f * 1e3))
            .collect(),
        stretch_percent: 100.0 * stretch,
        opposite_flank_cut_um: 1e3 * checks.opposite_cut_mm,
        jacket_depth_um: 1e3 * checks.jacket_depth_mm,
        budget_um: 1e3 * checks.budget_mm,
        penetration: checks.penetration,
        undercut: checks.undercut,
        contact_line: line0,
        contact_point,
    };
    if c.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{} on the {:?} flank, worm d_S = {} mm: {} iterations, cond {:.3e}",
            out.method, fl, out.worm_diameter_mm, out.iterations, out.condition
        );
        println!(
            "dK: dphi_S {:.6e} rad, dgamma {:.5} deg, dd {:.5} mm, dnu_yA {:.5} mm",
            out.dphi_s_rad, out.dgamma_deg, out.dd_mm, out.dnu_ya_mm
        );
        let a = &out.axes_bsp2;
        println!("machine (5) at phi_S = 0: B1 {:.6} deg, V1 {:.4} mm, A1 {:.5} deg, X1 {:.5} mm, Z1 {:.5} mm",
            a.b1_deg, a.v1_mm, a.a1_deg, a.x1_mm, a.z1_mm);
        println!("{:>12} {:>10}", "w [mm]", "f [um]");
        for (w, f) in out.profile_um.iter().step_by(2) {
            println!("{w:>12.5} {f:>10.4}");
        }
        println!(
            "stretching P_FS {:+.3} %, opposite flank cut {:.2} um, jacket {:.2} um below root (budget {:.1} um)",
            out.stretch_percent, out.opposite_flank_cut_um, out.jacket_depth_um, out.budget_um
        );
        if out.penetration || out.undercut {
            println!(
                "WARNING: beyond [solve] budget_mm ({}{}); output because accept_penetration = true",
                if out.penetration { "PENETRATION of the opposite flank" } else { "" },
                if out.undercut { " UNDERCUT: jacket below the root" } else { "" }
            );
        }
        if let Some(cp) = &out.contact_point {
            println!(
                "contact line through (w {:.5} mm, b {:.4} mm) at worm axial position nu_zS {:.5} mm",
                cp.w_mm, cp.b_mm, cp.nu_zs_mm
            );
            let a = &cp.axes_bsp2;
            println!("machine (5) there: B1 {:.6} deg, V1 {:.4} mm, A1 {:.5} deg, X1 {:.5} mm, Z1 {:.5} mm",
                a.b1_deg, a.v1_mm, a.a1_deg, a.x1_mm, a.z1_mm);
        }
    }
    if let Some(path) = &c.report {
        let mut r = HtmlReport::new("gearcomp dress solve");
        r.paragraph(&format!(
            "dK = ({:.6e} rad, {:.5} deg, {:.5} mm, {:.5} mm)",
            out.dphi_s_rad, out.dgamma_deg, out.dd_mm, out.dnu_ya_mm
        ));
        r.chart(
            &Chart::new("Profile modification f_nFS", "w [mm]", "f [um]")
                .with(Series::line("f_nFS(w; dK)", out.profile_um.clone())),
        )?;
        let mut lines = Chart::new("Contact line worm-dresser", "w [mm]", "b [mm]")
            .with(Series::points("at nu_zS = 0", out.contact_line.clone()));
        if let Some(cp) = &out.contact_point {
            lines = lines
                .with(Series::points(
                    format!("at nu_zS = {:.4} mm", cp.nu_zs_mm),
                    cp.contact_line.clone(),
                ))
                .with(Series::points("prescribed point", vec![(cp.w_mm, cp.b_mm)]));
        }
        r.chart(&lines)?;
        r.write(path)?;
    }
    Ok(())
}

/// A plan row with the angles the interface shows in degrees.
#[derive(Debug, Serialize)]
struct PlanRowOut<'a> {
    /// Worm normal profile angle at d_S/2 used for this dressing.
    alpha_n_deg: f64,
    /// Profile angle of the unchanged helicoid at d_S/2.
    alpha_keep_deg: f64,
    /// Δγ in degrees.
    dgamma_deg: f64,
    #[serde(flatten)]
    row: &'a PlanRow,
}

fn run_plan(c: &Common) -> anyhow::Result<()> {
    let (cfg, worm, dresser) = load(&c.config)?;
    let Some(pc) = cfg.plan else {
        bail!(
            "{}: a [plan] table is needed for `dress plan`",
            c.config.display()
        );
    };
    check_key("[plan] crowning_um", pc.crowning_um, -50.0, 50.0, "µm")?;
    check_key("[plan] budget_mm", pc.budget_mm, 0.0, 5.0, "mm")?;
    if pc.diameters_mm.is_empty() || pc.diameters_mm.len() > 1000 {
        bail!(
            "[plan] diameters_mm: has {} diameters, allowed 1 ..= 1000 (mm)",
            pc.diameters_mm.len()
        );
    }
    let d_lo = (min_worn_diameter_mm(&worm) * 1e4).ceil() / 1e4;
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
    let rows: Vec<PlanRow> = plan_with_options(&worm, &dresser, &spec, &options)?;
    if c.json {
        let out: Vec<PlanRowOut<'_>> = rows
            .iter()
            .map(|r| PlanRowOut {
                alpha_n_deg: r.alpha_n_rad.to_degrees(),
                alpha_keep_deg: r.alpha_keep_rad.to_degrees(),
                dgamma_deg: r.dk.dgamma_rad.to_degrees(),
                row: r,
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{:>8} {:>10} {:>12} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9} {:>9} flags",
            "d_S mm",
            "alpha deg",
            "dphi rad",
            "dgam deg",
            "dd mm",
            "dnu mm",
            "dev um",
            "range um",
            "foot um",
            "tip um",
            "P %",
            "opp um",
            "jack um"
        );
        println!(
            "(dev, range: f - target over 5 % ..= 95 % of the active profile, the span of the targets; \
             foot = 0 %, the dresser's fillet/flank junction, and tip = 100 % are given apart)"
        );
        for r in &rows {
            let flags = match (r.penetration, r.undercut) {
                (true, true) => "PENETRATION UNDERCUT",
                (true, false) => "PENETRATION",
                (false, true) => "UNDERCUT",
                (false, false) => "",
            };
            println!("{:>8.2} {:>10.5} {:>12.4e} {:>10.5} {:>10.5} {:>10.5} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>8.4} {:>9.2} {:>9.2} {flags}",
                r.d_s_mm, r.alpha_n_rad.to_degrees(), r.dk.dphi_s_rad, r.dk.dgamma_rad.to_degrees(), r.dk.dd_mm, r.dk.dnu_ya_mm,
                r.deviation_max_um, r.deviation_range_um, r.deviation_foot_um, r.deviation_tip_um, 100.0 * r.stretch,
                1e3 * r.opposite_cut_mm, 1e3 * r.jacket_depth_mm);
        }
    }
    if let Some(path) = &c.report {
        let mut r = HtmlReport::new("gearcomp dress plan");
        let d =
            |f: &dyn Fn(&PlanRow) -> f64| rows.iter().map(|r| (r.d_s_mm, f(r))).collect::<Vec<_>>();
        r.chart(
            &Chart::new(
                "Profile deviation per dressing",
                "d_S [mm]",
                "max |f - target| [um]",
            )
            .with(Series::line("deviation", d(&|r| r.deviation_max_um))),
        )?;
        r.chart(
            &Chart::new("Axis corrections per dressing", "d_S [mm]", "dK")
                .with(Series::line("dphi_S [mrad]", d(&|r| 1e3 * r.dk.dphi_s_rad)))
                .with(Series::line(
                    "dgamma [deg]",
                    d(&|r| r.dk.dgamma_rad.to_degrees()),
                ))
                .with(Series::line("dd [10 um]", d(&|r| 100.0 * r.dk.dd_mm)))
                .with(Series::line("dnu_yA [mm]", d(&|r| r.dk.dnu_ya_mm))),
        )?;
        let mut prof = Chart::new(
            "Profile modification after each dressing",
            "w [mm]",
            "f - target [um]",
        );
        for row in &rows {
            prof = prof.with(Series::line(
                format!("d_S {}", row.d_s_mm),
                row.profile.clone(),
            ));
        }
        r.chart(&prof)?;
        r.write(path)?;
    }
    Ok(())
}

#[derive(Debug, Serialize)]
struct TopoPositionOut {
    /// Width position of the contact line's reference point (mid profile), mm.
    b0_mm: f64,
    /// Uncorrected worm axial position at which the contact line passes it.
    nu_zs_mm: f64,
    /// Crowning wanted there (3-point), µm.
    #[serde(skip_serializing_if = "Option::is_none")]
    crowning_um: Option<f64>,
    dphi_s_rad: f64,
    dgamma_deg: f64,
    dd_mm: f64,
    dnu_ya_mm: f64,
    /// Machine (5) at this axial position.
    axes_bsp2: AxesOut,
    iterations: usize,
    /// Largest of the 9 residuals (µm).
    max_residual_um: f64,
    /// Opposite-flank cut (µm) and jacket depth below the root (µm) at this position.
    opposite_flank_cut_um: f64,
    jacket_depth_um: f64,
    /// Either beyond `[solve] budget_mm` (only with `accept_penetration = true`).
    penetration: bool,
    undercut: bool,
}

#[derive(Debug, Serialize)]
struct TopoOut {
    method: String,
    flank: Flank,
    worm_diameter_mm: f64,
    /// Roll distances of the target curves (mm), constant over the width.
    target_w_mm: Vec<f64>,
    positions: Vec<TopoPositionOut>,
    /// Quasi-static worm topology: roll distances (rows), width positions (columns), f (µm).
    map_w_mm: Vec<f64>,
    map_b_mm: Vec<f64>,
    /// f_nFS(w, b) (µm), row-major [i_w][i_b].
    map_f_um: Vec<Vec<f64>>,
}

/// `dress solve` with `[solve.topological]`: the topological 3- or 4-point program over the
/// worm width ([`solve_topological_request`]), its machine axes per position and the dressed
/// worm.
fn run_solve_topological(
    c: &Common,
    sc: &SolveCfg,
    tc: &TopologicalInput,
    design: &Worm,
    setup: &DressingSetup,
) -> anyhow::Result<()> {
    let input = SolveInput {
        flank: sc.flank,
        method: sc.method,
        diameter_mm: sc.diameter_mm,
        crowning_um: sc.crowning_um,
        points: sc.points.clone(),
        budget_mm: sc.budget_mm,
        accept_penetration: sc.accept_penetration,
    };
    let o = solve_topological_request(&input, tc, sc.contact_point.is_some(), design, setup)?;
    let fl = o.flank;
    let n = tc.positions;
    let [b_lo, b_hi] = tc.b_range_mm;
    let program = &o.program;
    let mut positions = Vec::with_capacity(n);
    for (s, ck) in program.solutions.iter().zip(&o.checks) {
        positions.push(TopoPositionOut {
            opposite_flank_cut_um: 1e3 * ck.opposite_cut_mm,
            jacket_depth_um: 1e3 * ck.jacket_depth_mm,
            penetration: ck.penetration,
            undercut: ck.undercut,
            b0_mm: s.b0_mm,
            nu_zs_mm: s.nu_zs_mm,
            crowning_um: o.crowning.as_ref().map(|cw| cw.at(s.b0_mm).0),
            dphi_s_rad: s.dk.dphi_s_rad,
            dgamma_deg: s.dk.dgamma_rad.to_degrees(),
            dd_mm: s.dk.dd_mm,
            dnu_ya_mm: s.dk.dnu_ya_mm,
            axes_bsp2: axes_at(setup, &s.dk, s.nu_zs_mm)?,
            iterations: s.iterations,
            max_residual_um: 1e3 * s.residual_mm.iter().fold(0.0f64, |m, r| m.max(r.abs())),
        });
    }
    let nb = o.map_b_mm.len();
    let map_f_um: Vec<Vec<f64>> = o
        .map_f_mm
        .chunks(nb)
        .map(|row| row.iter().map(|f| 1e3 * f).collect())
        .collect();
    let out = TopoOut {
        method: format!("topological {:?}", sc.method),
        flank: fl,
        worm_diameter_mm: setup.worm.d_s_mm,
        target_w_mm: o.target_w_mm.clone(),
        positions,
        map_w_mm: o.map_w_mm.clone(),
        map_b_mm: o.map_b_mm.clone(),
        map_f_um,
    };
    if c.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{} on the {:?} flank, worm d_S = {} mm, {} positions",
            out.method, fl, out.worm_diameter_mm, n
        );
        println!(
            "{:>9} {:>10} {:>8} {:>12} {:>10} {:>10} {:>10} {:>11} {:>10} {:>10} {:>10} {:>4} {:>9}",
            "b0 mm", "nu_zS mm", "c um", "dphi rad", "dgam deg", "dd mm", "dnu mm",
            "B1 deg", "V1 mm", "A1 deg", "X1 mm", "it", "res um"
        );
        for p in &out.positions {
            println!(
                "{:>9.3} {:>10.4} {:>8.4} {:>12.4e} {:>10.5} {:>10.5} {:>10.5} {:>11.5} {:>10.4} {:>10.5} {:>10.5} {:>4} {:>9.2e}",
                p.b0_mm, p.nu_zs_mm, p.crowning_um.unwrap_or(f64::NAN), p.dphi_s_rad, p.dgamma_deg,
                p.dd_mm, p.dnu_ya_mm, p.axes_bsp2.b1_deg, p.axes_bsp2.v1_mm, p.axes_bsp2.a1_deg,
                p.axes_bsp2.x1_mm, p.iterations, p.max_residual_um
            );
        }
    }
    if let Some(path) = &c.report {
        let mut r = HtmlReport::new("gearcomp dress solve (topological)");
        r.paragraph(&format!(
            "{} positions over b = {b_lo} .. {b_hi} mm; dK(nu_zS) is the natural cubic spline through them, held beyond the ends.",
            n
        ));
        let nus: Vec<f64> = out.positions.iter().map(|p| p.nu_zs_mm).collect();
        let (nu_lo, nu_hi) = nus
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let curve = |f: &dyn Fn(&AxisCorrection) -> f64| -> Vec<(f64, f64)> {
            (0..=100)
                .map(|i| {
                    let nu = nu_lo + (nu_hi - nu_lo) * f64::from(i) / 100.0;
                    (nu, f(&program.schedule.at(nu)))
                })
                .collect()
        };
        r.chart(
            &Chart::new("Dressing program dK(nu_zS)", "nu_zS [mm]", "dK")
                .with(Series::line(
                    "dphi_S [mrad]",
                    curve(&|k| 1e3 * k.dphi_s_rad),
                ))
                .with(Series::line(
                    "dgamma [deg]",
                    curve(&|k| k.dgamma_rad.to_degrees()),
                ))
                .with(Series::line("dd [10 um]", curve(&|k| 100.0 * k.dd_mm)))
                .with(Series::line("dnu_yA [mm]", curve(&|k| k.dnu_ya_mm)))
                .with(Series::points(
                    "solved dgamma [deg]",
                    out.positions
                        .iter()
                        .map(|p| (p.nu_zs_mm, p.dgamma_deg))
                        .collect(),
                )),
        )?;
        let mut map = Chart::new(
            "Dressed worm f_nFS(w, b) (quasi-static), one line per b",
            "w [mm]",
            "f [um]",
        );
        for (j, b) in out.map_b_mm.iter().enumerate() {
            map = map.with(Series::line(
                format!("b {b:.2} mm"),
                out.map_w_mm
                    .iter()
                    .zip(out.map_f_um.iter())
                    .map(|(w, row)| (*w, row[j]))
                    .collect(),
            ));
        }
        r.chart(&map)?;
        let mut across = Chart::new(
            "f_nFS along the width at the target roll distances",
            "b [mm]",
            "f [um]",
        );
        for (i, w) in out.map_w_mm.iter().enumerate().step_by(5) {
            across = across.with(Series::line(
                format!("w {w:.3} mm"),
                out.map_b_mm
                    .iter()
                    .zip(out.map_f_um[i].iter())
                    .map(|(b, f)| (*b, *f))
                    .collect(),
            ));
        }
        r.chart(&across)?;
        r.write(path)?;
    }
    Ok(())
}
