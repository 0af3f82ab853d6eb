//! The results of `gearcomp dress` in the units the user reads (degrees, µm, mm), with their
//! text tables and HTML reports: the dresser design ([`DesignSummary`]), a solved `[solve]`
//! request ([`SolveSummary`]), a worm's dressing plan ([`plan_table`], [`plan_html`],
//! [`PlanRowDeg`]) and a topological program ([`TopologicalSummary`]).
//!
//! Each summary is built from the library's result in internal units (rad, mm) and converts
//! at this interface only: angles to degrees, profile deviations and clearances to µm
//! (1 mm = 1000 µm). The records serialise (serde) to the JSON the command prints; fields
//! that only the renderers need are not serialised.

use std::fmt::Write as _;

use gearcomp_report::{Chart, HtmlReport, Series};
use serde::Serialize;

use crate::campaign::PlanRow;
use crate::dresser::Dresser;
use crate::envelope::DressingSetup;
use crate::kinematics::AxisCorrection;
use crate::request::{Method, SolveOutcome};
use crate::schedule::{CorrectionSchedule, TabulatedSchedule};
use crate::simulation::{contact_line, fit_contact_line};
use crate::solve::axial_position_for_contact_point;
use crate::topological_request::TopologicalOutcome;
use crate::worm::{Flank, Worm};
use crate::{DressError, Result};

use gearcomp_geometry::units::UM_PER_MM;

/// Points of the dresser axial profile in the design summary (201, end points included).
const PROFILE_STEPS: u32 = 200;

/// The machine axes of machine (5) (`AxesBsp2`) with the angles in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MachineAxesDeg {
    /// B1 (deg).
    pub b1_deg: f64,
    /// V1 (mm).
    pub v1_mm: f64,
    /// A1 (deg).
    pub a1_deg: f64,
    /// X1 (mm).
    pub x1_mm: f64,
    /// Z1 (mm).
    pub z1_mm: f64,
}

impl MachineAxesDeg {
    /// The axes for the correction `dk` at the worm axial position `nu_zs_mm`.
    pub fn at(setup: &DressingSetup, dk: &AxisCorrection, nu_zs_mm: f64) -> Result<Self> {
        let a = setup.machine_axes_at(dk, nu_zs_mm)?;
        Ok(MachineAxesDeg {
            b1_deg: a.b1_rad.to_degrees(),
            v1_mm: a.v1_mm,
            a1_deg: a.a1_rad.to_degrees(),
            x1_mm: a.x1_mm,
            z1_mm: a.z1_mm,
        })
    }

    fn text(&self) -> String {
        format!(
            "B1 {:.6} deg, V1 {:.4} mm, A1 {:.5} deg, X1 {:.5} mm, Z1 {:.5} mm",
            self.b1_deg, self.v1_mm, self.a1_deg, self.x1_mm, self.z1_mm
        )
    }
}

/// `w_lo + (w_hi − w_lo)·i/n` for i = 0 ..= n.
fn stations(w_lo: f64, w_hi: f64, n: u32) -> Vec<f64> {
    (0..=n)
        .map(|i| w_lo + (w_hi - w_lo) * f64::from(i) / f64::from(n))
        .collect()
}

/// The dresser designed for the new worm (right flank, uncorrected setting).
#[derive(Debug, Clone, Serialize)]
pub struct DesignSummary {
    /// Worm base radius r_b (mm).
    pub base_radius_mm: f64,
    /// Worm base helix angle β_b (deg).
    pub base_helix_angle_deg: f64,
    /// Worm lead 2π·p (mm).
    pub lead_mm: f64,
    /// Worm tip radius r_a (mm).
    pub tip_radius_mm: f64,
    /// Worm root radius r_f (mm).
    pub root_radius_mm: f64,
    /// Uncorrected centre distance d₀ (mm).
    pub nominal_centre_distance_mm: f64,
    /// Uncorrected crossing angle γ₀ (deg).
    pub nominal_crossing_angle_deg: f64,
    /// Dresser fillet radius (mm).
    pub fillet_radius_mm: f64,
    /// Active profile [w_Nf, w_Na] (mm).
    pub active_profile_mm: (f64, f64),
    /// Dresser radius that dresses the worm tip w_Na (mm).
    pub tip_dresser_radius_mm: f64,
    /// Direction ρ_FS of the contact line, eq. (9) (deg).
    pub contact_line_direction_deg: f64,
    /// Dresser axial profile (z_A mm, R_A mm).
    pub profile: Vec<(f64, f64)>,
    /// Contact line worm–dresser (w mm, b mm) at 11 roll distances over the active profile.
    #[serde(skip)]
    pub contact_line: Vec<(f64, f64)>,
    /// Dresser outside diameter d_A (mm).
    #[serde(skip)]
    pub dresser_d_a_mm: f64,
    /// Worm starts z_S.
    #[serde(skip)]
    pub worm_z_s: u32,
    /// New worm diameter d_S0 (mm).
    #[serde(skip)]
    pub worm_d_s0_mm: f64,
}

impl DesignSummary {
    /// The design of `dresser` for the new `worm`: the dresser profile at 201 points over
    /// ±u_max, the contact line at 11 points over the active profile and its direction.
    pub fn new(worm: Worm, dresser: Dresser) -> Result<Self> {
        let setup = DressingSetup::new(worm, dresser);
        let fl = Flank::Right;
        let (w_nf, w_na) = setup.active_profile(fl)?;
        let k0 = AxisCorrection::default();
        let u_end = setup.dresser.u_max();
        let profile = stations(-u_end, u_end, PROFILE_STEPS)
            .into_iter()
            .map(|z| (z, setup.dresser.profile(z).0))
            .collect();
        let line = contact_line(&setup, fl, &stations(w_nf, w_na, 10), &k0)?;
        let (rho, _, _) = fit_contact_line(&line);
        Ok(DesignSummary {
            base_radius_mm: worm.r_b_mm,
            base_helix_angle_deg: worm.beta_b_rad.to_degrees(),
            lead_mm: worm.p_mm * 2.0 * std::f64::consts::PI,
            tip_radius_mm: worm.r_a_mm,
            root_radius_mm: worm.r_f_mm,
            nominal_centre_distance_mm: setup.nominal.d_mm,
            nominal_crossing_angle_deg: setup.nominal.gamma_rad.to_degrees(),
            fillet_radius_mm: setup.dresser.side(fl).fillet_radius_mm,
            active_profile_mm: (w_nf, w_na),
            tip_dresser_radius_mm: setup.association(fl, w_na, &k0)?,
            contact_line_direction_deg: rho.to_degrees(),
            profile,
            contact_line: line,
            dresser_d_a_mm: setup.dresser.spec.d_a_mm,
            worm_z_s: worm.z_s,
            worm_d_s0_mm: worm.d_s0_mm,
        })
    }

    /// The text lines of `dress design`.
    pub fn text(&self) -> String {
        let (w_nf, w_na) = self.active_profile_mm;
        format!(
            "worm: r_b {:.5} mm, beta_b {:.5} deg, lead {:.5} mm, r_a {:.3} mm, r_f {:.3} mm\n\
             uncorrected setting: d0 {:.4} mm, gamma0 {:.5} deg\n\
             dresser: fillet radius {:.4} mm, dresses the tip with radius {:.5} mm\n\
             active profile w = [{:.5}, {:.5}] mm; contact line direction rho_FS {:.3} deg\n",
            self.base_radius_mm,
            self.base_helix_angle_deg,
            self.lead_mm,
            self.tip_radius_mm,
            self.root_radius_mm,
            self.nominal_centre_distance_mm,
            self.nominal_crossing_angle_deg,
            self.fillet_radius_mm,
            self.tip_dresser_radius_mm,
            w_nf,
            w_na,
            self.contact_line_direction_deg
        )
    }

    /// The HTML report: dresser axial profile and contact line.
    pub fn html(&self) -> gearcomp_report::Result<HtmlReport> {
        let mut r = HtmlReport::new("gearcomp dress design");
        r.paragraph(&format!(
            "Dresser d_A = {} mm designed for the worm z_S = {}, d_S0 = {} mm.",
            self.dresser_d_a_mm, self.worm_z_s, self.worm_d_s0_mm
        ));
        r.chart(
            &Chart::new("Dresser axial profile", "z_A [mm]", "R_A [mm]")
                .with(Series::line("profile", self.profile.clone())),
        )?;
        r.chart(
            &Chart::new("Contact line worm-dresser (eq. 9)", "w [mm]", "b [mm]")
                .with(Series::points("contact line", self.contact_line.clone())),
        )?;
        Ok(r)
    }
}

/// The contact line of a solve moved to pass through a prescribed worm point.
#[derive(Debug, Clone, Serialize)]
pub struct ContactPointSummary {
    /// Roll distance w of the point (mm).
    pub w_mm: f64,
    /// Axial position b of the point (mm).
    pub b_mm: f64,
    /// Worm axial position at which the contact line passes (w, b).
    pub nu_zs_mm: f64,
    /// Machine (5) at that position.
    pub axes_bsp2: MachineAxesDeg,
    /// The contact line there, (w mm, b mm).
    pub contact_line: Vec<(f64, f64)>,
}

/// A solved `[solve]` request (3-/4-point or curve fit) for one worm diameter.
#[derive(Debug, Clone, Serialize)]
pub struct SolveSummary {
    /// Solve method (`ThreePoint`, …).
    pub method: String,
    /// Flank dressed.
    pub flank: Flank,
    /// Worm diameter d_S (mm).
    pub worm_diameter_mm: f64,
    /// Newton iterations.
    pub iterations: usize,
    /// Condition number of the last Jacobian.
    pub condition: f64,
    /// Δφ_S (rad).
    pub dphi_s_rad: f64,
    /// Δγ (deg).
    pub dgamma_deg: f64,
    /// Δd (mm).
    pub dd_mm: f64,
    /// Δν_yA (mm).
    pub dnu_ya_mm: f64,
    /// Machine (5) at φ_S = 0.
    pub axes_bsp2: MachineAxesDeg,
    /// (w mm, f_nFS µm) over the active profile.
    pub profile_um: Vec<(f64, f64)>,
    /// Profile stretching P_FS against the new worm dressed uncorrected (%).
    pub stretch_percent: f64,
    /// Opposite-flank cut (µm).
    pub opposite_flank_cut_um: f64,
    /// Jacket depth below the root (µm).
    pub jacket_depth_um: f64,
    /// The clearance budget both are compared with (µm), `[solve] budget_mm`.
    pub budget_um: f64,
    /// Opposite-flank cut beyond the budget (only with `accept_penetration = true`).
    pub penetration: bool,
    /// Jacket deeper than the budget below the root (only with `accept_penetration = true`).
    pub undercut: bool,
    /// Contact line (w mm, b mm) at ν_zS = 0.
    pub contact_line: Vec<(f64, f64)>,
    /// ν_zS as fifth unknown: present when [solve] has a contact_point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_point: Option<ContactPointSummary>,
}

impl SolveSummary {
    /// The summary of `outcome` (solved with `method` on `flank`) at 21 roll distances over
    /// the active profile; with `contact_point = Some((w_fraction, b_mm))` (`[solve]
    /// contact_point`, w as a fraction 0 ..= 1 of the active profile, |b| ≤ 10 000 mm) also
    /// the worm axial position ν_zS at which the contact line passes that point (eq. (14)).
    pub fn new(
        outcome: &SolveOutcome,
        method: Method,
        flank: Flank,
        contact_point: Option<(f64, f64)>,
    ) -> Result<Self> {
        let setup = &outcome.setup;
        let (w_nf, w_na) = outcome.active_mm;
        let at = |q: f64| w_nf + q * (w_na - w_nf);
        let (sol, checks) = (&outcome.solution, &outcome.checks);
        let dk = sol.dk;
        let ws: Vec<f64> = (0..=20).map(|i| at(f64::from(i) / 20.0)).collect();
        let line0 = contact_line(setup, flank, &ws, &dk)?;
        let contact_point = match contact_point {
            None => None,
            Some((w_fraction, b_mm)) => {
                check_contact_point(w_fraction, b_mm)?;
                let w0 = at(w_fraction);
                // Fifth unknown: with ΔK constant the contact line only translates with ν_zS.
                let nu = axial_position_for_contact_point(setup, flank, w0, b_mm, &dk)?;
                Some(ContactPointSummary {
                    w_mm: w0,
                    b_mm,
                    nu_zs_mm: nu,
                    axes_bsp2: MachineAxesDeg::at(setup, &dk, nu)?,
                    contact_line: line0.iter().map(|(w, b)| (*w, b - nu)).collect(),
                })
            }
        };
        let prof = setup.profile(flank, &ws, &dk)?;
        Ok(SolveSummary {
            method: format!("{method:?}"),
            flank,
            worm_diameter_mm: setup.worm.d_s_mm,
            iterations: sol.iterations,
            condition: sol.cond,
            dphi_s_rad: dk.dphi_s_rad,
            dgamma_deg: dk.dgamma_rad.to_degrees(),
            dd_mm: dk.dd_mm,
            dnu_ya_mm: dk.dnu_ya_mm,
            axes_bsp2: MachineAxesDeg::at(setup, &dk, 0.0)?,
            profile_um: ws
                .iter()
                .zip(prof.iter())
                .map(|(w, f)| (*w, f * UM_PER_MM))
                .collect(),
            stretch_percent: 100.0 * outcome.stretch,
            opposite_flank_cut_um: UM_PER_MM * checks.opposite_cut_mm,
            jacket_depth_um: UM_PER_MM * checks.jacket_depth_mm,
            budget_um: UM_PER_MM * checks.budget_mm,
            penetration: checks.penetration,
            undercut: checks.undercut,
            contact_line: line0,
            contact_point,
        })
    }

    /// The text of `dress solve`: ΔK, machine axes, the profile at every second roll
    /// distance, stretching and clearances, the contact point.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} on the {:?} flank, worm d_S = {} mm: {} iterations, cond {:.3e}",
            self.method, self.flank, self.worm_diameter_mm, self.iterations, self.condition
        );
        let _ = writeln!(
            s,
            "dK: dphi_S {:.6e} rad, dgamma {:.5} deg, dd {:.5} mm, dnu_yA {:.5} mm",
            self.dphi_s_rad, self.dgamma_deg, self.dd_mm, self.dnu_ya_mm
        );
        let _ = writeln!(s, "machine (5) at phi_S = 0: {}", self.axes_bsp2.text());
        let _ = writeln!(s, "{:>12} {:>10}", "w [mm]", "f [um]");
        for (w, f) in self.profile_um.iter().step_by(2) {
            let _ = writeln!(s, "{w:>12.5} {f:>10.4}");
        }
        let _ = writeln!(
            s,
            "stretching P_FS {:+.3} %, opposite flank cut {:.2} um, jacket {:.2} um below root (budget {:.1} um)",
            self.stretch_percent, self.opposite_flank_cut_um, self.jacket_depth_um, self.budget_um
        );
        if self.penetration || self.undercut {
            let _ = writeln!(
                s,
                "WARNING: beyond [solve] budget_mm ({}{}); output because accept_penetration = true",
                if self.penetration { "PENETRATION of the opposite flank" } else { "" },
                if self.undercut { " UNDERCUT: jacket below the root" } else { "" }
            );
        }
        if let Some(cp) = &self.contact_point {
            let _ = writeln!(
                s,
                "contact line through (w {:.5} mm, b {:.4} mm) at worm axial position nu_zS {:.5} mm",
                cp.w_mm, cp.b_mm, cp.nu_zs_mm
            );
            let _ = writeln!(s, "machine (5) there: {}", cp.axes_bsp2.text());
        }
        s
    }

    /// The HTML report: ΔK, the profile modification and the contact line(s).
    pub fn html(&self) -> gearcomp_report::Result<HtmlReport> {
        let mut r = HtmlReport::new("gearcomp dress solve");
        r.paragraph(&format!(
            "dK = ({:.6e} rad, {:.5} deg, {:.5} mm, {:.5} mm)",
            self.dphi_s_rad, self.dgamma_deg, self.dd_mm, self.dnu_ya_mm
        ));
        r.chart(
            &Chart::new("Profile modification f_nFS", "w [mm]", "f [um]")
                .with(Series::line("f_nFS(w; dK)", self.profile_um.clone())),
        )?;
        let mut lines = Chart::new("Contact line worm-dresser", "w [mm]", "b [mm]")
            .with(Series::points("at nu_zS = 0", self.contact_line.clone()));
        if let Some(cp) = &self.contact_point {
            lines = lines
                .with(Series::points(
                    format!("at nu_zS = {:.4} mm", cp.nu_zs_mm),
                    cp.contact_line.clone(),
                ))
                .with(Series::points("prescribed point", vec![(cp.w_mm, cp.b_mm)]));
        }
        r.chart(&lines)?;
        Ok(r)
    }
}

/// `[solve] contact_point`: w_fraction in 0 ..= 1, b_mm finite with |b| ≤ 10 000 mm.
fn check_contact_point(w_fraction: f64, b_mm: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&w_fraction) {
        return Err(DressError::Request(format!(
            "[solve] contact_point.w_fraction = {w_fraction} is outside the allowed range 0 ..= 1"
        )));
    }
    if !b_mm.is_finite() || b_mm.abs() > 1e4 {
        return Err(DressError::Request(format!(
            "[solve] contact_point.b_mm = {b_mm} is outside the allowed range -10000 ..= 10000"
        )));
    }
    Ok(())
}

/// A plan row with the angles the interface shows in degrees (JSON of `dress plan`).
#[derive(Debug, Serialize)]
pub struct PlanRowDeg<'a> {
    /// Worm normal profile angle at d_S/2 used for this dressing.
    pub alpha_n_deg: f64,
    /// Profile angle of the unchanged helicoid at d_S/2.
    pub alpha_keep_deg: f64,
    /// Δγ in degrees.
    pub dgamma_deg: f64,
    /// The row in internal units.
    #[serde(flatten)]
    pub row: &'a PlanRow,
}

impl<'a> PlanRowDeg<'a> {
    /// The row with its angles in degrees.
    pub fn new(row: &'a PlanRow) -> Self {
        PlanRowDeg {
            alpha_n_deg: row.alpha_n_rad.to_degrees(),
            alpha_keep_deg: row.alpha_keep_rad.to_degrees(),
            dgamma_deg: row.dk.dgamma_rad.to_degrees(),
            row,
        }
    }
}

/// The text table of `dress plan`: one line per dressing, flags for a budget overrun.
pub fn plan_table(rows: &[PlanRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
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
    let _ = writeln!(
        s,
        "(dev, range: f - target over 5 % ..= 95 % of the active profile, the span of the targets; \
         foot = 0 %, the dresser's fillet/flank junction, and tip = 100 % are given apart)"
    );
    for r in rows {
        let flags = match (r.penetration, r.undercut) {
            (true, true) => "PENETRATION UNDERCUT",
            (true, false) => "PENETRATION",
            (false, true) => "UNDERCUT",
            (false, false) => "",
        };
        let _ = writeln!(s, "{:>8.2} {:>10.5} {:>12.4e} {:>10.5} {:>10.5} {:>10.5} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>8.4} {:>9.2} {:>9.2} {flags}",
            r.d_s_mm, r.alpha_n_rad.to_degrees(), r.dk.dphi_s_rad, r.dk.dgamma_rad.to_degrees(), r.dk.dd_mm, r.dk.dnu_ya_mm,
            r.deviation_max_um, r.deviation_range_um, r.deviation_foot_um, r.deviation_tip_um, 100.0 * r.stretch,
            UM_PER_MM * r.opposite_cut_mm, UM_PER_MM * r.jacket_depth_mm);
    }
    s
}

/// The HTML report of `dress plan`: deviation and ΔK per dressing, the profile after each.
pub fn plan_html(rows: &[PlanRow]) -> gearcomp_report::Result<HtmlReport> {
    let mut r = HtmlReport::new("gearcomp dress plan");
    let d = |f: &dyn Fn(&PlanRow) -> f64| rows.iter().map(|r| (r.d_s_mm, f(r))).collect::<Vec<_>>();
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
    for row in rows {
        prof = prof.with(Series::line(
            format!("d_S {}", row.d_s_mm),
            row.profile.clone(),
        ));
    }
    r.chart(&prof)?;
    Ok(r)
}

/// One position of a topological program.
#[derive(Debug, Clone, Serialize)]
pub struct TopoPositionSummary {
    /// Width position of the contact line's reference point (mid profile), mm.
    pub b0_mm: f64,
    /// Uncorrected worm axial position at which the contact line passes it.
    pub nu_zs_mm: f64,
    /// Crowning wanted there (3-point), µm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crowning_um: Option<f64>,
    /// Δφ_S (rad).
    pub dphi_s_rad: f64,
    /// Δγ (deg).
    pub dgamma_deg: f64,
    /// Δd (mm).
    pub dd_mm: f64,
    /// Δν_yA (mm).
    pub dnu_ya_mm: f64,
    /// Machine (5) at this axial position.
    pub axes_bsp2: MachineAxesDeg,
    /// Newton iterations.
    pub iterations: usize,
    /// Largest of the 9 residuals (µm).
    pub max_residual_um: f64,
    /// Opposite-flank cut (µm) at this position.
    pub opposite_flank_cut_um: f64,
    /// Jacket depth below the root (µm) at this position.
    pub jacket_depth_um: f64,
    /// Opposite-flank cut beyond `[solve] budget_mm` (only with `accept_penetration = true`).
    pub penetration: bool,
    /// Jacket beyond `[solve] budget_mm` (only with `accept_penetration = true`).
    pub undercut: bool,
}

/// A topological program over the worm width (`[solve.topological]`) and the dressed worm.
#[derive(Debug, Clone, Serialize)]
pub struct TopologicalSummary {
    /// "topological" and the solve method.
    pub method: String,
    /// Flank dressed.
    pub flank: Flank,
    /// Worm diameter d_S (mm).
    pub worm_diameter_mm: f64,
    /// Roll distances of the target curves (mm), constant over the width.
    pub target_w_mm: Vec<f64>,
    /// The solution at each position.
    pub positions: Vec<TopoPositionSummary>,
    /// Quasi-static worm topology: roll distances (rows, mm).
    pub map_w_mm: Vec<f64>,
    /// Width positions (columns, mm).
    pub map_b_mm: Vec<f64>,
    /// f_nFS(w, b) (µm), row-major [i_w][i_b].
    pub map_f_um: Vec<Vec<f64>>,
    /// ΔK(ν_zS) through the solutions.
    #[serde(skip)]
    pub schedule: TabulatedSchedule,
    /// Width range [b_start, b_end] swept (mm).
    #[serde(skip)]
    pub b_range_mm: [f64; 2],
}

impl TopologicalSummary {
    /// The summary of `o` (solved with `method` over `b_range_mm` on the worm of `setup`):
    /// machine axes per position, the largest residual and the dressed worm in µm.
    pub fn new(
        o: &TopologicalOutcome,
        method: Method,
        b_range_mm: [f64; 2],
        setup: &DressingSetup,
    ) -> Result<Self> {
        let mut positions = Vec::with_capacity(o.program.solutions.len());
        for (s, ck) in o.program.solutions.iter().zip(&o.checks) {
            positions.push(TopoPositionSummary {
                opposite_flank_cut_um: UM_PER_MM * ck.opposite_cut_mm,
                jacket_depth_um: UM_PER_MM * ck.jacket_depth_mm,
                penetration: ck.penetration,
                undercut: ck.undercut,
                b0_mm: s.b0_mm,
                nu_zs_mm: s.nu_zs_mm,
                crowning_um: o.crowning.as_ref().map(|cw| cw.at(s.b0_mm).0),
                dphi_s_rad: s.dk.dphi_s_rad,
                dgamma_deg: s.dk.dgamma_rad.to_degrees(),
                dd_mm: s.dk.dd_mm,
                dnu_ya_mm: s.dk.dnu_ya_mm,
                axes_bsp2: MachineAxesDeg::at(setup, &s.dk, s.nu_zs_mm)?,
                iterations: s.iterations,
                max_residual_um: UM_PER_MM
                    * s.residual_mm.iter().fold(0.0f64, |m, r| m.max(r.abs())),
            });
        }
        let nb = o.map_b_mm.len();
        let map_f_um = o
            .map_f_mm
            .chunks(nb)
            .map(|row| row.iter().map(|f| UM_PER_MM * f).collect())
            .collect();
        Ok(TopologicalSummary {
            method: format!("topological {method:?}"),
            flank: o.flank,
            worm_diameter_mm: setup.worm.d_s_mm,
            target_w_mm: o.target_w_mm.clone(),
            positions,
            map_w_mm: o.map_w_mm.clone(),
            map_b_mm: o.map_b_mm.clone(),
            map_f_um,
            schedule: o.program.schedule.clone(),
            b_range_mm,
        })
    }

    /// The text table: one line per position (ΔK, machine axes, iterations, residual).
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} on the {:?} flank, worm d_S = {} mm, {} positions",
            self.method,
            self.flank,
            self.worm_diameter_mm,
            self.positions.len()
        );
        let _ = writeln!(
            s,
            "{:>9} {:>10} {:>8} {:>12} {:>10} {:>10} {:>10} {:>11} {:>10} {:>10} {:>10} {:>4} {:>9}",
            "b0 mm", "nu_zS mm", "c um", "dphi rad", "dgam deg", "dd mm", "dnu mm",
            "B1 deg", "V1 mm", "A1 deg", "X1 mm", "it", "res um"
        );
        for p in &self.positions {
            let _ = writeln!(
                s,
                "{:>9.3} {:>10.4} {:>8.4} {:>12.4e} {:>10.5} {:>10.5} {:>10.5} {:>11.5} {:>10.4} {:>10.5} {:>10.5} {:>4} {:>9.2e}",
                p.b0_mm, p.nu_zs_mm, p.crowning_um.unwrap_or(f64::NAN), p.dphi_s_rad, p.dgamma_deg,
                p.dd_mm, p.dnu_ya_mm, p.axes_bsp2.b1_deg, p.axes_bsp2.v1_mm, p.axes_bsp2.a1_deg,
                p.axes_bsp2.x1_mm, p.iterations, p.max_residual_um
            );
        }
        s
    }

    /// The HTML report: ΔK(ν_zS) with the solved points, the dressed worm along w and along b.
    pub fn html(&self) -> gearcomp_report::Result<HtmlReport> {
        let mut r = HtmlReport::new("gearcomp dress solve (topological)");
        let [b_lo, b_hi] = self.b_range_mm;
        r.paragraph(&format!(
            "{} positions over b = {b_lo} .. {b_hi} mm; dK(nu_zS) is the natural cubic spline through them, held beyond the ends.",
            self.positions.len()
        ));
        r.chart(&self.program_chart())?;
        let mut map = Chart::new(
            "Dressed worm f_nFS(w, b) (quasi-static), one line per b",
            "w [mm]",
            "f [um]",
        );
        for (j, b) in self.map_b_mm.iter().enumerate() {
            map = map.with(Series::line(
                format!("b {b:.2} mm"),
                self.map_w_mm
                    .iter()
                    .zip(self.map_f_um.iter())
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
        for (i, w) in self.map_w_mm.iter().enumerate().step_by(5) {
            across = across.with(Series::line(
                format!("w {w:.3} mm"),
                self.map_b_mm
                    .iter()
                    .zip(self.map_f_um[i].iter())
                    .map(|(b, f)| (*b, *f))
                    .collect(),
            ));
        }
        r.chart(&across)?;
        Ok(r)
    }

    /// ΔK(ν_zS) at 101 points between the extreme solved positions, and the solved Δγ.
    fn program_chart(&self) -> Chart {
        let (nu_lo, nu_hi) = self
            .positions
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.nu_zs_mm), b.max(p.nu_zs_mm))
            });
        let curve = |f: &dyn Fn(&AxisCorrection) -> f64| -> Vec<(f64, f64)> {
            stations(nu_lo, nu_hi, 100)
                .into_iter()
                .map(|nu| (nu, f(&self.schedule.at(nu))))
                .collect()
        };
        Chart::new("Dressing program dK(nu_zS)", "nu_zS [mm]", "dK")
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
                self.positions
                    .iter()
                    .map(|p| (p.nu_zs_mm, p.dgamma_deg))
                    .collect(),
            ))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::dresser::DresserSpec;
    use crate::request::{solve_request, SolveInput, DEFAULT_BUDGET_MM};

    /// G1-Z5 (docs/dressing.md "Reference case G1-Z5"): z_S = 5, d_S0 = 160 mm, m_n = 3 mm,
    /// α_n = 20°, gap-filling dresser d_A = 100 mm, jacket 0.8 mm.
    fn g1_z5() -> (Worm, Dresser) {
        let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
        let spec = DresserSpec {
            d_a_mm: 100.0,
            jacket_width_mm: 0.8,
            clearance_mm: 0.0,
        };
        let dresser = Dresser::design(&worm, spec).unwrap();
        (worm, dresser)
    }

    fn crowning_request(crowning_um: f64) -> SolveInput {
        SolveInput {
            flank: Flank::Right,
            method: Method::ThreePoint,
            diameter_mm: None,
            crowning_um: Some(crowning_um),
            points: None,
            budget_mm: DEFAULT_BUDGET_MM,
            accept_penetration: false,
        }
    }

    #[test]
    fn stations_span_the_interval_evenly() {
        let s = stations(-2.0, 3.0, 10);
        assert_eq!(s.len(), 11);
        assert_eq!((s[0], s[10]), (-2.0, 3.0));
        for (i, x) in s.iter().enumerate() {
            assert!((x - (-2.0 + 0.5 * i as f64)).abs() < 1e-15);
        }
    }

    #[test]
    fn design_summary_of_g1_z5() {
        let (worm, dresser) = g1_z5();
        let d = DesignSummary::new(worm, dresser.clone()).unwrap();
        // Lead = z_S · axial pitch = z_S · π m_n / cos γ; 2π·p by definition of p.
        assert!((d.lead_mm - 2.0 * std::f64::consts::PI * worm.p_mm).abs() < 1e-12);
        assert!((d.base_radius_mm - worm.r_b_mm).abs() < 1e-15);
        // 201 profile points from −u_max to +u_max.
        let u = dresser.u_max();
        assert_eq!(d.profile.len(), 201);
        assert!((d.profile[0].0 + u).abs() < 1e-12 && (d.profile[200].0 - u).abs() < 1e-12);
        assert!((d.profile[100].0).abs() < 1e-12);
        // The contact-line direction agrees with an ordinary least-squares slope of the
        // same points: w sin ρ + b cos ρ = X ⇒ db/dw = −tan ρ.
        let n = d.contact_line.len() as f64;
        let (mw, mb) = d
            .contact_line
            .iter()
            .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
        let (sxy, sxx) = d.contact_line.iter().fold((0.0, 0.0), |(xy, xx), p| {
            (xy + (p.0 - mw) * (p.1 - mb), xx + (p.0 - mw) * (p.0 - mw))
        });
        let rho_deg = (-sxy / sxx).atan().to_degrees();
        assert!(
            (rho_deg - d.contact_line_direction_deg).abs() < 0.05,
            "{rho_deg} vs {}",
            d.contact_line_direction_deg
        );
        let text = d.text();
        assert_eq!(text.lines().count(), 4);
        assert!(text.contains(&format!("lead {:.5} mm", d.lead_mm)));
        // The renderer-only fields stay out of the JSON.
        let v = serde_json::to_value(&d).unwrap();
        assert_eq!(v.as_object().unwrap().len(), 12);
        assert!(v.get("contact_line").is_none() && v.get("dresser_d_a_mm").is_none());
    }

    #[test]
    fn solve_summary_in_micrometres_and_through_the_contact_point() {
        let (worm, dresser) = g1_z5();
        let outcome = solve_request(&worm, &dresser, &crowning_request(0.2)).unwrap();
        let s = SolveSummary::new(
            &outcome,
            Method::ThreePoint,
            Flank::Right,
            Some((0.5, 20.0)),
        )
        .unwrap();
        // 21 stations w_Nf + (w_Na − w_Nf)·i/20; f re-evaluated here from the setup in mm.
        let (w_nf, w_na) = outcome.active_mm;
        assert_eq!(s.profile_um.len(), 21);
        assert_eq!(s.profile_um[0].0, w_nf);
        assert!((s.profile_um[20].0 - w_na).abs() < 1e-12);
        let ws: Vec<f64> = s.profile_um.iter().map(|p| p.0).collect();
        let f_mm = outcome
            .setup
            .profile(Flank::Right, &ws, &outcome.solution.dk)
            .unwrap();
        for (p, f) in s.profile_um.iter().zip(&f_mm) {
            assert!((p.1 - 1000.0 * f).abs() < 1e-9);
        }
        assert!(s.budget_um == 100.0 && !s.penetration && !s.undercut);
        assert!(
            (s.dgamma_deg - outcome.solution.dk.dgamma_rad * 180.0 / std::f64::consts::PI).abs()
                < 1e-12
        );
        // The moved contact line passes (w0, b0): w0 is the mid station.
        let cp = s.contact_point.as_ref().unwrap();
        assert!((cp.w_mm - 0.5 * (w_nf + w_na)).abs() < 1e-12);
        let (w, b) = cp.contact_line[10];
        assert!(
            (w - cp.w_mm).abs() < 1e-12 && (b - 20.0).abs() < 1e-9,
            "{w} {b}"
        );
        for ((w0, b0), (w1, b1)) in s.contact_line.iter().zip(&cp.contact_line) {
            assert_eq!(w0, w1);
            assert!((b0 - b1 - cp.nu_zs_mm).abs() < 1e-12);
        }
        let text = s.text();
        // Header, ΔK, axes, column names, 11 profile rows, clearances, contact point (2).
        assert_eq!(text.lines().count(), 4 + 11 + 1 + 2, "{text}");
        assert!(text.starts_with("ThreePoint on the Right flank, worm d_S = 160 mm"));
        let err = SolveSummary::new(&outcome, Method::ThreePoint, Flank::Right, Some((1.5, 0.0)))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("contact_point.w_fraction = 1.5") && err.contains("0 ..= 1"),
            "{err}"
        );
        let err = SolveSummary::new(
            &outcome,
            Method::ThreePoint,
            Flank::Right,
            Some((0.5, f64::NAN)),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("contact_point.b_mm = NaN"), "{err}");
    }

    #[test]
    fn machine_axes_in_degrees() {
        let (worm, dresser) = g1_z5();
        let setup = DressingSetup::new(worm, dresser);
        let dk = AxisCorrection {
            dgamma_rad: 0.01,
            ..AxisCorrection::default()
        };
        let a = setup.machine_axes_at(&dk, 3.0).unwrap();
        let d = MachineAxesDeg::at(&setup, &dk, 3.0).unwrap();
        let deg = 180.0 / std::f64::consts::PI;
        assert!((d.b1_deg - a.b1_rad * deg).abs() < 1e-12);
        assert!((d.a1_deg - a.a1_rad * deg).abs() < 1e-12);
        assert_eq!((d.v1_mm, d.x1_mm, d.z1_mm), (a.v1_mm, a.x1_mm, a.z1_mm));
    }
}
