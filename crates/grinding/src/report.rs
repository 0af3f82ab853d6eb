//! The record of a grinding run and its text tables: what `gearcomp grind` prints.
//!
//! [`GrindReport`] is one `simulate` or `solve` run (contact path, diagonal ratio, worm and
//! wanted modification, the ground (w, z) map against the analytic map, ISO 1328-1 of the
//! ground flank, flagged points, warnings); [`EqualiseReport`] is one `equalise` run. Both
//! serialise to the command's JSON and render as its text table ([`GrindReport::to_table`],
//! [`EqualiseReport::to_table`]).
//!
//! Interface units: degrees for angles, µm for modifications (polynomial coefficients in
//! µm·mm⁻ᵏ), mm for lengths, converted by `gearcomp_geometry::units`. Exception kept for
//! copy-paste compatibility with `gearcomp dress` output: Δφ_S is in rad (`dphi_s_rad`).

use std::fmt::Write as _;

use gearcomp_geometry::units::{mm_to_um, rad_to_deg};
use serde::Serialize;

use crate::conical::ConicalPair;
use crate::contact::WormGearPair;
use crate::diagonal::LineMap;
use crate::envelope::{AnalyticTransfer, GroundFlank};
use crate::iso1328::{FlankEvaluation, MultiTraceEvaluation, OUT_OF_SCOPE};
use crate::kinematics::FeedCoupling;
use crate::modification::{FlankModification, LineModification, Poly};
use crate::solve::{IteratedSolve, IterationOptions};
use crate::Result;

/// Polynomial coefficients mm·mm⁻ᵏ → µm·mm⁻ᵏ.
pub fn poly_to_um(p: &Poly) -> Vec<f64> {
    p.0.iter().map(|&c| mm_to_um(c)).collect()
}

/// A line modification (25)/(26) at the interface.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LineModReport {
    /// Line direction ρ in degrees.
    pub rho_deg: f64,
    /// Centre roll distance w0 in mm.
    pub w0_mm: f64,
    /// F_C coefficients in µm·mm⁻ᵏ.
    pub c_um: Vec<f64>,
    /// F_L coefficients in µm·mm⁻ᵏ.
    pub l_um: Vec<f64>,
    /// F_Q coefficients in µm·mm⁻ᵏ.
    pub q_um: Vec<f64>,
}

impl LineModReport {
    /// The modification in interface units.
    pub fn from(m: &LineModification) -> Self {
        Self {
            rho_deg: rad_to_deg(m.rho_rad),
            w0_mm: m.w0_mm,
            c_um: poly_to_um(&m.c),
            l_um: poly_to_um(&m.l),
            q_um: poly_to_um(&m.q),
        }
    }
}

/// The contact path of the mesh.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathReport {
    /// The ground flank ("right" / "left").
    pub flank: &'static str,
    /// Centre distance d in mm.
    pub centre_distance_mm: f64,
    /// Crossing angle γ in degrees.
    pub crossing_deg: f64,
    /// C_Fw1 of (39).
    pub c_w1: f64,
    /// C_Fc1 of (39) in mm.
    pub c_c1_mm: f64,
    /// C_Fw2 of (40).
    pub c_w2: f64,
    /// C_Fc2 of (40) in mm.
    pub c_c2_mm: f64,
    /// dw1/dw2 along the contact path.
    pub dw1_dw2: f64,
    /// (R7) w1/cos β_b1 + w2/cos β_b2, constant on cylindrical chains only (null on conical).
    pub r7_sum_mm: Option<f64>,
    /// Direction ρ_KF of the contact line in degrees.
    pub rho_kf_deg: f64,
    /// Feed terms of the conical contact path (76)/(77)/(86) (conical chains only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conical: Option<ConicalPathReport>,
}

impl PathReport {
    /// The contact path of a cylindrical pair (chain (28)).
    pub fn cylindrical(p: &WormGearPair) -> PathReport {
        PathReport {
            flank: p.worm.flank.name(),
            centre_distance_mm: p.centre_distance_mm,
            crossing_deg: rad_to_deg(p.crossing_rad),
            c_w1: p.path.c_w1,
            c_c1_mm: p.path.c_c1_mm,
            c_w2: p.path.c_w2,
            c_c2_mm: p.path.c_c2_mm,
            dw1_dw2: p.path.a,
            r7_sum_mm: Some(p.path.r7_sum_mm),
            rho_kf_deg: rad_to_deg(p.rho_kf_rad()),
            conical: None,
        }
    }

    /// The contact path of a conical pair (chains (29)–(31)) with its feed terms.
    pub fn conical(pair: &ConicalPair) -> PathReport {
        let p = &pair.path;
        PathReport {
            flank: pair.worm.flank.name(),
            centre_distance_mm: pair.chain.centre_distance_mm,
            crossing_deg: rad_to_deg(pair.chain.crossing_rad),
            c_w1: p.c_w1,
            c_c1_mm: p.c_c1_mm,
            c_w2: p.c_w2,
            c_c2_mm: p.c_c2_mm,
            dw1_dw2: p.a,
            r7_sum_mm: None,
            rho_kf_deg: rad_to_deg(pair.rho_kf_rad()),
            conical: Some(ConicalPathReport {
                c_zv11: p.c_zv11,
                c_zv21: p.c_zv21,
                c_zv12: p.c_zv12,
                c_zv22: p.c_zv22,
                b_zv1: p.b_zv1,
                b_zv2: p.b_zv2,
                b_mm: p.b_mm,
            }),
        }
    }
}

/// Feed terms of (76)/(77)/(86) that a cylindrical chain does not have (or has as −1/0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConicalPathReport {
    /// C_FzV11.
    pub c_zv11: f64,
    /// C_FzV21.
    pub c_zv21: f64,
    /// C_FzV12.
    pub c_zv12: f64,
    /// C_FzV22.
    pub c_zv22: f64,
    /// Coefficient of z_V1 in (86).
    pub b_zv1: f64,
    /// Coefficient of z_V2 in (86).
    pub b_zv2: f64,
    /// Constant of (86) in mm.
    pub b_mm: f64,
}

/// The (w, z) maps of the ground flank.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapReport {
    /// Roll distances of the rows in mm.
    pub w_mm: Vec<f64>,
    /// Width positions of the columns in mm.
    pub z_mm: Vec<f64>,
    /// Ground f_Ft2 in µm, row per w, column per z.
    pub ground_um: Vec<Vec<f64>>,
    /// Analytic worm → gear map in µm.
    pub analytic_um: Vec<Vec<f64>>,
    /// Ground minus the design reference in µm.
    pub deviation_um: Vec<Vec<f64>>,
}

/// One `gearcomp grind simulate | solve` run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GrindReport {
    /// "simulate" or "solve".
    pub mode: &'static str,
    /// Worm cone angle ϑ1 in degrees (0 = cylindrical worm).
    pub worm_cone_deg: f64,
    /// Workpiece cone angle ϑ2 in degrees (0 = cylindrical gear).
    pub gear_cone_deg: f64,
    /// The contact path.
    pub path: PathReport,
    /// K_ZV1.
    pub diagonal_ratio: f64,
    /// z_V01 in mm.
    pub shift_offset_mm: f64,
    /// The line map X_F1 = k·X_F2 + c0, where it exists.
    pub line_map: Option<LineMap>,
    /// The worm modification given on the command line (None with --dress).
    pub worm_modification: Option<LineModReport>,
    /// The dressed worm (with --dress).
    pub dressed_worm: Option<DressedReport>,
    /// The wanted gear modification (solve).
    pub wanted_gear_modification: Option<LineModReport>,
    /// max |f_Ft2| in µm.
    pub max_abs_ground_um: f64,
    /// max |envelope − analytic map| in µm.
    pub max_abs_ground_minus_analytic_um: f64,
    /// max |ground − design| in µm.
    pub max_abs_deviation_um: f64,
    /// What the deviation is measured from.
    pub deviation_reference: &'static str,
    /// ISO 1328-1 at the middle profile and helix trace.
    pub iso1328: FlankEvaluation,
    /// ISO 1328-1 over three profile and three helix traces, against the design and against
    /// the unmodified flank, with the class achieved.
    pub iso1328_traces: TracesReport,
    /// Gear profile shift coefficient x.
    pub profile_shift: f64,
    /// Worm root and tip radii (mm) that bound the grinding thread (None on conical chains,
    /// where only the thread-turn bound applies).
    pub worm_radii_mm: Option<(f64, f64)>,
    /// Points whose envelope value is not explained by the analytic map and its second-order
    /// correction, or that the worm grinds with its tip or root edge.
    pub flagged_points: Vec<FlaggedPoint>,
    /// Warnings (also printed to stderr).
    pub warnings: Vec<String>,
    /// The iterated solve (solve on a cylindrical chain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solve: Option<SolveReport>,
    /// The (w, z) maps.
    pub map: MapReport,
}

/// ISO 1328-1 over three traces each way.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TracesReport {
    /// What "design" is: the wanted modification (solve) or the analytic worm → gear map of
    /// the given worm (simulate).
    pub design_reference: &'static str,
    /// Deviation from the design (intended modification removed).
    pub from_design: MultiTraceEvaluation,
    /// Deviation from the unmodified flank (involute helicoid / nominal beveloid flank).
    pub from_involute: MultiTraceEvaluation,
}

/// A grid point the analytic map does not explain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlaggedPoint {
    /// Roll distance in mm.
    pub w_mm: f64,
    /// Width position in mm.
    pub z_mm: f64,
    /// Envelope value in µm.
    pub ground_um: f64,
    /// Analytic map in µm.
    pub analytic_um: f64,
    /// Second-order model (analytic state's cut plus −½·gᵀH⁻¹g); None if it has no minimum.
    pub second_order_um: Option<f64>,
    /// Why it is flagged.
    pub reason: &'static str,
}

/// One simulation of the iterated solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IterationReport {
    /// 1 = the first-order worm.
    pub iteration: usize,
    /// max |ground − wish| in µm.
    pub max_abs_deviation_um: f64,
}

/// The iterated solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolveReport {
    /// Every envelope simulation; 1 = the first-order worm.
    pub iterations: Vec<IterationReport>,
    /// max |wish| in µm.
    pub wish_max_abs_um: f64,
    /// Remaining max |ground − wish| with the reported worm.
    pub remaining_um: f64,
    /// `remaining_um` in % of `wish_max_abs_um`.
    pub remaining_percent_of_wish: f64,
    /// Stopping rule: max(0.5 % of the wish, 0.01 µm).
    pub tolerance_um: f64,
    /// The stopping rule was met.
    pub converged: bool,
    /// The first-order worm (before the iteration).
    pub first_order_worm: LineModReport,
}

impl SolveReport {
    /// The report of an iterated solve run with `opts`.
    ///
    /// # Formula
    /// tolerance = max(rel_tol·max |wish|, abs_tol); remaining in % = 100·remaining/max |wish|
    /// (0 for no wish).
    pub fn new(it: &IteratedSolve, opts: &IterationOptions) -> SolveReport {
        let tol_mm = (opts.rel_tol * it.wish_max_abs_mm).max(opts.abs_tol_mm);
        SolveReport {
            iterations: it
                .iterations
                .iter()
                .map(|i| IterationReport {
                    iteration: i.iteration,
                    max_abs_deviation_um: mm_to_um(i.max_abs_deviation_mm),
                })
                .collect(),
            wish_max_abs_um: mm_to_um(it.wish_max_abs_mm),
            remaining_um: mm_to_um(it.remaining_mm),
            remaining_percent_of_wish: if it.wish_max_abs_mm > 0.0 {
                100.0 * it.remaining_mm / it.wish_max_abs_mm
            } else {
                0.0
            },
            tolerance_um: mm_to_um(tol_mm),
            converged: it.converged,
            first_order_worm: LineModReport::from(&it.first_order_worm),
        }
    }

    /// The warning of a solve that stopped above its tolerance (None if it converged).
    pub fn warning(&self) -> Option<String> {
        (!self.converged).then(|| {
            format!(
                "the iterated solve stopped at {:.4} µm remaining deviation ({:.3} % of the \
                 wish), above its tolerance {:.4} µm",
                self.remaining_um, self.remaining_percent_of_wish, self.tolerance_um
            )
        })
    }
}

/// Why a point is flagged: the worm grinds it with its tip or root edge.
pub const WORM_EDGE: &str = "the worm grinds this point with its tip or root edge";
/// Why a point is flagged: the envelope is not explained by the analytic map.
pub const NOT_EXPLAINED: &str = "envelope and analytic map differ beyond their second-order terms";

/// The ground flank compared, point by point, with the analytic worm → gear map (eq. (38))
/// and with the design.
///
/// The design is the wanted gear modification (solve), else the unmodified flank for the
/// deviation and the analytic map for `from_design_mm`.
#[derive(Debug, Clone, PartialEq)]
pub struct FlankComparison {
    /// The maps in µm.
    pub map: MapReport,
    /// Points the analytic map does not explain.
    pub flagged: Vec<FlaggedPoint>,
    /// max |ground| in mm.
    pub max_abs_ground_mm: f64,
    /// max |ground − analytic| in mm.
    pub max_abs_ground_minus_analytic_mm: f64,
    /// max |ground − wanted| in mm (wanted = 0 without one).
    pub max_abs_deviation_mm: f64,
    /// ground − wanted (0 without one) per grid point, w outer, in mm.
    pub deviation_mm: Vec<f64>,
    /// ground − design (wanted, else the analytic map) per grid point, in mm.
    pub from_design_mm: Vec<f64>,
    /// ground per grid point, in mm.
    pub ground_mm: Vec<f64>,
}

impl FlankComparison {
    /// Compares `ground` (ground with `worm` under `coupling` on `mesh`) with the analytic
    /// map and the wanted modification.
    ///
    /// # Errors
    /// The analytic map's error at a grid point.
    pub fn new<M: AnalyticTransfer + ?Sized>(
        mesh: &M,
        coupling: &FeedCoupling,
        worm: &dyn FlankModification,
        ground: &GroundFlank,
        wanted: Option<&LineModification>,
    ) -> Result<FlankComparison> {
        let g = ground.grid;
        let mut c = FlankComparison {
            map: MapReport {
                w_mm: (0..g.n_w).map(|i| g.w_mm(i)).collect(),
                z_mm: (0..g.n_z).map(|j| g.z_mm(j)).collect(),
                ground_um: Vec::with_capacity(g.n_w),
                analytic_um: Vec::with_capacity(g.n_w),
                deviation_um: Vec::with_capacity(g.n_w),
            },
            flagged: Vec::new(),
            max_abs_ground_mm: 0.0,
            max_abs_ground_minus_analytic_mm: 0.0,
            max_abs_deviation_mm: 0.0,
            deviation_mm: Vec::with_capacity(g.len()),
            from_design_mm: Vec::with_capacity(g.len()),
            ground_mm: Vec::with_capacity(g.len()),
        };
        for i in 0..g.n_w {
            let (mut rg, mut ra, mut rd) = (Vec::new(), Vec::new(), Vec::new());
            for j in 0..g.n_z {
                let (w, z) = (g.w_mm(i), g.z_mm(j));
                let an = mesh.predicted_gear_f_ft_mm(coupling, worm, w, z)?;
                let (f, design) = c.add_point(ground, (i, j), an, wanted);
                rg.push(mm_to_um(f));
                ra.push(mm_to_um(an));
                rd.push(mm_to_um(f - design));
            }
            c.map.ground_um.push(rg);
            c.map.analytic_um.push(ra);
            c.map.deviation_um.push(rd);
        }
        Ok(c)
    }

    /// Adds grid point (i, j) with analytic value `an` (mm); returns (ground, wanted) in mm.
    fn add_point(
        &mut self,
        ground: &GroundFlank,
        (i, j): (usize, usize),
        an: f64,
        wanted: Option<&LineModification>,
    ) -> (f64, f64) {
        let (w, z) = (ground.grid.w_mm(i), ground.grid.z_mm(j));
        let gp = ground.at(i, j);
        let f = gp.f_ft_mm;
        let design = wanted.map_or(0.0, |m| m.f_ft_mm(w, z));
        self.deviation_mm.push(f - design);
        self.from_design_mm
            .push(f - wanted.map_or(an, |m| m.f_ft_mm(w, z)));
        self.ground_mm.push(f);
        if !gp.explained {
            self.flagged.push(FlaggedPoint {
                w_mm: w,
                z_mm: z,
                ground_um: mm_to_um(f),
                analytic_um: mm_to_um(an),
                second_order_um: gp.second_order_f_ft_mm.map(mm_to_um),
                reason: if gp.worm_edge {
                    WORM_EDGE
                } else {
                    NOT_EXPLAINED
                },
            });
        }
        self.max_abs_ground_mm = self.max_abs_ground_mm.max(f.abs());
        self.max_abs_ground_minus_analytic_mm =
            self.max_abs_ground_minus_analytic_mm.max((f - an).abs());
        self.max_abs_deviation_mm = self.max_abs_deviation_mm.max((f - design).abs());
        (f, design)
    }

    /// One warning per reason with flagged points: their count and the first point.
    pub fn flag_warnings(&self) -> Vec<String> {
        let n = self.map.w_mm.len() * self.map.z_mm.len();
        let mut warnings = Vec::new();
        for reason in [WORM_EDGE, NOT_EXPLAINED] {
            let pts: Vec<&FlaggedPoint> =
                self.flagged.iter().filter(|p| p.reason == reason).collect();
            if let Some(p) = pts.first() {
                warnings.push(format!(
                    "{} of {n} points: {reason} (first at w = {:.4} mm, z = {:.4} mm: envelope \
                     {:.4} µm, analytic {:.4} µm); see flagged_points",
                    pts.len(),
                    p.w_mm,
                    p.z_mm,
                    p.ground_um,
                    p.analytic_um
                ));
            }
        }
        warnings
    }
}

impl MapReport {
    /// Index of the grid value nearest to `x` (the first of equals).
    pub fn nearest(v: &[f64], x: f64) -> usize {
        v.iter()
            .enumerate()
            .fold((0, f64::INFINITY), |(bi, bd), (i, y)| {
                let d = (y - x).abs();
                if d < bd {
                    (i, d)
                } else {
                    (bi, bd)
                }
            })
            .0
    }

    /// Profile trace (w, value) of `values` (row per w) at column `j`.
    pub fn profile_trace(&self, values: &[Vec<f64>], j: usize) -> Vec<(f64, f64)> {
        self.w_mm
            .iter()
            .zip(values)
            .map(|(w, row)| (*w, row[j]))
            .collect()
    }

    /// Helix trace (z, value) of `values` at row `i`.
    pub fn helix_trace(&self, values: &[Vec<f64>], i: usize) -> Vec<(f64, f64)> {
        self.z_mm
            .iter()
            .zip(&values[i])
            .map(|(z, v)| (*z, *v))
            .collect()
    }

    /// Profile trace of envelope − analytic map at column `j`.
    pub fn envelope_minus_analytic_trace(&self, j: usize) -> Vec<(f64, f64)> {
        self.w_mm
            .iter()
            .zip(self.ground_um.iter().zip(&self.analytic_um))
            .map(|(w, (g, a))| (*w, g[j] - a[j]))
            .collect()
    }
}

/// The dressed worm of `grind simulate --dress`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DressedReport {
    /// The dress config file.
    pub config: String,
    /// The correction applied (given ΔK or the 3-point solve).
    pub correction: &'static str,
    /// Worm starts z_S.
    pub worm_starts: u32,
    /// Design diameter d_S0 in mm.
    pub worm_design_diameter_mm: f64,
    /// Present diameter d_S in mm.
    pub worm_diameter_mm: f64,
    /// Dresser diameter d_A in mm.
    pub dresser_diameter_mm: f64,
    /// ΔK: Δφ_S in rad.
    pub dphi_s_rad: f64,
    /// ΔK: Δγ in degrees.
    pub dgamma_deg: f64,
    /// ΔK: Δd in mm.
    pub dd_mm: f64,
    /// ΔK: Δν_yA in mm.
    pub dnu_ya_mm: f64,
    /// Newton iterations of the 3-point solve.
    pub newton_iterations: Option<usize>,
    /// Dresser contact-line direction ρ_F1 (37) in degrees.
    pub rho_f1_deg: f64,
    /// Axial-section estimate of ρ_F1 in degrees.
    pub rho_f1_axial_section_estimate_deg: f64,
    /// Dressed roll range of the worm in mm.
    pub dressed_roll_range_mm: (f64, f64),
    /// Dressed radius range of the worm in mm.
    pub dressed_radius_range_mm: (f64, f64),
    /// Worm roll range the gear uses in mm.
    pub used_roll_range_mm: (f64, f64),
    /// (w mm, f_nFS µm) of the dressed worm profile.
    pub profile_um: Vec<(f64, f64)>,
}

/// Polynomial coefficients as "c0, c1, …" in scientific notation ("0" if none).
pub fn fmt_poly(v: &[f64]) -> String {
    if v.is_empty() {
        "0".into()
    } else {
        v.iter()
            .map(|c| format!("{c:.6e}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// ISO 1328-1 rows (name, value µm, tolerance µm, within): F_α, f_fα, f_Hα, F_β, f_fβ, f_Hβ;
/// the slopes f_H are compared by magnitude. Tolerance and verdict are `None` for a gear
/// outside the standard's scope.
pub fn iso_rows(e: &FlankEvaluation) -> Vec<(&'static str, f64, Option<f64>, Option<bool>)> {
    let (p, h) = (&e.profile, &e.helix);
    let row = |name, v: f64, tol: Option<f64>| (name, v, tol, tol.map(|t| v.abs() <= t));
    let t = e.tolerances;
    vec![
        row("F_α", p.total_um, t.map(|t| t.total_alpha_t_um)),
        row("f_fα", p.form_um, t.map(|t| t.f_f_alpha_t_um)),
        row("f_Hα", p.slope_um, t.map(|t| t.f_h_alpha_t_um)),
        row("F_β", h.total_um, t.map(|t| t.total_beta_t_um)),
        row("f_fβ", h.form_um, t.map(|t| t.f_f_beta_t_um)),
        row("f_Hβ", h.slope_um, t.map(|t| t.f_h_beta_t_um)),
    ]
}

/// The chain of a run with cone angles: (29), (30) or (31); None for the cylindrical chain.
fn conical_chain(worm_cone_deg: f64, gear_cone_deg: f64) -> Option<&'static str> {
    match (worm_cone_deg != 0.0, gear_cone_deg != 0.0) {
        (false, false) => None,
        (true, false) => Some("(29), conical worm"),
        (false, true) => Some("(30), conical workpiece"),
        _ => Some("(31), conical worm and workpiece"),
    }
}

impl GrindReport {
    /// The text table of the run.
    pub fn to_table(&self) -> String {
        let mut t = String::new();
        self.setup_lines(&mut t);
        self.modification_lines(&mut t);
        self.iso_lines(&mut t);
        self.trace_lines(&mut t);
        self.closing_lines(&mut t);
        t
    }

    /// Title, cone angles, centre distance, contact path, diagonal ratio, line map.
    fn setup_lines(&self, t: &mut String) {
        let p = &self.path;
        let _ = writeln!(t, "gearcomp grind {} — {} flank", self.mode, p.flank);
        if let Some(chain) = conical_chain(self.worm_cone_deg, self.gear_cone_deg) {
            let _ = writeln!(
                t,
                "  cone angles: worm ϑ1 {:.6}°, gear ϑ2 {:.6}° (chain {chain})",
                self.worm_cone_deg, self.gear_cone_deg
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
        path_roll_lines(t, p);
        let _ = writeln!(
            t,
            "  diagonal ratio K_ZV1 {:.6}, shift offset z_V01 {:.3} mm",
            self.diagonal_ratio, self.shift_offset_mm
        );
        if let Some(lm) = &self.line_map {
            let _ = writeln!(
                t,
                "  line map X_F1 = {:.6}·X_F2 + {:.6} mm (ρ_F1 {:.4}°, ρ_F2 {:.4}°)",
                lm.k,
                lm.c0_mm,
                rad_to_deg(lm.rho1_rad),
                rad_to_deg(lm.rho2_rad)
            );
        }
    }

    /// Worm modification or dressed worm, wanted gear modification, ground-flank maxima.
    fn modification_lines(&self, t: &mut String) {
        if let Some(wm) = &self.worm_modification {
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
        if let Some(d) = &self.dressed_worm {
            d.table_lines(t);
        }
        if let Some(g) = &self.wanted_gear_modification {
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
            self.max_abs_ground_um,
            self.max_abs_ground_minus_analytic_um,
            self.deviation_reference,
            self.max_abs_deviation_um
        );
    }

    /// ISO 1328-1 of the middle traces, row by row, and the verdict.
    fn iso_lines(&self, t: &mut String) {
        let e = &self.iso1328;
        let _ = writeln!(
            t,
            "  ISO 1328-1:2013 {} (profile at z = {:.2} mm over w {:.3}…{:.3} mm; helix at w = {:.3} mm over z {:.3}…{:.3} mm)",
            e.tolerances
                .map_or("deviations".to_string(), |t| format!("class {}", t.class)),
            e.profile_z_mm,
            e.profile.range_mm.0,
            e.profile.range_mm.1,
            e.helix_w_mm,
            e.helix.range_mm.0,
            e.helix.range_mm.1
        );
        let _ = writeln!(t, "    {:<6} {:>10} {:>10}  ok", "", "value µm", "tol µm");
        for (name, v, tol, ok) in iso_rows(e) {
            let ok = ok.map_or("–", |ok| if ok { "yes" } else { "NO" });
            let tol = tol.map_or("–".to_string(), |tol| format!("{tol:.1}"));
            let _ = writeln!(t, "    {name:<6} {v:>10.3} {tol:>10}  {ok}");
        }
        let verdict = match e.within_tolerance {
            Some(true) => "within tolerance",
            Some(false) => "OUT of tolerance",
            None => OUT_OF_SCOPE,
        };
        let _ = writeln!(t, "  verdict: {verdict}");
    }

    /// ISO 1328-1 over three traces, from the design and from the unmodified flank, and the
    /// pitch line.
    fn trace_lines(&self, t: &mut String) {
        let tr = &self.iso1328_traces;
        let from_design = format!("from the design ({})", tr.design_reference);
        for (what, m) in [
            (from_design.as_str(), &tr.from_design),
            ("from the unmodified flank", &tr.from_involute),
        ] {
            let at = |v: Vec<f64>| {
                v.iter()
                    .map(|a| format!("{a:.2}"))
                    .collect::<Vec<_>>()
                    .join("/")
            };
            let _ = writeln!(
                t,
                "  ISO 1328-1, 3 profile traces (z {}) and 3 helix traces (w {}), deviation {what}:",
                at(m.profiles.iter().map(|p| p.at_mm).collect()),
                at(m.helices.iter().map(|p| p.at_mm).collect())
            );
            let (p, h) = (&m.profile_worst, &m.helix_worst);
            let _ = writeln!(
                t,
                "    F_α {:.3}  f_fα {:.3}  f_Hα {:.3}  F_β {:.3}  f_fβ {:.3}  f_Hβ {:.3} µm; class {}: {}; \
                 class achieved: {}",
                p.total_um,
                p.form_um,
                p.slope_um,
                h.total_um,
                h.form_um,
                h.slope_um,
                m.tolerances
                    .map_or("–".to_string(), |t| t.class.to_string()),
                match m.within_tolerance {
                    Some(true) => "within",
                    Some(false) => "OUT",
                    None => "no tolerances (outside ISO 1328-1's scope)",
                },
                match (m.tolerances, m.class_achieved) {
                    (None, _) => "–".to_string(),
                    (Some(_), c) => c.map_or("worse than 11".to_string(), |c| c.to_string()),
                }
            );
        }
        let _ = writeln!(t, "  {}", tr.from_design.pitch);
    }

    /// The iterated solve, the worm thread radii and the warnings.
    fn closing_lines(&self, t: &mut String) {
        if let Some(sv) = &self.solve {
            let steps = sv
                .iterations
                .iter()
                .map(|i| format!("{:.4}", i.max_abs_deviation_um))
                .collect::<Vec<_>>()
                .join(" → ");
            let _ =
                writeln!(
                t,
                "  iterated solve: {} simulation(s), max |ground − wish| {steps} µm; remaining \
                 {:.4} µm = {:.3} % of the wish {:.4} µm (tolerance {:.4} µm){}",
                sv.iterations.len(),
                sv.remaining_um,
                sv.remaining_percent_of_wish,
                sv.wish_max_abs_um,
                sv.tolerance_um,
                if sv.converged { "" } else { " — NOT converged" }
            );
        }
        if let Some((root, tip)) = self.worm_radii_mm {
            let _ = writeln!(t, "  worm thread between r = {root:.4} and {tip:.4} mm");
        }
        for w in &self.warnings {
            let _ = writeln!(t, "  WARNING: {w}");
        }
    }
}

/// The roll-distance relation of the path: (86) with its feed terms on a conical chain,
/// dw1/dw2 and the (R7) sum on a cylindrical one.
fn path_roll_lines(t: &mut String, p: &PathReport) {
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
}

impl DressedReport {
    /// The dressed profile (w mm, f_nFS µm) for the table: every ⌈(n − 1)/20⌉-th point and
    /// the last, so at most 21 rows (empty for an empty table).
    pub fn sample_profile_um(roll_mm: &[f64], f_mm: &[f64]) -> Vec<(f64, f64)> {
        let n = roll_mm.len().min(f_mm.len());
        let step = n.saturating_sub(1).div_ceil(20).max(1);
        roll_mm
            .iter()
            .zip(f_mm)
            .enumerate()
            .filter(|(i, _)| i % step == 0 || *i + 1 == n)
            .map(|(_, (w, v))| (*w, mm_to_um(*v)))
            .collect()
    }

    /// The dressed worm's lines of the run's table (set-up, ΔK, ranges, profile).
    pub fn table_lines(&self, t: &mut String) {
        let d = self;
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
}

/// Both flanks' diagonal ratio at one worm cone angle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlankK {
    /// Worm cone angle ϑ1 in degrees.
    pub cone1_deg: f64,
    /// K_ZV1 of the left flank.
    pub k_left: f64,
    /// K_ZV1 of the right flank.
    pub k_right: f64,
    /// Worm line direction ρ_l1 in degrees.
    pub rho1_left_deg: f64,
    /// Worm line direction ρ_r1 in degrees.
    pub rho1_right_deg: f64,
}

impl FlankK {
    /// From ϑ1 (rad) and (K_l, K_r, ρ_l1 rad, ρ_r1 rad).
    pub fn new(cone1_rad: f64, r: (f64, f64, f64, f64)) -> FlankK {
        FlankK {
            cone1_deg: rad_to_deg(cone1_rad),
            k_left: r.0,
            k_right: r.1,
            rho1_left_deg: rad_to_deg(r.2),
            rho1_right_deg: rad_to_deg(r.3),
        }
    }
}

/// One `gearcomp grind equalise` run (A6/T14).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EqualiseReport {
    /// "equalise".
    pub mode: &'static str,
    /// Gear cone angle ϑ2 in degrees.
    pub gear_cone_deg: f64,
    /// Wanted ρ_l2 in degrees.
    pub gear_rho_left_deg: f64,
    /// Wanted ρ_r2 in degrees.
    pub gear_rho_right_deg: f64,
    /// Where the worm line directions come from.
    pub worm_lines: &'static str,
    /// The searched ϑ1 range in degrees.
    pub cone_range_deg: (f64, f64),
    /// The equalising worm cone angle ϑ1.
    pub cone1_deg: f64,
    /// The common diagonal ratio (mean of the two flanks' values at ϑ1).
    pub k_zv1: f64,
    /// Both flanks at ϑ1.
    pub equalised: FlankK,
    /// Both flanks at the worm's present cone angle ([worm] cone_angle_deg).
    pub at_given_cone: FlankK,
}

impl EqualiseReport {
    /// The text table of the run.
    pub fn to_table(&self) -> String {
        let o = self;
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
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::flank::{Flank, Hand, InvoluteGear};

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
    }

    #[test]
    fn polynomials_in_micrometres() {
        // 1 mm = 1000 µm, per coefficient
        assert_eq!(poly_to_um(&Poly(vec![1e-3, -2.5e-6])), [1.0, -0.0025]);
        assert_eq!(fmt_poly(&[]), "0");
        assert_eq!(fmt_poly(&[1.0, -0.0025]), "1.000000e0, -2.500000e-3");
    }

    #[test]
    fn cylindrical_path_of_the_reference_pair() {
        let (a, b) = (20f64.to_radians(), 15f64.to_radians());
        let gear = InvoluteGear::new(31, 3.0, a, b).unwrap();
        let worm = InvoluteGear::worm(1, 3.0, a, 50.0, Hand::Right).unwrap();
        let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
        let p = PathReport::cylindrical(&pair);
        // reference setting: d = r1 + r2 with r = z·m_n/(2·cos β), γ = −(β1 + β2)
        let beta1 = (3.0f64 / 100.0).acos();
        close(
            p.centre_distance_mm,
            50.0 + 31.0 * 3.0 / (2.0 * b.cos()),
            1e-9,
        );
        close(p.crossing_deg, -(beta1 + b).to_degrees(), 1e-9);
        assert_eq!(p.flank, "right");
        assert!(p.r7_sum_mm.is_some() && p.conical.is_none());
        let t = path_table(&p);
        assert!(t.contains("roll distances: dw1/dw2"), "{t}");
    }

    fn path_table(p: &PathReport) -> String {
        let mut t = String::new();
        path_roll_lines(&mut t, p);
        t
    }

    #[test]
    fn chain_names_follow_the_cone_angles() {
        assert_eq!(conical_chain(0.0, 0.0), None);
        assert_eq!(conical_chain(2.0, 0.0), Some("(29), conical worm"));
        assert_eq!(conical_chain(0.0, -3.0), Some("(30), conical workpiece"));
        assert_eq!(
            conical_chain(1.0, 1.0),
            Some("(31), conical worm and workpiece")
        );
    }

    #[test]
    fn equalise_table_in_degrees() {
        let q = std::f64::consts::FRAC_PI_4;
        let f = FlankK::new(q, (1.5, -0.5, -q, 2.0 * q));
        assert_eq!(
            (f.cone1_deg, f.rho1_left_deg, f.rho1_right_deg),
            (45.0, -45.0, 90.0)
        );
        let r = EqualiseReport {
            mode: "equalise",
            gear_cone_deg: 3.0,
            gear_rho_left_deg: -20.0,
            gear_rho_right_deg: 20.0,
            worm_lines: "axial-section estimate",
            cone_range_deg: (-15.0, 15.0),
            cone1_deg: 45.0,
            k_zv1: 0.5,
            equalised: f.clone(),
            at_given_cone: f,
        };
        let t = r.to_table();
        assert!(t.contains("  worm cone ϑ1 = 45.000000°\n"), "{t}");
        assert!(t.contains("searched ϑ1 in [-15°, 15°]"), "{t}");
        let row = format!(
            "  {:<22} {:>12} {:>12} {:>12} {:>12} {:>12}",
            "equalised", "45.000000", "1.500000", "-0.500000", "-45.000000", "90.000000"
        );
        assert!(t.contains(&row), "{t}");
    }

    #[test]
    fn comparison_of_a_hand_made_ground_flank() {
        use crate::envelope::{FlankGrid, GroundFlank};
        use crate::modification::Uniform;
        let (a, b) = (20f64.to_radians(), 15f64.to_radians());
        let gear = InvoluteGear::new(31, 3.0, a, b).unwrap();
        let worm = InvoluteGear::worm(1, 3.0, a, 50.0, Hand::Right).unwrap();
        let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
        let cpl = FeedCoupling::linear(0.0, 0.0).unwrap();
        // a uniform worm stock u maps to f_Ft2 = −(cos β_b1/cos β_b2)·u everywhere (eq. (38))
        let u = 0.004;
        let an = -(pair.worm.beta_b_rad.cos() / pair.gear.beta_b_rad.cos()) * u;
        let grid = FlankGrid::new((40.0, 44.0), (-5.0, 5.0), 3, 2).unwrap();
        let mut ground = GroundFlank::new(grid);
        for p in &mut ground.points {
            p.f_ft_mm = an;
            p.explained = true;
        }
        // one point (i = 1, j = 0) 2 µm off and not explained
        ground.points[2].f_ft_mm = an + 0.002;
        ground.points[2].explained = false;
        let wanted =
            LineModification::new(0.0, 42.0, Poly(vec![0.001]), Poly(vec![]), Poly(vec![]))
                .unwrap();
        let worm_mod = Uniform { f_ft_mm: u };
        let c = FlankComparison::new(&pair, &cpl, &worm_mod, &ground, Some(&wanted)).unwrap();
        assert_eq!(
            (c.map.w_mm.clone(), c.map.z_mm.clone()),
            (vec![40.0, 42.0, 44.0], vec![-5.0, 5.0])
        );
        for row in &c.map.analytic_um {
            for v in row {
                close(*v, an * 1e3, 1e-9);
            }
        }
        close(c.max_abs_ground_minus_analytic_mm, 0.002, 1e-15);
        close(c.max_abs_ground_mm, (an + 0.002).abs().max(an.abs()), 1e-15);
        // the wanted modification is 1 µm everywhere
        close(
            c.max_abs_deviation_mm,
            (an + 0.002 - 0.001).abs().max((an - 0.001).abs()),
            1e-15,
        );
        close(c.deviation_mm[2], an + 0.002 - 0.001, 1e-15);
        close(c.from_design_mm[0], an - 0.001, 1e-15);
        close(c.map.deviation_um[1][0], (an + 0.002 - 0.001) * 1e3, 1e-12);
        assert_eq!(c.flagged.len(), 1);
        let f = &c.flagged[0];
        assert_eq!((f.w_mm, f.z_mm, f.reason), (42.0, -5.0, NOT_EXPLAINED));
        let w = c.flag_warnings();
        assert_eq!(w.len(), 1);
        assert!(
            w[0].starts_with("1 of 6 points: envelope and analytic map differ"),
            "{w:?}"
        );
        // without a wanted modification the design is the analytic map
        let c = FlankComparison::new(&pair, &cpl, &worm_mod, &ground, None).unwrap();
        close(c.from_design_mm[2], 0.002, 1e-15);
        close(c.deviation_mm[2], an + 0.002, 1e-15);
        // traces of the map
        assert_eq!(MapReport::nearest(&c.map.w_mm, 42.9), 1);
        assert_eq!(MapReport::nearest(&c.map.w_mm, 43.1), 2);
        let trace = c.map.envelope_minus_analytic_trace(0);
        assert_eq!(trace.len(), 3);
        close(trace[1].1, 2.0, 1e-9);
        close(trace[0].1, 0.0, 1e-12);
        let helix = c.map.helix_trace(&c.map.ground_um, 1);
        assert_eq!((helix[0].0, helix[1].0), (-5.0, 5.0));
    }

    #[test]
    fn dressed_profile_is_sampled_to_21_rows_with_the_last() {
        // 45 points: step ⌈44/20⌉ = 3 → indices 0, 3, …, 42 (15 rows) and the last, 44
        let w: Vec<f64> = (0..45).map(f64::from).collect();
        let f: Vec<f64> = w.iter().map(|x| x * 1e-4).collect();
        let s = DressedReport::sample_profile_um(&w, &f);
        let idx: Vec<f64> = s.iter().map(|p| p.0).collect();
        let mut want: Vec<f64> = (0..15).map(|i| f64::from(3 * i)).collect();
        want.push(44.0);
        assert_eq!(idx, want);
        close(s[1].1, 0.3, 1e-12);
        // 21 points: every point
        assert_eq!(
            DressedReport::sample_profile_um(&w[..21], &f[..21]).len(),
            21
        );
        assert!(DressedReport::sample_profile_um(&[], &[]).is_empty());
        assert_eq!(
            DressedReport::sample_profile_um(&[1.0], &[0.0]),
            [(1.0, 0.0)]
        );
    }
}
