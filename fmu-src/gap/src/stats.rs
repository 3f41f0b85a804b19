//! Small statistics used by the workflow: noise level from the data, autocorrelation and the
//! effective sample size, the Ljung–Box whiteness test, cross-correlation and the correlation
//! ratio used to find the operating region where a residual lives.

/// `x²` as a product (bit-identical to `powi(2)`, without the platform's libm in question).
pub fn sq(x: f64) -> f64 {
    x * x
}

/// Median of a slice (copied, NaN-free input assumed). Returns 0 for an empty slice.
pub fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Noise standard deviation of a densely sampled signal from its second differences,
/// `d_i = y_{i+1} − 2 y_i + y_{i−1}`, which for white noise of variance σ² have variance 6σ²
/// while a smooth signal contributes almost nothing; the scale is the MAD (×1.4826, consistent
/// for Gaussian data) so steps and kinks in the signal do not inflate it
/// (difference-based variance estimation, Gasser, Sroka & Jennen-Steinmetz 1986).
pub fn noise_sigma(y: &[f64]) -> f64 {
    if y.len() < 5 {
        return 0.0;
    }
    let d: Vec<f64> = y.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
    robust_scale(&d) / 6f64.sqrt()
}

/// Robust standard deviation: the median absolute deviation from the median × 1.4826
/// (consistent for Gaussian data), which a few outliers do not move.
pub fn robust_scale(x: &[f64]) -> f64 {
    let m = median(x);
    let dev: Vec<f64> = x.iter().map(|v| (v - m).abs()).collect();
    1.4826 * median(&dev)
}

/// Range (max − min) of a signal.
pub fn range(y: &[f64]) -> f64 {
    let (lo, hi) = y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// Root mean square.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Maximum absolute value.
pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m: f64, v| m.max(v.abs()))
}

/// Sample autocorrelation at `lag` (mean removed, biased normalisation as in Box & Jenkins).
pub fn autocorr(x: &[f64], lag: usize) -> f64 {
    let n = x.len();
    if n <= lag + 1 {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / n as f64;
    let c0: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    if c0 <= 0.0 {
        return 0.0;
    }
    let ck: f64 = (0..n - lag).map(|i| (x[i] - m) * (x[i + lag] - m)).sum();
    ck / c0
}

/// Effective number of independent samples of a residual whose correlation is approximated by an
/// AR(1) process with lag-1 coefficient ρ: `N_eff = N (1 − ρ) / (1 + ρ)` (the variance inflation
/// of a mean of AR(1) data, e.g. Bayley & Hammersley 1946). ρ is clamped to [0, 0.995].
pub fn n_eff(n: usize, rho: f64) -> f64 {
    let r = rho.clamp(0.0, 0.995);
    (n as f64 * (1.0 - r) / (1.0 + r)).max(1.0)
}

/// Effective number of independent samples of a residual from its autocorrelation:
/// `N_eff = N / (1 + 2 Σ_{k=1..K} (1 − k/(K+1)) ρ_k)` with Bartlett weights and K = min(100, N/10)
/// lags (the variance inflation of a mean of a stationary series, e.g. Priestley 1981 §5.3; for
/// AR(1) it tends to `N (1 − ρ)/(1 + ρ)`). The inflation is clamped to [1, N].
pub fn n_eff_series(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 4 {
        return n as f64;
    }
    let kmax = (n / 10).clamp(1, 100);
    let m = x.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = x.iter().map(|v| v - m).collect();
    let c0: f64 = d.iter().map(|v| v * v).sum();
    if c0 <= 0.0 {
        return n as f64;
    }
    let mut infl = 1.0;
    for k in 1..=kmax {
        let ck: f64 = d[..n - k].iter().zip(&d[k..]).map(|(a, b)| a * b).sum();
        infl += 2.0 * (1.0 - k as f64 / (kmax + 1) as f64) * ck / c0;
    }
    n as f64 / infl.clamp(1.0, n as f64)
}

/// Ljung–Box statistic `Q = N (N + 2) Σ_{k=1..h} ρ_k² / (N − k)` and its p-value from χ²(h)
/// (Ljung & Box 1978). Small p: the residual is not white.
pub fn ljung_box(x: &[f64], h: usize) -> (f64, f64) {
    let n = x.len() as f64;
    let h = h.min(x.len().saturating_sub(2)).max(1);
    let q: f64 = (1..=h)
        .map(|k| sq(autocorr(x, k)) / (n - k as f64))
        .sum::<f64>()
        * n
        * (n + 2.0);
    (q, chi2_sf(q, h as f64))
}

/// Survival function of the χ² distribution with `k` degrees of freedom: Q(k/2, x/2), the upper
/// regularised incomplete gamma function (series and continued fraction, Numerical Recipes §6.2).
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    gamma_q(0.5 * k, 0.5 * x)
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9), accurate to ~1e-15 for x > 0.
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return libm::log(pi / libm::sin(pi * x)) - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * libm::log(2.0 * std::f64::consts::PI) + (x + 0.5) * libm::log(t) - t + libm::log(a)
}

fn gamma_q(a: f64, x: f64) -> f64 {
    if x < a + 1.0 {
        // series for P(a, x)
        let mut sum = 1.0 / a;
        let mut del = sum;
        let mut ap = a;
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        let p = sum * libm::exp(-x + a * libm::log(x) - ln_gamma(a));
        (1.0 - p).clamp(0.0, 1.0)
    } else {
        // continued fraction for Q(a, x) (modified Lentz)
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (libm::exp(-x + a * libm::log(x) - ln_gamma(a)) * h).clamp(0.0, 1.0)
    }
}

/// Largest absolute normalised cross-correlation between `r` and `u` over lags 0..=max_lag
/// (`u` leading `r`); returns (lag, correlation).
pub fn max_cross_corr(r: &[f64], u: &[f64], max_lag: usize) -> (usize, f64) {
    let n = r.len().min(u.len());
    if n < 3 {
        return (0, 0.0);
    }
    let mr = r[..n].iter().sum::<f64>() / n as f64;
    let mu = u[..n].iter().sum::<f64>() / n as f64;
    let sr = r[..n].iter().map(|v| sq(v - mr)).sum::<f64>().sqrt();
    let su = u[..n].iter().map(|v| sq(v - mu)).sum::<f64>().sqrt();
    if sr <= 0.0 || su <= 0.0 {
        return (0, 0.0);
    }
    let mut best = (0, 0.0f64);
    for lag in 0..=max_lag.min(n - 2) {
        let c: f64 = (lag..n)
            .map(|i| (r[i] - mr) * (u[i - lag] - mu))
            .sum::<f64>()
            / (sr * su);
        if c.abs() > best.1.abs() {
            best = (lag, c);
        }
    }
    best
}

/// One bin of an operating-region split.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RegionBin {
    pub lo: f64,
    pub hi: f64,
    pub count: usize,
    pub mean: f64,
    pub rms: f64,
}

/// Split `r` into `nbins` bins of equal count by the value of `v` (quantile bins; a bin boundary at
/// v = 0 is added when `v` changes sign, so "positive vs negative velocity" is always separated),
/// and return the bins with the correlation ratio η² = between-bin variance / total variance
/// (Pearson's correlation ratio): how much of the residual the variable's region explains.
pub fn region_bins(r: &[f64], v: &[f64], nbins: usize) -> (Vec<RegionBin>, f64) {
    let n = r.len().min(v.len());
    if n < 2 * nbins || nbins < 2 {
        return (Vec::new(), 0.0);
    }
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&a, &b| v[a].partial_cmp(&v[b]).unwrap_or(std::cmp::Ordering::Equal));
    let mut cuts: Vec<usize> = (1..nbins).map(|k| k * n / nbins).collect();
    if v[idx[0]] < 0.0 && v[idx[n - 1]] > 0.0 {
        let zero = idx.partition_point(|&i| v[i] < 0.0);
        if zero > 0 && zero < n {
            cuts.push(zero);
            cuts.sort_unstable();
            cuts.dedup();
        }
    }
    let mut bounds = vec![0];
    bounds.extend(cuts.into_iter().filter(|&c| c > 0 && c < n));
    bounds.push(n);
    bounds.dedup();
    let mean_all = r[..n].iter().sum::<f64>() / n as f64;
    let total: f64 = r[..n].iter().map(|x| sq(x - mean_all)).sum();
    let mut between = 0.0;
    let mut bins = Vec::new();
    for w in bounds.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let vals: Vec<f64> = idx[a..b].iter().map(|&i| r[i]).collect();
        let m = vals.iter().sum::<f64>() / vals.len() as f64;
        between += vals.len() as f64 * sq(m - mean_all);
        bins.push(RegionBin {
            lo: v[idx[a]],
            hi: v[idx[b - 1]],
            count: b - a,
            mean: m,
            rms: rms(&vals),
        });
    }
    let eta2 = if total > 0.0 { between / total } else { 0.0 };
    (bins, eta2)
}

#[cfg(test)]
mod tests {
    use super::{
        autocorr, chi2_sf, ljung_box, max_cross_corr, n_eff, n_eff_series, noise_sigma, region_bins,
    };

    /// Deterministic Gaussian noise (xorshift + Box–Muller) for the tests.
    pub(crate) fn gauss(seed: u64, n: usize) -> Vec<f64> {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407)
            | 1;
        let mut u = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (a, b) = (u(), u());
                (-2.0 * libm::log(a)).sqrt() * libm::cos(2.0 * std::f64::consts::PI * b)
            })
            .collect()
    }

    #[test]
    fn chi2_survival_matches_tables() {
        // Values from standard χ² tables: upper 5 % points.
        assert!((chi2_sf(3.841_458_820_694_124, 1.0) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(31.410_432_844_230_92, 20.0) - 0.05).abs() < 1e-9);
        assert!((chi2_sf(18.307_038_053_275_146, 10.0) - 0.05).abs() < 1e-9);
        // Q(1, x/2) for k = 2 is exp(−x/2).
        assert!((chi2_sf(7.0, 2.0) - libm::exp(-3.5f64)).abs() < 1e-12);
    }

    #[test]
    fn noise_level_is_found_under_a_signal() {
        let n = 10_000;
        let e = gauss(1, n);
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * 1e-3;
                3.0 * libm::sin(2.0 * t) + if t > 5.0 { 1.0 } else { 0.0 } + 0.02 * e[i]
            })
            .collect();
        let s = noise_sigma(&y);
        assert!((s / 0.02 - 1.0).abs() < 0.05, "sigma {s}");
    }

    #[test]
    fn effective_sample_size_and_whiteness() {
        let n = 5000;
        let e = gauss(7, n);
        let (_, p_white) = ljung_box(&e, 20);
        assert!(p_white > 0.01, "white noise rejected: p = {p_white}");
        let mut ar = vec![0.0; n];
        for i in 1..n {
            ar[i] = 0.9 * ar[i - 1] + e[i];
        }
        let rho = autocorr(&ar, 1);
        assert!((rho - 0.9).abs() < 0.03, "rho {rho}");
        let ne = n_eff(n, rho);
        assert!(ne > n as f64 / 25.0 && ne < n as f64 / 14.0, "n_eff {ne}");
        // Bartlett-weighted: the weights shrink the sum of an AR(1) (0.9) to about 1 + 2·8.1
        // with K = 100 lags, so N_eff ≈ N/17 here, close to the AR(1) value N/19.
        let ns = n_eff_series(&ar);
        assert!(
            ns > n as f64 / 25.0 && ns < n as f64 / 10.0,
            "n_eff_series {ns}"
        );
        let nw = n_eff_series(&e);
        assert!(nw > 0.8 * n as f64, "white: {nw}");
        let (_, p_ar) = ljung_box(&ar, 20);
        assert!(p_ar < 1e-6);
    }

    #[test]
    fn regions_separate_sign_of_a_variable() {
        let n = 4000;
        let e = gauss(3, n);
        let v: Vec<f64> = (0..n).map(|i| libm::sin(i as f64 * 0.01)).collect();
        let r: Vec<f64> = (0..n).map(|i| 0.5 * v[i].signum() + 0.1 * e[i]).collect();
        let (bins, eta2) = region_bins(&r, &v, 8);
        assert!(eta2 > 0.9, "eta2 {eta2}");
        assert!(bins.iter().any(|b| b.hi < 0.0) && bins.iter().any(|b| b.lo > 0.0));
        let (_, eta_noise) = region_bins(&e, &v, 8);
        assert!(eta_noise < 0.01);
        let (lag, c) = max_cross_corr(&r, &v, 10);
        assert!(c > 0.7 && lag <= 10);
    }
}
