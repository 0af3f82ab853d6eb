//! Sensor selection (CN105397560): Pearson correlation, fuzzy-equivalence clustering by the
//! max–min transitive closure with its λ-cut dendrogram, one representative per class;
//! and the alternatives of the open-source workbench (fuzzy c-means, grey relational grade).

use crate::error::{invalid, Result};
use nalgebra::DMatrix;

/// Pearson correlation coefficient of two equally long series.
///
/// # Formula
/// r = Σ(x−x̄)(y−ȳ) / √(Σ(x−x̄)²·Σ(y−ȳ)²)
/// # Domain
/// Both series must vary; a constant series is an error (r undefined).
/// # Source
/// CN105397560, [0013]–[0025], eqs. (1)–(2) (docs/identification.md, "CN105397560 as implemented")
pub fn pearson(x: &[f64], y: &[f64], name: &str) -> Result<f64> {
    if x.len() != y.len() || x.len() < 2 {
        return Err(invalid(
            name,
            format!("{} and {} samples", x.len(), y.len()),
            "two series of equal length ≥ 2",
        ));
    }
    let n = x.len() as f64;
    // Both sums in one pass: each is the same chain of additions as `iter().sum()` (which
    // starts at −0.0), bit for bit; two independent chains run side by side.
    let (mut sx, mut sy) = (-0.0f64, -0.0f64);
    for (a, b) in x.iter().zip(y) {
        sx += a;
        sy += b;
    }
    pearson_about(x, y, sx / n, sy / n)
        .ok_or_else(|| invalid(name, "a constant series", "series that vary"))
}

/// [`pearson`] of equally long `x`, `y` with their means `mx`, `my` given (computed once
/// per column by [`correlation_matrix`]: the same figures as [`pearson`]'s own); `None`
/// when a series is constant.
fn pearson_about(x: &[f64], y: &[f64], mx: f64, my: f64) -> Option<f64> {
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (dx, dy) = (a - mx, b - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    (sxx > 0.0 && syy > 0.0).then(|| (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}

/// The Pearson correlation matrix of the columns (diagonal 1).
///
/// # Source
/// CN105397560, eq. (1) [RECONSTRUCTED]
pub fn correlation_matrix(columns: &[&[f64]], names: &[String]) -> Result<DMatrix<f64>> {
    let c = columns.len();
    let mut r = DMatrix::identity(c, c);
    let means: Vec<f64> = columns
        .iter()
        .map(|x| x.iter().sum::<f64>() / x.len() as f64)
        .collect();
    if let Some(r) = correlation_matrix_varying(columns, &means) {
        return Ok(r);
    }
    for i in 0..c {
        for j in i + 1..c {
            let label = || {
                format!(
                    "correlation({}, {})",
                    names.get(i).map_or("?", |s| s),
                    names.get(j).map_or("?", |s| s)
                )
            };
            let (x, y) = (columns[i], columns[j]);
            let v = if x.len() == y.len() && x.len() >= 2 {
                pearson_about(x, y, means[i], means[j])
                    .ok_or_else(|| invalid(&label(), "a constant series", "series that vary"))?
            } else {
                pearson(x, y, &label())?
            };
            r[(i, j)] = v;
            r[(j, i)] = v;
        }
    }
    Ok(r)
}

/// [`correlation_matrix`] of `columns` when every one has the same length ≥ 2 and varies,
/// `None` otherwise: each entry bit for bit the one [`correlation_matrix`] gives for those two
/// columns, and |entry| the one [`pearson`] gives (the same means, sums and quotient; a
/// column's figures do not depend on the other columns).
pub(crate) fn correlation_matrix_if_varying(columns: &[&[f64]]) -> Option<DMatrix<f64>> {
    let means: Vec<f64> = columns
        .iter()
        .map(|x| x.iter().sum::<f64>() / x.len() as f64)
        .collect();
    correlation_matrix_varying(columns, &means)
}

/// [`correlation_matrix`] when every column has the same length ≥ 2 and varies (`None`
/// otherwise: the pairwise loop then names the first constant pair). The same figures, bit
/// for bit, as [`pearson_about`] per pair: each column's Σ(x − x̄)² is the sum that
/// `pearson_about` accumulates for it, whatever the pair, so it is taken once per column;
/// each cross sum Σ(x − x̄)(y − ȳ) is accumulated in the same order as there, four pairs
/// (i, j..j+4) at a time in one pass over the rows (independent sums, so the additions of
/// one no longer wait for the previous one's).
fn correlation_matrix_varying(columns: &[&[f64]], means: &[f64]) -> Option<DMatrix<f64>> {
    let c = columns.len();
    let n = columns.first()?.len();
    if n < 2 || columns.iter().any(|x| x.len() != n) {
        return None;
    }
    let ss: Vec<f64> = columns
        .iter()
        .zip(means)
        .map(|(x, &m)| {
            x.iter().fold(0.0, |s, &a| {
                let d = a - m;
                s + d * d
            })
        })
        .collect();
    if !ss.iter().all(|&s| s > 0.0) {
        return None;
    }
    let mut r = DMatrix::identity(c, c);
    let mut put = |i: usize, j: usize, sxy: f64| {
        let v = (sxy / (ss[i] * ss[j]).sqrt()).clamp(-1.0, 1.0);
        r[(i, j)] = v;
        r[(j, i)] = v;
    };
    for i in 0..c {
        let mut j = i + 1;
        while j + 4 <= c {
            let ys = [columns[j], columns[j + 1], columns[j + 2], columns[j + 3]];
            let my = [means[j], means[j + 1], means[j + 2], means[j + 3]];
            let s = cross_sums(columns[i], means[i], ys, my);
            for (q, sxy) in s.into_iter().enumerate() {
                put(i, j + q, sxy);
            }
            j += 4;
        }
        while j < c {
            let [sxy] = cross_sums(columns[i], means[i], [columns[j]], [means[j]]);
            put(i, j, sxy);
            j += 1;
        }
    }
    Some(r)
}

/// Σ(x − mx)(y_q − my_q) for each q, each sum in row order (as [`pearson_about`]'s `sxy`).
fn cross_sums<const B: usize>(x: &[f64], mx: f64, ys: [&[f64]; B], my: [f64; B]) -> [f64; B] {
    let n = x.len();
    let ys = ys.map(|y| &y[..n]);
    let mut acc = [0.0; B];
    for (k, &a) in x.iter().enumerate() {
        let dx = a - mx;
        for q in 0..B {
            acc[q] += dx * (ys[q][k] - my[q]);
        }
    }
    acc
}

/// Max–min transitive closure t(R) of a fuzzy similarity matrix, and the number of
/// squarings it took.
///
/// # Formula
/// (R∘R)_ij = max_k min(r_ik, r_kj); square until R^(2k) = R^k.
/// # Source
/// CN105397560, [0010]–[0011] (fuzzy clustering by the correlation matrix); fuzzy-equivalence
/// clustering as written in docs/identification.md, "CN105397560 as implemented"
pub fn transitive_closure(similarity: &DMatrix<f64>) -> (DMatrix<f64>, usize) {
    let c = similarity.nrows();
    let mut r = similarity.clone();
    let mut squarings = 0;
    loop {
        let mut next = r.clone();
        for i in 0..c {
            for j in 0..c {
                let mut best = f64::NEG_INFINITY;
                for k in 0..c {
                    best = best.max(r[(i, k)].min(r[(k, j)]));
                }
                next[(i, j)] = best;
            }
        }
        squarings += 1;
        if next == r || squarings > 64 {
            return (r, squarings);
        }
        r = next;
    }
}

/// Equivalence classes of the λ-cut t(R)_ij ≥ λ, each sorted, ordered by first member.
pub fn lambda_cut(closure: &DMatrix<f64>, lambda: f64) -> Vec<Vec<usize>> {
    let c = closure.nrows();
    let mut seen = vec![false; c];
    let mut out = Vec::new();
    for i in 0..c {
        if seen[i] {
            continue;
        }
        let class: Vec<usize> = (i..c)
            .filter(|&j| j == i || closure[(i, j)] >= lambda)
            .collect();
        for &j in &class {
            seen[j] = true;
        }
        out.push(class);
    }
    out
}

/// One merge of the dendrogram: two classes join at a similarity level.
#[derive(Debug, Clone, PartialEq)]
pub struct Merge {
    /// The λ level (|r|) at which they join.
    pub level: f64,
    /// Members of the first class (contains the lower index).
    pub left: Vec<usize>,
    /// Members of the second class.
    pub right: Vec<usize>,
}

/// The full fuzzy-equivalence dendrogram (identical to single linkage on |r|).
#[derive(Debug, Clone, PartialEq)]
pub struct Dendrogram {
    /// Number of leaves (variables).
    pub leaves: usize,
    /// The c − 1 merges, by decreasing level.
    pub merges: Vec<Merge>,
}

impl Dendrogram {
    /// Builds the dendrogram by single linkage on a similarity matrix.
    ///
    /// Edges are taken by decreasing similarity, ties by the lower index pair, so the
    /// classes after m merges are exactly the λ-cuts of the max–min closure.
    ///
    /// # Source
    /// CN105397560 ("clustering dendrogram"); single-linkage equivalence per
    /// docs/identification.md, "CN105397560 as implemented" [RECONSTRUCTED]
    pub fn single_linkage(similarity: &DMatrix<f64>) -> Self {
        let c = similarity.nrows();
        let mut edges: Vec<(f64, usize, usize)> = Vec::with_capacity(c * c / 2);
        for i in 0..c {
            for j in i + 1..c {
                edges.push((similarity[(i, j)], i, j));
            }
        }
        edges.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut label: Vec<usize> = (0..c).collect();
        let mut merges = Vec::with_capacity(c.saturating_sub(1));
        for (w, i, j) in edges {
            let (a, b) = (label[i], label[j]);
            if a == b {
                continue;
            }
            let (lo, hi) = (a.min(b), a.max(b));
            let left: Vec<usize> = (0..c).filter(|&k| label[k] == lo).collect();
            let right: Vec<usize> = (0..c).filter(|&k| label[k] == hi).collect();
            for l in label.iter_mut() {
                if *l == hi {
                    *l = lo;
                }
            }
            merges.push(Merge {
                level: w,
                left,
                right,
            });
            if merges.len() + 1 == c {
                break;
            }
        }
        Self { leaves: c, merges }
    }

    /// The classes after cutting to `k` classes (1 ≤ k ≤ leaves), ordered by first member.
    pub fn classes(&self, k: usize) -> Result<Vec<Vec<usize>>> {
        if k == 0 || k > self.leaves {
            return Err(invalid(
                "classes",
                k,
                &format!("1 ≤ classes ≤ {} (the number of inputs)", self.leaves),
            ));
        }
        let mut label: Vec<usize> = (0..self.leaves).collect();
        for m in self.merges.iter().take(self.leaves - k) {
            let lo = m.left[0].min(m.right[0]);
            for &r in m.left.iter().chain(&m.right) {
                label[r] = lo;
            }
        }
        let mut out: Vec<Vec<usize>> = Vec::new();
        for i in 0..self.leaves {
            if label[i] == i {
                out.push((i..self.leaves).filter(|&j| label[j] == i).collect());
            }
        }
        Ok(out)
    }

    /// Leaf order that draws the tree without crossings.
    pub fn leaf_order(&self) -> Vec<usize> {
        let mut groups: Vec<Vec<usize>> = (0..self.leaves).map(|i| vec![i]).collect();
        let mut owner: Vec<usize> = (0..self.leaves).collect();
        for m in &self.merges {
            let (a, b) = (owner[m.left[0]], owner[m.right[0]]);
            let moved = std::mem::take(&mut groups[b]);
            for &x in &moved {
                owner[x] = a;
            }
            groups[a].extend(moved);
        }
        groups.into_iter().flatten().collect()
    }
}

/// Per class, the member with the largest score (ties: lower index).
///
/// # Source
/// CN105397560, representative = largest |r_TiTa| (or |r_TiδM|) in its class [RECONSTRUCTED]
pub fn representatives(classes: &[Vec<usize>], score: &[f64]) -> Vec<usize> {
    classes
        .iter()
        .filter_map(|cl| {
            cl.iter()
                .copied()
                .fold(None, |best: Option<usize>, i| match best {
                    Some(b) if score[b] >= score[i] => Some(b),
                    _ => Some(i),
                })
        })
        .collect()
}

fn range_normalise(x: &[f64]) -> Vec<f64> {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let span = hi - lo;
    if span > 0.0 {
        x.iter().map(|v| (v - lo) / span).collect()
    } else {
        vec![0.0; x.len()]
    }
}

/// Grey relational grade of each comparison series with the reference series.
///
/// # Formula
/// x ← (x − min x)/(max x − min x); Δ_i(k) = |x_0(k) − x_i(k)|;
/// ξ_i(k) = (Δmin + ρ·Δmax)/(Δ_i(k) + ρ·Δmax), Δmin/Δmax over all i, k; γ_i = mean_k ξ_i(k)
/// # Domain
/// 0 < ρ ≤ 1 (ρ = 0.5 in the workbench); grades lie in (0, 1].
/// # Source
/// Deng's grey relational analysis as used by the public workbench GOODDASH/soft_py (`func.py`)
/// [SOURCE]
pub fn grey_relational_grades(reference: &[f64], series: &[&[f64]], rho: f64) -> Result<Vec<f64>> {
    if !(rho > 0.0 && rho <= 1.0) {
        return Err(invalid("rho", rho, "0 < ρ ≤ 1"));
    }
    let x0 = range_normalise(reference);
    let deltas: Vec<Vec<f64>> = series
        .iter()
        .map(|s| {
            range_normalise(s)
                .iter()
                .zip(&x0)
                .map(|(a, b)| (a - b).abs())
                .collect()
        })
        .collect();
    let dmin = deltas
        .iter()
        .flatten()
        .fold(f64::INFINITY, |a, &b| a.min(b));
    let dmax = deltas.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
    if dmax == 0.0 {
        return Ok(vec![1.0; series.len()]);
    }
    Ok(deltas
        .iter()
        .map(|d| {
            d.iter()
                .map(|v| (dmin + rho * dmax) / (v + rho * dmax))
                .sum::<f64>()
                / d.len().max(1) as f64
        })
        .collect())
}

/// Fuzzy c-means clustering of variables (each range-normalised series is one point).
/// Returns the membership matrix (classes × variables) and the hard classes (largest
/// membership), ordered by first member.
///
/// # Formula
/// u_ik = 1 / Σ_j (d_ik/d_jk)^(2/(m−1)),  v_i = Σ_k u_ik^m x_k / Σ_k u_ik^m; stop when
/// max |Δu| < tol.
/// # Domain
/// m > 1 (2 in the workbench), 1 ≤ classes ≤ variables. Initial centres by farthest-point
/// seeding from the first variable, so the result is deterministic (the workbench seeds
/// randomly).
/// # Source
/// Bezdek's FCM as used by GOODDASH/soft_py (skfuzzy `cmeans`, m = 2, error 1e-3,
/// maxiter 2000) [SOURCE]
pub fn fuzzy_c_means(
    series: &[&[f64]],
    classes: usize,
    m: f64,
    tol: f64,
    max_iter: usize,
) -> Result<(DMatrix<f64>, Vec<Vec<usize>>)> {
    let c = series.len();
    if classes == 0 || classes > c {
        return Err(invalid("classes", classes, &format!("1 ≤ classes ≤ {c}")));
    }
    if !(m > 1.0 && m.is_finite()) {
        return Err(invalid("fuzziness m", m, "m > 1"));
    }
    let pts: Vec<Vec<f64>> = series.iter().map(|s| range_normalise(s)).collect();
    let dist2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    let mut centres: Vec<Vec<f64>> = vec![pts[0].clone()];
    while centres.len() < classes {
        let far = (0..c)
            .map(|k| {
                let d = centres
                    .iter()
                    .map(|v| dist2(&pts[k], v))
                    .fold(f64::INFINITY, f64::min);
                (d, k)
            })
            .fold((f64::NEG_INFINITY, 0), |a, b| if b.0 > a.0 { b } else { a });
        centres.push(pts[far.1].clone());
    }
    let mut u = DMatrix::zeros(classes, c);
    let expo = 2.0 / (m - 1.0);
    for _ in 0..max_iter {
        let mut next = DMatrix::zeros(classes, c);
        for k in 0..c {
            let d: Vec<f64> = centres.iter().map(|v| dist2(&pts[k], v).sqrt()).collect();
            if let Some(z) = d.iter().position(|&x| x < 1e-300) {
                next[(z, k)] = 1.0;
                continue;
            }
            for i in 0..classes {
                next[(i, k)] = 1.0 / d.iter().map(|dj| (d[i] / dj).powf(expo)).sum::<f64>();
            }
        }
        let change = (&next - &u).amax();
        u = next;
        for (i, v) in centres.iter_mut().enumerate() {
            let w: Vec<f64> = (0..c).map(|k| u[(i, k)].powf(m)).collect();
            let sw: f64 = w.iter().sum();
            if sw > 0.0 {
                for (t, x) in v.iter_mut().enumerate() {
                    *x = (0..c).map(|k| w[k] * pts[k][t]).sum::<f64>() / sw;
                }
            }
        }
        if change < tol {
            break;
        }
    }
    let mut hard: Vec<Vec<usize>> = vec![Vec::new(); classes];
    for k in 0..c {
        let best = (0..classes).fold(0, |b, i| if u[(i, k)] > u[(b, k)] { i } else { b });
        hard[best].push(k);
    }
    hard.retain(|h| !h.is_empty());
    hard.sort_by_key(|h| h[0]);
    Ok((u, hard))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Eq. (1) for one pair as written (means, then the three sums in row order).
    fn textbook_r(x: &[f64], y: &[f64]) -> f64 {
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for (a, b) in x.iter().zip(y) {
            sxy += (a - mx) * (b - my);
            sxx += (a - mx) * (a - mx);
            syy += (b - my) * (b - my);
        }
        (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0)
    }

    #[test]
    fn correlation_matrix_and_pearson_are_the_pairwise_definition_bit_for_bit() {
        let mut next = crate::test_uniform(99);
        for c in 1..=11 {
            for n in [2, 3, 7, 250] {
                // Columns sharing a drift (strongly correlated, large offsets) plus noise.
                let drift: Vec<f64> = (0..n).map(|_| next()).collect();
                let cols: Vec<Vec<f64>> = (0..c)
                    .map(|j| {
                        let (a, off) = (next() * 4.0 - 2.0, 20.0 + 10.0 * j as f64);
                        drift.iter().map(|d| off + a * d + 0.1 * next()).collect()
                    })
                    .collect();
                let refs: Vec<&[f64]> = cols.iter().map(|v| v.as_slice()).collect();
                let names: Vec<String> = (0..c).map(|j| format!("t{j}")).collect();
                let r = correlation_matrix(&refs, &names).unwrap();
                for i in 0..c {
                    assert_eq!(r[(i, i)], 1.0);
                    for j in i + 1..c {
                        let want = textbook_r(&cols[i], &cols[j]);
                        assert_eq!(
                            r[(i, j)].to_bits(),
                            want.to_bits(),
                            "c {c} n {n} ({i}, {j})"
                        );
                        let p = pearson(&cols[i], &cols[j], "p").unwrap();
                        assert_eq!(
                            p.to_bits(),
                            want.to_bits(),
                            "pearson c {c} n {n} ({i}, {j})"
                        );
                        assert_eq!(r[(j, i)].to_bits(), want.to_bits());
                    }
                }
            }
        }
        // A constant column: the first pair holding it is named, as before.
        let cols = [
            vec![1.0, 2.0, 4.0],
            vec![3.0, 3.0, 3.0],
            vec![0.0, 1.0, 5.0],
        ];
        let refs: Vec<&[f64]> = cols.iter().map(|v| v.as_slice()).collect();
        let names = ["a".to_string(), "b".to_string(), "c".to_string()];
        let e = correlation_matrix(&refs, &names).unwrap_err().to_string();
        assert!(
            e.contains("correlation(a, b)") && e.contains("constant"),
            "{e}"
        );
    }

    #[test]
    fn closure_equals_single_linkage_on_random_similarities() {
        // Deterministic pseudo-random symmetric similarity matrices.
        let mut s = 12345u64;
        for _ in 0..20 {
            let c = 7;
            let mut r = DMatrix::identity(c, c);
            for i in 0..c {
                for j in i + 1..c {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let v = (s >> 11) as f64 / (1u64 << 53) as f64;
                    r[(i, j)] = v;
                    r[(j, i)] = v;
                }
            }
            let (t, _) = transitive_closure(&r);
            let d = Dendrogram::single_linkage(&r);
            for (m, merge) in d.merges.iter().enumerate() {
                let k = c - m - 1;
                assert_eq!(lambda_cut(&t, merge.level), d.classes(k).unwrap());
            }
        }
    }

    #[test]
    fn grey_grade_of_identical_series_is_one_and_fcm_separates_two_groups() {
        let a = [1.0, 2.0, 3.0, 4.0];
        let b = [4.0, 3.0, 2.0, 1.0];
        let g = grey_relational_grades(&a, &[&a, &b], 0.5).unwrap();
        assert!((g[0] - 1.0).abs() < 1e-15);
        // Δ = |2x−1| on normalised series: 1, 1/3, 1/3, 1; Δmax = 1, Δmin = 0.
        let expect = (0.5 / 1.5 + 0.5 / (1.0 / 3.0 + 0.5)) / 2.0;
        assert!((g[1] - expect).abs() < 1e-15, "{}", g[1]);
        let c = [1.1, 2.0, 3.0, 4.1];
        let d = [4.0, 3.1, 2.0, 1.2];
        let (_, hard) = fuzzy_c_means(&[&a, &b, &c, &d], 2, 2.0, 1e-9, 500).unwrap();
        assert_eq!(hard, vec![vec![0, 2], vec![1, 3]]);
    }
}
