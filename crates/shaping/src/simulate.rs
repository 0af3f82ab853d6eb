//! A cut in simulation: a constant-speed crank read through its encoder, the interpolator,
//! C1 and C2 servo models, and the evaluation of what the gear would get: the C2 tracking
//! error against the ideal coupling and the helix slope deviation f_Hβ against ISO 1328-1.
//!
//! Geometry fixed by this crate (docs/shaping.md): the facewidth is centred in the stroke;
//! the generated tooth trace at stroke position Z is g(Z) = C2/ρ − C1 (rad, workpiece), from
//! the mesh condition of the cutter and the workpiece; its deviation from the design trace
//! times the workpiece base radius is the transverse helix deviation.

use std::f64::consts::TAU;

use nalgebra::{DMatrix, DVector};

use crate::crank::MAX_CRANK_RADIUS_MM;
use crate::error::{check_range, Result, ShapingError};
use crate::interpolator::{Demands, Interpolator, InterpolatorConfig};
use crate::ratio::Ratio;
use crate::servo::{ServoAxis, ServoModel};
use gearcomp_geometry::iso1328::{
    helix_evaluation_range, round_tolerance_um, tolerances_unrounded,
};

/// What to simulate.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SimulationConfig {
    /// Interpolator set-up (validated again by the simulation).
    pub interp: InterpolatorConfig,
    /// C1 (workpiece) drive model; units rad.
    pub c1_servo: ServoModel,
    /// C2 (cutter) drive model; units rad.
    pub c2_servo: ServoModel,
    /// Double strokes to simulate; the last one is evaluated (1–100).
    pub strokes: u32,
    /// Facewidth b of the workpiece in mm (centred in the stroke).
    pub face_width_mm: f64,
    /// Normal pressure angle α_n in rad.
    pub pressure_angle_rad: f64,
    /// ISO 1328-1:2013 flank tolerance class (1–11).
    pub iso_class: u8,
}

/// One sample of the evaluated (last) stroke.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TracePoint {
    /// Time since the start of the evaluated stroke in s.
    pub t_s: f64,
    /// True crank angle θ in rad.
    pub theta_rad: f64,
    /// True stroke position Z in mm.
    pub z_mm: f64,
    /// True stroke velocity v_Z in mm/s.
    pub v_z_mm_s: f64,
    /// C2 error against the ideal coupling in rad.
    pub c2_error_rad: f64,
    /// Resulting transverse deviation at the workpiece base circle in µm.
    pub deviation_um: f64,
    /// X command in mm.
    pub x_mm: f64,
}

/// The helix the simulated cut would produce.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LeadEvaluation {
    /// Design lead of the workpiece π·m_n·Z_C1/sin β' in mm; None for a spur gear (a
    /// straight tooth trace has no lead).
    pub design_lead_mm: Option<f64>,
    /// Lead of the least-squares tooth trace in mm; None for a spur gear (the trace's
    /// residual slope is reported as f_Hβ instead).
    pub measured_lead_mm: Option<f64>,
    /// (measured − design)/design; None for a spur gear.
    pub lead_rel_error: Option<f64>,
    /// Helix evaluation length L_β in mm.
    pub evaluation_length_mm: f64,
    /// Helix slope deviation f_Hβ in µm (signed, transverse, at the base circle).
    pub f_h_beta_um: f64,
    /// ISO 1328-1 tolerance f_HβT, rounded, in µm; None when the gear is outside the
    /// standard's scope ([`iso1328_in_scope`]: the lead is simulated all the same).
    pub tolerance_um: Option<f64>,
    /// ISO 1328-1 tolerance f_HβT before rounding, in µm; None outside the scope.
    pub tolerance_unrounded_um: Option<f64>,
    /// Tolerance class used.
    pub iso_class: u8,
    /// |f_Hβ| ≤ f_HβT; None outside the scope (no verdict).
    pub within_tolerance: Option<bool>,
    /// Samples in the evaluation range.
    pub samples: usize,
}

/// Result of [`simulate`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct SimulationResult {
    /// Control cycles run.
    pub cycles: u64,
    /// Axis demands from the feasibility check.
    pub demands: Demands,
    /// Samples of the last stroke.
    pub trace: Vec<TracePoint>,
    /// Largest |C2 error| over the last stroke in rad.
    pub c2_error_max_rad: f64,
    /// RMS C2 error over the last stroke in rad.
    pub c2_error_rms_rad: f64,
    /// Largest |C2 error| in the cutting part of the last stroke (within the facewidth), rad.
    pub c2_error_cutting_max_rad: f64,
    /// Start of the facewidth in stroke coordinates, mm.
    pub face_start_mm: f64,
    /// End of the facewidth in stroke coordinates, mm.
    pub face_end_mm: f64,
    /// Lead and f_Hβ of the simulated cut.
    pub lead: LeadEvaluation,
}

/// True when a gear of reference diameter `d_mm` and normal module `m_n_mm` is inside the
/// scope of ISO 1328-1:2013 (clause 1: 5 ≤ d ≤ 15 000 mm, 0.5 ≤ m_n ≤ 70 mm; the facewidth
/// 4 ≤ b ≤ 1 200 mm holds for every accepted B), so that its f_HβT applies.
pub fn iso1328_in_scope(d_mm: f64, m_n_mm: f64) -> bool {
    (5.0..=15_000.0).contains(&d_mm) && (0.5..=70.0).contains(&m_n_mm)
}

/// Smallest overtravel of the cutter beyond each face of the workpiece, in mm.
pub const MIN_OVERTRAVEL_MM: f64 = 1.0;

/// Smallest facewidth B accepted, in mm (the lower end of ISO 1328-1:2013's scope).
pub const MIN_FACE_WIDTH_MM: f64 = 4.0;

/// Checks the parts of a simulation set-up the interpolator does not: strokes to simulate,
/// facewidth B against the stroke, pressure angle and the servo loops. [`simulate`] calls
/// it; a G83 block calls it when it is converted, so the error carries the block's line.
pub fn validate_simulation(cfg: &SimulationConfig) -> Result<()> {
    let stroke = cfg.interp.crank.stroke_mm();
    check_range(
        "strokes to simulate",
        f64::from(cfg.strokes),
        1.0,
        100.0,
        "",
    )?;
    // The smallest facewidth (4 mm, ISO 1328-1 scope) with its overtravel must fit in the
    // stroke 2R; a shorter stroke cannot cut any facewidth, so the crank radius is wrong.
    let min_radius_mm = 0.5 * (MIN_FACE_WIDTH_MM + 2.0 * MIN_OVERTRAVEL_MM);
    let r_mm = cfg.interp.crank.crank_radius_mm();
    if r_mm < min_radius_mm {
        return Err(ShapingError::OutOfRange {
            field: "crank radius R (the stroke 2R must hold the smallest facewidth, 4 mm, plus \
                    1 mm overtravel at each end)",
            value: r_mm,
            min: min_radius_mm,
            max: MAX_CRANK_RADIUS_MM,
            unit: "mm",
        });
    }
    check_range(
        "facewidth B",
        cfg.face_width_mm,
        MIN_FACE_WIDTH_MM,
        stroke - 2.0 * MIN_OVERTRAVEL_MM,
        "mm",
    )?;
    check_range(
        "ISO 1328-1 tolerance class (iso_class, --class)",
        f64::from(cfg.iso_class),
        1.0,
        11.0,
        "",
    )?;
    check_range(
        "pressure angle",
        cfg.pressure_angle_rad.to_degrees(),
        10.0,
        30.0,
        "deg",
    )?;
    for m in [cfg.c1_servo, cfg.c2_servo] {
        if let ServoModel::Loop(p) = m {
            p.validate()?;
        }
    }
    // Too few control cycles inside L_β (a short facewidth at a high S and a long cycle)
    // were found only by `simulate`, after conversion and at column 1.
    let n = helix_sample_count(cfg);
    if n < MIN_HELIX_SAMPLES {
        return Err(ShapingError::InsufficientData {
            what: HELIX_SAMPLES_WHAT,
            got: n,
            need: MIN_HELIX_SAMPLES,
        });
    }
    Ok(())
}

const HELIX_SAMPLES_WHAT: &str = "helix at S (control cycles inside the evaluation range of the \
     last cutting stroke; lower S or the cycle time, or widen the facewidth B)";

/// The control cycles a simulation runs and the helix evaluation range on the stroke.
struct Sampling {
    counts_per_cycle: f64,
    total_cycles: u64,
    last_start: u64,
    l_beta: f64,
    eval_lo: f64,
    eval_hi: f64,
}

fn sampling(cfg: &SimulationConfig) -> Sampling {
    let ic = cfg.interp;
    let stroke = ic.crank.stroke_mm();
    let cpr = f64::from(ic.crank_cpr);
    let counts_per_cycle = cpr * ic.strokes_per_min / 60.0 * ic.cycle_s;
    let cycles_per_stroke = cpr / counts_per_cycle;
    let (l_lo, l_hi) = helix_evaluation_range((0.0, cfg.face_width_mm), ic.cut.m_n_mm());
    let l_beta = l_hi - l_lo;
    let eval_lo = 0.5 * (stroke - l_beta);
    Sampling {
        counts_per_cycle,
        total_cycles: (f64::from(cfg.strokes) * cycles_per_stroke).ceil() as u64,
        last_start: ((f64::from(cfg.strokes) - 1.0) * cycles_per_stroke).ceil() as u64,
        l_beta,
        eval_lo,
        eval_hi: eval_lo + l_beta,
    }
}

/// Control cycles of the last simulated stroke that fall in the cutting stroke inside the
/// helix evaluation range: the samples [`simulate`] fits the lead and f_Hβ to (same
/// selection).
pub fn helix_sample_count(cfg: &SimulationConfig) -> usize {
    let s = sampling(cfg);
    let crank = cfg.interp.crank;
    let cpr = f64::from(cfg.interp.crank_cpr);
    (s.last_start..s.total_cycles)
        .filter(|&k| {
            let theta = TAU * (k as f64 * s.counts_per_cycle).rem_euclid(cpr) / cpr;
            let z = crank.z_mm(theta);
            theta <= std::f64::consts::PI && z >= s.eval_lo && z <= s.eval_hi
        })
        .count()
}

/// Least number of samples the helix fit needs.
pub const MIN_HELIX_SAMPLES: usize = 3;

/// Runs the simulation; the crank turns at exactly the nominal speed from θ = 0.
pub fn simulate(cfg: &SimulationConfig) -> Result<SimulationResult> {
    let mut interp = Interpolator::new(cfg.interp)?;
    validate_simulation(cfg)?;
    let ic = cfg.interp;
    let stroke = ic.crank.stroke_mm();
    let cut = ic.cut;
    let beta = cut.beta_rad();
    let d_mm = cut.m_n_mm() * f64::from(cut.z_c1()) / beta.cos();
    // Classes are checked by `validate_simulation`; outside the standard's d and m_n scope
    // there is no tolerance (fine-pitch Q < 0.5 mm, d < 5 mm or d > 15 000 mm were refused
    // after conversion, at column 1 and naming no G83 word, though the cut is valid).
    let tol_raw = if iso1328_in_scope(d_mm, cut.m_n_mm()) {
        Some(
            tolerances_unrounded(d_mm, cut.m_n_mm(), cfg.face_width_mm, cfg.iso_class)?
                .f_h_beta_t_um,
        )
    } else {
        None
    };
    // Base radius r_b = r·cos α_t, tan α_t = tan α_n / cos β (ISO 21771:2007, 5.2).
    let alpha_t = gearcomp_geometry::transverse_pressure_angle_rad(cfg.pressure_angle_rad, beta);
    let r_b1_mm = 0.5 * d_mm * alpha_t.cos();

    let rho = cut.generating_ratio().to_f64();
    let k_h = cut.helical_gain_rad_per_mm();
    let c1_scale = TAU / f64::from(ic.c1_cpr);
    let c2_scale = TAU / f64::from(ic.c2_cpr);
    let cpr = f64::from(ic.crank_cpr);
    let Sampling {
        counts_per_cycle,
        total_cycles,
        last_start,
        l_beta,
        eval_lo,
        eval_hi,
    } = sampling(cfg);
    let face_start = 0.5 * (stroke - cfg.face_width_mm);
    let face_end = face_start + cfg.face_width_mm;

    let first = interp.cycle(0);
    let mut c1 = ServoAxis::new(
        cfg.c1_servo,
        first.c1_counts.to_f64() * c1_scale,
        first.c1_vel_rad_s,
    );
    let mut c2 = ServoAxis::new(
        cfg.c2_servo,
        first.c2_counts() * c2_scale,
        first.c2_vel_rad_s,
    );
    let z0 = ic.crank.z_mm(0.0);
    let omega = interp.omega_nominal_rad_s();

    let mut trace = Vec::with_capacity((total_cycles - last_start + 1) as usize);
    let mut lead_z = Vec::new();
    let mut lead_g = Vec::new();
    let mut lead_dev = Vec::new();
    let (mut err_max, mut err_sq, mut err_cut_max) = (0.0f64, 0.0f64, 0.0f64);
    let mut out = first;
    for k in 0..total_cycles {
        let counts_true = k as f64 * counts_per_cycle;
        if k > 0 {
            let raw = (counts_true.floor() as i64).rem_euclid(i64::from(ic.crank_cpr));
            out = interp.cycle(u32::try_from(raw).unwrap_or(0));
        }
        let c1_act = c1.step(
            out.c1_counts.to_f64() * c1_scale,
            out.c1_vel_rad_s,
            0.0,
            ic.cycle_s,
        );
        let c2_act = c2.step(
            out.c2_counts() * c2_scale,
            out.c2_vel_rad_s,
            out.c2_acc_rad_s2,
            ic.cycle_s,
        );
        if k < last_start {
            continue;
        }
        let theta = TAU * counts_true.rem_euclid(cpr) / cpr;
        let z = ic.crank.z_mm(theta);
        let e = c2_act - rho * c1_act - k_h * (z - z0);
        let dev_um = e / rho * r_b1_mm * 1e3;
        err_max = err_max.max(e.abs());
        err_sq += e * e;
        let cutting = theta <= std::f64::consts::PI;
        if cutting && z >= face_start && z <= face_end {
            err_cut_max = err_cut_max.max(e.abs());
        }
        if cutting && z >= eval_lo && z <= eval_hi {
            lead_z.push(z);
            lead_g.push(c2_act / rho - c1_act);
            lead_dev.push(dev_um);
        }
        trace.push(TracePoint {
            t_s: (k - last_start) as f64 * ic.cycle_s,
            theta_rad: theta,
            z_mm: z,
            v_z_mm_s: ic.crank.velocity_mm_s(theta, omega),
            c2_error_rad: e,
            deviation_um: dev_um,
            x_mm: out.x_mm,
        });
    }

    let n = lead_z.len();
    if n < MIN_HELIX_SAMPLES {
        return Err(ShapingError::InsufficientData {
            what: HELIX_SAMPLES_WHAT,
            got: n,
            need: MIN_HELIX_SAMPLES,
        });
    }
    let g_slope = line_slope(&lead_z, &lead_g)?;
    let dev_slope = line_slope(&lead_z, &lead_dev)?;
    // A spur gear's trace is straight: no lead. TAU/|slope| of its residual slope would be a
    // meaningless huge number (4.9e20 mm was printed), so there is none.
    let design_lead = cut.workpiece_lead_mm();
    let (design_lead, measured_lead, lead_rel_error) = if design_lead.is_finite() {
        let measured = TAU / g_slope.abs();
        (
            Some(design_lead),
            Some(measured),
            Some((measured - design_lead) / design_lead),
        )
    } else {
        (None, None, None)
    };
    let f_hb = dev_slope * l_beta;
    let tol = tol_raw.map(round_tolerance_um);
    Ok(SimulationResult {
        cycles: total_cycles,
        demands: *interp.demands(),
        c2_error_rms_rad: (err_sq / trace.len().max(1) as f64).sqrt(),
        trace,
        c2_error_max_rad: err_max,
        c2_error_cutting_max_rad: err_cut_max,
        face_start_mm: face_start,
        face_end_mm: face_end,
        lead: LeadEvaluation {
            design_lead_mm: design_lead,
            measured_lead_mm: measured_lead,
            lead_rel_error,
            evaluation_length_mm: l_beta,
            f_h_beta_um: f_hb,
            tolerance_um: tol,
            tolerance_unrounded_um: tol_raw,
            iso_class: cfg.iso_class,
            within_tolerance: tol.map(|t| f_hb.abs() <= t),
            samples: n,
        },
    })
}

/// Slope of the least-squares line y = a + s·x, solved by QR (no normal equations).
///
/// The abscissa is centred first so the two columns are well conditioned.
pub fn line_slope(x: &[f64], y: &[f64]) -> Result<f64> {
    let n = x.len().min(y.len());
    if n < 2 {
        return Err(ShapingError::InsufficientData {
            what: "least-squares line",
            got: n,
            need: 2,
        });
    }
    let xm = x[..n].iter().sum::<f64>() / n as f64;
    let a = DMatrix::from_fn(n, 2, |i, j| if j == 0 { 1.0 } else { x[i] - xm });
    let b = DVector::from_column_slice(&y[..n]);
    let qr = a.qr();
    let qtb = qr.q().transpose() * b;
    let r = qr.r();
    let r11 = r[(1, 1)];
    if r11.abs() < f64::EPSILON * n as f64 {
        return Err(ShapingError::InsufficientData {
            what: "least-squares line (all abscissae equal)",
            got: 1,
            need: 2,
        });
    }
    Ok(qtb[1] / r11)
}

/// Summary of running a whole G83 cycle through the interpolator (no servo model).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ExecutionSummary {
    /// Double strokes run: to full depth, then one workpiece revolution.
    pub strokes: u64,
    /// Control cycles run.
    pub cycles: u64,
    /// Machining time in s at the nominal stroke rate.
    pub cut_time_s: f64,
    /// Workpiece revolutions turned.
    pub c1_revolutions: f64,
    /// Radial infeed reached in mm.
    pub x_infeed_mm: f64,
    /// Exact coupling residual: numerator of the reduced fraction
    /// C2_gen − ρ·(cpr_C2/cpr_C1)·C1 in C2 counts (0 = no drift), see [`coupling_residual`].
    pub coupling_residual: i128,
}

/// Largest number of control cycles [`execute_program`] runs.
pub const MAX_EXECUTION_CYCLES: u64 = 50_000_000;

/// Double strokes, control cycles and crank counts per cycle of a whole cycle, refused when
/// it would exceed [`MAX_EXECUTION_CYCLES`].
pub fn execution_plan(cfg: &InterpolatorConfig, ip: &Interpolator) -> Result<(u64, u64, f64)> {
    let infeed_strokes = if cfg.radial_feed_mm > 0.0 {
        (cfg.depth_mm / cfg.radial_feed_mm).ceil() as u64
    } else {
        0
    };
    let per = ip.c1_counts_per_stroke().unsigned_abs();
    let rev_strokes = if per > 0 {
        u64::from(cfg.c1_cpr).div_ceil(per)
    } else {
        1
    };
    let strokes = infeed_strokes + rev_strokes;
    let cpr = f64::from(cfg.crank_cpr);
    let counts_per_cycle = cpr * cfg.strokes_per_min / 60.0 * cfg.cycle_s;
    let cycles = (strokes as f64 * cpr / counts_per_cycle).ceil() as u64;
    if cycles > MAX_EXECUTION_CYCLES {
        return Err(ShapingError::OutOfRange {
            field: "control cycles of the whole cut (reduce X/U or raise F)",
            value: cycles as f64,
            min: 1.0,
            max: MAX_EXECUTION_CYCLES as f64,
            unit: "",
        });
    }
    Ok((strokes, cycles, counts_per_cycle))
}

/// The exact coupling residual of a whole cut: the numerator of the reduced fraction
/// C2_gen − ρ·(cpr_C2/cpr_C1)·C1 in C2 counts; 0 exactly when nothing drifted.
///
/// `c2_gen` and `c1` are exact positions (whole counts, remainder, denominator). Every product
/// is formed from reduced fractions with the common factors cancelled first (as
/// [`Ratio::checked_mul`] does), so the check stays within 128 bits for every accepted set-up;
/// the cross-multiplied form C2_gen·ρ_den·cpr_C1·den_C1 − ρ_num·cpr_C2·C1·den_C2 overflowed
/// i128 at valid encoder resolutions near 2^26 counts per revolution.
///
/// # Formula
/// r = C2_gen − ρ·(cpr_C2/cpr_C1)·C1, reduced; the residual is r's numerator.
pub fn coupling_residual(
    rho: Ratio,
    c1_cpr: u32,
    c2_cpr: u32,
    c2_gen: (i128, i128, i128),
    c1: (i128, i128, i128),
) -> Result<i128> {
    let exact = |(whole, rem, den): (i128, i128, i128), what: &'static str| {
        let den = den.max(1);
        whole
            .checked_mul(den)
            .and_then(|v| v.checked_add(rem))
            .ok_or_else(|| ShapingError::Overflow {
                what,
                detail: format!("{whole} + {rem}/{den} counts"),
            })
            .and_then(|num| Ratio::new(num, den))
    };
    let c2 = exact(c2_gen, "coupling check (C2 position)")?;
    let c1 = exact(c1, "coupling check (C1 position)")?;
    let expected = rho
        .checked_mul(Ratio::new(i128::from(c2_cpr), i128::from(c1_cpr))?)?
        .checked_mul(c1)?;
    if expected == c2 {
        return Ok(0);
    }
    // Drifted: the difference over the reduced common denominator.
    let overflow = || ShapingError::Overflow {
        what: "coupling check",
        detail: format!(
            "C2 = {}/{}, expected {}/{}",
            c2.numer(),
            c2.denom(),
            expected.numer(),
            expected.denom()
        ),
    };
    let g = crate::ratio::gcd(c2.denom(), expected.denom()).max(1);
    let a = c2
        .numer()
        .checked_mul(expected.denom() / g)
        .ok_or_else(overflow)?;
    let b = expected
        .numer()
        .checked_mul(c2.denom() / g)
        .ok_or_else(overflow)?;
    let den = (c2.denom() / g)
        .checked_mul(expected.denom())
        .ok_or_else(overflow)?;
    let diff = a.checked_sub(b).ok_or_else(overflow)?;
    Ok(Ratio::new(diff, den)?.numer())
}

/// Runs a whole cycle: strokes to reach the depth at the radial feed, then one full
/// workpiece revolution at depth, with the crank at nominal speed; checks the exact coupling
/// identity at the end.
///
/// # Formula
/// strokes = ⌈X/U⌉ + ⌈cpr_C1 / c1_per_stroke⌉ (F > 0: at least one C1 count per stroke);
/// residual = numerator of C2_gen − ρ·(cpr_C2/cpr_C1)·C1, reduced (exactly 0 when nothing
/// drifts; [`coupling_residual`]).
pub fn execute_program(cfg: &InterpolatorConfig) -> Result<ExecutionSummary> {
    let mut ip = Interpolator::new(*cfg)?;
    let (strokes, cycles, counts_per_cycle) = execution_plan(cfg, &ip)?;
    let mut out = ip.cycle(0);
    for k in 1..=cycles {
        let raw =
            ((k as f64 * counts_per_cycle).floor() as i64).rem_euclid(i64::from(cfg.crank_cpr));
        out = ip.cycle(u32::try_from(raw).unwrap_or(0));
    }
    let rho = cfg.cut.generating_ratio();
    let g = out.c2_generating_counts;
    let c1 = out.c1_counts;
    let residual = coupling_residual(
        rho,
        cfg.c1_cpr,
        cfg.c2_cpr,
        (i128::from(g.whole), g.rem, g.den),
        (i128::from(c1.whole), c1.rem, c1.den),
    )?;
    Ok(ExecutionSummary {
        strokes,
        cycles: cycles + 1,
        cut_time_s: cycles as f64 * cfg.cycle_s,
        c1_revolutions: c1.to_f64() / f64::from(cfg.c1_cpr),
        x_infeed_mm: out.x_infeed_mm,
        coupling_residual: residual,
    })
}
