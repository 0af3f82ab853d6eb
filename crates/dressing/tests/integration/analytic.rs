//! An analytic envelope of the dresser written for the tests, independent of `envelope.rs`:
//! the dressing motion is taken from chain (1) (`kinematics::k_r`) at each time, the meshing
//! condition n·v = 0 is solved on the dresser surface by a scan over the dresser angle and
//! bisection, the velocity comes from central differences of the chain, the screw invariant of
//! the motion is measured numerically from the chain, and the worm flank normal line is
//! intersected with the swept contact curve by a scan over the dresser profile and bisection.
//! No Newton iteration, no screw-frame code of the library.
#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::{k_r, AxisCorrection, DressPose};
use gearcomp_dressing::worm::Flank;
use nalgebra::{Matrix4, Vector3, Vector4};
use std::f64::consts::PI;

/// Chain (1) at time t of the corrected motion: φ_S = t + Δφ_S, ν_zS = p t.
fn chain(setup: &DressingSetup, dk: &AxisCorrection, t: f64) -> Matrix4<f64> {
    let n = setup.nominal;
    k_r(&DressPose {
        phi_s_rad: t + dk.dphi_s_rad,
        nu_zs_mm: setup.worm.p_mm * t,
        gamma_rad: n.gamma_rad + dk.dgamma_rad,
        d_mm: n.d_mm + dk.dd_mm,
        nu_ya_mm: n.nu_ya_mm + dk.dnu_ya_mm,
        phi_a_rad: 0.0,
    })
}

fn apply(m: &Matrix4<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    let v = m * Vector4::new(p.x, p.y, p.z, 1.0);
    Vector3::new(v.x, v.y, v.z)
}

fn apply_dir(m: &Matrix4<f64>, d: &Vector3<f64>) -> Vector3<f64> {
    let v = m * Vector4::new(d.x, d.y, d.z, 0.0);
    Vector3::new(v.x, v.y, v.z)
}

/// The analytic envelope of one corrected dressing.
pub struct Analytic<'a> {
    setup: &'a DressingSetup,
    k0: Matrix4<f64>,
    kp: Matrix4<f64>,
    km: Matrix4<f64>,
    h: f64,
    /// dz/dψ of a worm-frame point under the relative motion (the screw parameter).
    screw_k: f64,
}

impl<'a> Analytic<'a> {
    pub fn new(setup: &'a DressingSetup, dk: &AxisCorrection) -> Self {
        let h = 1e-5;
        let k0 = chain(setup, dk, 0.0);
        let kp = chain(setup, dk, h);
        let km = chain(setup, dk, -h);
        // The motion of a worm-frame point q0 that moves with the dresser: K(t)·K(0)⁻¹·q0.
        let inv0 = k0.try_inverse().unwrap();
        let q0 = Vector3::new(50.0, 0.0, 0.0);
        let q1 = apply(&(chain(setup, dk, 0.01) * inv0), &q0);
        let dpsi = q1.y.atan2(q1.x) - q0.y.atan2(q0.x);
        let screw_k = (q1.z - q0.z) / dpsi;
        Self {
            setup,
            k0,
            kp,
            km,
            h,
            screw_k,
        }
    }

    /// Meshing function n·v at the dresser point (station z_A, angle θ), and the point in the
    /// worm frame at t = 0.
    fn mesh(&self, z_a: f64, th: f64) -> (f64, Vector3<f64>) {
        let (r, dr, _) = self.setup.dresser.profile(z_a);
        let (s, c) = th.sin_cos();
        let a = Vector3::new(r * c, r * s, z_a);
        let na = Vector3::new(c, s, -dr);
        let q = apply(&self.k0, &a);
        let v = (apply(&self.kp, &a) - apply(&self.km, &a)) / (2.0 * self.h);
        (apply_dir(&self.k0, &na).dot(&v), q)
    }

    /// Contact point of dresser station z_A (the meshing root nearest the worm axis).
    fn contact(&self, z_a: f64) -> Option<Vector3<f64>> {
        let n = 360;
        let mut best: Option<Vector3<f64>> = None;
        let mut prev = (-PI, self.mesh(z_a, -PI).0);
        for i in 1..=n {
            let th = -PI + 2.0 * PI * f64::from(i) / f64::from(n);
            let m = self.mesh(z_a, th).0;
            if m.signum() != prev.1.signum() {
                let (mut a, mut fa, mut b) = (prev.0, prev.1, th);
                for _ in 0..70 {
                    let mid = 0.5 * (a + b);
                    let fm = self.mesh(z_a, mid).0;
                    if fm.signum() == fa.signum() {
                        a = mid;
                        fa = fm;
                    } else {
                        b = mid;
                    }
                }
                let q = self.mesh(z_a, 0.5 * (a + b)).1;
                let r = (q.x * q.x + q.y * q.y).sqrt();
                if best.is_none_or(|bq| r < (bq.x * bq.x + bq.y * bq.y).sqrt()) {
                    best = Some(q);
                }
            }
            prev = (th, m);
        }
        best
    }

    fn zeta(&self, q: &Vector3<f64>) -> f64 {
        q.z - self.screw_k * q.y.atan2(q.x)
    }

    /// f along the outward normal at roll distance w: the least s among the intersections of
    /// the flank normal line (|s| ≤ m_n) with the swept contact curve of the dresser side of
    /// `flank`.
    pub fn f_mm(&self, flank: Flank, w_mm: f64) -> Option<f64> {
        let (p, n) = self.setup.ray(flank, w_mm);
        let side = self.setup.dresser.side(flank);
        let u_max = self.setup.dresser.u_max();
        let lead = 2.0 * PI * self.screw_k.abs();
        let (pxy, nxy) = (p.xy(), n.xy());
        // Residual of station u: ζ mismatch at the line point of the contact radius.
        let resid = |u: f64| -> Option<(f64, f64)> {
            let c = self.contact(u * side.z_sign)?;
            let rc2 = c.x * c.x + c.y * c.y;
            let (qa, qb, qc) = (
                nxy.norm_squared(),
                2.0 * pxy.dot(&nxy),
                pxy.norm_squared() - rc2,
            );
            let disc = qb * qb - 4.0 * qa * qc;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            let (s1, s2) = ((-qb + sq) / (2.0 * qa), (-qb - sq) / (2.0 * qa));
            let s = if s1.abs() < s2.abs() { s1 } else { s2 };
            let l = p + n * s;
            let mut dz = self.zeta(&c) - self.zeta(&l);
            dz -= lead * (dz / lead).round();
            Some((dz, s))
        };
        let s_lim = self.setup.worm.m_n_mm;
        let nu = 600;
        let mut best: Option<f64> = None;
        let mut prev: Option<(f64, f64)> = None;
        for i in 0..=nu {
            let u = u_max * 0.999 * f64::from(i) / f64::from(nu);
            let Some((h, _)) = resid(u) else {
                prev = None;
                continue;
            };
            if let Some((u0, h0)) = prev {
                if h.signum() != h0.signum() && (h - h0).abs() < lead / 4.0 {
                    let (mut a, mut ha, mut b) = (u0, h0, u);
                    for _ in 0..70 {
                        let m = 0.5 * (a + b);
                        let Some((hm, _)) = resid(m) else { break };
                        if hm.signum() == ha.signum() {
                            a = m;
                            ha = hm;
                        } else {
                            b = m;
                        }
                    }
                    // Only intersections on the flank's vector, |s| ≤ m_n, count (the
                    // simulation's vectors are that long; farther ones lie in other threads).
                    if let Some((_, s)) = resid(0.5 * (a + b)) {
                        if s.abs() <= s_lim {
                            best = Some(best.map_or(s, |bs: f64| bs.min(s)));
                        }
                    }
                }
            }
            prev = Some((u, h));
        }
        best
    }
}
