//! The noise model of each measured output: its level and its correlation.
//!
//! The level is first estimated from the data's second differences ([`stats::noise_sigma`]),
//! which is the standard deviation for white noise. Sensor noise is often not white (an
//! anti-alias filter, encoder interpolation, a drifting amplifier); for AR(1) noise
//! `e_i = ρ e_{i−1} + w_i` of marginal standard deviation σ the second differences have variance
//! `σ² (6 − 8ρ + 2ρ²)` instead of `6σ²`, so that estimate is the level of the fast part only
//! (a quarter of σ at ρ = 0.9) and every statistic built on independent samples would call the
//! slow part of the noise a missing effect.
//!
//! ρ is estimated from the calibrated base model's residual: its first differences have lag-1
//! autocorrelation `−(1 − ρ)/2` for AR(1) noise (`−1/2` for white noise), and a smooth
//! misfit (a missing effect) adds little to them. The level is then corrected to the marginal
//! one, `σ = σ_d2 √(6 / (6 − 8ρ + 2ρ²))`, and the statistics that assume independent samples
//! carry ρ: the start test's mean of the first samples ([`mean_variance_factor`]), the whiteness
//! test on the innovations `(r_i − ρ r_{i−1}) / √(1 − ρ²)`, and, as before, the effective sample
//! sizes of ΔBIC and the intervals.

use super::{OutputErrors, OutputTrace};
use crate::policy::{
    AR1_AGREEMENT, AR1_CLIP, AR1_SIGNIFICANCE, LOW_INFORMATION_RHO, MAX_RHO, MIN_AR1_SAMPLES,
    MIN_NOISE_SHARE_OF_RANGE, MIN_RHO, NOISE_LIKE_RMS,
};
use crate::stats;
use std::collections::BTreeMap;

/// AR(1) coefficient of the noise in residual `r` (one output, in time order) from the lag-1
/// autocorrelation `c` of its first differences: `ρ = 1 + 2c`. Differences beyond 5 robust
/// standard deviations are clipped (a switch or a jump of the misfit), and ρ is 0 unless it
/// exceeds [`MIN_RHO`] and four standard errors of `c` for white noise (`1/√N`, Bartlett).
pub(super) fn ar1_coefficient(r: &[f64]) -> f64 {
    if r.len() < MIN_AR1_SAMPLES {
        return 0.0;
    }
    let d: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
    let med = stats::median(&d);
    let lim = AR1_CLIP * stats::robust_scale(&d);
    if lim.is_nan() || lim <= 0.0 {
        return 0.0;
    }
    let clipped: Vec<f64> = d.iter().map(|v| (v - med).clamp(-lim, lim)).collect();
    let c = stats::autocorr(&clipped, 1);
    let rho = (1.0 + 2.0 * c).clamp(0.0, MAX_RHO);
    let se = 2.0 / (clipped.len() as f64).sqrt();
    if rho >= MIN_RHO && rho > AR1_SIGNIFICANCE * se {
        rho
    } else {
        0.0
    }
}

/// The noise model of one output from its residual `r` (in time order, in units of the
/// output's second-difference level): the AR(1) coefficient and the factor from that level to
/// the marginal one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct NoiseFit {
    pub(crate) rho: f64,
    pub(crate) level: f64,
}

/// [`NoiseFit`] of residual `r`, its correlation detected on the differences
/// ([`ar1_coefficient`]; see [`fit_with`]).
pub(crate) fn noise_fit(r: &[f64]) -> NoiseFit {
    fit_with(r, ar1_coefficient(r))
}

/// [`NoiseFit`] of residual `r` from `rho_d`, its AR(1) coefficient as estimated on the
/// differences (0: no correlation found). The correlation is kept only if the residual can be
/// that noise: its RMS within 1.5 × the marginal level that coefficient implies
/// ([`marginal_factor`]), or that of the residual's own lag-1 coefficient where the two
/// coefficients agree within their sampling error. A residual far above it holds a misfit of
/// the model, whose smooth course also correlates the differences: its coefficient says nothing
/// about the noise, and the noise is taken as white. A residual that is noise then gives the
/// coefficient directly (its lag-1 autocorrelation, far less variable near 1 than the
/// differences' estimate) and the marginal level: the closed form, but not above the
/// residual's own RMS (the closed form's factor grows without bound as ρ nears 1).
fn fit_with(r: &[f64], rho_d: f64) -> NoiseFit {
    let white = NoiseFit {
        rho: 0.0,
        level: 1.0,
    };
    if rho_d == 0.0 {
        return white;
    }
    let rms = stats::rms(r);
    let rho_a = stats::autocorr(r, 1).clamp(MIN_RHO, MAX_RHO);
    // The differences' estimate varies by about 2/√N; the residual's own coefficient agrees
    // with it within three of those when the residual is noise, and exceeds it when a smooth
    // misfit dominates.
    let agree = (rho_a - rho_d).abs() <= AR1_AGREEMENT / (r.len() as f64).sqrt();
    let noise_like = rms <= NOISE_LIKE_RMS * marginal_factor(rho_d)
        || (agree && rms <= NOISE_LIKE_RMS * marginal_factor(rho_a));
    if !noise_like {
        return white;
    }
    let rho = rho_a;
    NoiseFit {
        rho,
        level: marginal_factor(rho).min(rms).max(1.0),
    }
}

/// [`noise_fit`] with the AR(1) coefficient from the ratio of the robust scales (MAD) of the
/// residual's second and first differences instead of their autocorrelation: for AR(1) noise
/// `var(Δ²e) / var(Δe) = 3 − ρ` (`var(Δe) = 2σ²(1 − ρ)`, `var(Δ²e) = 2σ²(1 − ρ)(3 − ρ)`), and
/// a median-based scale ignores the few large differences a model's misfit makes where an
/// output switches (a motor current at its starts and stops). Used only to clear a
/// record refused as begun away from the model's state: it can only find noise, never an
/// effect.
pub(super) fn spike_robust_fit(r: &[f64]) -> NoiseFit {
    fit_with(r, scale_ratio_coefficient(r))
}

/// `3 − (s₂/s₁)²` from the robust scales of the first and second differences of `r`, clamped to
/// [0, [`MAX_RHO`]]; 0 below [`MIN_RHO`] or for a residual too short or too flat to tell.
fn scale_ratio_coefficient(r: &[f64]) -> f64 {
    if r.len() < MIN_AR1_SAMPLES {
        return 0.0;
    }
    let d1: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
    let d2: Vec<f64> = d1.windows(2).map(|w| w[1] - w[0]).collect();
    let (s1, s2) = (stats::robust_scale(&d1), stats::robust_scale(&d2));
    if !(s1 > 0.0 && s2.is_finite()) {
        return 0.0;
    }
    let rho = (3.0 - stats::sq(s2 / s1)).clamp(0.0, MAX_RHO);
    if rho < MIN_RHO {
        0.0
    } else {
        rho
    }
}

/// The second-difference noise level of a measured output ([`stats::noise_sigma`]), kept above
/// 1e-4 of its range so that a noiseless output does not get an infinite weight.
pub(crate) fn difference_level(y: &[f64]) -> f64 {
    stats::noise_sigma(y)
        .max(MIN_NOISE_SHARE_OF_RANGE * stats::range(y))
        .max(1e-12)
}

/// The noise model of every output again, from the final model's residual, for the report:
/// with a missing effect in the record, the base residual held the effect's misfit, which can
/// hide the noise's correlation or pass for it; the final model's residual shows the noise
/// itself where the model is right. Only the report's noise levels and coefficients change
/// (the errors as multiples of the noise, the disagreement); white noise leaves them as they
/// were. Beside them, each output's white level (what no model explains) and the misfit the
/// final model leaves beyond it, so that correlated noise and unexplained misfit stay two
/// numbers.
pub(super) fn refine_after_final_fit(
    outputs: &mut BTreeMap<String, OutputErrors>,
    traces: &[OutputTrace],
) {
    for tr in traces {
        let Some(o) = outputs.get_mut(&tr.name) else {
            continue;
        };
        let level = difference_level(&tr.measured);
        let r: Vec<f64> = tr
            .measured
            .iter()
            .zip(&tr.final_fit)
            .map(|(m, y)| (y - m) / level)
            .collect();
        let fit = noise_fit(&r);
        o.noise_sigma = level * fit.level;
        o.noise_ar1 = fit.rho;
        o.noise_white = level;
        o.unexplained_rms = (o.rmse_after * o.rmse_after - level * level)
            .max(0.0)
            .sqrt();
    }
}

/// The report's note on correlated noise (None when every output's noise is white): which
/// outputs, their coefficients, what the statistics did about it, and, from
/// [`LOW_INFORMATION_RHO`] on, that the record holds few effective samples.
pub(super) fn correlated_noise_note(outputs: &BTreeMap<String, OutputErrors>) -> Option<String> {
    let listed: Vec<String> = outputs
        .iter()
        .filter(|(_, o)| o.noise_ar1 > 0.0)
        .map(|(n, o)| format!("{n} {:.2}", o.noise_ar1))
        .collect();
    if listed.is_empty() {
        return None;
    }
    let mut note = format!(
        "The measurement noise is correlated (AR(1) coefficient {}): its levels are the \
         marginal standard deviations, the start test and the whiteness test allow for the \
         correlation, and ΔBIC and the intervals use effective sample sizes.",
        listed.join(", ")
    );
    let max = outputs.values().map(|o| o.noise_ar1).fold(0.0, f64::max);
    if max >= LOW_INFORMATION_RHO {
        note += &format!(
            " At a coefficient of {max:.2} the record holds about {:.0} % of its samples' \
             information (N (1 − ρ)/(1 + ρ)): slow noise and a slow model error look alike, \
             so treat ΔBIC, the intervals and a named effect with caution; a longer record or \
             faster sensor sampling helps.",
            100.0 * (1.0 - max) / (1.0 + max)
        );
    }
    Some(note)
}

/// Factor from the second-difference level to the marginal standard deviation of AR(1) noise
/// with coefficient ρ: `√(6 / (6 − 8ρ + 2ρ²))` (1 for white noise).
pub(super) fn marginal_factor(rho: f64) -> f64 {
    let r = rho.clamp(0.0, MAX_RHO);
    (6.0 / (6.0 - 8.0 * r + 2.0 * r * r)).sqrt()
}

/// Variance of the mean of `m` consecutive AR(1) samples relative to that of `m` independent
/// ones: `1 + 2 Σ_{k=1}^{m−1} (1 − k/m) ρ^k` (e.g. Priestley 1981 §5.3).
// `powi` is compiler-builtins' `__powidf2` (repeated squaring), not the platform's libm: the
// same bits on every CPU and platform.
#[allow(clippy::disallowed_methods)]
pub(super) fn mean_variance_factor(rho: f64, m: usize) -> f64 {
    let r = rho.clamp(0.0, MAX_RHO);
    1.0 + 2.0
        * (1..m)
            .map(|k| (1.0 - k as f64 / m as f64) * r.powi(k as i32))
            .sum::<f64>()
}

/// The innovations of residual `r` under AR(1) noise with coefficient ρ, in units of the
/// marginal level: `(r_i − ρ r_{i−1}) / √(1 − ρ²)` (the residual itself for ρ = 0), which are
/// white when the residual is that noise.
pub(super) fn innovations(r: &[f64], rho: f64) -> Vec<f64> {
    if rho <= 0.0 {
        return r.to_vec();
    }
    let s = (1.0 - rho * rho).sqrt();
    r.windows(2).map(|w| (w[1] - rho * w[0]) / s).collect()
}

#[cfg(test)]
mod tests {
    use super::{
        ar1_coefficient, innovations, marginal_factor, mean_variance_factor, noise_fit,
        spike_robust_fit,
    };
    use crate::stats;

    /// AR(1) series of marginal standard deviation 1 (LCG + Box–Muller, deterministic).
    fn ar1(n: usize, rho: f64, seed: u64) -> Vec<f64> {
        let mut s = seed;
        let mut uniform = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let mut e = 0.0;
        let c = (1.0 - rho * rho).sqrt();
        (0..n)
            .map(|i| {
                let (u1, u2) = (uniform(), uniform());
                let w = (-2.0 * libm::log(u1)).sqrt() * libm::cos(std::f64::consts::TAU * u2);
                e = if i == 0 { w } else { rho * e + c * w };
                e
            })
            .collect()
    }

    #[test]
    fn white_noise_is_not_called_correlated() {
        for seed in 1..6 {
            assert_eq!(ar1_coefficient(&ar1(1000, 0.0, seed)), 0.0);
        }
    }

    #[test]
    fn the_coefficient_and_the_marginal_level_are_recovered() {
        for (rho, seed) in [(0.9, 3), (0.97, 4), (0.6, 5)] {
            let e = ar1(4000, rho, seed);
            let est = ar1_coefficient(&e);
            assert!((est - rho).abs() < 0.05, "rho {rho}: {est}");
            // In units of the second-difference level, as the workflow's residuals are.
            let s_d2 = stats::noise_sigma(&e);
            let r: Vec<f64> = e.iter().map(|v| v / s_d2).collect();
            let fit = noise_fit(&r);
            assert!((fit.rho - rho).abs() < 0.04, "rho {rho}: {fit:?}");
            // The second-difference level times the factor is the marginal level (1).
            let sigma = s_d2 * fit.level;
            assert!((sigma - 1.0).abs() < 0.15, "rho {rho}: sigma {sigma}");
        }
    }

    #[test]
    fn a_smooth_misfit_does_not_make_white_noise_correlated() {
        // A misfit of 3 noise levels over 2 s at 250 Hz (a slow sine).
        let e: Vec<f64> = ar1(1000, 0.0, 9)
            .iter()
            .enumerate()
            .map(|(i, v)| v + 3.0 * libm::sin(i as f64 / 250.0 * std::f64::consts::PI))
            .collect();
        assert_eq!(noise_fit(&e).rho, 0.0);
    }

    #[test]
    fn switching_misfits_hide_correlation_from_the_differences_not_from_their_scales() {
        // AR(1) 0.97 noise in second-difference units, plus a one-sample misfit of 20 of them
        // every 25 samples (a current missed at a motor's starts and stops). The
        // autocorrelation of r (the coefficient taken) is lowered by the spikes too.
        let e = ar1(700, 0.97, 11);
        let s_d2 = stats::noise_sigma(&e);
        let r: Vec<f64> = e
            .iter()
            .enumerate()
            .map(|(i, v)| v / s_d2 + if i % 25 == 0 { 20.0 } else { 0.0 })
            .collect();
        assert_eq!(noise_fit(&r).rho, 0.0, "{:?}", noise_fit(&r));
        let fit = spike_robust_fit(&r);
        assert!(fit.rho > 0.5, "{fit:?}");
        // White noise with the same misfit stays white.
        let w: Vec<f64> = ar1(700, 0.0, 12)
            .iter()
            .enumerate()
            .map(|(i, v)| v + if i % 25 == 0 { 20.0 } else { 0.0 })
            .collect();
        assert_eq!(spike_robust_fit(&w).rho, 0.0, "{:?}", spike_robust_fit(&w));
    }

    #[test]
    fn closed_forms() {
        assert_eq!(marginal_factor(0.0), 1.0);
        // 6 − 7.2 + 1.62 = 0.42
        assert!((marginal_factor(0.9) - (6.0f64 / 0.42).sqrt()).abs() < 1e-12);
        assert_eq!(mean_variance_factor(0.0, 3), 1.0);
        // 1 + 2 (2/3 · 0.9 + 1/3 · 0.81) = 2.74
        assert!((mean_variance_factor(0.9, 3) - 2.74).abs() < 1e-12);
        assert_eq!(innovations(&[1.0, 2.0], 0.0), vec![1.0, 2.0]);
    }
}
