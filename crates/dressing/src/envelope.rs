//! The dressed worm flank for a constant correction ΔK, by two independent methods:
//! the screw (one-row) evaluation of the vector-shortening simulation, and the analytic envelope
//! through the meshing condition.

use crate::dresser::{Dresser, Nominal};
use crate::error::{DressError, Result};
use crate::kinematics::{k_r, solve_bsp2, AxesBsp2, AxisCorrection, DressPose};
use crate::transform::{rigid_inverse, rotation, rx, rz, translation, tx, ty};
use crate::worm::{Flank, Worm};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Steps of the entry-depth scan over [−2.5 m_n, 1.5 m_n]: 0.02 m_n each.
const ENTRY_SCAN_STEPS: usize = 200;

/// Worm, dresser and the uncorrected setting for this worm: everything a dressing needs.
#[derive(Debug, Clone)]
pub struct DressingSetup {
    /// The worm as it is now (possibly redressed to a smaller diameter).
    pub worm: Worm,
    /// The dresser (designed for the new worm).
    pub dresser: Dresser,
    /// Uncorrected setting for the current worm.
    pub nominal: Nominal,
    /// Half-width of the window of worm rotation searched for the contact (rad).
    pub t_window_rad: f64,
}

/// The dresser's pose relative to the worm at t = 0 for a given ΔK, pre-inverted.
///
/// The motion with constant ΔK is a screw: worm point q at time t has dresser coordinates
/// X⁻¹·(R_z(t) q + t p e_z), X = R_z(−Δφ_S)·R_x(−γ)·T_x(−d)·T_y(ν_yA).
#[derive(Debug, Clone, Copy)]
pub struct ScrewFrame {
    /// Rotation of X⁻¹.
    pub rinv: Matrix3<f64>,
    /// Translation of X⁻¹.
    pub tinv: Vector3<f64>,
    /// Lead parameter p (mm/rad).
    pub p_mm: f64,
}

/// Result of dressing one flank point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointDressing {
    /// f_nFS: dressed flank along the outward normal, > 0 = material left (mm).
    pub f_mm: f64,
    /// Dresser radius that dressed this point, r_FA (mm).
    pub r_a_mm: f64,
    /// z_A of the dresser point (mm).
    pub z_a_mm: f64,
    /// Worm rotation (relative to the nominal contact) at which it was dressed (rad).
    pub t_rad: f64,
    /// ∂²g/∂t² at the envelope (mm/rad²), > 0 for a true envelope.
    pub g_tt: f64,
    /// ∂g/∂s at the envelope.
    pub g_s: f64,
}

/// Value and derivatives of g(s, t) = ρ_A − R_A(z_A) for the point P + s n at time t.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GEval {
    pub g: f64,
    pub g_s: f64,
    pub g_t: f64,
    pub g_tt: f64,
    pub g_ts: f64,
    pub rho: f64,
    pub z_a: f64,
}

impl DressingSetup {
    /// Machine-(5) axis values (B1, V1, A1, X1, Z1, B3) that realise the corrected dressing
    /// pose at φ_S = Δφ_S, ν_zS = 0, taking the uncorrected setting as the reference for the
    /// choice among equivalent axis sets.
    ///
    /// # Source
    /// JP6903407B2, eqs. (1) and (5) [SEED]; docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
    pub fn machine_axes(&self, dk: &AxisCorrection) -> Result<AxesBsp2> {
        self.machine_axes_at(dk, 0.0)
    }

    /// Machine-(5) axis values when the worm is at axial position ν_zS of the lead-coupled
    /// dressing motion (φ_S = ν_zS/p + Δφ_S), e.g. where the contact line passes a chosen point.
    ///
    /// # Formula
    /// K_R(φ_S = ν_zS/p + Δφ_S, ν_zS, γ_0 + Δγ, d_0 + Δd, ν_yA,0 + Δν_yA) → (5), B1 unwrapped
    /// next to ν_zS/p
    /// # Source
    /// JP6903407B2, eqs. (1), (5), lead-coupled ν_zS [SEED]; docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
    pub fn machine_axes_at(&self, dk: &AxisCorrection, nu_zs_mm: f64) -> Result<AxesBsp2> {
        DressError::check("nu_zs_mm", nu_zs_mm, -1e5, 1e5)?;
        let n = self.nominal;
        let turn = nu_zs_mm / self.worm.p_mm;
        let pose = DressPose {
            phi_s_rad: turn + dk.dphi_s_rad,
            nu_zs_mm,
            gamma_rad: n.gamma_rad + dk.dgamma_rad,
            d_mm: n.d_mm + dk.dd_mm,
            nu_ya_mm: n.nu_ya_mm + dk.dnu_ya_mm,
            phi_a_rad: 0.0,
        };
        let reference = AxesBsp2 {
            b1_rad: turn,
            v1_mm: nu_zs_mm,
            a1_rad: n.gamma_rad,
            x1_mm: n.d_mm,
            z1_mm: 0.0,
            b3_rad: 0.0,
        };
        solve_bsp2(&k_r(&pose), &reference)
    }

    /// Setup for `worm` (current diameter) and a `dresser` designed for the new worm.
    pub fn new(worm: Worm, dresser: Dresser) -> Self {
        let nominal = Nominal::for_worm(&worm, dresser.spec.d_a_mm);
        Self {
            worm,
            dresser,
            nominal,
            t_window_rad: 0.8,
        }
    }

    /// The pre-inverted dresser pose for ΔK.
    pub fn frame(&self, dk: &AxisCorrection) -> ScrewFrame {
        let x = rz(-dk.dphi_s_rad)
            * rx(-(self.nominal.gamma_rad + dk.dgamma_rad))
            * tx(-(self.nominal.d_mm + dk.dd_mm))
            * ty(self.nominal.nu_ya_mm + dk.dnu_ya_mm);
        let xi = rigid_inverse(&x);
        ScrewFrame {
            rinv: rotation(&xi),
            tinv: translation(&xi),
            p_mm: self.worm.p_mm,
        }
    }

    /// g and its derivatives for the ray P + s n at time t.
    #[inline]
    pub(crate) fn g_eval(
        &self,
        fr: &ScrewFrame,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        s: f64,
        t: f64,
    ) -> GEval {
        let (st, ct) = t.sin_cos();
        let q = p + n * s;
        let (x, y) = (ct * q.x - st * q.y, st * q.x + ct * q.y);
        let (nx, ny) = (ct * n.x - st * n.y, st * n.x + ct * n.y);
        let qa = fr.rinv * Vector3::new(x, y, q.z + t * fr.p_mm) + fr.tinv;
        let qs = fr.rinv * Vector3::new(nx, ny, n.z);
        let qt = fr.rinv * Vector3::new(-y, x, fr.p_mm);
        let qtt = fr.rinv * Vector3::new(-x, -y, 0.0);
        let qts = fr.rinv * Vector3::new(-ny, nx, 0.0);
        let rho = (qa.x * qa.x + qa.y * qa.y).sqrt();
        let rho_s = (qa.x * qs.x + qa.y * qs.y) / rho;
        let rho_t = (qa.x * qt.x + qa.y * qt.y) / rho;
        let rho_tt =
            (qt.x * qt.x + qt.y * qt.y + qa.x * qtt.x + qa.y * qtt.y) / rho - rho_t * rho_t / rho;
        let rho_ts =
            (qt.x * qs.x + qt.y * qs.y + qa.x * qts.x + qa.y * qts.y) / rho - rho_t * rho_s / rho;
        let (r, dr, ddr) = self.dresser.profile(qa.z);
        GEval {
            g: rho - r,
            g_s: rho_s - dr * qs.z,
            g_t: rho_t - dr * qt.z,
            g_tt: rho_tt - ddr * qt.z * qt.z - dr * qtt.z,
            g_ts: rho_ts - ddr * qt.z * qs.z - dr * qts.z,
            rho,
            z_a: qa.z,
        }
    }

    /// Flank point P and outward normal n used to evaluate roll distance w (axial section ψ = π).
    pub fn ray(&self, flank: Flank, w_mm: f64) -> (Vector3<f64>, Vector3<f64>) {
        let b = self.worm.b_axial_section(flank, w_mm);
        (
            self.worm.point(flank, w_mm, b),
            self.worm.normal(flank, w_mm, b),
        )
    }

    /// f_nFS(w; ΔK) and r_FA by the screw evaluation of the vector-shortening simulation.
    ///
    /// With ΔK constant the dressing motion is a screw, so one vector per roll distance
    /// suffices: its final end is the least entry point into the dresser over all times,
    /// f = min_t s*(t), found where g(s, t) = 0 and ∂g/∂t = 0 (2-D Newton with analytic
    /// derivatives, started from a scan over t).
    ///
    /// # Formula
    /// g(s,t) = ρ_A(q) − R_A(z_A(q)), q = X⁻¹(R_z(t)(P + s n) + t p e_z); f = s at g = g_t = 0
    /// # Source
    /// JP6903407B2, dressing simulation, eqs. (8)–(10), Fig. 1 [SEED]; docs/dressing.md "Derivation: screw reduction" [RECONSTRUCTED]
    pub fn dress_point(
        &self,
        flank: Flank,
        w_mm: f64,
        dk: &AxisCorrection,
    ) -> Result<PointDressing> {
        let fr = self.frame(dk);
        let (p, n) = self.ray(flank, w_mm);
        self.dress_ray(&fr, &p, &n, 0.0)
    }

    /// Envelope point for the ray (P, n) and a prepared frame; `t_hint` centres the scan.
    pub(crate) fn dress_ray(
        &self,
        fr: &ScrewFrame,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        t_hint: f64,
    ) -> Result<PointDressing> {
        let u_max = self.dresser.u_max();
        let m_n = self.worm.m_n_mm;
        // Scan: least g over t at s = 0 (points beyond the tabulated dresser count as outside).
        let nscan = 160;
        let (mut t0, mut gmin) = (t_hint, f64::INFINITY);
        let tw = self.t_window_rad;
        for i in 0..=nscan {
            let t = t_hint - tw + 2.0 * tw * i as f64 / nscan as f64;
            let e = self.g_eval(fr, p, n, 0.0, t);
            if e.z_a.abs() < u_max && e.g < gmin {
                gmin = e.g;
                t0 = t;
            }
        }
        if !gmin.is_finite() {
            return Err(DressError::NoConvergence {
                what: "envelope scan",
                detail: "the dresser never comes near this flank point".into(),
            });
        }
        let (mut s, mut t) = (0.0, t0);
        for _ in 0..100 {
            let e = self.g_eval(fr, p, n, s, t);
            let det = e.g_s * e.g_tt - e.g_t * e.g_ts;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let mut ds = (e.g * e.g_tt - e.g_t * e.g_t) / det;
            let mut dt = (e.g_s * e.g_t - e.g_ts * e.g) / det;
            // Keep steps sane: the solution is within a few mm and a fraction of a turn.
            let lim_t = 0.05;
            if dt.abs() > lim_t {
                let k = lim_t / dt.abs();
                dt *= k;
                ds *= k;
            }
            // Depth step and stop in units of m_n (1 mm and 1e-13 mm at module 1), so a worm
            // scaled by k takes the k-scaled Newton path and stops above its rounding floor.
            ds = ds.clamp(-m_n, m_n);
            s -= ds;
            t -= dt;
            if ds.abs() < 1e-13 * m_n && dt.abs() < 1e-12 {
                let e = self.g_eval(fr, p, n, s, t);
                if e.g_tt <= 0.0 {
                    break;
                }
                return Ok(PointDressing {
                    f_mm: s,
                    r_a_mm: e.rho,
                    z_a_mm: e.z_a,
                    t_rad: t,
                    g_tt: e.g_tt,
                    g_s: e.g_s,
                });
            }
        }
        // Newton did not settle (a ridge of the envelope, a start on the wrong branch, or a
        // deep cut): evaluate the definition directly, f = min_t s*(t).
        self.dress_ray_bracketed(fr, p, n, t_hint)
    }

    /// Entry depth s*(t) of the ray P + s n into the dresser at time t: the smallest s in
    /// [−s_in, s_out] with g(s, t) ≤ 0 (scan, then bisection); `s_out` when the dresser misses.
    fn entry_depth(
        &self,
        fr: &ScrewFrame,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        t: f64,
        s_in: f64,
        s_out: f64,
    ) -> f64 {
        let u_max = self.dresser.u_max();
        let inside = |s: f64| {
            let e = self.g_eval(fr, p, n, s, t);
            e.z_a.abs() < u_max && e.g <= 0.0
        };
        // The entry is bracketed by a fixed number of steps over [−s_in, s_out] (both ∝ m_n):
        // 0.02 m_n per step, the 0.02 mm of module 1, so the scan costs the same at every size
        // and a worm scaled by k is scanned at the k-scaled stations (docs/dressing.md
        // "Scan resolution").
        let steps = ENTRY_SCAN_STEPS;
        let h = (s_in + s_out) / steps as f64;
        let mut lo = -s_in;
        if inside(lo) {
            return lo;
        }
        for k in 1..=steps {
            let hi = (-s_in + h * k as f64).min(s_out);
            if inside(hi) {
                let mut a = lo;
                let mut b = hi;
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if inside(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                return 0.5 * (a + b);
            }
            lo = hi;
        }
        s_out
    }

    /// The screw evaluation by its definition, without Newton: f = min_t s*(t) over the
    /// window, by a scan over t and a golden-section refinement; the result is polished by the
    /// 2-D Newton when that converges next to it (then it also carries g_tt).
    fn dress_ray_bracketed(
        &self,
        fr: &ScrewFrame,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        t_hint: f64,
    ) -> Result<PointDressing> {
        let m_n = self.worm.m_n_mm;
        let (s_in, s_out) = (2.5 * m_n, 1.5 * m_n);
        let tw = self.t_window_rad;
        let nscan = 320;
        let dt = 2.0 * tw / nscan as f64;
        let (mut best_t, mut best_s) = (t_hint, f64::INFINITY);
        for i in 0..=nscan {
            let t = t_hint - tw + dt * i as f64;
            let s = self.entry_depth(fr, p, n, t, s_in, s_out);
            if s < best_s {
                best_s = s;
                best_t = t;
            }
        }
        if best_s >= s_out {
            return Err(DressError::NoConvergence {
                what: "envelope scan",
                detail: "the dresser never comes near this flank point".into(),
            });
        }
        let (mut lo, mut hi) = (best_t - dt, best_t + dt);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let sd = |t: f64| self.entry_depth(fr, p, n, t, s_in, s_out);
        let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut f1, mut f2) = (sd(x1), sd(x2));
        for _ in 0..60 {
            if f1 < f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - g * (hi - lo);
                f1 = sd(x1);
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + g * (hi - lo);
                f2 = sd(x2);
            }
        }
        let t = 0.5 * (lo + hi);
        let s = sd(t).min(best_s);
        if s <= -s_in {
            return Err(DressError::NoConvergence {
                what: "envelope (screw) point",
                detail: format!("the dresser cuts deeper than {s_in} mm below the nominal flank"),
            });
        }
        let e = self.g_eval(fr, p, n, s, t);
        Ok(PointDressing {
            f_mm: s,
            r_a_mm: e.rho,
            z_a_mm: e.z_a,
            t_rad: t,
            g_tt: e.g_tt,
            g_s: e.g_s,
        })
    }

    /// f_nFS(w; ΔK) and r_FA by the analytic envelope: meshing condition on the dresser surface,
    /// then the screw image of the contact curve intersected with the flank normal line.
    ///
    /// Independent of [`Self::dress_point`]: it works from the dresser towards the worm
    /// (surface normals and relative velocity) instead of shortening worm vectors.
    ///
    /// # Formula
    /// meshing: n_S · v = 0 with v = (y, −x, −p) (screw velocity of the dresser point in the
    /// worm frame); screw invariants r = √(x²+y²), ζ = z − p ψ; solve r_c(z_A) = r_l(s),
    /// ζ_c(z_A) = ζ_l(s)
    /// # Source
    /// JP6903407B2, analytic alternative to the dressing simulation [SEED]; meshing condition [RECONSTRUCTED]
    pub fn dress_point_meshing(
        &self,
        flank: Flank,
        w_mm: f64,
        dk: &AxisCorrection,
    ) -> Result<PointDressing> {
        let x = rz(-dk.dphi_s_rad)
            * rx(-(self.nominal.gamma_rad + dk.dgamma_rad))
            * tx(-(self.nominal.d_mm + dk.dd_mm))
            * ty(self.nominal.nu_ya_mm + dk.dnu_ya_mm);
        let xr = rotation(&x);
        let xt = translation(&x);
        let p = self.worm.p_mm;
        let unwrap = |psi: f64| {
            let mut a = psi;
            while a < 0.0 {
                a += 2.0 * PI;
            }
            while a >= 2.0 * PI {
                a -= 2.0 * PI;
            }
            a
        };
        // Contact point of dresser profile station z_A: invariants (r, ζ).
        let contact = |za: f64| -> Option<(f64, f64, f64)> {
            let (r, dr, _) = self.dresser.profile(za);
            let mesh = |th: f64| {
                let (s, c) = th.sin_cos();
                let q = xr * Vector3::new(r * c, r * s, za) + xt;
                let nn = xr * Vector3::new(c, s, -dr);
                (nn.dot(&Vector3::new(q.y, -q.x, -p)), q)
            };
            let mut th = 0.0;
            for _ in 0..60 {
                let h = 1e-7;
                let (m0, _) = mesh(th);
                let d = (mesh(th + h).0 - mesh(th - h).0) / (2.0 * h);
                if d == 0.0 {
                    return None;
                }
                let step = (m0 / d).clamp(-0.2, 0.2);
                th -= step;
                if step.abs() < 1e-14 {
                    break;
                }
            }
            let (_, q) = mesh(th);
            let rr = (q.x * q.x + q.y * q.y).sqrt();
            let psi = unwrap(q.y.atan2(q.x));
            Some((rr, q.z - p * psi, r))
        };
        let (pp, nn) = self.ray(flank, w_mm);
        let line = |s: f64| {
            let q = pp + nn * s;
            let psi = unwrap(q.y.atan2(q.x));
            ((q.x * q.x + q.y * q.y).sqrt(), q.z - p * psi)
        };
        let side = self.dresser.side(flank);
        // Start at the dresser point that dressed the same depth below the tip on the new worm:
        // the uncorrected centre distance follows the root, so worm radius r of the current worm
        // sits where r + (d_0,design − d_0) sat on the design worm (a geometric guess, not the
        // screw evaluation, to keep the two methods independent).
        let lowered = self.dresser.design_nominal.d_mm - self.nominal.d_mm;
        let w_design = self
            .dresser
            .design_worm
            .roll_from_radius(self.worm.radius_from_roll(w_mm) + lowered);
        let (u0, _, _) = side.u_of_w.eval(w_design);
        let (mut za, mut s) = (u0 * side.z_sign, 0.0);
        let lead = 2.0 * PI * p;
        let resid = |za: f64, s: f64| -> Option<(f64, f64, f64)> {
            let (rc, zc, ra) = contact(za)?;
            let (rl, zl) = line(s);
            let mut dz = zc - zl;
            dz -= lead * (dz / lead).round();
            Some((rc - rl, dz, ra))
        };
        for _ in 0..60 {
            let (f1, f2, ra) = resid(za, s).ok_or(DressError::NoConvergence {
                what: "meshing condition",
                detail: format!("z_A = {za} mm"),
            })?;
            let h = 1e-6;
            let a = resid(za + h, s);
            let b = resid(za - h, s);
            let c = resid(za, s + h);
            let d = resid(za, s - h);
            let (Some(a), Some(b), Some(c), Some(d)) = (a, b, c, d) else {
                break;
            };
            let j11 = (a.0 - b.0) / (2.0 * h);
            let j21 = (a.1 - b.1) / (2.0 * h);
            let j12 = (c.0 - d.0) / (2.0 * h);
            let j22 = (c.1 - d.1) / (2.0 * h);
            let det = j11 * j22 - j12 * j21;
            if det == 0.0 {
                break;
            }
            let dza = (f1 * j22 - j12 * f2) / det;
            let ds = (j11 * f2 - j21 * f1) / det;
            za -= dza.clamp(-0.5, 0.5);
            s -= ds.clamp(-0.5, 0.5);
            if dza.abs() < 1e-12 && ds.abs() < 1e-12 {
                return Ok(PointDressing {
                    f_mm: s,
                    r_a_mm: ra,
                    z_a_mm: za,
                    t_rad: f64::NAN,
                    g_tt: f64::NAN,
                    g_s: f64::NAN,
                });
            }
        }
        Err(DressError::NoConvergence {
            what: "analytic envelope",
            detail: format!("flank {flank:?}, w = {w_mm} mm"),
        })
    }

    /// Profile modification f_nFS(w_i; ΔK) at several roll distances (mm).
    pub fn profile(&self, flank: Flank, ws_mm: &[f64], dk: &AxisCorrection) -> Result<Vec<f64>> {
        let fr = self.frame(dk);
        ws_mm
            .iter()
            .map(|&w| {
                let (p, n) = self.ray(flank, w);
                self.dress_ray(&fr, &p, &n, 0.0).map(|d| d.f_mm)
            })
            .collect()
    }

    /// Radius association r_FA(w; ΔK): the dresser radius that dresses roll distance w (eq. (10)).
    ///
    /// # Source
    /// JP6903407B2, eq. (10) (radius association) [SEED]
    pub fn association(&self, flank: Flank, w_mm: f64, dk: &AxisCorrection) -> Result<f64> {
        self.dress_point(flank, w_mm, dk).map(|d| d.r_a_mm)
    }

    /// Inverse association: the roll distance that dresser radius r_A dresses under ΔK.
    pub fn roll_dressed_by(
        &self,
        flank: Flank,
        r_a_mm: f64,
        dk: &AxisCorrection,
        w_start_mm: f64,
    ) -> Result<f64> {
        let mut w = w_start_mm;
        let h = 1e-4;
        for _ in 0..40 {
            let r0 = self.association(flank, w, dk)? - r_a_mm;
            // r_FA(w) has a kink where the fillet meets the flank: stop on the residual too.
            if r0.abs() < 1e-10 {
                return Ok(w);
            }
            let d = (self.association(flank, w + h, dk)? - self.association(flank, w - h, dk)?)
                / (2.0 * h);
            if d == 0.0 {
                break;
            }
            let step = (r0 / d).clamp(-1.0, 1.0);
            w -= step;
            if step.abs() < 1e-11 {
                return Ok(w);
            }
        }
        self.roll_dressed_by_bracketed(flank, r_a_mm, dk, w_start_mm)
    }

    /// [`Self::roll_dressed_by`] without derivatives: r_FA(w) falls with w, so step outward
    /// from the start until r_FA(w) − r_A changes sign, then bisect. The search covers the
    /// involute from 1 m_n below the root to 1 m_n above the tip.
    fn roll_dressed_by_bracketed(
        &self,
        flank: Flank,
        r_a_mm: f64,
        dk: &AxisCorrection,
        w_start_mm: f64,
    ) -> Result<f64> {
        let wm = &self.worm;
        let w_min = wm.roll_from_radius((wm.r_f_mm - wm.m_n_mm).max(wm.r_b_mm * 1.001));
        let w_max = wm.roll_from_radius(wm.r_a_mm + wm.m_n_mm);
        let h = 0.05 * wm.m_n_mm;
        let res = |w: f64| self.association(flank, w, dk).map(|r| r - r_a_mm).ok();
        let w0 = w_start_mm.clamp(w_min, w_max);
        let no_root = || DressError::NoConvergence {
            what: "inverse radius association",
            detail: format!(
                "no flank point between radius {:.3} and {:.3} mm is dressed by the dresser \
                 radius {r_a_mm:.4} mm under this correction",
                wm.radius_from_roll(w_min),
                wm.radius_from_roll(w_max)
            ),
        };
        let r0 = res(w0).ok_or_else(no_root)?;
        if r0 == 0.0 {
            return Ok(w0);
        }
        // r_FA falls with w: r0 > 0 means the root lies at larger w.
        let dir = if r0 > 0.0 { 1.0 } else { -1.0 };
        let (mut a, mut ra) = (w0, r0);
        let mut b = None;
        let mut k = 1.0;
        loop {
            let w = (w0 + dir * h * k).clamp(w_min, w_max);
            let Some(rw) = res(w) else { break };
            if rw.signum() != ra.signum() {
                b = Some(w);
                break;
            }
            (a, ra) = (w, rw);
            if w <= w_min || w >= w_max {
                break;
            }
            k += 1.0;
        }
        let Some(mut b) = b else {
            return Err(no_root());
        };
        for _ in 0..80 {
            let m = 0.5 * (a + b);
            let Some(rm) = res(m) else {
                return Err(no_root());
            };
            if rm.signum() == ra.signum() {
                (a, ra) = (m, rm);
            } else {
                b = m;
            }
            if (b - a).abs() < 1e-12 {
                break;
            }
        }
        Ok(0.5 * (a + b))
    }

    /// Active profile [w_Nf, w_Na] of `flank` under uncorrected dressing: w_Na on the tip circle,
    /// w_Nf dressed by the fillet/flank tangent point of the dresser.
    ///
    /// # Source
    /// docs/dressing.md "Conventions fixed here (JP6903407B2 leaves them open)", docs/dressing.md "Derivation: dresser envelope and tip fillet" [RECONSTRUCTED]
    pub fn active_profile(&self, flank: Flank) -> Result<(f64, f64)> {
        let side = self.dresser.side(flank);
        let r_t = self.dresser.profile(side.u_tangent_mm * side.z_sign).0;
        let w_na = self.worm.roll_from_radius(self.worm.r_a_mm);
        let w_guess = self
            .worm
            .roll_from_radius(self.worm.r_f_mm + (self.dresser.spec.d_a_mm / 2.0 - r_t));
        let w_nf = self.roll_dressed_by(flank, r_t, &AxisCorrection::default(), w_guess)?;
        Ok((w_nf, w_na))
    }

    /// Depth of the dresser jacket below the worm root circle under ΔK (mm; > 0 = below).
    ///
    /// The worm radius swept by a dresser point is screw-invariant, so the least radius over the
    /// jacket cylinder (at t = 0) is the deepest the jacket reaches.
    pub fn jacket_depth(&self, dk: &AxisCorrection) -> f64 {
        let fr = self.frame(dk);
        // X = inverse of X⁻¹: dresser point → worm frame.
        let r = fr.rinv.transpose();
        let t = -(r * fr.tinv);
        let rj = self.dresser.spec.d_a_mm / 2.0;
        let hj = self.dresser.spec.jacket_width_mm / 2.0;
        let radial = |za: f64, th: f64| {
            let q = r * Vector3::new(rj * th.cos(), rj * th.sin(), za) + t;
            (q.x * q.x + q.y * q.y).sqrt()
        };
        let mut best = f64::INFINITY;
        for k in 0..=8 {
            let za = -hj + 2.0 * hj * k as f64 / 8.0;
            let (mut lo, mut hi) = (-0.5, 0.5);
            let g = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..80 {
                let x1 = hi - g * (hi - lo);
                let x2 = lo + g * (hi - lo);
                if radial(za, x1) < radial(za, x2) {
                    hi = x2;
                } else {
                    lo = x1;
                }
            }
            best = best.min(radial(za, 0.5 * (lo + hi)));
        }
        self.worm.r_f_mm - best
    }

    /// Largest cut into the opposite flank under ΔK (mm; > 0 = material removed below nominal),
    /// over its active profile.
    ///
    /// # Source
    /// JP6903407B2, section on the maximum producible profile modification and the choice of dresser and worm [SEED]; docs/dressing.md "Reference case G1-Z5" (clearance budget) [RECONSTRUCTED]
    pub fn opposite_flank_cut(&self, flank: Flank, dk: &AxisCorrection) -> Result<f64> {
        let opp = flank.opposite();
        let (w0, w1) = self.active_profile(opp)?;
        let ws: Vec<f64> = (0..=20).map(|i| w0 + (w1 - w0) * i as f64 / 20.0).collect();
        let f = self.profile(opp, &ws, dk)?;
        Ok(f.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(-v)))
    }
}
