//! The per-control-cycle interpolator of the electronic helical guide.
//!
//! Every cycle it reads the crank (A-axis) encoder, unwraps it, estimates the crank speed,
//! evaluates the exact stroke kinematics and commands C1, C2 (position and feed-forward
//! velocity) and X (radial infeed per stroke and return-stroke lift-off). The generating part
//! of C2 and the C1 command are exact rationals of the unwrapped crank count, so they never
//! drift; the helical part is a function of the wrapped crank angle only, so it cannot drift
//! either. Feasibility against the C2 and X limits is checked once, in [`Interpolator::new`].

use std::f64::consts::{PI, TAU};

use crate::coupling::GearCut;
use crate::crank::SliderCrank;
use crate::error::{check_range, Result, ShapingError};
use crate::ratio::{ExactCounts, Ratio};
use crate::units::{rad_s2_to_rev_s2, rad_s_to_rpm, rpm_to_rad_s};

/// Speed and acceleration limits of a rotary axis.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RotaryLimits {
    /// Largest speed in rad/s.
    pub max_speed_rad_s: f64,
    /// Largest acceleration in rad/s².
    pub max_accel_rad_s2: f64,
}

/// Speed and acceleration limits of a linear axis.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LinearLimits {
    /// Largest speed in mm/s.
    pub max_speed_mm_s: f64,
    /// Largest acceleration in mm/s².
    pub max_accel_mm_s2: f64,
}

/// Everything the interpolator needs, in internal units (rad, mm, s).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct InterpolatorConfig {
    /// Gear, cutter and coupling.
    pub cut: GearCut,
    /// Stroke drive.
    pub crank: SliderCrank,
    /// Nominal crank speed = double strokes per minute.
    pub strokes_per_min: f64,
    /// Control cycle time T_s in s (0.25–4 ms).
    pub cycle_s: f64,
    /// Crank encoder counts per revolution.
    pub crank_cpr: u32,
    /// C1 (workpiece) command counts per revolution.
    pub c1_cpr: u32,
    /// C2 (cutter) command counts per revolution.
    pub c2_cpr: u32,
    /// Circular feed per double stroke, on the pitch circle, in mm.
    pub circular_feed_mm: f64,
    /// Radial infeed per double stroke in mm.
    pub radial_feed_mm: f64,
    /// Total radial depth in mm.
    pub depth_mm: f64,
    /// Return-stroke lift-off of X in mm.
    pub lift_off_mm: f64,
    /// C2 limits.
    pub c2_limits: RotaryLimits,
    /// X limits.
    pub x_limits: LinearLimits,
    /// Dead-time compensation τ in control cycles (0–15): the helical term is evaluated at
    /// the crank angle predicted for the instant the command takes effect, θ + ω·τ·T_s.
    pub delay_compensation_cycles: f64,
}

/// What happened in a cycle; the caller acts on it (never a panic in the cycle).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum CycleStatus {
    /// Normal cycle.
    #[default]
    Ok,
    /// The encoder reading was ≥ counts per revolution; the previous command is held.
    EncoderOutOfRange,
    /// The estimated crank speed exceeds the nominal speed by more than 5 %: the feasibility
    /// check no longer covers the motion.
    Overspeed,
    /// Exact arithmetic would overflow (after ~10^12 strokes); the previous command is held.
    Overflow,
}

/// One cycle's commands.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct CycleOutput {
    /// Cycle status.
    pub status: CycleStatus,
    /// Unwrapped crank position in counts.
    pub crank_counts: i64,
    /// Crank angle θ in [0, 2π) (0 = near dead point).
    pub theta_rad: f64,
    /// Estimated crank speed ω in rad/s.
    pub omega_rad_s: f64,
    /// Double strokes begun since start (0 in the first).
    pub stroke_index: i64,
    /// Stroke position Z in mm.
    pub z_mm: f64,
    /// Stroke velocity v_Z in mm/s.
    pub v_z_mm_s: f64,
    /// Stroke acceleration a_Z in mm/s² (steady crank speed assumed).
    pub a_z_mm_s2: f64,
    /// C1 command relative to start, exact counts.
    pub c1_counts: ExactCounts,
    /// C1 feed-forward velocity in rad/s.
    pub c1_vel_rad_s: f64,
    /// Generating part of the C2 command relative to start, exact counts.
    pub c2_generating_counts: ExactCounts,
    /// Helical part of the C2 command relative to start, counts.
    pub c2_helical_counts: f64,
    /// C2 feed-forward velocity in rad/s.
    pub c2_vel_rad_s: f64,
    /// C2 feed-forward acceleration in rad/s².
    pub c2_acc_rad_s2: f64,
    /// Radial infeed reached in mm.
    pub x_infeed_mm: f64,
    /// Lift-off retraction in mm.
    pub x_lift_mm: f64,
    /// X command (into the work, relative to touch) = infeed − lift-off, in mm.
    pub x_mm: f64,
    /// X feed-forward velocity in mm/s.
    pub x_vel_mm_s: f64,
}

impl CycleOutput {
    /// Full C2 command relative to start in counts.
    pub fn c2_counts(&self) -> f64 {
        self.c2_generating_counts.to_f64() + self.c2_helical_counts
    }
}

/// Peak axis demands of a set-up, in internal units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Demands {
    /// Crank angle of the largest stroke speed (rad).
    pub theta_peak_rad: f64,
    /// Largest |v_Z| in mm/s.
    pub v_z_peak_mm_s: f64,
    /// C1 speed in rad/s.
    pub c1_speed_rad_s: f64,
    /// Generating part of the C2 speed in rad/s (magnitude).
    pub c2_generating_rad_s: f64,
    /// Peak helical part of the C2 speed in rad/s (magnitude).
    pub c2_helical_peak_rad_s: f64,
    /// Peak |C2 speed| in rad/s.
    pub c2_speed_rad_s: f64,
    /// Peak |C2 acceleration| in rad/s².
    pub c2_accel_rad_s2: f64,
    /// Peak |X speed| in mm/s.
    pub x_speed_mm_s: f64,
    /// Peak |X acceleration| in mm/s².
    pub x_accel_mm_s2: f64,
    /// Circular feed actually realised after rounding C1 to whole counts per stroke, mm.
    pub realised_circular_feed_mm: f64,
}

/// Length of the speed-estimation window in cycles.
const SPEED_WINDOW: usize = 8;

/// The cyclic interpolator. Build once (validates and checks feasibility), then call
/// [`Interpolator::cycle`] once per control cycle; `cycle` does not allocate.
#[derive(Debug, Clone)]
pub struct Interpolator {
    cfg: InterpolatorConfig,
    omega_nominal_rad_s: f64,
    c1_counts_per_stroke: i64,
    ratio_c1: Ratio,
    ratio_c2: Ratio,
    k_h_counts_per_mm: f64,
    c1_rad_per_crank_rad: f64,
    generating_ratio: f64,
    demands: Demands,
    started: bool,
    prev_raw: u32,
    n_counts: i64,
    n0_counts: i64,
    z0_mm: f64,
    ring: [i64; SPEED_WINDOW],
    ring_len: usize,
    ring_pos: usize,
    last: CycleOutput,
}

/// Largest encoder resolution accepted, counts per revolution.
pub const MAX_CPR: u32 = 1 << 26;

impl Interpolator {
    /// Validates the configuration, computes the exact ratios and refuses infeasible set-ups.
    pub fn new(cfg: InterpolatorConfig) -> Result<Self> {
        check_range(
            "strokes per minute S",
            cfg.strokes_per_min,
            1.0,
            3000.0,
            "1/min",
        )?;
        check_range("cycle time", cfg.cycle_s * 1e3, 0.25, 4.0, "ms")?;
        for (field, cpr) in [
            ("crank encoder counts per revolution", cfg.crank_cpr),
            ("C1 counts per revolution", cfg.c1_cpr),
            ("C2 counts per revolution", cfg.c2_cpr),
        ] {
            check_range(field, f64::from(cpr), 360.0, f64::from(MAX_CPR), "")?;
        }
        let r_c1 = cfg.cut.workpiece_pitch_radius_mm();
        // F must turn the workpiece: at least half a C1 count per stroke (rounded to one).
        let half_count_mm = 0.5 * TAU / f64::from(cfg.c1_cpr) * r_c1;
        check_range(
            "circular feed F (at least half a C1 count per stroke)",
            cfg.circular_feed_mm,
            half_count_mm,
            10.0,
            "mm",
        )?;
        check_range("radial feed U", cfg.radial_feed_mm, 0.0, 1.0, "mm")?;
        check_range("radial depth X", cfg.depth_mm, 0.0, 100.0, "mm")?;
        check_range("lift-off E", cfg.lift_off_mm, 0.0, 10.0, "mm")?;
        check_range(
            "C2 speed limit",
            cfg.c2_limits.max_speed_rad_s,
            1e-6,
            1e6,
            "rad/s",
        )?;
        check_range(
            "C2 acceleration limit",
            cfg.c2_limits.max_accel_rad_s2,
            1e-6,
            1e9,
            "rad/s^2",
        )?;
        check_range(
            "X speed limit",
            cfg.x_limits.max_speed_mm_s,
            1e-6,
            1e6,
            "mm/s",
        )?;
        check_range(
            "X acceleration limit",
            cfg.x_limits.max_accel_mm_s2,
            1e-6,
            1e9,
            "mm/s^2",
        )?;
        check_range(
            "delay compensation",
            cfg.delay_compensation_cycles,
            0.0,
            15.0,
            "cycles",
        )?;

        let cut = cfg.cut;
        let c1_counts_f = cfg.circular_feed_mm / r_c1 * f64::from(cfg.c1_cpr) / TAU;
        let c1_counts_per_stroke = c1_counts_f.round() as i64;
        if c1_counts_per_stroke == 0 {
            return Err(ShapingError::OutOfRange {
                field: "circular feed F (at least half a C1 count per stroke)",
                value: cfg.circular_feed_mm,
                min: half_count_mm,
                max: 10.0,
                unit: "mm",
            });
        }
        let ratio_c1 = Ratio::new(i128::from(c1_counts_per_stroke), i128::from(cfg.crank_cpr))?;
        let ratio_c2 = cut
            .generating_ratio()
            .checked_mul(Ratio::new(i128::from(cfg.c2_cpr), i128::from(cfg.c1_cpr))?)?
            .checked_mul(ratio_c1)?;
        let k_h = cut.helical_gain_rad_per_mm();
        let omega = rpm_to_rad_s(cfg.strokes_per_min);
        let c1_rad_per_crank_rad = c1_counts_per_stroke as f64 / f64::from(cfg.c1_cpr);
        let generating_ratio = cut.generating_ratio().to_f64();

        let (theta_peak, dz_peak) = cfg.crank.peak_velocity();
        let c1_speed = c1_rad_per_crank_rad * omega;
        let gen = (generating_ratio * c1_speed).abs();
        let hel = k_h.abs() * omega * dz_peak;
        let demands = Demands {
            theta_peak_rad: theta_peak,
            v_z_peak_mm_s: omega * dz_peak,
            c1_speed_rad_s: c1_speed,
            c2_generating_rad_s: gen,
            c2_helical_peak_rad_s: hel,
            c2_speed_rad_s: gen + hel,
            c2_accel_rad_s2: k_h.abs() * omega * omega * cfg.crank.max_abs_d2z_dtheta2_mm(),
            x_speed_mm_s: (cfg.lift_off_mm + 0.5 * cfg.radial_feed_mm) * omega,
            x_accel_mm_s2: (2.0 * cfg.lift_off_mm + 0.5 * cfg.radial_feed_mm) * omega * omega,
            realised_circular_feed_mm: c1_counts_per_stroke as f64 * TAU / f64::from(cfg.c1_cpr)
                * r_c1,
        };
        check_feasible(&cfg, &demands)?;

        Ok(Self {
            cfg,
            omega_nominal_rad_s: omega,
            c1_counts_per_stroke,
            ratio_c1,
            ratio_c2,
            k_h_counts_per_mm: k_h * f64::from(cfg.c2_cpr) / TAU,
            c1_rad_per_crank_rad,
            generating_ratio,
            demands,
            started: false,
            prev_raw: 0,
            n_counts: 0,
            n0_counts: 0,
            z0_mm: 0.0,
            ring: [0; SPEED_WINDOW],
            ring_len: 0,
            ring_pos: 0,
            last: CycleOutput::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &InterpolatorConfig {
        &self.cfg
    }

    /// Peak demands computed by the feasibility check.
    pub fn demands(&self) -> &Demands {
        &self.demands
    }

    /// C1 counts per double stroke (the circular feed rounded to whole counts).
    pub fn c1_counts_per_stroke(&self) -> i64 {
        self.c1_counts_per_stroke
    }

    /// Exact C1 counts per crank count.
    pub fn ratio_c1(&self) -> Ratio {
        self.ratio_c1
    }

    /// Exact C2 (generating) counts per crank count.
    pub fn ratio_c2(&self) -> Ratio {
        self.ratio_c2
    }

    /// Helical gain in C2 counts per mm of Z.
    pub fn helical_gain_counts_per_mm(&self) -> f64 {
        self.k_h_counts_per_mm
    }

    /// Nominal crank speed ω in rad/s.
    pub fn omega_nominal_rad_s(&self) -> f64 {
        self.omega_nominal_rad_s
    }

    /// Runs one control cycle on the raw crank encoder reading `raw_counts` ∈ [0, cpr).
    ///
    /// # Formula
    /// N_k = N_{k−1} + wrap(raw_k − raw_{k−1}) (shortest way round);
    /// ω_k = 2π·(N_k − N_{k−m})/(cpr·m·T_s), m = min(k, 8) (ω_nominal in the first cycle);
    /// θ_k = 2π·(N_k mod cpr)/cpr; Z, v_Z, a_Z from [`SliderCrank`];
    /// C1_k = (c1_per_stroke/cpr_A)·(N_k − N_0) (exact);
    /// C2_k = ρ·(cpr_C2/cpr_C1)·C1_k (exact) + k_h·(cpr_C2/2π)·(Z(θ_k + ω_k·τ·T_s) − Z_0);
    /// v_C2 = ρ·ω_C1 + k_h·v_Z; a_C2 = k_h·a_Z (helical terms at the predicted angle, τ the
    /// dead-time compensation);
    /// X = min(depth, f_r·(k + ramp(θ))) − lift(θ) (depth from the start when f_r = 0), with ramp = (1 − cos(θ − π))/2 and
    /// lift = E·(1 − cos 2(θ − π))/2 on the return stroke θ ∈ [π, 2π), both 0 when cutting.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016) eq. (1) and abstract (crank angle measured, speed computed each cycle) [SEED];
    /// position form and cycle structure docs/shaping.md "Derivation: the control cycle and the
    /// position form" [RECONSTRUCTED];
    /// lift-off and infeed profiles: this crate's choice, docs/shaping.md [RECONSTRUCTED]
    pub fn cycle(&mut self, raw_counts: u32) -> CycleOutput {
        let cpr = self.cfg.crank_cpr;
        if raw_counts >= cpr {
            self.last.status = CycleStatus::EncoderOutOfRange;
            return self.last;
        }
        if self.started {
            let cpr_i = i64::from(cpr);
            let mut d = i64::from(raw_counts) - i64::from(self.prev_raw);
            if 2 * d > cpr_i {
                d -= cpr_i;
            } else if 2 * d < -cpr_i {
                d += cpr_i;
            }
            self.n_counts += d;
        } else {
            self.n_counts = i64::from(raw_counts);
            self.n0_counts = self.n_counts;
            self.z0_mm = self
                .cfg
                .crank
                .z_mm(TAU * f64::from(raw_counts) / f64::from(cpr));
        }
        self.prev_raw = raw_counts;

        let omega = if self.ring_len == 0 {
            self.omega_nominal_rad_s
        } else {
            let m = self.ring_len;
            let oldest = self.ring[(self.ring_pos + SPEED_WINDOW - m) % SPEED_WINDOW];
            TAU * (self.n_counts - oldest) as f64 / (f64::from(cpr) * m as f64 * self.cfg.cycle_s)
        };
        self.ring[self.ring_pos] = self.n_counts;
        self.ring_pos = (self.ring_pos + 1) % SPEED_WINDOW;
        self.ring_len = (self.ring_len + 1).min(SPEED_WINDOW);
        self.started = true;

        let rel = self.n_counts - self.n0_counts;
        let (Some(c1), Some(c2g)) = (self.ratio_c1.apply(rel), self.ratio_c2.apply(rel)) else {
            self.last.status = CycleStatus::Overflow;
            return self.last;
        };

        let cpr_i = i64::from(cpr);
        let theta = TAU * self.n_counts.rem_euclid(cpr_i) as f64 / f64::from(cpr);
        let crank = &self.cfg.crank;
        let (z, dz, d2z) = crank.state(theta);
        let v_z = omega * dz;
        let a_z = omega * omega * d2z;
        let k_h = self.cfg.cut.helical_gain_rad_per_mm();
        let c1_vel = self.c1_rad_per_crank_rad * omega;
        let (z_h, v_h, a_h) = if self.cfg.delay_compensation_cycles > 0.0 {
            let th = theta + omega * self.cfg.delay_compensation_cycles * self.cfg.cycle_s;
            let (zp, dzp, d2zp) = crank.state(th);
            (zp, omega * dzp, omega * omega * d2zp)
        } else {
            (z, v_z, a_z)
        };

        let stroke_index = self.n_counts.div_euclid(cpr_i) - self.n0_counts.div_euclid(cpr_i);
        let (ramp, dramp, lift, dlift) = if theta >= PI {
            let phi = theta - PI;
            let e = self.cfg.lift_off_mm;
            (
                0.5 * (1.0 - phi.cos()),
                0.5 * phi.sin(),
                0.5 * e * (1.0 - (2.0 * phi).cos()),
                e * (2.0 * phi).sin(),
            )
        } else {
            (0.0, 0.0, 0.0, 0.0)
        };
        // U = 0 means no infeed cycle: the cutter works at full depth from the first stroke.
        let infeed_raw = if self.cfg.radial_feed_mm > 0.0 {
            self.cfg.radial_feed_mm * (stroke_index as f64 + ramp)
        } else {
            self.cfg.depth_mm
        };
        let (infeed, dinfeed) = if infeed_raw >= self.cfg.depth_mm {
            (self.cfg.depth_mm, 0.0)
        } else {
            (infeed_raw, self.cfg.radial_feed_mm * dramp)
        };

        let status = if omega > 1.05 * self.omega_nominal_rad_s {
            CycleStatus::Overspeed
        } else {
            CycleStatus::Ok
        };
        self.last = CycleOutput {
            status,
            crank_counts: self.n_counts,
            theta_rad: theta,
            omega_rad_s: omega,
            stroke_index,
            z_mm: z,
            v_z_mm_s: v_z,
            a_z_mm_s2: a_z,
            c1_counts: c1,
            c1_vel_rad_s: c1_vel,
            c2_generating_counts: c2g,
            c2_helical_counts: self.k_h_counts_per_mm * (z_h - self.z0_mm),
            c2_vel_rad_s: self.generating_ratio * c1_vel + k_h * v_h,
            c2_acc_rad_s2: k_h * a_h,
            x_infeed_mm: infeed,
            x_lift_mm: lift,
            x_mm: infeed - lift,
            x_vel_mm_s: (dinfeed - dlift) * omega,
        };
        self.last
    }
}

fn check_feasible(cfg: &InterpolatorConfig, d: &Demands) -> Result<()> {
    let s = cfg.strokes_per_min;
    let c2_speed_limit = cfg.c2_limits.max_speed_rad_s;
    if d.c2_speed_rad_s > c2_speed_limit {
        let s_max = if d.c2_speed_rad_s > 0.0 {
            s * c2_speed_limit / d.c2_speed_rad_s
        } else {
            s
        };
        return Err(ShapingError::Infeasible {
            axis: "C2",
            quantity: "speed",
            required: rad_s_to_rpm(d.c2_speed_rad_s),
            limit: rad_s_to_rpm(c2_speed_limit),
            unit: "rpm",
            detail: format!(
                "at S = {s} strokes/min: generating {:.4} rpm + helical {:.4} rpm at crank \
                 angle {:.2} deg; reduce S to at most {s_max:.1} strokes/min or the circular feed",
                rad_s_to_rpm(d.c2_generating_rad_s),
                rad_s_to_rpm(d.c2_helical_peak_rad_s),
                d.theta_peak_rad.to_degrees()
            ),
        });
    }
    let c2_acc_limit = cfg.c2_limits.max_accel_rad_s2;
    if d.c2_accel_rad_s2 > c2_acc_limit {
        let s_max = s * (c2_acc_limit / d.c2_accel_rad_s2).sqrt();
        return Err(ShapingError::Infeasible {
            axis: "C2",
            quantity: "acceleration",
            required: rad_s2_to_rev_s2(d.c2_accel_rad_s2),
            limit: rad_s2_to_rev_s2(c2_acc_limit),
            unit: "rev/s^2",
            detail: format!(
                "helical term k_h·a_Z at the far dead point, at S = {s} strokes/min; reduce S \
                 to at most {s_max:.1} strokes/min"
            ),
        });
    }
    if d.x_speed_mm_s > cfg.x_limits.max_speed_mm_s {
        return Err(ShapingError::Infeasible {
            axis: "X",
            quantity: "speed",
            required: d.x_speed_mm_s,
            limit: cfg.x_limits.max_speed_mm_s,
            unit: "mm/s",
            detail: format!(
                "lift-off E = {} mm and radial feed U = {} mm within one return stroke at S = {s} \
                 strokes/min",
                cfg.lift_off_mm, cfg.radial_feed_mm
            ),
        });
    }
    if d.x_accel_mm_s2 > cfg.x_limits.max_accel_mm_s2 {
        return Err(ShapingError::Infeasible {
            axis: "X",
            quantity: "acceleration",
            required: d.x_accel_mm_s2,
            limit: cfg.x_limits.max_accel_mm_s2,
            unit: "mm/s^2",
            detail: format!(
                "lift-off E = {} mm and radial feed U = {} mm within one return stroke at S = {s} \
                 strokes/min",
                cfg.lift_off_mm, cfg.radial_feed_mm
            ),
        });
    }
    Ok(())
}
