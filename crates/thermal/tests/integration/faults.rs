//! Sensor faults: each raises its own alarm, freezes the axes that read the channel at
//! their last good value (no jump in the offset), and compensation resumes when the
//! channel is good again.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_thermal::sensor::ntc_beta_resistance_ohm;
use gearcomp_thermal::{
    Alarm, AxisStatus, Engine, EngineConfig, EngineStatus, Fault, Inputs, Output, Reading,
};

const CONFIG: &str = r#"
[[channels]]
name = "A"
sensor = { kind = "ntc_beta", r0_ohm = 10000.0, beta_k = 3950.0 }
valid_min = -10.0
valid_max = 80.0
stale_timeout_s = 5.0
stuck_timeout_s = 60.0
stuck_tolerance = 0.0005

[[channels]]
name = "B"
sensor = { kind = "pt100" }
valid_min = -10.0
valid_max = 80.0
stale_timeout_s = 5.0

[[axes]]
name = "Z"
apply = { kind = "measuring_system" }
max_offset_um = 100.0

[[axes.terms]]
kind = "difference"
a = "A"
b = "B"
kz_um_per_c = -3.75
"#;

struct Rig {
    engine: Engine,
    t_s: f64,
}

fn ntc(temp_c: f64) -> f64 {
    ntc_beta_resistance_ohm(temp_c, 10_000.0, 25.0, 3950.0)
}

fn pt100(temp_c: f64) -> f64 {
    gearcomp_thermal::sensor::rtd_resistance_ohm(temp_c, 100.0)
}

impl Rig {
    fn new() -> Self {
        let cfg = EngineConfig::from_toml_str(CONFIG).unwrap();
        Self {
            engine: Engine::new(&cfg).unwrap(),
            t_s: 0.0,
        }
    }

    /// A warming machine: A rises 0.01 °C per second, B stays at 20 °C.
    fn a_c(&self) -> f64 {
        20.0 + 0.01 * self.t_s
    }

    fn step_with(&mut self, a: Reading, b: Reading) -> Output {
        let r = [a, b];
        let out = self.engine.step(&Inputs {
            time_s: self.t_s,
            readings: &r,
            trigger: true,
            safe_point: true,
            positions_mm: &[],
        });
        self.t_s += 1.0;
        out
    }

    fn good(&mut self) -> Output {
        let t = self.t_s;
        self.step_with(
            Reading {
                raw: ntc(self.a_c()),
                stamp_s: t,
            },
            Reading {
                raw: pt100(20.0),
                stamp_s: t,
            },
        )
    }

    fn warm_up(&mut self) -> f64 {
        let mut out = self.good();
        for _ in 0..30 {
            out = self.good();
        }
        assert_eq!(out.status, EngineStatus::Running);
        let off = out.axes()[0].offset_um;
        // Kz·(A − B) with A = 20 + 0.01·30 → −1.125 µm (NTC conversion to 1e-9 °C).
        assert!((off - -3.75 * 0.01 * 30.0).abs() < 1e-6, "{off}");
        off
    }
}

fn assert_frozen(out: &Output, last_good_um: f64, channel: u16, fault: Fault) {
    assert_eq!(out.status, EngineStatus::Alarm);
    assert_eq!(out.alarm, Some(Alarm::Channel { channel, fault }));
    let z = out.axes()[0];
    assert_eq!(z.status, AxisStatus::Frozen);
    assert_eq!(
        z.offset_um, last_good_um,
        "the offset must not move while frozen"
    );
}

#[test]
fn nan_reading_freezes_with_alarm() {
    let mut rig = Rig::new();
    let last = rig.warm_up();
    for _ in 0..5 {
        let t = rig.t_s;
        let out = rig.step_with(
            Reading {
                raw: f64::NAN,
                stamp_s: t,
            },
            Reading {
                raw: pt100(20.0),
                stamp_s: t,
            },
        );
        assert_frozen(&out, last, 0, Fault::NotANumber);
    }
    // Recovers: the offset follows the law again (A kept rising meanwhile).
    let out = rig.good();
    assert_eq!(out.status, EngineStatus::Running);
    assert!(out.axes()[0].offset_um < last);
}

#[test]
fn open_and_short_circuit_thermistor() {
    let mut rig = Rig::new();
    let last = rig.warm_up();
    let t = rig.t_s;
    // An open NTC: megohms, i.e. far below −10 °C.
    let out = rig.step_with(
        Reading {
            raw: 5.0e7,
            stamp_s: t,
        },
        Reading {
            raw: pt100(20.0),
            stamp_s: t,
        },
    );
    assert_frozen(&out, last, 0, Fault::OpenCircuit);
    let t = rig.t_s;
    let out = rig.step_with(
        Reading {
            raw: 0.0,
            stamp_s: t,
        },
        Reading {
            raw: pt100(20.0),
            stamp_s: t,
        },
    );
    assert_frozen(&out, last, 0, Fault::ShortCircuit);
    // An open Pt100 reads hot.
    let t = rig.t_s;
    let out = rig.step_with(
        Reading {
            raw: ntc(20.0),
            stamp_s: t,
        },
        Reading {
            raw: 1.0e6,
            stamp_s: t,
        },
    );
    assert_frozen(&out, last, 1, Fault::OpenCircuit);
}

#[test]
fn stuck_value_is_detected_after_its_timeout() {
    let mut rig = Rig::new();
    rig.warm_up();
    let stuck_raw = ntc(rig.a_c());
    let mut first_alarm = None;
    let mut offsets = Vec::new();
    for k in 0..80 {
        let t = rig.t_s;
        let out = rig.step_with(
            Reading {
                raw: stuck_raw,
                stamp_s: t,
            },
            Reading {
                raw: pt100(20.0),
                stamp_s: t,
            },
        );
        offsets.push(out.axes()[0].offset_um);
        if first_alarm.is_none() && out.alarm.is_some() {
            first_alarm = Some(k);
            assert_eq!(
                out.alarm,
                Some(Alarm::Channel {
                    channel: 0,
                    fault: Fault::Stuck
                })
            );
        }
    }
    // Unchanged for more than 60 s at 1 s cycles: the 62nd identical reading.
    assert_eq!(first_alarm, Some(61));
    assert!(
        offsets.windows(2).all(|w| w[0] == w[1]),
        "no jump while stuck"
    );
}

#[test]
fn stale_channel_freezes() {
    let mut rig = Rig::new();
    let last = rig.warm_up();
    // The A reading stops updating: its stamp and value stay those of the last good cycle.
    let stamp = rig.t_s - 1.0;
    let raw = ntc(20.0 + 0.01 * stamp);
    let mut frozen = Vec::new();
    for _ in 0..10 {
        let t = rig.t_s;
        let out = rig.step_with(
            Reading {
                raw,
                stamp_s: stamp,
            },
            Reading {
                raw: pt100(20.0),
                stamp_s: t,
            },
        );
        if t - stamp > 5.0 {
            assert_frozen(&out, last, 0, Fault::Stale);
            frozen.push(out.axes()[0].offset_um);
        } else {
            assert_eq!(
                out.status,
                EngineStatus::Running,
                "within the timeout at {t}"
            );
        }
    }
    assert_eq!(frozen.len(), 5);
}

#[test]
fn out_of_order_timestamps_are_rejected() {
    let mut rig = Rig::new();
    let last = rig.warm_up();
    // A channel stamp going backwards.
    let t = rig.t_s;
    let out = rig.step_with(
        Reading {
            raw: ntc(35.0),
            stamp_s: t - 20.0,
        },
        Reading {
            raw: pt100(20.0),
            stamp_s: t,
        },
    );
    assert_frozen(&out, last, 0, Fault::OutOfOrder);
    // The cycle time going backwards: the whole cycle is ignored.
    let r = [
        Reading {
            raw: ntc(35.0),
            stamp_s: 3.0,
        },
        Reading {
            raw: pt100(20.0),
            stamp_s: 3.0,
        },
    ];
    let out = rig.engine.step(&Inputs {
        time_s: 3.0,
        readings: &r,
        trigger: true,
        safe_point: true,
        positions_mm: &[],
    });
    assert!(matches!(out.alarm, Some(Alarm::TimeOutOfOrder { time_s, .. }) if time_s == 3.0));
    assert_eq!(out.axes()[0].offset_um, last);
    assert_eq!(out.axes()[0].status, AxisStatus::Frozen);
    // A wrong number of readings is an alarm too, not a panic.
    let out = rig.engine.step(&Inputs {
        time_s: 1e6,
        readings: &r[..1],
        trigger: true,
        safe_point: true,
        positions_mm: &[],
    });
    assert_eq!(
        out.alarm,
        Some(Alarm::InputCount {
            got: 1,
            expected: 2
        })
    );
    assert_eq!(out.axes()[0].offset_um, last);
}
