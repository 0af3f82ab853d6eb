//! Natural cubic spline y(x) on strictly increasing knots, with first and second derivatives.

use crate::error::{DressError, Result};

/// A natural cubic spline (C²), extrapolated linearly beyond its knots.
#[derive(Debug, Clone, PartialEq)]
pub struct Spline {
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
}

impl Spline {
    /// Builds the spline through (x_i, y_i); x must be strictly increasing, at least 3 knots.
    ///
    /// # Formula
    /// tridiagonal system h_{i−1} M_{i−1} + 2(h_{i−1}+h_i) M_i + h_i M_{i+1} = 6(Δ_i − Δ_{i−1}),
    /// M_0 = M_n = 0
    pub fn new(x: Vec<f64>, y: Vec<f64>) -> Result<Self> {
        let n = x.len();
        if n < 3 || y.len() != n {
            return Err(DressError::Geometry(format!(
                "spline needs ≥ 3 knots with matching values, got {} / {}",
                n,
                y.len()
            )));
        }
        if x.windows(2).any(|w| w[1] <= w[0] || !w[1].is_finite()) {
            return Err(DressError::Geometry(
                "spline knots are not strictly increasing".into(),
            ));
        }
        let mut a = vec![0.0; n];
        let mut b = vec![1.0; n];
        let mut c = vec![0.0; n];
        let mut d = vec![0.0; n];
        for i in 1..n - 1 {
            let h0 = x[i] - x[i - 1];
            let h1 = x[i + 1] - x[i];
            a[i] = h0;
            b[i] = 2.0 * (h0 + h1);
            c[i] = h1;
            d[i] = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
        }
        // Thomas algorithm.
        for i in 1..n {
            let w = a[i] / b[i - 1];
            b[i] -= w * c[i - 1];
            d[i] -= w * d[i - 1];
        }
        let mut m = vec![0.0; n];
        m[n - 1] = d[n - 1] / b[n - 1];
        for i in (0..n - 1).rev() {
            m[i] = (d[i] - c[i] * m[i + 1]) / b[i];
        }
        Ok(Self { x, y, m })
    }

    /// First knot.
    pub fn x_min(&self) -> f64 {
        self.x[0]
    }

    /// Last knot.
    pub fn x_max(&self) -> f64 {
        self.x[self.x.len() - 1]
    }

    /// (y, y′, y″) at x; linear beyond the ends.
    pub fn eval(&self, xq: f64) -> (f64, f64, f64) {
        let n = self.x.len();
        if xq <= self.x[0] {
            let (y0, d0, _) = self.seg(0, self.x[0]);
            return (y0 + d0 * (xq - self.x[0]), d0, 0.0);
        }
        if xq >= self.x[n - 1] {
            let (y1, d1, _) = self.seg(n - 2, self.x[n - 1]);
            return (y1 + d1 * (xq - self.x[n - 1]), d1, 0.0);
        }
        let i = match self.x.binary_search_by(|v| v.total_cmp(&xq)) {
            Ok(i) => i.min(n - 2),
            Err(i) => i - 1,
        };
        self.seg(i, xq)
    }

    fn seg(&self, i: usize, xq: f64) -> (f64, f64, f64) {
        let h = self.x[i + 1] - self.x[i];
        let a = (self.x[i + 1] - xq) / h;
        let b = (xq - self.x[i]) / h;
        let (m0, m1) = (self.m[i], self.m[i + 1]);
        let y = a * self.y[i]
            + b * self.y[i + 1]
            + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let dy = (self.y[i + 1] - self.y[i]) / h - (3.0 * a * a - 1.0) * h / 6.0 * m0
            + (3.0 * b * b - 1.0) * h / 6.0 * m1;
        let ddy = a * m0 + b * m1;
        (y, dy, ddy)
    }
}
