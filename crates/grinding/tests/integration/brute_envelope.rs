//! An independent, bounded brute-force envelope (test-only), written separately from the
//! production minimiser (`conical_sim::EnvelopeGrinder`):
//!
//! - the worm surface is not intersected by a 3-D Newton on its (w, z) parameters; instead
//!   every space point X is given its signed normal distance h from the unmodified worm
//!   helicoid and its foot point in closed form (an involute helicoid is the set
//!   E(w, z) + h·N(w, z); the transverse base tangent through X fixes τ, the rest is a
//!   linear 3 × 3 system solved by hand), and X lies in worm material iff h < cos β_b1·f_Ft1
//!   at the foot point;
//! - each ray (gear point P along its outward normal, in worm coordinates) is scanned in fixed
//!   steps for the first entry into worm material whose foot point lies between the worm's
//!   root and tip radii, then bisected;
//! - the machine states (gear rotation, feed) are searched by a dense grid and repeated
//!   zooming, not by Newton steps.
//!
//! Shared with production: the flank parameterisation (`InvoluteFlank::point/normal`, tested
//! against the involute closed form) and the relative pose with the generating coupling
//! (`MeshKinematics::relative_pose`, tested by T4/T5/T10).

use gearcomp_grinding::conical_sim::MeshKinematics;
use gearcomp_grinding::flank::InvoluteFlank;
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::FlankModification;
use nalgebra::{Point3, Vector3};

/// Signed normal distance h of X from the helicoid and the foot point (w, z), branch of the
/// thread turn nearest to X (turns and starts repeat every 2π/z in τ).
pub fn helicoid_distance(f: &InvoluteFlank, starts: u32, x: &Vector3<f64>) -> (f64, f64, f64) {
    let s = f.s();
    let (sb, cb) = f.beta_b_rad.sin_cos();
    let tb = sb / cb;
    let rb = f.r_b_mm;
    let rho2 = x.x * x.x + x.y * x.y;
    let lambda = (rho2 - rb * rb).max(0.0).sqrt();
    let theta = x.y.atan2(x.x);
    // transverse part of X = r_b·e_r(τ) − s·λ·e_t(τ)  ⇒  θ_X = τ − s·atan(λ/r_b)
    let tau = theta + s * (lambda / rb).atan();
    // X = E(w, z) + h·N: λ = w + h·cos β_b, z_X = z + s·h·sin β_b,
    // r_b·(τ − η) = s·w + z·tan β_b  ⇒  h = cos β_b·(λ + s·z_X·tan β_b − s·r_b·(τ − η))
    let period = 2.0 * std::f64::consts::PI / f64::from(starts);
    let h0 = cb * (lambda + s * x.z * tb - s * rb * (tau - f.eta_rad));
    let step = cb * rb * period;
    let k = (h0 / step).round();
    let h = h0 - k * step;
    let w = lambda - h * cb;
    let z = x.z - s * h * sb;
    (h, w, z)
}

/// Settings of the brute-force search.
#[derive(Debug, Clone, Copy)]
pub struct BruteSettings {
    /// Worm roll-distance bounds (root, tip) in mm.
    pub w1_bounds_mm: (f64, f64),
    /// Ray half-length scanned (mm) and scan step (mm).
    pub ray_half_mm: f64,
    pub ray_step_mm: f64,
    /// Half windows of the state search around the analytic seed: rotation (mm of r_b2·φ2)
    /// and feed (mm).
    pub half_u_mm: f64,
    pub half_v_mm: f64,
}

#[allow(clippy::too_many_arguments)]
/// Cut of one machine state: the first entry of the ray into worm material within the worm's
/// radii, or None.
fn cut<M: MeshKinematics + ?Sized>(
    mesh: &M,
    starts: u32,
    coupling: &FeedCoupling,
    worm_mod: &dyn FlankModification,
    set: &BruteSettings,
    p: &Vector3<f64>,
    n: &Vector3<f64>,
    phi2: f64,
    z_v2: f64,
) -> Option<(f64, f64, f64)> {
    let pose = mesh.relative_pose(phi2, coupling.z_v1_mm(z_v2), z_v2);
    let p1 = pose.transform_point(&Point3::from(*p)).coords;
    let d1 = pose.rotation * n;
    let wf = mesh.worm_flank();
    let cb = wf.beta_b_rad.cos();
    let g = |t: f64| {
        let (h, w, z) = helicoid_distance(wf, starts, &(p1 + d1 * t));
        (h - cb * worm_mod.f_ft_mm(w, z), w, z)
    };
    let inside = |w: f64| w >= set.w1_bounds_mm.0 && w <= set.w1_bounds_mm.1;
    let n_steps = (2.0 * set.ray_half_mm / set.ray_step_mm).ceil() as usize;
    let mut t0 = -set.ray_half_mm;
    let (mut g0, _, _) = g(t0);
    for k in 1..=n_steps {
        let t1 = -set.ray_half_mm + k as f64 * set.ray_step_mm;
        let (g1, _, _) = g(t1);
        if g0 > 0.0 && g1 <= 0.0 {
            let (mut a, mut b) = (t0, t1);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if g(m).0 > 0.0 {
                    a = m;
                } else {
                    b = m;
                }
            }
            let t = 0.5 * (a + b);
            let (_, w, z) = g(t);
            // a jump between thread turns is not an entry into material
            if (g0 - g1).abs() < 0.5 * set.ray_step_mm * 4.0 + 1e-3 && inside(w) {
                return Some((t, w, z));
            }
        }
        t0 = t1;
        g0 = g1;
    }
    None
}

/// Bounded brute-force envelope at gear point (w2, z2): (f_n2 in mm, worm w1, worm z1).
pub fn brute_envelope<M: MeshKinematics + ?Sized>(
    mesh: &M,
    starts: u32,
    coupling: &FeedCoupling,
    worm_mod: &dyn FlankModification,
    set: &BruteSettings,
    w2: f64,
    z2: f64,
) -> Option<(f64, f64, f64)> {
    let gear = mesh.gear_flank();
    let p = gear.point(w2, z2);
    let n = gear.normal(w2, z2);
    let seed = mesh.seed_point(coupling, w2, z2).ok()?;
    let rb2 = gear.r_b_mm;
    let eval = |u: f64, v: f64| {
        cut(
            mesh,
            starts,
            coupling,
            worm_mod,
            set,
            &p,
            &n,
            seed.phi2_rad + u / rb2,
            seed.z_v2_mm + v,
        )
    };
    let (mut cu, mut cv) = (0.0, 0.0);
    let (mut hu, mut hv) = (set.half_u_mm, set.half_v_mm);
    let mut best: Option<(f64, f64, f64)> = None;
    for n_grid in [41usize, 15, 15, 15, 15, 15, 15] {
        let mut lvl_best: Option<((f64, f64, f64), f64, f64)> = None;
        for i in 0..n_grid {
            for j in 0..n_grid {
                let u = cu - hu + 2.0 * hu * i as f64 / (n_grid - 1) as f64;
                let v = cv - hv + 2.0 * hv * j as f64 / (n_grid - 1) as f64;
                if let Some(c) = eval(u, v) {
                    if lvl_best.is_none_or(|(b, _, _)| c.0 < b.0) {
                        lvl_best = Some((c, u, v));
                    }
                }
            }
        }
        let (c, u, v) = lvl_best?;
        best = Some(c);
        cu = u;
        cv = v;
        hu *= 4.0 / (n_grid - 1) as f64;
        hv *= 4.0 / (n_grid - 1) as f64;
    }
    best
}
