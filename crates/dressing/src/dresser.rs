//! Profile roller dresser: a surface of revolution designed so that, with the uncorrected
//! dressing motion, it dresses the nominal worm gap exactly (both flanks, jacket, tip fillets).

use crate::error::{DressError, Result};
use crate::spline::Spline;
use crate::worm::{Flank, Worm};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The uncorrected dressing setting (values used for the dresser design).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Nominal {
    /// d_0, centre distance (mm).
    pub d_mm: f64,
    /// γ_0, crossing angle (rad).
    pub gamma_rad: f64,
    /// ν_yA,0 (mm).
    pub nu_ya_mm: f64,
}

impl Nominal {
    /// Uncorrected setting for `worm` and a dresser of outer diameter `d_a_mm`.
    ///
    /// # Formula
    /// d_0 = r_fS + d_A/2 (jacket on the current root circle), γ_0 = lead angle at d_S0/2
    /// (kept over the worm's life: "uncorrected" = only the centre distance follows the
    /// diameter), ν_yA,0 = 0
    /// # Source
    /// docs/dressing.md "Conventions fixed here (JP6903407B2 leaves them open)" [RECONSTRUCTED]; JP6903407B2, claim 1, lead-coupled ν_zS of the worm dressing description [SEED]
    pub fn for_worm(worm: &Worm, d_a_mm: f64) -> Self {
        Self {
            d_mm: worm.r_f_mm + d_a_mm / 2.0,
            gamma_rad: worm.lead_angle_at(worm.d_s0_mm / 2.0),
            nu_ya_mm: 0.0,
        }
    }

    /// Dresser centre C and axis direction a in worm coordinates at φ_S = 0 (eq. (1)).
    pub fn centre_axis(&self) -> (Vector3<f64>, Vector3<f64>) {
        let (s, c) = self.gamma_rad.sin_cos();
        (
            Vector3::new(-self.d_mm, self.nu_ya_mm * c, -self.nu_ya_mm * s),
            Vector3::new(0.0, s, c),
        )
    }
}

/// What the user asks for when designing a dresser.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DresserSpec {
    /// Outer (jacket) diameter d_A (mm).
    pub d_a_mm: f64,
    /// Width of the outer jacket (cylinder) (mm).
    pub jacket_width_mm: f64,
    /// Clearance per flank (mm): the dresser is thinner than the gap by this much per side.
    pub clearance_mm: f64,
}

/// One side of the dresser profile (the part that dresses one worm flank).
#[derive(Debug, Clone, PartialEq)]
pub struct DresserSide {
    /// Which worm flank this side dresses.
    pub flank: Flank,
    /// +1 if this side lies at z_A > 0, −1 otherwise.
    pub z_sign: f64,
    /// Flank radius R_A as a function of u = |z_A| (mm → mm).
    pub radius: Spline,
    /// Design association: worm roll distance w ↦ u = |z_A| of the dresser point that dresses it.
    pub u_of_w: Spline,
    /// Inverse of the above: u ↦ w.
    pub w_of_u: Spline,
    /// Design contact curve: worm roll distance w ↦ axial position b on the worm.
    pub b_of_w: Spline,
    /// Fillet radius (mm), tangent to jacket and flank.
    pub fillet_radius_mm: f64,
    /// u of the fillet/flank tangent point (mm).
    pub u_tangent_mm: f64,
    /// Worm roll distance dressed by the tangent point at the design setting: w_Nf (mm).
    pub w_nf_mm: f64,
}

/// A designed profile roller dresser.
#[derive(Debug, Clone, PartialEq)]
pub struct Dresser {
    /// The specification it was built from.
    pub spec: DresserSpec,
    /// The worm it was designed for.
    pub design_worm: Worm,
    /// The dressing setting it was designed for.
    pub design_nominal: Nominal,
    /// The two sides, [left flank's side, right flank's side].
    pub sides: [DresserSide; 2],
}

/// Number of knots of the tabulated flank: spacing ≈ 0.01 mm keeps the spline error < 1e-10 mm.
const N_KNOTS: usize = 1201;

/// Contact point of the worm flank at roll distance w with a dresser of revolution with centre
/// `c`, axis `a`: the point where the flank normal line meets the dresser axis.
///
/// # Formula
/// g(b) = n(w,b) · (a × (E(w,b) − C)) = 0;  z_A = (E − C)·a,  R_A = |E − C − z_A a|
/// # Source
/// docs/dressing.md "Derivation: dresser envelope and tip fillet" (form-grinding contact condition) [RECONSTRUCTED]
pub fn design_contact(
    worm: &Worm,
    flank: Flank,
    w_mm: f64,
    c: &Vector3<f64>,
    a: &Vector3<f64>,
) -> Result<(f64, f64, f64)> {
    let g = |b: f64| {
        let e = worm.point(flank, w_mm, b);
        worm.normal(flank, w_mm, b).dot(&a.cross(&(e - c)))
    };
    let mut b = worm.b_axial_section(flank, w_mm);
    let h = 1e-5;
    let mut last_step = f64::INFINITY;
    for _ in 0..60 {
        let gb = g(b);
        let db = (g(b + h) - g(b - h)) / (2.0 * h);
        if db == 0.0 || !db.is_finite() {
            break;
        }
        let mut step = gb / db;
        step = step.clamp(-worm.p_mm, worm.p_mm);
        b -= step;
        // Converged when the step is below 1e-13 mm, or when it no longer shrinks while
        // already below 1e-9·(1 + |b|) mm: the rounding floor of g / g′ (1.5e-13 mm on a
        // module-100 worm, 1e-12 mm and more for b of hundreds of mm), where Newton only
        // oscillates; a valid large worm's dresser "did not converge" there. An error δb
        // along the flank line moves (z_A, R_A) off the envelope only to second order.
        let size = step.abs();
        let at_floor = size >= 0.5 * last_step && size < 1e-9 * (1.0 + b.abs());
        last_step = size;
        if size < 1e-13 || at_floor {
            let e = worm.point(flank, w_mm, b);
            let za = (e - c).dot(a);
            let ra = (e - c - a * za).norm();
            return Ok((b, za, ra));
        }
    }
    Err(DressError::NoConvergence {
        what: "dresser design contact point",
        detail: format!("flank {flank:?}, w = {w_mm} mm"),
    })
}

impl Dresser {
    /// Designs the dresser for `worm` at its uncorrected setting.
    ///
    /// Both flanks are the exact envelope of the nominal gap (thickened by the clearance),
    /// the jacket has radius d_A/2 and the given width, and a circular fillet tangent to jacket
    /// and flank joins them.
    ///
    /// # Source
    /// JP6903407B2, worm dressing description (dresser of revolution, line contact) [SEED]; contact
    /// condition and fillet docs/dressing.md "Derivation: dresser envelope and tip fillet" [RECONSTRUCTED]
    pub fn design(worm: &Worm, spec: DresserSpec) -> Result<Self> {
        DressError::check("d_a_mm", spec.d_a_mm, 5.0, 2000.0)?;
        DressError::check(
            "jacket_width_mm",
            spec.jacket_width_mm,
            0.0,
            worm.axial_pitch_mm() / 2.0,
        )?;
        DressError::check("clearance_mm", spec.clearance_mm, 0.0, 0.2 * worm.m_n_mm)?;
        let mut w_design = *worm;
        w_design.thicken_mm = spec.clearance_mm;
        let nominal = Nominal::for_worm(&w_design, spec.d_a_mm);
        let (c, a) = nominal.centre_axis();
        let r_jac = spec.d_a_mm / 2.0;
        let hj = spec.jacket_width_mm / 2.0;
        let r_lo = (w_design.r_f_mm - 0.25 * worm.m_n_mm).max(worm.r_b_mm * 1.001);
        let r_hi = w_design.r_a_mm + 0.5 * worm.m_n_mm;
        let (w_lo, w_hi) = (worm.roll_from_radius(r_lo), worm.roll_from_radius(r_hi));
        let mut sides = Vec::with_capacity(2);
        for flank in [Flank::Left, Flank::Right] {
            let mut ws = Vec::with_capacity(N_KNOTS);
            let mut us = Vec::with_capacity(N_KNOTS);
            let mut rs = Vec::with_capacity(N_KNOTS);
            let mut bs = Vec::with_capacity(N_KNOTS);
            let mut z_sum = 0.0;
            for i in 0..N_KNOTS {
                let w = w_lo + (w_hi - w_lo) * i as f64 / (N_KNOTS - 1) as f64;
                let (b, za, ra) = design_contact(&w_design, flank, w, &c, &a)?;
                ws.push(w);
                us.push(za);
                rs.push(ra);
                bs.push(b);
                z_sum += za;
            }
            let z_sign = if z_sum >= 0.0 { 1.0 } else { -1.0 };
            for u in &mut us {
                *u *= z_sign;
            }
            let flank_spline = Spline::new(us.clone(), rs.clone()).map_err(|_| {
                DressError::Geometry(format!(
                    "dresser flank for the {flank:?} worm flank is not monotone (interference)"
                ))
            })?;
            let u_of_w = Spline::new(ws.clone(), us.clone())?;
            let w_of_u = Spline::new(us.clone(), ws.clone())?;
            let b_of_w = Spline::new(ws.clone(), bs)?;
            // Flank must lie above the jacket at the jacket edge: gap wider than the jacket.
            let gap = gap_width_text(&flank_spline, r_jac);
            let (r_at_edge, _, _) = flank_spline.eval(hj);
            if r_at_edge <= r_jac {
                return Err(DressError::Geometry(format!(
                    "jacket width {} mm is not narrower than the worm gap at the root circle{gap}",
                    spec.jacket_width_mm
                )));
            }
            let (rho, u_t) = fillet(&flank_spline, hj, r_jac).map_err(|_| {
                DressError::Geometry(format!(
                    "no fillet tangent to jacket and flank exists for jacket_width_mm = {} mm \
                     with diameter_mm = {} mm (the jacket edge must lie inside the worm gap \
                     with room for a fillet){gap}",
                    spec.jacket_width_mm, spec.d_a_mm
                ))
            })?;
            let (w_nf, _, _) = w_of_u.eval(u_t);
            sides.push(DresserSide {
                flank,
                z_sign,
                radius: flank_spline,
                u_of_w,
                w_of_u,
                b_of_w,
                fillet_radius_mm: rho,
                u_tangent_mm: u_t,
                w_nf_mm: w_nf,
            });
        }
        let right = sides.pop();
        let left = sides.pop();
        match (left, right) {
            (Some(l), Some(r)) if l.z_sign != r.z_sign => Ok(Self {
                spec,
                design_worm: *worm,
                design_nominal: nominal,
                sides: [l, r],
            }),
            _ => Err(DressError::Geometry(
                "both worm flanks map to the same side of the dresser".into(),
            )),
        }
    }

    /// The side that dresses `flank`.
    pub fn side(&self, flank: Flank) -> &DresserSide {
        match flank {
            Flank::Left => &self.sides[0],
            Flank::Right => &self.sides[1],
        }
    }

    /// Dresser profile radius R_A(z_A) with dR/dz_A and d²R/dz_A² (jacket, fillets, flanks).
    ///
    /// # Formula
    /// |z_A| ≤ b_j/2: R = d_A/2; fillet: R = d_A/2 − ρ + √(ρ² − (|z_A| − b_j/2)²); flank: spline
    pub fn profile(&self, z_a_mm: f64) -> (f64, f64, f64) {
        let side = if z_a_mm * self.sides[0].z_sign >= 0.0 {
            &self.sides[0]
        } else {
            &self.sides[1]
        };
        let u = z_a_mm.abs();
        let sg = if z_a_mm >= 0.0 { 1.0 } else { -1.0 };
        let hj = self.spec.jacket_width_mm / 2.0;
        let r_jac = self.spec.d_a_mm / 2.0;
        if u <= hj {
            (r_jac, 0.0, 0.0)
        } else if u < side.u_tangent_mm {
            let rho = side.fillet_radius_mm;
            let du = u - hj;
            let root = (rho * rho - du * du).max(1e-300).sqrt();
            (
                r_jac - rho + root,
                -sg * du / root,
                -rho * rho / (root * root * root),
            )
        } else {
            let (r, dr, ddr) = side.radius.eval(u);
            (r, sg * dr, ddr)
        }
    }

    /// Largest |z_A| of the tabulated flanks (beyond: linear extrapolation).
    pub fn u_max(&self) -> f64 {
        self.sides[0]
            .radius
            .x_max()
            .min(self.sides[1].radius.x_max())
    }

    /// Design association: dresser radius that dresses worm roll distance w of `flank` at the
    /// design setting.
    pub fn design_radius_for(&self, flank: Flank, w_mm: f64) -> f64 {
        let side = self.side(flank);
        let (u, _, _) = side.u_of_w.eval(w_mm);
        self.profile(u * side.z_sign).0
    }
}

/// ": jacket_width_mm must be below W mm (...)" with W = 2 u, R(u) = r_jac on the dresser
/// flank: the worm gap's axial width where the jacket radius meets the flank (empty when the
/// tabulated flank does not cross the jacket radius).
fn gap_width_text(flank: &Spline, r_jac: f64) -> String {
    let (mut lo, mut hi) = (flank.x_min().max(0.0), flank.x_max());
    let above = |u: f64| flank.eval(u).0 > r_jac;
    if !above(lo) || above(hi) {
        return String::new();
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if above(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    format!(
        "; [dresser] jacket_width_mm must be in 0 < jacket_width_mm < {:.5} mm, the width of \
         the worm gap at the dresser's jacket radius (diameter_mm / 2), less room for the fillets",
        lo + hi
    )
}

/// Largest fillet radius searched, in mm (beyond any dresser of `[dresser] diameter_mm` ≤
/// 2000 mm).
const MAX_FILLET_RADIUS_MM: f64 = 10_240.0;

/// Fillet tangent to the jacket line R = r_jac at u = hj and to the flank R(u).
/// Returns (radius, u of the tangent point on the flank).
fn fillet(flank: &Spline, hj: f64, r_jac: f64) -> Result<(f64, f64)> {
    let u_max = flank.x_max();
    // Distance from the fillet centre (hj, r_jac − ρ) to the flank curve, and where it is least.
    let dist = |rho: f64| -> (f64, f64) {
        let cz = hj;
        let cr = r_jac - rho;
        let d = |u: f64| {
            let (r, _, _) = flank.eval(u);
            ((u - cz).powi(2) + (r - cr).powi(2)).sqrt()
        };
        let n = 400;
        let (mut best_u, mut best) = (hj, f64::INFINITY);
        for i in 0..=n {
            let u = hj + (u_max - hj) * i as f64 / n as f64;
            let v = d(u);
            if v < best {
                best = v;
                best_u = u;
            }
        }
        let step = (u_max - hj) / n as f64;
        let (mut lo, mut hi) = ((best_u - step).max(hj), (best_u + step).min(u_max));
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..100 {
            let x1 = hi - g * (hi - lo);
            let x2 = lo + g * (hi - lo);
            if d(x1) < d(x2) {
                hi = x2;
            } else {
                lo = x1;
            }
        }
        let u = 0.5 * (lo + hi);
        (d(u) - rho, u)
    };
    // Bracket the radius: from 10 mm up by doubling, since the fillet scales with the worm
    // (a fixed 10 mm upper end refused the dresser of every worm above module ≈ 35 mm
    // whose similar module-3 design had a 0.8 mm fillet).
    let (lo, mut hi) = (1e-6, 10.0);
    while dist(hi).0 >= 0.0 && hi < MAX_FILLET_RADIUS_MM {
        hi *= 2.0;
    }
    let mut lo = lo;
    if dist(lo).0 <= 0.0 || dist(hi).0 >= 0.0 {
        return Err(DressError::Geometry(
            "no fillet tangent to jacket and flank exists".into(),
        ));
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if dist(mid).0 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-13 {
            break;
        }
    }
    let rho = 0.5 * (lo + hi);
    let (_, mut u_t) = dist(rho);
    // The golden search leaves u_t at √ε; polish it on the foot-point condition
    // (u − b_j/2) + (R(u) − c_R)·R′(u) = 0 so fillet and flank meet without a step.
    let cr = r_jac - rho;
    for _ in 0..20 {
        let (r, dr, ddr) = flank.eval(u_t);
        let h = (u_t - hj) + (r - cr) * dr;
        let dh = 1.0 + dr * dr + (r - cr) * ddr;
        let step = h / dh;
        u_t -= step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    Ok((rho, u_t))
}
