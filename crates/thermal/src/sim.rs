//! A lumped thermal network of a gear machine, for demonstrations and tests.
//!
//! Nodes (bed, column, spindle/hob/wheel head, table, hydraulic oil, optional coolant)
//! exchange heat through conductances and with the ambient air, whose temperature follows
//! a daily cycle. Heat enters from the spindle (proportional to speed), from cutting (into
//! the head, or into bed and table through hot chips when cutting dry) and from the
//! hydraulic pump. The true centre-distance drift is a linear combination of node
//! temperature rises; sensors read node temperatures (or a head-growth transducer) with
//! Gaussian noise from a seeded ChaCha generator, so every run is reproducible.
//!
//! # Formula
//! C_i·dT_i/dt = Σ_j G_ij·(T_j − T_i) + G_i,amb·(T_amb(t) − T_i) + G_i,ch·(T_ch − T_i) + Q_i(t)
//! T_amb(t) = T_mean + a·cos(2π·(h(t) − h_max)/24 h)
//! drift(t) = Σ_i g_i·(T_i(t) − T_i(0))        [µm; positive = centre distance grew]
//! Integrated with implicit Euler (unconditionally stable; the step is ≤ 1 % of the
//! shortest time constant in the presets, so the integration error is far below the
//! sensor noise).
//! # Source
//! lumped-capacitance network [STANDARD heat transfer]; magnitudes tuned to EP0138375
//! (≈ 76 µm size error over a run) and JPH0761598B2 (≈ −20 µm after 6 h on the grinder)
//! [RECONSTRUCTED: constants are illustrative, not from the seeds]

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::error::{check_range, invalid, Result};
use crate::sensor::{ntc_beta_resistance_ohm, rtd_resistance_ohm};
use crate::units::{h_to_s, s_to_h};

/// One lumped thermal mass.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSpec {
    /// Name, e.g. "bed".
    pub name: String,
    /// Heat capacity in J/K.
    pub capacity_j_per_k: f64,
    /// Conductance to the ambient air in W/K.
    pub g_ambient_w_per_k: f64,
    /// Conductance to a chiller (coolant unit) in W/K; 0 if none.
    pub g_chiller_w_per_k: f64,
}

/// A heat source on a node.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatSpec {
    /// Node index.
    pub node: usize,
    /// Constant power while the machine runs, W (hydraulic pump, drives).
    pub running_w: f64,
    /// Power per 1000 rpm of spindle speed, W.
    pub w_per_krpm: f64,
    /// Extra power while cutting, W.
    pub cutting_w: f64,
}

/// What a simulated sensor reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SensorSignal {
    /// A node temperature in °C.
    Celsius {
        /// Node index.
        node: usize,
    },
    /// A node temperature as a Pt100 resistance in Ω.
    Pt100 {
        /// Node index.
        node: usize,
    },
    /// A node temperature as an NTC (β model) resistance in Ω.
    Ntc {
        /// Node index.
        node: usize,
        /// R0 in Ω at 25 °C.
        r0_ohm: f64,
        /// β in K.
        beta_k: f64,
    },
    /// A displacement transducer: mid_um + um_per_k·(T_node − T_node(0)), µm.
    Displacement {
        /// Node index.
        node: usize,
        /// Growth per kelvin, µm/K.
        um_per_k: f64,
        /// Reading at thermal equilibrium, µm.
        mid_um: f64,
    },
}

/// A simulated sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSensor {
    /// Channel name (the engine configuration uses the same).
    pub name: String,
    /// What it reads.
    pub signal: SensorSignal,
    /// Noise standard deviation in the engineering unit (°C or µm).
    pub noise_sd: f64,
}

/// A complete machine for the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct MachineSpec {
    /// Short name.
    pub name: String,
    /// What the preset represents.
    pub description: String,
    /// Thermal masses.
    pub nodes: Vec<NodeSpec>,
    /// Conductances between nodes (i, j, W/K).
    pub couplings: Vec<(usize, usize, f64)>,
    /// Heat sources.
    pub heat: Vec<HeatSpec>,
    /// Mean ambient temperature, °C (also the start temperature of every node).
    pub ambient_mean_c: f64,
    /// Amplitude of the daily ambient cycle, K.
    pub ambient_amplitude_k: f64,
    /// Clock hour of the ambient maximum.
    pub ambient_max_at_h: f64,
    /// Clock hour at which the shift (t = 0) starts.
    pub shift_start_h: f64,
    /// Chiller set temperature, °C (for nodes with a chiller conductance).
    pub chiller_c: f64,
    /// Spindle speed during the shift, rpm.
    pub spindle_rpm: f64,
    /// Cutting time of one part, s.
    pub cut_s: f64,
    /// Load/unload time between parts (the safe point), s.
    pub load_s: f64,
    /// Drift gains g_i, µm/K, per node.
    pub drift_um_per_k: Vec<f64>,
    /// Noise of the measured drift (a probe on the machine), µm.
    pub drift_noise_um: f64,
    /// The sensors.
    pub sensors: Vec<SimSensor>,
    /// Integration step, s.
    pub dt_s: f64,
}

/// The simulator's state after a step.
#[derive(Debug, Clone, PartialEq)]
pub struct SimState {
    /// Time since the shift start, s.
    pub time_s: f64,
    /// Ambient temperature, °C.
    pub ambient_c: f64,
    /// Node temperatures, °C.
    pub node_c: Vec<f64>,
    /// Raw sensor readings (°C, Ω or µm per sensor).
    pub raw: Vec<f64>,
    /// Sensor readings in engineering units (°C or µm), with noise.
    pub value: Vec<f64>,
    /// True centre-distance drift, µm.
    pub drift_um: f64,
    /// Drift as a probe would measure it (with noise), µm.
    pub measured_drift_um: f64,
    /// True while cutting; false at the load/unload safe point.
    pub cutting: bool,
}

/// The running simulation.
#[derive(Debug, Clone)]
pub struct Simulator {
    spec: MachineSpec,
    step_matrix: DMatrix<f64>,
    x: DVector<f64>,
    x0: DVector<f64>,
    rhs: DVector<f64>,
    rng: ChaCha8Rng,
    state: SimState,
    k: u64,
}

impl MachineSpec {
    /// Checks sizes, indices and ranges.
    pub fn validate(&self) -> Result<()> {
        let n = self.nodes.len();
        if n == 0 {
            return Err(invalid("nodes", 0, "at least one node"));
        }
        for (i, nd) in self.nodes.iter().enumerate() {
            check_range(
                &format!("nodes[{i}].capacity_j_per_k"),
                nd.capacity_j_per_k,
                1.0,
                1e12,
                "1…1e12 J/K",
            )?;
            check_range(
                &format!("nodes[{i}].g_ambient_w_per_k"),
                nd.g_ambient_w_per_k,
                0.0,
                1e9,
                "≥ 0 W/K",
            )?;
            check_range(
                &format!("nodes[{i}].g_chiller_w_per_k"),
                nd.g_chiller_w_per_k,
                0.0,
                1e9,
                "≥ 0 W/K",
            )?;
        }
        for (k, &(i, j, g)) in self.couplings.iter().enumerate() {
            if i >= n || j >= n || i == j {
                return Err(invalid(
                    format!("couplings[{k}]"),
                    format!("({i}, {j})"),
                    "two different node indices",
                ));
            }
            check_range(&format!("couplings[{k}].g_w_per_k"), g, 0.0, 1e9, "≥ 0 W/K")?;
        }
        for (k, h) in self.heat.iter().enumerate() {
            if h.node >= n {
                return Err(invalid(format!("heat[{k}].node"), h.node, "a node index"));
            }
        }
        if self.drift_um_per_k.len() != n {
            return Err(invalid(
                "drift_um_per_k",
                self.drift_um_per_k.len(),
                "one gain per node",
            ));
        }
        for (k, s) in self.sensors.iter().enumerate() {
            let node = match s.signal {
                SensorSignal::Celsius { node }
                | SensorSignal::Pt100 { node }
                | SensorSignal::Ntc { node, .. }
                | SensorSignal::Displacement { node, .. } => node,
            };
            if node >= n {
                return Err(invalid(format!("sensors[{k}].node"), node, "a node index"));
            }
            check_range(
                &format!("sensors[{k}].noise_sd"),
                s.noise_sd,
                0.0,
                1e3,
                "≥ 0",
            )?;
        }
        check_range("dt_s", self.dt_s, 0.01, 3600.0, "0.01…3600 s")?;
        check_range("cut_s", self.cut_s, 0.0, 1e6, "≥ 0 s")?;
        check_range("load_s", self.load_s, 0.0, 1e6, "≥ 0 s")?;
        if self.cut_s + self.load_s <= 0.0 {
            return Err(invalid("cut_s + load_s", 0, "> 0 s"));
        }
        check_range("spindle_rpm", self.spindle_rpm, 0.0, 1e5, "0…1e5 rpm")?;
        check_range("drift_noise_um", self.drift_noise_um, 0.0, 1e3, "≥ 0 µm")?;
        Ok(())
    }

    /// Ambient temperature at shift time `t_s`.
    ///
    /// # Formula
    /// T_amb = T_mean + a·cos(2π·(h − h_max)/24),  h = shift_start_h + t/3600
    pub fn ambient_c(&self, t_s: f64) -> f64 {
        let h = self.shift_start_h + s_to_h(t_s);
        self.ambient_mean_c
            + self.ambient_amplitude_k
                * (std::f64::consts::TAU * (h - self.ambient_max_at_h) / 24.0).cos()
    }

    /// True while cutting at shift time `t_s` (parts: cut, then load/unload).
    pub fn cutting_at(&self, t_s: f64) -> bool {
        t_s.rem_euclid(self.cut_s + self.load_s) < self.cut_s
    }
}

impl Simulator {
    /// Starts a simulation at thermal equilibrium with the ambient at t = 0.
    pub fn new(spec: MachineSpec, seed: u64) -> Result<Self> {
        spec.validate()?;
        let n = spec.nodes.len();
        let mut a = DMatrix::<f64>::zeros(n, n);
        for (i, nd) in spec.nodes.iter().enumerate() {
            a[(i, i)] -= (nd.g_ambient_w_per_k + nd.g_chiller_w_per_k) / nd.capacity_j_per_k;
        }
        for &(i, j, g) in &spec.couplings {
            a[(i, i)] -= g / spec.nodes[i].capacity_j_per_k;
            a[(j, j)] -= g / spec.nodes[j].capacity_j_per_k;
            a[(i, j)] += g / spec.nodes[i].capacity_j_per_k;
            a[(j, i)] += g / spec.nodes[j].capacity_j_per_k;
        }
        let m = DMatrix::<f64>::identity(n, n) - a * spec.dt_s;
        let step_matrix = m
            .lu()
            .try_inverse()
            .ok_or_else(|| invalid("nodes", n, "a thermal network with a regular step matrix"))?;
        let t0 = spec.ambient_c(0.0);
        let x = DVector::from_element(n, t0);
        let mut sim = Self {
            step_matrix,
            x0: x.clone(),
            x,
            rhs: DVector::zeros(n),
            rng: ChaCha8Rng::seed_from_u64(seed),
            state: SimState {
                time_s: 0.0,
                ambient_c: t0,
                node_c: vec![t0; n],
                raw: vec![0.0; spec.sensors.len()],
                value: vec![0.0; spec.sensors.len()],
                drift_um: 0.0,
                measured_drift_um: 0.0,
                cutting: spec.cutting_at(0.0),
            },
            spec,
            k: 0,
        };
        sim.observe();
        Ok(sim)
    }

    /// The machine being simulated.
    pub fn spec(&self) -> &MachineSpec {
        &self.spec
    }

    /// The current state.
    pub fn state(&self) -> &SimState {
        &self.state
    }

    fn observe(&mut self) {
        let spec = &self.spec;
        let st = &mut self.state;
        for (i, v) in st.node_c.iter_mut().enumerate() {
            *v = self.x[i];
        }
        st.drift_um = spec
            .drift_um_per_k
            .iter()
            .enumerate()
            .map(|(i, g)| g * (self.x[i] - self.x0[i]))
            .sum();
        let unit = |sd: f64| Normal::new(0.0, sd.max(0.0)).ok();
        st.measured_drift_um =
            st.drift_um + unit(spec.drift_noise_um).map_or(0.0, |d| d.sample(&mut self.rng));
        for (k, s) in spec.sensors.iter().enumerate() {
            let noise = unit(s.noise_sd).map_or(0.0, |d| d.sample(&mut self.rng));
            let (value, raw) = match s.signal {
                SensorSignal::Celsius { node } => {
                    let v = self.x[node] + noise;
                    (v, v)
                }
                SensorSignal::Pt100 { node } => {
                    let v = self.x[node] + noise;
                    (v, rtd_resistance_ohm(v, 100.0))
                }
                SensorSignal::Ntc {
                    node,
                    r0_ohm,
                    beta_k,
                } => {
                    let v = self.x[node] + noise;
                    (v, ntc_beta_resistance_ohm(v, r0_ohm, 25.0, beta_k))
                }
                SensorSignal::Displacement {
                    node,
                    um_per_k,
                    mid_um,
                } => {
                    let v = mid_um + um_per_k * (self.x[node] - self.x0[node]) + noise;
                    (v, v)
                }
            };
            st.value[k] = value;
            st.raw[k] = raw;
        }
    }

    /// Advances one step of `dt_s` and returns the new state.
    pub fn advance(&mut self) -> &SimState {
        self.k += 1;
        let spec = &self.spec;
        let t_s = self.k as f64 * spec.dt_s;
        let amb = spec.ambient_c(t_s);
        let cutting = spec.cutting_at(t_s);
        for (i, nd) in spec.nodes.iter().enumerate() {
            let b = nd.g_ambient_w_per_k * amb + nd.g_chiller_w_per_k * spec.chiller_c;
            self.rhs[i] = self.x[i] + spec.dt_s * b / nd.capacity_j_per_k;
        }
        for h in &spec.heat {
            let q_w = h.running_w
                + h.w_per_krpm * spec.spindle_rpm / 1000.0
                + if cutting { h.cutting_w } else { 0.0 };
            self.rhs[h.node] += spec.dt_s * q_w / spec.nodes[h.node].capacity_j_per_k;
        }
        self.x = &self.step_matrix * &self.rhs;
        self.state.time_s = t_s;
        self.state.ambient_c = amb;
        self.state.cutting = cutting;
        self.observe();
        &self.state
    }

    /// Number of steps that cover `hours`.
    pub fn steps_for_hours(&self, hours: f64) -> usize {
        (h_to_s(hours) / self.spec.dt_s).round().max(0.0) as usize
    }
}
