//! Medians, means, ranges, spreads, the paired-ratio interval timing checks are judged on, and a
//! least-squares line.

/// The median of `values` (the mean of the middle two for an even count), `NaN` values left out;
/// `NaN` when empty.
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Which of the middle two an even count's [`median_index`] picks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Middle {
    /// The smaller.
    Lower,
    /// The larger.
    Upper,
}

/// The index of the median of `values` (for an even count, the `middle` of the middle two), where
/// a run, not a value, must be chosen. Panics when `values` is empty.
pub fn median_index(values: &[f64], middle: Middle) -> usize {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    match middle {
        Middle::Lower => order[(values.len() - 1) / 2],
        Middle::Upper => order[values.len() / 2],
    }
}

/// The smallest and largest of `values`: `(inf, 0)` when empty (times and errors are never
/// negative).
pub fn range(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
}

/// The mean of `values`; 0 when empty.
pub fn mean(values: impl IntoIterator<Item = f64>) -> f64 {
    let (sum, n) = values
        .into_iter()
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    sum / n.max(1) as f64
}

/// The sample standard deviation of `v`; 0 with fewer than two values.
pub fn std_dev(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// The median of the per-round ratios `a_r / b_r` and a distribution-free confidence interval
/// for it: the `k`-th smallest and `k`-th largest ratio, with `k` the largest index whose
/// two-sided coverage `1 - 2 P(Bin(n, 1/2) < k)` is at least 95% (Conover, *Practical
/// Nonparametric Statistics*, §3.2). Rounds missing from either side are skipped.
pub fn paired_ratio(a: &[f64], b: &[f64]) -> Option<PairedRatio> {
    let mut q: Vec<f64> = a.iter().zip(b).map(|(x, y)| x / y).collect();
    q.retain(|x| x.is_finite());
    let n = q.len();
    if n == 0 {
        return None;
    }
    q.sort_by(f64::total_cmp);
    // P(Bin(n, 1/2) <= j) for every j, in exact binomial coefficients (n is small).
    let mut cdf = Vec::with_capacity(n + 1);
    let (mut c, mut acc) = (1.0f64, 0.0f64);
    for j in 0..=n {
        if j > 0 {
            c = c * (n + 1 - j) as f64 / j as f64;
        }
        acc += c;
        cdf.push(acc / 2f64.powi(n as i32));
    }
    // Largest k with 1 - 2 P(X <= k-1) >= 0.95; 1 (the whole range) when n < 6 has none.
    let k = (2..=n / 2)
        .rev()
        .find(|&k| 1.0 - 2.0 * cdf[k - 1] >= 0.95)
        .unwrap_or(1);
    Some(PairedRatio {
        median: median(&q),
        lo: q[k - 1],
        hi: q[n - k],
        coverage: 1.0 - 2.0 * cdf[k - 1],
        n,
    })
}

/// The result of [`paired_ratio`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairedRatio {
    /// Median of the per-round ratios.
    pub median: f64,
    /// Lower end of the interval.
    pub lo: f64,
    /// Upper end of the interval.
    pub hi: f64,
    /// The interval's exact coverage (at least 0.95 when `n >= 6`).
    pub coverage: f64,
    /// Rounds compared.
    pub n: usize,
}

impl PairedRatio {
    /// `median (lo–hi)` with three decimals.
    pub fn text(&self) -> String {
        format!("{:.3} ({:.3}–{:.3})", self.median, self.lo, self.hi)
    }
}

/// A least-squares line `y = a + b x` through the points; `None` with fewer than two distinct x.
pub fn fit_line(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    if points.len() < 2 || sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binom(n: usize, k: usize) -> f64 {
        (0..k).fold(1.0, |c, j| c * (n - j) as f64 / (j + 1) as f64)
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[f64::NAN, 1.0]), 1.0);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn the_median_run_is_picked_lower_or_upper() {
        assert_eq!(median_index(&[3.0, 1.0, 2.0], Middle::Lower), 2);
        assert_eq!(median_index(&[3.0, 1.0, 2.0], Middle::Upper), 2);
        assert_eq!(median_index(&[5.0], Middle::Lower), 0);
        assert_eq!(median_index(&[4.0, 1.0, 3.0, 2.0], Middle::Lower), 3);
        assert_eq!(median_index(&[4.0, 1.0, 3.0, 2.0], Middle::Upper), 2);
    }

    #[test]
    fn ranges_means_and_spreads() {
        assert_eq!(range([2.0, 0.5, 3.0]), (0.5, 3.0));
        assert_eq!(range([]), (f64::INFINITY, 0.0));
        assert_eq!(mean([1.0, 2.0, 6.0]), 3.0);
        assert_eq!(mean([]), 0.0);
        assert!((std_dev(&[1.0, 3.0]) - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(std_dev(&[1.0]), 0.0);
    }

    #[test]
    fn a_line_through_points_is_fitted_exactly() {
        let (a, b) = fit_line(&[(1.0, 3.0), (2.0, 5.0), (4.0, 9.0)]).unwrap();
        assert!(
            (a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12,
            "{a} {b}"
        );
        assert_eq!(fit_line(&[(1.0, 3.0), (1.0, 5.0)]), None);
    }

    #[test]
    fn paired_ratios_give_the_median_and_an_order_statistic_interval() {
        // Ratios 0.90, 0.95, ..., 1.40 (11 rounds): median 1.15; the 95% interval drops the two
        // most extreme on each side (k = 2: coverage 1 - 2 * 12/2048 = 0.98828).
        let b = vec![2.0; 11];
        let a: Vec<f64> = (0..11)
            .rev()
            .map(|i| 2.0 * (0.90 + 0.05 * i as f64))
            .collect();
        let p = paired_ratio(&a, &b).unwrap();
        assert_eq!(p.n, 11);
        assert!((p.median - 1.15).abs() < 1e-12, "{p:?}");
        assert!(
            (p.lo - 0.95).abs() < 1e-12 && (p.hi - 1.35).abs() < 1e-12,
            "{p:?}"
        );
        assert!((p.coverage - (1.0 - 24.0 / 2048.0)).abs() < 1e-12, "{p:?}");
        assert_eq!(p.text(), "1.150 (0.950–1.350)");
        // Pairs are kept together: sorting one side alone would change the ratios.
        let p2 = paired_ratio(&[1.0, 3.0], &[3.0, 1.0]).unwrap();
        assert!((p2.median - (1.0 / 3.0 + 3.0) / 2.0).abs() < 1e-12);
        // Too few rounds for 95%: the interval is the whole range, and says its coverage.
        let p3 = paired_ratio(&[1.0, 2.0, 3.0], &[1.0; 3]).unwrap();
        assert_eq!((p3.lo, p3.hi), (1.0, 3.0));
        assert!(p3.coverage < 0.95);
        assert!(paired_ratio(&[], &[]).is_none());
        // WF 1% slower in every round but one: consistently slower, not a tie.
        let n = 15;
        let k = (1..=n / 2).rev().find(|&k| {
            let tail: f64 = (0..k).map(|j| binom(n, j)).sum::<f64>() / 2f64.powi(n as i32);
            1.0 - 2.0 * tail >= 0.95
        });
        assert_eq!(k, Some(4), "n = 15 drops three ratios on each side");
        let wf: Vec<f64> = (0..n).map(|i| if i == 0 { 0.9 } else { 1.01 }).collect();
        let p4 = paired_ratio(&wf, &vec![1.0; n]).unwrap();
        assert!(p4.lo > 1.0, "consistently slower is not a tie: {p4:?}");
    }
}
