//! Independent numeric constructions of span and ball measurements on a helical involute
//! gear, written from the generated flank surfaces and not from the library's formulas.
//!
//! Shared by the library's property tests and the `gearcomp gear` CLI property tests
//! (included there with `#[path]`), so both compare against the same construction.
//!
//! The flank of an external gear is built as the surface it is: in every transverse
//! section the involute unwound from the base circle, P(u) = r_b·[e(φ₀ − u) + u·(−sin, cos)(φ₀ − u)],
//! and the section turned by w·tan β/r at axial position w (the helix). φ₀ is found by
//! requiring the curve to pass through the reference-circle point of the tooth (half the
//! transverse thickness s_t = m_t·(π/2 + 2·x·tan α_n) either side of the tooth centre).
//! - Span: a plane tangent to the base cylinder is intersected with the two outer flanks
//!   of k teeth, numerically (bisection on the roll parameter), at two axial positions;
//!   this gives two straight lines in the plane; W_k is their distance, and the anvils
//!   touch at the ends of the common perpendicular whose midpoint lies on the line where
//!   the plane touches the base cylinder.
//! - Ball: the ball centre on the space's centre line is moved radially until its
//!   distance to the helical flank (nested golden-section minimisation over roll and axial
//!   position) equals D/2.
#![allow(dead_code)]

use std::f64::consts::PI;

/// Gear data for the construction (external gear).
#[derive(Debug, Clone, Copy)]
pub struct Gear3 {
    pub m_n: f64,
    pub alpha_n: f64,
    pub beta: f64,
    pub z: u32,
    /// Generating profile shift (thickness).
    pub x: f64,
    /// Base angle of the right flank of tooth 0 (from [`Gear3::new`]).
    phi0: f64,
}

impl Gear3 {
    /// A gear for the construction; finds the flank's base angle once.
    pub fn new(m_n: f64, alpha_n: f64, beta: f64, z: u32, x: f64) -> Gear3 {
        let mut g = Gear3 {
            m_n,
            alpha_n,
            beta,
            z,
            x,
            phi0: 0.0,
        };
        g.phi0 = g.find_phi0();
        g
    }
    pub fn m_t(&self) -> f64 {
        self.m_n / self.beta.cos()
    }
    pub fn alpha_t(&self) -> f64 {
        (self.alpha_n.tan() / self.beta.cos()).atan()
    }
    pub fn r(&self) -> f64 {
        0.5 * f64::from(self.z) * self.m_t()
    }
    pub fn r_b(&self) -> f64 {
        self.r() * self.alpha_t().cos()
    }
    /// Twist of the transverse section per mm of axial position (rad/mm).
    fn twist(&self) -> f64 {
        self.beta.tan() / self.r()
    }
    /// Base angle φ₀ of the right flank of tooth 0, found from the reference-circle point.
    fn find_phi0(&self) -> f64 {
        let s_t = self.m_t() * (PI / 2.0 + 2.0 * self.x * self.alpha_n.tan());
        let psi_r = s_t / (2.0 * self.r());
        // Roll u_r where the unwound curve reaches the reference circle: bisection on |P|.
        let r_b = self.r_b();
        let (mut a, mut b) = (0.0f64, 3.0f64);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if r_b * (1.0 + m * m).sqrt() < self.r() {
                a = m;
            } else {
                b = m;
            }
        }
        let u_r = 0.5 * (a + b);
        // Polar angle of P(u_r) with φ₀ = 0, measured from the curve itself.
        let p = self.unwound(0.0, u_r);
        let ang = p.1.atan2(p.0);
        psi_r - ang
    }
    /// Point of the involute with base angle φ₀ at roll u (right flank: unwinds towards
    /// decreasing angle).
    fn unwound(&self, phi0: f64, u: f64) -> (f64, f64) {
        let r_b = self.r_b();
        let g = phi0 - u;
        // The string leaves the base circle at angle g and runs back towards φ₀.
        (r_b * (g.cos() - u * g.sin()), r_b * (g.sin() + u * g.cos()))
    }
    /// Right (`right = true`) or left flank of the tooth centred at angle `centre`, roll u,
    /// axial position w: a 3D point.
    pub fn flank(&self, right: bool, centre: f64, u: f64, w: f64) -> [f64; 3] {
        let (px, py) = self.unwound(self.phi0, u);
        let py = if right { py } else { -py };
        let rot = centre + self.twist() * w;
        let (s, c) = rot.sin_cos();
        [c * px - s * py, s * px + c * py, w]
    }
}

fn bisect(a: f64, b: f64, f: impl Fn(f64) -> f64) -> Option<f64> {
    bisect_n(a, b, 200, f)
}

fn bisect_n(mut a: f64, mut b: f64, n: usize, f: impl Fn(f64) -> f64) -> Option<f64> {
    let (mut fa, fb) = (f(a), f(b));
    if !(fa.is_finite() && fb.is_finite()) || fa.signum() == fb.signum() {
        return None;
    }
    for _ in 0..n {
        let m = 0.5 * (a + b);
        let fm = f(m);
        if fm.signum() == fa.signum() {
            a = m;
            fa = fm;
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

/// Result of the span construction.
#[derive(Debug, Clone, Copy)]
pub struct SpanConstruction {
    pub span_mm: f64,
    pub contact_diameter_mm: f64,
    /// Axial distance between the two contact points.
    pub axial_mm: f64,
}

/// Span over k teeth by intersecting a base tangent plane with the two outer flanks.
pub fn span(g: &Gear3, k: u32) -> Option<SpanConstruction> {
    let r_b = g.r_b();
    let pitch = 2.0 * PI / f64::from(g.z);
    // Plane touching the base cylinder midway between the two outer flanks.
    let phi_p = 0.5 * f64::from(k - 1) * pitch;
    let (n, t) = ([phi_p.cos(), phi_p.sin()], [-phi_p.sin(), phi_p.cos()]);
    // s-coordinate in the plane of a flank's intersection at axial position w.
    let cut = |right: bool, centre: f64, w: f64| -> Option<f64> {
        let f = |u: f64| {
            let p = g.flank(right, centre, u, w);
            (p[0] - r_b * n[0]) * n[0] + (p[1] - r_b * n[1]) * n[1]
        };
        let u = bisect(0.0, 2.5, f)?;
        let p = g.flank(right, centre, u, w);
        Some((p[0] - r_b * n[0]) * t[0] + (p[1] - r_b * n[1]) * t[1])
    };
    let dw = 1.0;
    let l0 = cut(false, 0.0, 0.0)?;
    let l1 = cut(false, 0.0, dw)?;
    let r0 = cut(true, f64::from(k - 1) * pitch, 0.0)?;
    let r1 = cut(true, f64::from(k - 1) * pitch, dw)?;
    // Lines s = a + c·w in the plane; the two slopes must agree (parallel flanks).
    let (cl, cr) = ((l1 - l0) / dw, (r1 - r0) / dw);
    if (cl - cr).abs() > 1e-9 * (1.0 + cl.abs()) {
        return None;
    }
    let c = 0.5 * (cl + cr);
    let norm = (1.0 + c * c).sqrt();
    // Distance between the parallel lines: the offset at w = 0 projected on the unit normal
    // (1, −c)/norm of the direction (c, 1).
    let span_mm = (l0 - r0).abs() / norm;
    // Common perpendicular: from (r0, 0) along the normal to line L; its midpoint moves along
    // the lines' direction until its s-coordinate is 0 (plane's contact line).
    let sgn = (l0 - r0).signum();
    let foot_r = (r0, 0.0);
    let foot_l = (r0 + sgn * span_mm / norm, -sgn * span_mm * c / norm);
    let mid_s = 0.5 * (foot_r.0 + foot_l.0);
    // Move both feet by λ·(c, 1) so the midpoint reaches s = 0.
    let lambda = if c.abs() > 1e-15 { -mid_s / c } else { 0.0 };
    let s_contact = if c.abs() > 1e-15 {
        foot_l.0 + lambda * c
    } else {
        // Spur: every position along the axis is equivalent; the foot points lie at ±W/2
        // only if the plane is centred, which it is by symmetry.
        0.5 * (foot_l.0 - foot_r.0)
    };
    let contact_diameter_mm = 2.0 * (r_b * r_b + s_contact * s_contact).sqrt();
    let axial_mm = (foot_l.1 - foot_r.1).abs();
    Some(SpanConstruction {
        span_mm,
        contact_diameter_mm,
        axial_mm,
    })
}

fn golden(mut a: f64, mut b: f64, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let g: f64 = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..75 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    (x, f(x))
}

/// Result of the ball construction.
#[derive(Debug, Clone, Copy)]
pub struct BallConstruction {
    /// Diameter of the circle through the ball centres.
    pub centre_diameter_mm: f64,
    /// Dimension over two balls.
    pub dimension_mm: f64,
    /// Diameter where the ball touches the flank.
    pub contact_diameter_mm: f64,
}

/// Dimension over balls of diameter `ball` by placing the ball in the space next to tooth 0
/// (centre on the space's centre line in the transverse plane w = 0) at the radius where
/// its distance to the helical flank is D/2.
pub fn ball(g: &Gear3, ball: f64) -> Option<BallConstruction> {
    let half_space = PI / f64::from(g.z);
    let (cx, cy) = (half_space.cos(), half_space.sin());
    // Roll range of the flank up to a little beyond the tip circle (x from the gear).
    let r_a = g.r() + g.m_n * (1.0 + g.x.max(0.0)) + ball;
    let u_max = ((r_a / g.r_b()).powi(2) - 1.0).sqrt();
    let w_range = 2.0 * ball + g.m_n;
    // Nearest point of the right flank of tooth 0 to the centre at radius rho.
    let nearest = |rho: f64| -> (f64, [f64; 3]) {
        let cpt = [rho * cx, rho * cy, 0.0];
        let dist2 = |u: f64, w: f64| {
            let p = g.flank(true, 0.0, u, w);
            (p[0] - cpt[0]).powi(2) + (p[1] - cpt[1]).powi(2) + (p[2] - cpt[2]).powi(2)
        };
        let (w_best, _) = golden(-w_range, w_range, |w| golden(0.0, u_max, |u| dist2(u, w)).1);
        let (u_best, d2) = golden(0.0, u_max, |u| dist2(u, w_best));
        (d2.sqrt(), g.flank(true, 0.0, u_best, w_best))
    };
    let r_b = g.r_b();
    // Going out along the centre line the space widens and the distance grows; a centre
    // deep inside the base circle moves away from the flank's start again. Start from the
    // closest approach, then bisect outwards.
    let hi = g.r() + 3.0 * g.m_n + ball;
    let (rho_min, _) = golden(0.7 * r_b, hi, |rho| nearest(rho).0);
    let rho = bisect_n(rho_min, hi, 64, |rho| nearest(rho).0 - 0.5 * ball)?;
    let (_, p) = nearest(rho);
    let odd = if g.z.is_multiple_of(2) {
        1.0
    } else {
        (PI / (2.0 * f64::from(g.z))).cos()
    };
    Some(BallConstruction {
        centre_diameter_mm: 2.0 * rho,
        dimension_mm: 2.0 * rho * odd + ball,
        contact_diameter_mm: 2.0 * (p[0] * p[0] + p[1] * p[1]).sqrt(),
    })
}

/// Recommended k by DIN 3960 3.6.4, written out:
/// k = round(z/π·[tan α_Mt/cos²β_b − 2·x·tan α_n/z − inv α_t] + 0.5), cos α_Mt = d_b/(d + 2·x·m_n).
pub fn din3960_k(g: &Gear3, x_nominal: f64) -> u32 {
    let z = f64::from(g.z);
    let at = g.alpha_t();
    let d = 2.0 * g.r();
    let d_b = 2.0 * g.r_b();
    let beta_b = (g.beta.tan() * at.cos()).atan();
    let amt = (d_b / (d + 2.0 * x_nominal * g.m_n)).acos();
    let inv = |a: f64| a.tan() - a;
    let k = z / PI
        * (amt.tan() / beta_b.cos().powi(2) - 2.0 * x_nominal * g.alpha_n.tan() / z - inv(at))
        + 0.5;
    k.round().max(1.0) as u32
}

/// Root form diameter of rack generation (ISO 21771 5.4.5) and tip diameter, for the
/// DIN 867 rack (h_aP* = 1, h_fP* = 1.25, ρ_fP* = 0.25), at shift x (tip at nominal x_tip).
pub fn flank_limits_din867(g: &Gear3, x_tip: f64) -> (f64, f64) {
    let at = g.alpha_t();
    let h_ffp = g.m_n * (1.25 - 0.25 * (1.0 - g.alpha_n.sin()));
    let l = g.r() * at.sin() - (h_ffp - g.x * g.m_n) / at.sin();
    let r_b = g.r_b();
    let d_ff = if l >= 0.0 {
        2.0 * (r_b * r_b + l * l).sqrt()
    } else {
        2.0 * r_b
    };
    (d_ff, 2.0 * g.r() + 2.0 * g.m_n * (1.0 + x_tip))
}
