//! What `gearcomp grind` prints: the output records (JSON) and the text tables.

use std::fmt::Write as _;

use super::*;

#[derive(Debug, Serialize)]
pub(super) struct LineModOut {
    pub(super) rho_deg: f64,
    pub(super) w0_mm: f64,
    pub(super) c_um: Vec<f64>,
    pub(super) l_um: Vec<f64>,
    pub(super) q_um: Vec<f64>,
}

impl LineModOut {
    pub(super) fn from(m: &LineModification) -> Self {
        Self {
            rho_deg: rad_to_deg(m.rho_rad),
            w0_mm: m.w0_mm,
            c_um: poly_to_um(&m.c),
            l_um: poly_to_um(&m.l),
            q_um: poly_to_um(&m.q),
        }
    }
}

#[derive(Debug, Serialize)]
pub(super) struct PathOut {
    pub(super) flank: &'static str,
    pub(super) centre_distance_mm: f64,
    pub(super) crossing_deg: f64,
    pub(super) c_w1: f64,
    pub(super) c_c1_mm: f64,
    pub(super) c_w2: f64,
    pub(super) c_c2_mm: f64,
    pub(super) dw1_dw2: f64,
    /// (R7) w1/cos β_b1 + w2/cos β_b2, constant on cylindrical chains only (null on conical).
    pub(super) r7_sum_mm: Option<f64>,
    pub(super) rho_kf_deg: f64,
    /// Feed terms of the conical contact path (76)/(77)/(86) (conical chains only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) conical: Option<ConicalPathOut>,
}

/// Feed terms of (76)/(77)/(86) that a cylindrical chain does not have (or has as −1/0).
#[derive(Debug, Serialize)]
pub(super) struct ConicalPathOut {
    pub(super) c_zv11: f64,
    pub(super) c_zv21: f64,
    pub(super) c_zv12: f64,
    pub(super) c_zv22: f64,
    pub(super) b_zv1: f64,
    pub(super) b_zv2: f64,
    pub(super) b_mm: f64,
}

#[derive(Debug, Serialize)]
pub(super) struct MapOut {
    pub(super) w_mm: Vec<f64>,
    pub(super) z_mm: Vec<f64>,
    /// Row per w, column per z.
    pub(super) ground_um: Vec<Vec<f64>>,
    pub(super) analytic_um: Vec<Vec<f64>>,
    pub(super) deviation_um: Vec<Vec<f64>>,
}

#[derive(Debug, Serialize)]
pub(super) struct Output {
    pub(super) mode: &'static str,
    /// Worm cone angle ϑ1 in degrees (0 = cylindrical worm).
    pub(super) worm_cone_deg: f64,
    /// Workpiece cone angle ϑ2 in degrees (0 = cylindrical gear).
    pub(super) gear_cone_deg: f64,
    pub(super) path: PathOut,
    pub(super) diagonal_ratio: f64,
    pub(super) shift_offset_mm: f64,
    pub(super) line_map: Option<LineMap>,
    /// The worm modification given on the command line (None with --dress).
    pub(super) worm_modification: Option<LineModOut>,
    /// The dressed worm (with --dress).
    pub(super) dressed_worm: Option<DressedOut>,
    pub(super) wanted_gear_modification: Option<LineModOut>,
    pub(super) max_abs_ground_um: f64,
    pub(super) max_abs_ground_minus_analytic_um: f64,
    pub(super) max_abs_deviation_um: f64,
    pub(super) deviation_reference: &'static str,
    pub(super) iso1328: FlankEvaluation,
    /// ISO 1328-1 over three profile and three helix traces, against the design and against
    /// the unmodified flank, with the class achieved.
    pub(super) iso1328_traces: TracesOut,
    /// Gear profile shift coefficient x.
    pub(super) profile_shift: f64,
    /// Worm root and tip radii (mm) that bound the grinding thread (None on conical chains,
    /// where only the thread-turn bound applies).
    pub(super) worm_radii_mm: Option<(f64, f64)>,
    /// Points whose envelope value is not explained by the analytic map and its second-order
    /// correction, or that the worm grinds with its tip or root edge.
    pub(super) flagged_points: Vec<FlaggedPoint>,
    /// Warnings (also printed to stderr).
    pub(super) warnings: Vec<String>,
    /// The iterated solve (solve on a cylindrical chain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) solve: Option<SolveOut>,
    pub(super) map: MapOut,
}

#[derive(Debug, Serialize)]
pub(super) struct TracesOut {
    /// What "design" is: the wanted modification (solve) or the analytic worm → gear map of
    /// the given worm (simulate).
    pub(super) design_reference: &'static str,
    /// Deviation from the design (intended modification removed).
    pub(super) from_design: MultiTraceEvaluation,
    /// Deviation from the unmodified flank (involute helicoid / nominal beveloid flank).
    pub(super) from_involute: MultiTraceEvaluation,
}

#[derive(Debug, Serialize)]
pub(super) struct FlaggedPoint {
    pub(super) w_mm: f64,
    pub(super) z_mm: f64,
    pub(super) ground_um: f64,
    pub(super) analytic_um: f64,
    /// Second-order model (analytic state's cut plus −½·gᵀH⁻¹g); None if it has no minimum.
    pub(super) second_order_um: Option<f64>,
    pub(super) reason: &'static str,
}

#[derive(Debug, Serialize)]
pub(super) struct SolveIterationOut {
    pub(super) iteration: usize,
    pub(super) max_abs_deviation_um: f64,
}

#[derive(Debug, Serialize)]
pub(super) struct SolveOut {
    /// Every envelope simulation; 1 = the first-order worm.
    pub(super) iterations: Vec<SolveIterationOut>,
    pub(super) wish_max_abs_um: f64,
    /// Remaining max |ground − wish| with the reported worm.
    pub(super) remaining_um: f64,
    pub(super) remaining_percent_of_wish: f64,
    /// Stopping rule: max(0.5 % of the wish, 0.01 µm).
    pub(super) tolerance_um: f64,
    pub(super) converged: bool,
    /// The first-order worm (before the iteration).
    pub(super) first_order_worm: LineModOut,
}

#[derive(Debug, Serialize)]
pub(super) struct DressedOut {
    pub(super) config: String,
    pub(super) correction: &'static str,
    pub(super) worm_starts: u32,
    pub(super) worm_design_diameter_mm: f64,
    pub(super) worm_diameter_mm: f64,
    pub(super) dresser_diameter_mm: f64,
    pub(super) dphi_s_rad: f64,
    pub(super) dgamma_deg: f64,
    pub(super) dd_mm: f64,
    pub(super) dnu_ya_mm: f64,
    pub(super) newton_iterations: Option<usize>,
    pub(super) rho_f1_deg: f64,
    pub(super) rho_f1_axial_section_estimate_deg: f64,
    pub(super) dressed_roll_range_mm: (f64, f64),
    pub(super) dressed_radius_range_mm: (f64, f64),
    pub(super) used_roll_range_mm: (f64, f64),
    /// (w mm, f_nFS µm) of the dressed worm profile.
    pub(super) profile_um: Vec<(f64, f64)>,
}

pub(super) fn fmt_poly(v: &[f64]) -> String {
    if v.is_empty() {
        "0".into()
    } else {
        v.iter()
            .map(|c| format!("{c:.6e}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

pub(super) fn table(out: &Output) -> String {
    let mut t = String::new();
    let p = &out.path;
    let _ = writeln!(t, "gearcomp grind {} — {} flank", out.mode, p.flank);
    if out.worm_cone_deg != 0.0 || out.gear_cone_deg != 0.0 {
        let chain = match (out.worm_cone_deg != 0.0, out.gear_cone_deg != 0.0) {
            (true, false) => "(29), conical worm",
            (false, true) => "(30), conical workpiece",
            _ => "(31), conical worm and workpiece",
        };
        let _ = writeln!(
            t,
            "  cone angles: worm ϑ1 {:.6}°, gear ϑ2 {:.6}° (chain {chain})",
            out.worm_cone_deg, out.gear_cone_deg
        );
    }
    let _ = writeln!(
        t,
        "  centre distance {:.6} mm, crossing angle {:.6}°",
        p.centre_distance_mm, p.crossing_deg
    );
    let _ = writeln!(
        t,
        "  contact path: C_Fw1 {:.6}  C_Fc1 {:.6} mm  C_Fw2 {:.6}  C_Fc2 {:.6} mm",
        p.c_w1, p.c_c1_mm, p.c_w2, p.c_c2_mm
    );
    match (&p.conical, p.r7_sum_mm) {
        (Some(c), _) => {
            let _ = writeln!(
                t,
                "  feed terms: C_FzV11 {:.6}  C_FzV21 {:.6}  C_FzV12 {:.6}  C_FzV22 {:.6}",
                c.c_zv11, c.c_zv21, c.c_zv12, c.c_zv22
            );
            let _ = writeln!(
                t,
                "  roll distances (86): w1 = {:.6}·w2 + {:.6}·z_V1 + {:.6}·z_V2 + {:.6} mm; \
                 ρ_KF {:.6}°",
                p.dw1_dw2, c.b_zv1, c.b_zv2, c.b_mm, p.rho_kf_deg
            );
        }
        (None, r7) => {
            let _ = writeln!(
                t,
                "  roll distances: dw1/dw2 {:.6}, w1/cos β_b1 + w2/cos β_b2 = {:.6} mm; ρ_KF {:.6}°",
                p.dw1_dw2,
                r7.unwrap_or(f64::NAN),
                p.rho_kf_deg
            );
        }
    }
    let _ = writeln!(
        t,
        "  diagonal ratio K_ZV1 {:.6}, shift offset z_V01 {:.3} mm",
        out.diagonal_ratio, out.shift_offset_mm
    );
    if let Some(lm) = &out.line_map {
        let _ = writeln!(
            t,
            "  line map X_F1 = {:.6}·X_F2 + {:.6} mm (ρ_F1 {:.4}°, ρ_F2 {:.4}°)",
            lm.k,
            lm.c0_mm,
            rad_to_deg(lm.rho1_rad),
            rad_to_deg(lm.rho2_rad)
        );
    }
    if let Some(wm) = &out.worm_modification {
        let _ = writeln!(
            t,
            "  worm modification (ρ_F1 {:.4}°, w0 {:.4} mm): F_C [{}] F_L [{}] F_Q [{}] (µm·mm⁻ᵏ)",
            wm.rho_deg,
            wm.w0_mm,
            fmt_poly(&wm.c_um),
            fmt_poly(&wm.l_um),
            fmt_poly(&wm.q_um)
        );
    }
    if let Some(d) = &out.dressed_worm {
        dressed_table(&mut t, d);
    }
    if let Some(g) = &out.wanted_gear_modification {
        let _ = writeln!(
            t,
            "  wanted gear modification (ρ_F2 {:.4}°, w0 {:.4} mm): F_C [{}] F_L [{}] F_Q [{}]",
            g.rho_deg,
            g.w0_mm,
            fmt_poly(&g.c_um),
            fmt_poly(&g.l_um),
            fmt_poly(&g.q_um)
        );
    }
    let _ = writeln!(
        t,
        "  ground flank: max |f_Ft2| {:.4} µm; envelope − analytic map: max {:.4} µm; \
         deviation from {}: max {:.4} µm",
        out.max_abs_ground_um,
        out.max_abs_ground_minus_analytic_um,
        out.deviation_reference,
        out.max_abs_deviation_um
    );
    let e = &out.iso1328;
    let tl = &e.tolerances;
    let _ = writeln!(
        t,
        "  ISO 1328-1:2013 class {} (profile at z = {:.2} mm over w {:.3}…{:.3} mm; helix at w = {:.3} mm over z {:.3}…{:.3} mm)",
        tl.class,
        e.profile_z_mm,
        e.profile.range_mm.0,
        e.profile.range_mm.1,
        e.helix_w_mm,
        e.helix.range_mm.0,
        e.helix.range_mm.1
    );
    let _ = writeln!(t, "    {:<6} {:>10} {:>10}  ok", "", "value µm", "tol µm");
    for (name, v, tol, ok) in iso_rows(e) {
        let _ = writeln!(
            t,
            "    {:<6} {:>10.3} {:>10.1}  {}",
            name,
            v,
            tol,
            if ok { "yes" } else { "NO" }
        );
    }
    let _ = writeln!(
        t,
        "  verdict: {}",
        if e.within_tolerance {
            "within tolerance"
        } else {
            "OUT of tolerance"
        }
    );
    let tr = &out.iso1328_traces;
    for (what, m) in [
        (
            format!("from the design ({})", tr.design_reference),
            &tr.from_design,
        ),
        ("from the unmodified flank".to_string(), &tr.from_involute),
    ] {
        let _ = writeln!(
            t,
            "  ISO 1328-1, 3 profile traces (z {}) and 3 helix traces (w {}), deviation {what}:",
            m.profiles
                .iter()
                .map(|p| format!("{:.2}", p.at_mm))
                .collect::<Vec<_>>()
                .join("/"),
            m.helices
                .iter()
                .map(|p| format!("{:.2}", p.at_mm))
                .collect::<Vec<_>>()
                .join("/")
        );
        let _ = writeln!(
            t,
            "    F_α {:.3}  f_fα {:.3}  f_Hα {:.3}  F_β {:.3}  f_fβ {:.3}  f_Hβ {:.3} µm; class {}: {}; \
             class achieved: {}",
            m.profile_worst.total_um,
            m.profile_worst.form_um,
            m.profile_worst.slope_um,
            m.helix_worst.total_um,
            m.helix_worst.form_um,
            m.helix_worst.slope_um,
            m.tolerances.class,
            if m.within_tolerance { "within" } else { "OUT" },
            m.class_achieved
                .map_or("worse than 11".to_string(), |c| c.to_string())
        );
    }
    let _ = writeln!(t, "  {}", tr.from_design.pitch);
    if let Some(sv) = &out.solve {
        let _ =
            writeln!(
            t,
            "  iterated solve: {} simulation(s), max |ground − wish| {} µm; remaining {:.4} µm \
             = {:.3} % of the wish {:.4} µm (tolerance {:.4} µm){}",
            sv.iterations.len(),
            sv.iterations
                .iter()
                .map(|i| format!("{:.4}", i.max_abs_deviation_um))
                .collect::<Vec<_>>()
                .join(" → "),
            sv.remaining_um,
            sv.remaining_percent_of_wish,
            sv.wish_max_abs_um,
            sv.tolerance_um,
            if sv.converged { "" } else { " — NOT converged" }
        );
    }
    if let Some((root, tip)) = out.worm_radii_mm {
        let _ = writeln!(t, "  worm thread between r = {root:.4} and {tip:.4} mm");
    }
    for w in &out.warnings {
        let _ = writeln!(t, "  WARNING: {w}");
    }
    t
}

pub(super) fn dressed_table(t: &mut String, d: &DressedOut) {
    let _ = writeln!(
        t,
        "  dressed worm ({}): {} start(s), d_S0 {:.3} mm, d_S {:.3} mm, dresser d_A {:.3} mm, \
         correction: {}{}",
        d.config,
        d.worm_starts,
        d.worm_design_diameter_mm,
        d.worm_diameter_mm,
        d.dresser_diameter_mm,
        d.correction,
        d.newton_iterations
            .map_or(String::new(), |n| format!(" ({n} Newton iterations)"))
    );
    let _ = writeln!(
        t,
        "    ΔK: Δφ_S {:.6e} rad, Δγ {:.6}°, Δd {:.6} mm, Δν_yA {:.6} mm",
        d.dphi_s_rad, d.dgamma_deg, d.dd_mm, d.dnu_ya_mm
    );
    let _ = writeln!(
        t,
        "    dressed w {:.4}…{:.4} mm (r {:.4}…{:.4} mm); used by the gear w {:.4}…{:.4} mm; \
         ρ_F1 (37) {:.4}° (axial-section estimate {:.4}°)",
        d.dressed_roll_range_mm.0,
        d.dressed_roll_range_mm.1,
        d.dressed_radius_range_mm.0,
        d.dressed_radius_range_mm.1,
        d.used_roll_range_mm.0,
        d.used_roll_range_mm.1,
        d.rho_f1_deg,
        d.rho_f1_axial_section_estimate_deg
    );
    let _ = writeln!(t, "    {:>10} {:>12}", "w1 mm", "f_nFS µm");
    for (w, f) in &d.profile_um {
        let _ = writeln!(t, "    {w:>10.4} {f:>12.5}");
    }
}

pub(super) fn iso_rows(e: &FlankEvaluation) -> Vec<(&'static str, f64, f64, bool)> {
    let t = &e.tolerances;
    vec![
        (
            "F_α",
            e.profile.total_um,
            t.total_alpha_t_um,
            e.profile.total_um <= t.total_alpha_t_um,
        ),
        (
            "f_fα",
            e.profile.form_um,
            t.f_f_alpha_t_um,
            e.profile.form_um <= t.f_f_alpha_t_um,
        ),
        (
            "f_Hα",
            e.profile.slope_um,
            t.f_h_alpha_t_um,
            e.profile.slope_um.abs() <= t.f_h_alpha_t_um,
        ),
        (
            "F_β",
            e.helix.total_um,
            t.total_beta_t_um,
            e.helix.total_um <= t.total_beta_t_um,
        ),
        (
            "f_fβ",
            e.helix.form_um,
            t.f_f_beta_t_um,
            e.helix.form_um <= t.f_f_beta_t_um,
        ),
        (
            "f_Hβ",
            e.helix.slope_um,
            t.f_h_beta_t_um,
            e.helix.slope_um.abs() <= t.f_h_beta_t_um,
        ),
    ]
}

pub(super) fn emit(out: &Output, a: &SetupArgs) -> Result<()> {
    if let Some(path) = &a.report {
        write_report(out, path)?;
    }
    if a.json {
        for w in &out.warnings {
            eprintln!("warning: {w}");
        }
        println!("{}", serde_json::to_string_pretty(out)?);
    } else {
        print!("{}", table(out));
        if let Some(p) = &a.report {
            println!("  report: {}", p.display());
        }
    }
    Ok(())
}

#[derive(Debug, Serialize)]
pub(super) struct FlankKOut {
    pub(super) cone1_deg: f64,
    pub(super) k_left: f64,
    pub(super) k_right: f64,
    pub(super) rho1_left_deg: f64,
    pub(super) rho1_right_deg: f64,
}

#[derive(Debug, Serialize)]
pub(super) struct EqualiseOut {
    pub(super) mode: &'static str,
    pub(super) gear_cone_deg: f64,
    pub(super) gear_rho_left_deg: f64,
    pub(super) gear_rho_right_deg: f64,
    pub(super) worm_lines: &'static str,
    pub(super) cone_range_deg: (f64, f64),
    /// The equalising worm cone angle ϑ1.
    pub(super) cone1_deg: f64,
    /// The common diagonal ratio (mean of the two flanks' values at ϑ1).
    pub(super) k_zv1: f64,
    /// Both flanks at ϑ1.
    pub(super) equalised: FlankKOut,
    /// Both flanks at the worm's present cone angle ([worm] cone_angle_deg).
    pub(super) at_given_cone: FlankKOut,
}

pub(super) fn flank_k_out(cone1_rad: f64, r: (f64, f64, f64, f64)) -> FlankKOut {
    FlankKOut {
        cone1_deg: rad_to_deg(cone1_rad),
        k_left: r.0,
        k_right: r.1,
        rho1_left_deg: rad_to_deg(r.2),
        rho1_right_deg: rad_to_deg(r.3),
    }
}

pub(super) fn equalise_table(o: &EqualiseOut) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "gearcomp grind equalise: worm cone angle for two-flank diagonal grinding (A6/T14)"
    );
    let _ = writeln!(
        t,
        "  gear cone ϑ2 = {:.6}°, wanted ρ_l2 = {:.6}°, ρ_r2 = {:.6}°, worm lines: {}",
        o.gear_cone_deg, o.gear_rho_left_deg, o.gear_rho_right_deg, o.worm_lines
    );
    let _ = writeln!(
        t,
        "  searched ϑ1 in [{}°, {}°]",
        o.cone_range_deg.0, o.cone_range_deg.1
    );
    let _ = writeln!(t, "  worm cone ϑ1 = {:.6}°", o.cone1_deg);
    let _ = writeln!(t, "  common K_ZV1 = {:.6}", o.k_zv1);
    let _ = writeln!(
        t,
        "  {:<22} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "", "ϑ1 [°]", "K_l", "K_r", "ρ_l1 [°]", "ρ_r1 [°]"
    );
    for (name, f) in [
        ("equalised", &o.equalised),
        ("given [worm] cone", &o.at_given_cone),
    ] {
        let _ = writeln!(
            t,
            "  {:<22} {:>12.6} {:>12.6} {:>12.6} {:>12.6} {:>12.6}",
            name, f.cone1_deg, f.k_left, f.k_right, f.rho1_left_deg, f.rho1_right_deg
        );
    }
    t
}
