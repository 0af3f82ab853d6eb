//! What several integration tests build their cases from: a seeded generator and an
//! independent first-order lag.

/// Uniform numbers in [0, 1) from `seed` (xorshift64 of the seed times the golden ratio).
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Independent reference for a first-order lag in seconds: τ·ẏ + y = u, u held at each new
/// sample over the step that ends at it, y₀ = u₀ (the engine's convention), integrated by
/// classical Runge–Kutta with 64 sub-steps per sample step.
pub fn lag_rk4(t_s: &[f64], u: &[f64], tau_s: f64) -> Vec<f64> {
    let mut y = u[0];
    let mut out = vec![y];
    for k in 1..t_s.len() {
        let h = (t_s[k] - t_s[k - 1]) / 64.0;
        let f = |y: f64| (u[k] - y) / tau_s;
        for _ in 0..64 {
            let k1 = f(y);
            let k2 = f(y + 0.5 * h * k1);
            let k3 = f(y + 0.5 * h * k2);
            let k4 = f(y + h * k3);
            y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        out.push(y);
    }
    out
}
