//! Benchmarks of gearcomp-dressing: one envelope point (baseline), the 3- and 4-point solves,
//! the topological solves (one position; the 9-position D6 program), a 20-dressing worm life
//! plan, and the full simulation's throughput (vector–dresser tests per
//! second) against grid size and time step. Quote results as ratios to the baseline.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gearcomp_dressing::campaign::{plan, Correction, PlanSpec};
use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::simulation::{simulate, SimSpec};
use gearcomp_dressing::solve::{
    solve_four_point, solve_three_point, FourPoint, NewtonOptions, ThreePoint,
};
use gearcomp_dressing::topology::{
    solve_topological_four_point, solve_topological_three_point, topological_program,
    TopoFourPoint, TopoThreePoint, WidthPoly,
};
use gearcomp_dressing::worm::{Flank, Worm};
use std::hint::black_box;

fn setup(z: u32, d: f64, da: f64) -> DressingSetup {
    let worm = Worm::design(z, d, 3.0, 20f64.to_radians()).unwrap();
    let dr = Dresser::design(
        &worm,
        DresserSpec {
            d_a_mm: da,
            jacket_width_mm: 0.8,
            clearance_mm: 0.0,
        },
    )
    .unwrap();
    DressingSetup::new(worm, dr)
}

fn benches(c: &mut Criterion) {
    let z5 = setup(5, 160.0, 100.0);
    let g1 = setup(1, 280.0, 125.0);
    let fl = Flank::Right;
    let k0 = AxisCorrection::default();
    let (a, b) = z5.active_profile(fl).unwrap();
    let at = |q: f64| a + q * (b - a);
    let dk = AxisCorrection::from_array([6.057e-4, 0.5580f64.to_radians(), -0.0245, -1.0413]);
    let mut g = c.benchmark_group("dressing");
    g.sample_size(20);
    // Baseline: one flank point's envelope (f and r_FA) – the unit every solver is built from.
    g.bench_function("baseline_dress_point", |bch| {
        bch.iter(|| z5.dress_point(fl, black_box(at(0.5)), &dk).unwrap())
    });
    let r_tip = z5.association(fl, b, &k0).unwrap();
    let p3 = ThreePoint {
        flank: fl,
        w_mm: [at(0.05), at(0.5), at(0.95)],
        f_mm: [0.0, -0.2e-3, 0.0],
        w_assoc_mm: b,
        r_a_mm: r_tip,
    };
    g.bench_function("three_point_g1z5_c0.2um", |bch| {
        bch.iter(|| solve_three_point(&z5, black_box(&p3), k0, &NewtonOptions::default()).unwrap())
    });
    let (ga, gb) = g1.active_profile(fl).unwrap();
    let gat = |q: f64| ga + q * (gb - ga);
    let star = AxisCorrection::from_array([2e-4, 1e-3, -0.02, 0.05]);
    let w4 = [gat(0.1), gat(0.37), gat(0.63), gat(0.9)];
    let f4: Vec<f64> = w4
        .iter()
        .map(|&w| g1.dress_point(fl, w, &star).unwrap().f_mm)
        .collect();
    let p4 = FourPoint {
        flank: fl,
        w_mm: w4,
        f_mm: [f4[0], f4[1], f4[2], f4[3]],
    };
    g.bench_function("four_point_g1_d1", |bch| {
        bch.iter(|| solve_four_point(&g1, black_box(&p4), k0, &NewtonOptions::default()).unwrap())
    });
    // Topological 3-point with width-dependent association (22), one contact-line position.
    let p3t = TopoThreePoint {
        flank: fl,
        w_mm: [at(0.05), at(0.5), at(0.95)].map(WidthPoly::constant),
        f_mm: [
            WidthPoly::constant(0.0),
            WidthPoly::linear(-0.1e-3, -0.2e-3 / 40.0),
            WidthPoly::constant(0.0),
        ],
        w_assoc_mm: WidthPoly::linear(b, -0.3 / 40.0),
        r_a_mm: WidthPoly::constant(r_tip),
        w0_mm: at(0.5),
    };
    g.bench_function("topo3_one_position_g1z5", |bch| {
        bch.iter(|| {
            solve_topological_three_point(&z5, black_box(&p3t), 20.0, k0, &NewtonOptions::default())
                .unwrap()
        })
    });
    // D6: the 9-component 4-point program over 40 mm of width (9 positions, continuation).
    let p4t = TopoFourPoint {
        flank: fl,
        w_mm: [at(0.1), at(0.37), at(0.63), at(0.9)].map(WidthPoly::constant),
        f_mm: std::array::from_fn(|_| WidthPoly::linear(0.0, 2e-3 / 40.0)),
        w0_mm: at(0.5),
    };
    let opts6 = NewtonOptions {
        tol_mm: 1e-6,
        ..NewtonOptions::default()
    };
    let b0s: Vec<f64> = (0..9).map(|i| 5.0 * f64::from(i)).collect();
    g.bench_function("topo4_program_9_positions_g1z5", |bch| {
        bch.iter(|| {
            topological_program(black_box(&b0s), k0, |b0, k| {
                solve_topological_four_point(&z5, &p4t, b0, k, &opts6)
            })
            .unwrap()
        })
    });
    let ds: Vec<f64> = (0..20).map(|i| 280.0 - 3.0 * f64::from(i)).collect();
    let spec = PlanSpec {
        flank: fl,
        diameters_mm: ds,
        correction: Correction::ThreePoint,
        crowning_mm: 0.0,
        budget_mm: 0.1,
    };
    g.sample_size(10);
    g.bench_function("plan_g1_20_dressings", |bch| {
        bch.iter(|| plan(&g1.worm, &g1.dresser, black_box(&spec)).unwrap())
    });
    // Size independence: G1-Z5 with a 59.5 mm dresser (module 3) and the same × 100/3
    // (module 100, d = 5333 mm, dresser 1983 mm), a 3-point plan of three dressings with
    // 0.2 µm × k crowning. Quote module 100 / module 3.
    for (name, k) in [
        ("plan_g1z5_3_dressings_module_3", 1.0),
        ("plan_g1z5_3_dressings_module_100", 100.0 / 3.0),
    ] {
        let worm = Worm::design(5, 160.0 * k, 3.0 * k, 20f64.to_radians()).unwrap();
        let dr = Dresser::design(
            &worm,
            DresserSpec {
                d_a_mm: 59.5 * k,
                jacket_width_mm: 0.8 * k,
                clearance_mm: 0.0,
            },
        )
        .unwrap();
        let spec = PlanSpec {
            flank: fl,
            diameters_mm: vec![160.0 * k, 157.0 * k, 154.0 * k],
            correction: Correction::ThreePoint,
            crowning_mm: 0.2e-3 * k,
            budget_mm: 0.1 * k,
        };
        g.bench_function(name, |bch| {
            bch.iter(|| plan(&worm, &dr, black_box(&spec)).unwrap())
        });
    }
    g.finish();

    let mut g = c.benchmark_group("simulation");
    g.sample_size(10);
    let (sa, sb) = g1.active_profile(fl).unwrap();
    for (rows, cols, deg) in [
        (4usize, 41usize, 0.2f64),
        (8, 41, 0.2),
        (16, 41, 0.2),
        (8, 41, 0.1),
        (8, 41, 0.05),
    ] {
        let dt = deg.to_radians();
        let feed = g1.worm.p_mm * dt;
        let spec = SimSpec {
            flank: fl,
            w_mm: (0..rows)
                .map(|i| sa + (sb - sa) * i as f64 / (rows - 1) as f64)
                .collect(),
            b_mm: (0..cols)
                .map(|i| feed * i as f64 / (cols - 1) as f64)
                .collect(),
            dt_rad: dt,
            stock_mm: 0.05,
            inside_mm: 0.05,
            stop_nu_zs_mm: None,
        };
        let tests = simulate(&g1, &spec, &k0).unwrap().tests;
        g.throughput(Throughput::Elements(tests));
        g.bench_with_input(
            BenchmarkId::new("g1", format!("{rows}x{cols}-{deg}deg-{tests}tests")),
            &spec,
            |bch, s| bch.iter(|| simulate(&g1, s, &k0).unwrap()),
        );
    }
    g.finish();
}

criterion_group!(dressing, benches);
criterion_main!(dressing);
