//! Whether a named effect is an explanation: the share of the way from the current model's
//! misfit to the data's white noise level that it covers.
//!
//! With `RSS_k` and `RSS'_k` the weighted sums of squares of output `k` over the training part
//! before and after the effect, `N` its samples and `w_k` the white level of its second
//! differences in the run's weighted units (`σ_white,k / σ_k`), the share is
//! `Σ_k ln(RSS_k / RSS'_k) / Σ_k max(0, ln(RSS_k / (N w_k²)))`: the log-likelihood gain of the
//! effect over that of a model that left only white noise. The log scale makes a tenfold cut
//! of a misfit 1000× the noise count as a third of the way, whatever the unit.

use super::{noise, Ctx};
use crate::lm;
use crate::sim::GridModel;

/// The share covered by going from the residual `before` to `after` (training part, stacked by
/// output), or None when the current model is already at the white level everywhere.
pub(super) fn explained_share<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    before: &[f64],
    after: &[f64],
) -> Option<f64> {
    let white: Vec<f64> = ctx
        .meas
        .iter()
        .zip(&ctx.sigma)
        .map(|(y, s)| noise::difference_level(y) / s)
        .collect();
    share(before, after, &white, ctx.n_train)
}

/// [`explained_share`] for residuals of `white.len()` outputs of `n` samples each.
fn share(before: &[f64], after: &[f64], white: &[f64], n: usize) -> Option<f64> {
    let (mut gain, mut room) = (0.0, 0.0);
    for (k, w) in white.iter().enumerate() {
        let rows = k * n..(k + 1) * n;
        let (b, a) = (lm::sse(&before[rows.clone()]), lm::sse(&after[rows]));
        if !(b > 0.0 && a > 0.0) {
            continue;
        }
        gain += libm::log(b / a);
        room += libm::log(b / (n as f64 * w * w)).max(0.0);
    }
    (room > 0.0 && gain.is_finite()).then(|| gain / room)
}

#[cfg(test)]
mod tests {
    use super::share;

    #[test]
    fn the_share_is_the_log_way_to_the_white_level() {
        // One output, white level 1: a misfit of RMS 100 cut to 10 covers half the log way
        // (ln 10⁴ → ln 10², of ln 10⁴ to ln 1); cut to 90, 2.3 % of it.
        let n = 50;
        let at = |rms: f64| vec![rms; n];
        let s = share(&at(100.0), &at(10.0), &[1.0], n).unwrap();
        assert!((s - 0.5).abs() < 1e-12, "{s}");
        let s = share(&at(100.0), &at(90.0), &[1.0], n).unwrap();
        assert!(
            (s - libm::log(100.0 / 90.0) / libm::log(100.0)).abs() < 1e-12,
            "{s}"
        );
        // A second output already at its white level adds no room; what the effect does to it
        // counts in the gain.
        let before = [at(100.0), at(1.0)].concat();
        let after = [at(10.0), at(1.0)].concat();
        assert!((share(&before, &after, &[1.0, 1.0], n).unwrap() - 0.5).abs() < 1e-12);
        // At the white level everywhere there is no way to cover.
        assert!(share(&at(1.0), &at(0.9), &[1.0], n).is_none());
    }
}
