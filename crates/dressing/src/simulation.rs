//! The full time-stepped dressing simulation on a (w, b) grid of normal vectors, and the
//! contact line worm–dresser.

use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::schedule::CorrectionSchedule;
use crate::worm::Flank;
use nalgebra::Vector3;

/// Grid and time step of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSpec {
    /// Flank to simulate.
    pub flank: Flank,
    /// Roll distances of the grid rows (mm).
    pub w_mm: Vec<f64>,
    /// Axial positions b of the grid columns (mm).
    pub b_mm: Vec<f64>,
    /// Worm rotation per time step (rad); the axial feed per step is p·Δt.
    pub dt_rad: f64,
    /// Initial vector length outside the nominal flank (mm), the stock.
    pub stock_mm: f64,
    /// Vector length inside the nominal flank (mm), room for negative modifications.
    pub inside_mm: f64,
    /// Abort when the worm reaches this axial position ν_zS* (mm): the contact line is then
    /// where the vectors switch from final to not yet final (Fig. 1). `None`: a full pass.
    pub stop_nu_zs_mm: Option<f64>,
}

/// State after a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimResult {
    /// Final signed vector end f per grid point [row][column] (mm, > 0 = material left).
    pub f_mm: Vec<Vec<f64>>,
    /// Dresser radius of the last cut per grid point (mm; NaN if never cut).
    pub r_a_mm: Vec<Vec<f64>>,
    /// Number of cuts per grid point.
    pub cuts: Vec<Vec<u32>>,
    /// Number of time steps.
    pub steps: usize,
    /// Vector–dresser tests done.
    pub tests: u64,
}

/// Runs the vector-shortening simulation with constant ΔK.
///
/// Every grid point of the unmodified flank carries a vector P + s n, s ∈ [−inside, stock].
/// At every time step the dresser pose is evaluated from chain (1) (φ_S = t + Δφ_S, ν_zS = p t)
/// and each vector whose end lies inside the dresser is shortened to the entry point; the
/// dresser radius at that point is stored.
///
/// # Source
/// JP6903407B2, dressing simulation, eqs. (8)–(10), Fig. 1 [SEED]; signed vectors docs/dressing.md "Derivation: screw reduction" [RECONSTRUCTED]
pub fn simulate(setup: &DressingSetup, spec: &SimSpec, dk: &AxisCorrection) -> Result<SimResult> {
    simulate_scheduled(setup, spec, dk)
}

/// Runs the vector-shortening simulation with a correction that varies with the worm's axial
/// position, ΔK(ν_zS) (topological dressing): at time t the dresser pose is chain (1) with
/// φ_S = t + Δφ_S(ν_zS), ν_zS = p t, γ_0 + Δγ(ν_zS), d_0 + Δd(ν_zS), ν_yA,0 + Δν_yA(ν_zS).
///
/// Nothing is assumed about how fast ΔK varies: the vectors are shortened by the true
/// time-stepped motion, so this is the reference for the quasi-static model of
/// [`crate::topology::quasi_static_point`].
///
/// # Formula
/// p_A = X(t)⁻¹ (R_z(t) q + p t e_z), X(t) = R_z(−Δφ_S)·R_x(−γ)·T_x(−d)·T_y(ν_yA) at ΔK(p t)
/// # Source
/// JP6903407B2, eqs. (8)–(10), Fig. 1; eqs. (15)–(17), Fig. 2 (ΔK over the width) [SEED]; time-varying
/// ΔK docs/dressing.md "Derivation: topological programs" [RECONSTRUCTED]
pub fn simulate_scheduled<S: CorrectionSchedule + ?Sized>(
    setup: &DressingSetup,
    spec: &SimSpec,
    schedule: &S,
) -> Result<SimResult> {
    DressError::check("dt_rad", spec.dt_rad, 1e-7, 0.1)?;
    DressError::check("stock_mm", spec.stock_mm, 1e-4, 5.0)?;
    DressError::check("inside_mm", spec.inside_mm, 0.0, 5.0)?;
    if spec.w_mm.is_empty() || spec.b_mm.is_empty() {
        return Err(DressError::OutOfRange {
            field: "grid size",
            value: 0.0,
            min: 1.0,
            max: f64::INFINITY,
        });
    }
    for &v in spec.w_mm.iter().chain(spec.b_mm.iter()) {
        DressError::check("grid coordinate (w_mm, b_mm)", v, -1e5, 1e5)?;
    }
    let worm = &setup.worm;
    let nw = spec.w_mm.len();
    let nb = spec.b_mm.len();
    // Time window: per row the envelope time at the axial section and the half-window in which
    // the stock can be touched; t*(w, b) = t*_ref − (b − b_ref)/p because the flank is
    // screw-invariant. A varying ΔK moves t* a little, so the window is the union over ΔK
    // sampled across the first estimate's axial range.
    let window = |dk: &AxisCorrection, lo: &mut f64, hi: &mut f64| -> Result<()> {
        for &w in &spec.w_mm {
            let d = setup.dress_point(spec.flank, w, dk)?;
            let b_ref = worm.b_axial_section(spec.flank, w);
            let reach = (spec.stock_mm - d.f_mm).max(0.0) + spec.inside_mm;
            let half = 1.5 * (2.0 * d.g_s.abs() * reach / d.g_tt).sqrt() + 2.0 * spec.dt_rad;
            for &b in &spec.b_mm {
                let ts = d.t_rad - (b - b_ref) / worm.p_mm;
                *lo = lo.min(ts - half);
                *hi = hi.max(ts + half);
            }
        }
        Ok(())
    };
    let mut t_lo = f64::INFINITY;
    let mut t_hi = f64::NEG_INFINITY;
    window(&schedule.at(0.0), &mut t_lo, &mut t_hi)?;
    if !schedule.is_constant() {
        let (a, b) = (t_lo, t_hi);
        for i in 0..=8 {
            let t = a + (b - a) * f64::from(i) / 8.0;
            window(&schedule.at(worm.p_mm * t), &mut t_lo, &mut t_hi)?;
        }
    }
    let k0 = (t_lo / spec.dt_rad).floor() as i64;
    let mut k1 = (t_hi / spec.dt_rad).ceil() as i64;
    if let Some(nu) = spec.stop_nu_zs_mm {
        k1 = k1.min((nu / worm.p_mm / spec.dt_rad).floor() as i64);
    }
    let mut pts = Vec::with_capacity(nw * nb);
    for &w in &spec.w_mm {
        for &b in &spec.b_mm {
            pts.push((worm.point(spec.flank, w, b), worm.normal(spec.flank, w, b)));
        }
    }
    let mut len = vec![spec.stock_mm; nw * nb];
    let mut ra = vec![f64::NAN; nw * nb];
    let mut cuts = vec![0u32; nw * nb];
    let mut tests = 0u64;
    let u_max = setup.dresser.u_max();
    let mut fr = setup.frame(&schedule.at(0.0));
    for k in k0..=k1 {
        let t = k as f64 * spec.dt_rad;
        if !schedule.is_constant() {
            fr = setup.frame(&schedule.at(worm.p_mm * t));
        }
        for (i, (p, n)) in pts.iter().enumerate() {
            tests += 1;
            let end = setup.g_eval(&fr, p, n, len[i], t);
            if end.g >= 0.0 || end.z_a.abs() > u_max {
                continue;
            }
            let s_star = entry_point(setup, &fr, p, n, -spec.inside_mm, len[i], t)?;
            len[i] = s_star;
            ra[i] = setup.g_eval(&fr, p, n, s_star, t).rho;
            cuts[i] += 1;
        }
    }
    let to_rows = |v: &[f64]| v.chunks(nb).map(<[f64]>::to_vec).collect::<Vec<_>>();
    Ok(SimResult {
        f_mm: to_rows(&len),
        r_a_mm: to_rows(&ra),
        cuts: cuts.chunks(nb).map(<[u32]>::to_vec).collect(),
        steps: (k1 - k0 + 1).max(0) as usize,
        tests,
    })
}

/// Entry point s* ∈ [s0, s1] of the segment into the dresser at time t (g(s0) > 0 ≥ g(s1)).
fn entry_point(
    setup: &DressingSetup,
    fr: &crate::envelope::ScrewFrame,
    p: &Vector3<f64>,
    n: &Vector3<f64>,
    s0: f64,
    s1: f64,
    t: f64,
) -> Result<f64> {
    let (mut lo, mut hi) = (s0, s1);
    if setup.g_eval(fr, p, n, lo, t).g <= 0.0 {
        return Err(DressError::OutOfRange {
            field: "inside_mm (dresser reaches below the vector start)",
            value: -s0,
            min: 0.0,
            max: -s0,
        });
    }
    // Newton from the cut end, kept inside the bracket; bisection as fallback.
    let mut s = hi;
    for _ in 0..60 {
        let e = setup.g_eval(fr, p, n, s, t);
        if e.g > 0.0 {
            lo = s;
        } else {
            hi = s;
        }
        let mut next = s - e.g / e.g_s;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - s).abs() < 1e-14 || hi - lo < 1e-14 {
            return Ok(next);
        }
        s = next;
    }
    Ok(0.5 * (lo + hi))
}

/// Contact line worm–dresser at ν_zS = 0 for constant ΔK: per roll distance, the axial position
/// b where the flank is being dressed, b_BwFS(w; 0, ΔK).
///
/// # Formula
/// b = b_ref(w) + p·t*(w), t* = envelope time of the axial-section point (eq. (8))
/// # Source
/// JP6903407B2, eq. (8) [SEED]
pub fn contact_line(
    setup: &DressingSetup,
    flank: Flank,
    ws_mm: &[f64],
    dk: &AxisCorrection,
) -> Result<Vec<(f64, f64)>> {
    ws_mm
        .iter()
        .map(|&w| {
            let d = setup.dress_point(flank, w, dk)?;
            Ok((
                w,
                setup.worm.b_axial_section(flank, w) + setup.worm.p_mm * d.t_rad,
            ))
        })
        .collect()
}

/// Straight-line fit of a contact line, eq. (9): w sin ρ + b cos ρ = X.
/// Returns (ρ_FS rad, X_FS mm, largest distance of a point from the line mm), by total least
/// squares (SVD of the centred points).
///
/// # Source
/// JP6903407B2, eq. (9) [SEED]
pub fn fit_contact_line(points: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = points.len() as f64;
    let (mw, mb) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (w, bb)| (a + w / n, b + bb / n));
    let m = nalgebra::DMatrix::from_fn(points.len(), 2, |i, j| {
        if j == 0 {
            points[i].0 - mw
        } else {
            points[i].1 - mb
        }
    });
    // The normal is the right singular vector of the smaller singular value (the last); with
    // fewer than two points, or a NaN among them, there is none and the line is b = const.
    let normal = gearcomp_linalg::Svd::new(&m)
        .ok()
        .filter(|s| s.v_t.nrows() == 2)
        .map_or((0.0, 1.0), |s| (s.v_t[(1, 0)], s.v_t[(1, 1)]));
    // Normal (sin ρ, cos ρ) with cos ρ ≥ 0.
    let (mut sn, mut cs) = normal;
    if cs < 0.0 {
        sn = -sn;
        cs = -cs;
    }
    let rho = sn.atan2(cs);
    let x = mw * sn + mb * cs;
    let dev = points
        .iter()
        .map(|(w, b)| (w * sn + b * cs - x).abs())
        .fold(0.0, f64::max);
    (rho, x, dev)
}
