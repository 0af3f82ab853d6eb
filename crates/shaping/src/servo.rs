//! Single-axis servo model for the tracking simulation: a proportional position loop (gain
//! K_v) around a velocity loop closed to a first-order lag (time constant T_v), with velocity
//! feed-forward, position-encoder quantisation and a command delay of whole control cycles.
//!
//! # Formula
//! Per drive cycle h = T_s/n (n drive cycles per control cycle T_s), with the command delayed
//! by d control cycles and interpolated linearly towards the next one (fine interpolation):
//! v_set = K_v·(x_cmd,k−d − q(x)) + k_ff·v_ff,k−d + k_aff·T_v·a_ff,k−d,
//! q(x) = Δ·⌊x/Δ⌋ (encoder quantum Δ); the acceleration term cancels the velocity-loop lag;
//! the velocity loop v̇ = (v_set − v)/T_v is integrated exactly over the drive cycle (v_set
//! held): v⁺ = v_set + (v − v_set)·e^(−h/T_v),  x⁺ = x + v_set·h + (v − v_set)·T_v·(1 − e^(−h/T_v)).
//! Closed loop without feed-forward: G(s) = K_v / (s·(T_v·s + 1)).
//!
//! # Source
//! docs/shaping.md "Servo model": G(s) = K_v/(s(T_v s + 1)) [RECONSTRUCTED]; exact
//! zero-order-hold discretisation [DERIVED]

use crate::error::{check_range, Result};

/// Parameters of one axis' position/velocity loop (axis units: rad or mm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LoopParams {
    /// Position-loop gain K_v in 1/s.
    pub kv_per_s: f64,
    /// Time constant T_v of the closed velocity loop in s.
    pub velocity_time_constant_s: f64,
    /// Velocity feed-forward factor k_ff (0 = none, 1 = full).
    pub feed_forward: f64,
    /// Acceleration feed-forward factor k_aff (0 = none, 1 = cancels the velocity-loop lag).
    pub accel_feed_forward: f64,
    /// Position-encoder quantum Δ in axis units (rad or mm); 0 = unquantised.
    pub quantum: f64,
    /// Command delay in whole control cycles.
    pub delay_cycles: u32,
    /// Drive (servo) cycles per control cycle; the drive interpolates the command linearly
    /// between control cycles (fine interpolation) when the delay is at least one cycle.
    pub substeps: u32,
}

/// Largest number of drive cycles per control cycle.
pub const MAX_SUBSTEPS: u32 = 64;

/// Largest command delay accepted, in cycles.
pub const MAX_DELAY_CYCLES: u32 = 15;

impl LoopParams {
    /// Checks every parameter against its allowed range.
    pub fn validate(&self) -> Result<()> {
        check_range("servo position gain Kv", self.kv_per_s, 0.1, 1000.0, "1/s")?;
        check_range(
            "servo velocity-loop time constant",
            self.velocity_time_constant_s * 1e3,
            0.01,
            1000.0,
            "ms",
        )?;
        check_range("servo feed-forward factor", self.feed_forward, 0.0, 1.0, "")?;
        check_range(
            "servo acceleration feed-forward factor",
            self.accel_feed_forward,
            0.0,
            1.0,
            "",
        )?;
        check_range(
            "servo encoder quantum",
            self.quantum,
            0.0,
            1.0,
            "axis units",
        )?;
        check_range(
            "servo delay",
            f64::from(self.delay_cycles),
            0.0,
            f64::from(MAX_DELAY_CYCLES),
            "cycles",
        )?;
        check_range(
            "servo drive cycles per control cycle",
            f64::from(self.substeps),
            1.0,
            f64::from(MAX_SUBSTEPS),
            "",
        )?;
        Ok(())
    }
}

/// An axis drive model: ideal (actual = command) or the loop model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum ServoModel {
    /// Follows the command exactly, with no delay.
    Ideal,
    /// Position loop around velocity loop, see the module docs.
    Loop(LoopParams),
}

/// State of one simulated axis. Fixed-size; `step` does not allocate.
#[derive(Debug, Clone)]
pub struct ServoAxis {
    model: ServoModel,
    pos: f64,
    vel: f64,
    queue: [(f64, f64, f64); MAX_DELAY_CYCLES as usize + 1],
    head: usize,
}

impl ServoAxis {
    /// An axis in steady motion: starts at `pos` with velocity `vel`, the delay line filled
    /// with that state, as if it had been tracking already.
    pub fn new(model: ServoModel, pos: f64, vel: f64) -> Self {
        Self {
            model,
            pos,
            vel,
            queue: [(pos, vel, 0.0); MAX_DELAY_CYCLES as usize + 1],
            head: 0,
        }
    }

    /// Actual position (axis units).
    pub fn position(&self) -> f64 {
        self.pos
    }

    /// Actual velocity (axis units per s).
    pub fn velocity(&self) -> f64 {
        self.vel
    }

    /// Takes this cycle's command (position, velocity and acceleration feed-forward), returns
    /// the actual
    /// position at the start of the cycle (the instant the command belongs to) and advances
    /// the axis by `cycle_s` seconds. The ideal model returns the command itself.
    pub fn step(&mut self, cmd_pos: f64, cmd_vel: f64, cmd_acc: f64, cycle_s: f64) -> f64 {
        match self.model {
            ServoModel::Ideal => {
                self.pos = cmd_pos;
                self.vel = cmd_vel;
                cmd_pos
            }
            ServoModel::Loop(p) => {
                let n = self.queue.len();
                self.queue[self.head] = (cmd_pos, cmd_vel, cmd_acc);
                let d = (p.delay_cycles as usize).min(n - 1);
                let (x0, v0, a0) = self.queue[(self.head + n - d) % n];
                // The drive interpolates towards the next command when the delay leaves one.
                let (x1, v1, a1) = if d > 0 {
                    self.queue[(self.head + n - d + 1) % n]
                } else {
                    (x0 + v0 * cycle_s, v0, a0)
                };
                self.head = (self.head + 1) % n;
                let now = self.pos;
                let subs = p.substeps.clamp(1, MAX_SUBSTEPS);
                let h = cycle_s / f64::from(subs);
                let tv = p.velocity_time_constant_s;
                let decay = (-h / tv).exp();
                for j in 0..subs {
                    let f = f64::from(j) / f64::from(subs);
                    let fm = (f64::from(j) + 0.5) / f64::from(subs);
                    let xc = x0 + f * (x1 - x0);
                    let vc = v0 + fm * (v1 - v0);
                    let ac = a0 + fm * (a1 - a0);
                    let measured = if p.quantum > 0.0 {
                        p.quantum * (self.pos / p.quantum).floor()
                    } else {
                        self.pos
                    };
                    let v_set = p.kv_per_s * (xc - measured)
                        + p.feed_forward * vc
                        + p.accel_feed_forward * tv * ac;
                    self.pos += v_set * h + (self.vel - v_set) * tv * (1.0 - decay);
                    self.vel = v_set + (self.vel - v_set) * decay;
                }
                now
            }
        }
    }
}
