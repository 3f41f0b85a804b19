//! A disagreement no candidate explains: after the final fit, outputs whose residual stays
//! above [`DISAGREEMENT_RATIO`] times the noise level, or above `NOISE_RMS_RATIO` (1.2) times
//! it and not white (Ljung–Box p < 0.01 on the innovations of the output's noise model). Real rigs have mechanisms no FMU lists
//! (a sensor lag, a sensor gain or zero error, a wrong fixed geometry, another friction law);
//! then the report must not call the residuals noise, and says where the disagreement sits and
//! what simple mechanism its shape suggests.
//!
//! Shapes: the residual `e = measured − model` of an output is regressed, with an intercept, on
//! one signature of the model's output `y` at a time (least squares; the share of `Σ e²` a
//! signature explains decides):
//! - offset: the intercept alone (a sensor zero error);
//! - gain: `y − ȳ`, `e ≈ g (y − ȳ)` (a sensor gain error `g`, or a wrong fixed parameter that
//!   scales the output);
//! - lag: `ẏ`, `e ≈ −τ ẏ` (a first-order sensor lag `τ ṁ + m = y`, to first order
//!   `m ≈ y − τ ẏ`; also a pure delay τ);
//! - dead zone: `sign(ẏ)` where the output moves, `e ≈ −d sign(ẏ)` (a reading that trails the
//!   motion by `d`: backlash or a dead zone of width `2d` in the sensor's drive).

use super::noise;
use super::{OutputErrors, OutputTrace};
use crate::policy::{
    DISAGREEMENT_RATIO, DISAGREEMENT_WINDOWS, LJUNG_BOX_LAGS, MIN_EXPLAINED, MOVING_SHARE,
    NOISE_RMS_RATIO, SHAPE_OVER_OFFSET, WHITE_P,
};
use crate::stats;
use serde::Serialize;
use std::collections::BTreeMap;

/// One simple mechanism fitted to an output's residual.
#[derive(Clone, Debug, Serialize)]
pub struct Shape {
    /// "offset", "gain", "lag" or "dead zone".
    pub kind: &'static str,
    /// Offset and dead zone in the output's unit, gain relative (measured/model − 1), lag in s.
    pub value: f64,
    /// Share of the residual's mean square explained (0..1).
    pub explained: f64,
}

/// Where and how one output disagrees.
#[derive(Clone, Debug, Serialize)]
pub struct OutputDisagreement {
    pub output: String,
    pub rmse_over_noise: f64,
    /// Time windows (start, end in s; RMSE over noise there) above [`DISAGREEMENT_RATIO`].
    pub windows: Vec<(f64, f64, f64)>,
    /// Every shape, best first.
    pub shapes: Vec<Shape>,
}

/// The disagreement that remains after the final fit.
#[derive(Clone, Debug, Serialize)]
pub struct Disagreement {
    pub outputs: Vec<OutputDisagreement>,
    /// One paragraph for the report and the warnings.
    pub text: String,
}

/// The disagreement of the final model (`traces`: measured and final per output; `errors`:
/// RMSE and noise level per output), None when every output is within
/// [`DISAGREEMENT_RATIO`] of its noise level.
pub(super) fn disagreement(
    time: &[f64],
    traces: &[OutputTrace],
    errors: &BTreeMap<String, OutputErrors>,
) -> Option<Disagreement> {
    let mut outputs: Vec<OutputDisagreement> = traces
        .iter()
        .filter_map(|tr| {
            let e = errors.get(&tr.name)?;
            let ratio = e.rmse_after / e.noise_sigma;
            (e.noise_sigma > 0.0
                && (ratio > DISAGREEMENT_RATIO || (ratio > NOISE_RMS_RATIO && !white(tr, e))))
            .then(|| output_disagreement(time, tr, e.noise_sigma, ratio))
        })
        .collect();
    if outputs.is_empty() {
        return None;
    }
    outputs.sort_by(|a, b| b.rmse_over_noise.total_cmp(&a.rmse_over_noise));
    let text = describe(&outputs);
    Some(Disagreement { outputs, text })
}

fn output_disagreement(
    time: &[f64],
    tr: &OutputTrace,
    sigma: f64,
    ratio: f64,
) -> OutputDisagreement {
    let n = tr.measured.len().min(tr.final_fit.len()).min(time.len());
    let e: Vec<f64> = (0..n).map(|i| tr.measured[i] - tr.final_fit[i]).collect();
    OutputDisagreement {
        output: tr.name.clone(),
        rmse_over_noise: ratio,
        windows: windows(&time[..n], &e, sigma),
        shapes: shapes(&time[..n], &tr.final_fit[..n], &e),
    }
}

/// Whether the final residual of an output is white under its noise model (Ljung–Box over 20
/// lags of the innovations, p > 0.01).
fn white(tr: &OutputTrace, e: &OutputErrors) -> bool {
    let r: Vec<f64> = tr
        .measured
        .iter()
        .zip(&tr.final_fit)
        .map(|(m, y)| (y - m) / e.noise_sigma)
        .collect();
    stats::ljung_box(&noise::innovations(&r, e.noise_ar1), LJUNG_BOX_LAGS).1 > WHITE_P
}

/// The windows whose RMS residual exceeds [`DISAGREEMENT_RATIO`] σ (adjacent ones joined).
fn windows(time: &[f64], e: &[f64], sigma: f64) -> Vec<(f64, f64, f64)> {
    let n = e.len();
    let nw = DISAGREEMENT_WINDOWS.min(n / 10).max(1);
    let mut out: Vec<(f64, f64, f64, usize)> = Vec::new();
    for w in 0..nw {
        let (a, b) = (w * n / nw, (w + 1) * n / nw);
        let ms = e[a..b].iter().map(|v| v * v).sum::<f64>() / (b - a) as f64;
        let r = ms.sqrt() / sigma;
        if r <= DISAGREEMENT_RATIO {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.3 + 1 == w => {
                last.1 = time[b - 1];
                last.2 = last.2.max(r);
                last.3 = w;
            }
            _ => out.push((time[a], time[b - 1], r, w)),
        }
    }
    out.into_iter().map(|(a, b, r, _)| (a, b, r)).collect()
}

/// Least-squares fit of `e ≈ c + β x`: (β, share of Σ e² explained by the fit).
fn fit_with_intercept(x: &[f64], e: &[f64]) -> (f64, f64) {
    let n = e.len() as f64;
    let (mx, me) = (x.iter().sum::<f64>() / n, e.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|v| (v - mx) * (v - mx)).sum();
    let sxe: f64 = x.iter().zip(e).map(|(a, b)| (a - mx) * (b - me)).sum();
    let see: f64 = e.iter().map(|v| v * v).sum();
    if see <= 0.0 {
        return (0.0, 0.0);
    }
    let beta = if sxx > 0.0 { sxe / sxx } else { 0.0 };
    // Explained: the intercept's n me² plus the slope's β sxe.
    ((beta), ((n * me * me + beta * sxe) / see).clamp(0.0, 1.0))
}

/// Every shape fitted to residual `e` of model output `y`, best first.
fn shapes(time: &[f64], y: &[f64], e: &[f64]) -> Vec<Shape> {
    let n = e.len();
    if n < 3 {
        return Vec::new();
    }
    let mean_y = y.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = y.iter().map(|v| v - mean_y).collect();
    // Central differences (one-sided at the ends).
    let dy: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (y[b] - y[a]) / (time[b] - time[a]).max(1e-300)
        })
        .collect();
    let moving = MOVING_SHARE * dy.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let direction: Vec<f64> = dy
        .iter()
        .map(|&v| if v.abs() > moving { v.signum() } else { 0.0 })
        .collect();
    let me = e.iter().sum::<f64>() / n as f64;
    let see: f64 = e.iter().map(|v| v * v).sum();
    let offset_share = if see > 0.0 {
        (n as f64 * me * me / see).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (g, g_share) = fit_with_intercept(&centred, e);
    let (l, l_share) = fit_with_intercept(&dy, e);
    let (d, d_share) = fit_with_intercept(&direction, e);
    let mut out = vec![
        Shape {
            kind: "offset",
            value: me,
            explained: offset_share,
        },
        Shape {
            kind: "gain",
            // measured = (1 + g) model near the mean: e = g (y − ȳ) + const, relative to the
            // model's level where that is not near zero.
            value: g,
            explained: g_share,
        },
        Shape {
            kind: "lag",
            value: -l,
            explained: l_share,
        },
        Shape {
            kind: "dead zone",
            value: -d,
            explained: d_share,
        },
    ];
    out.sort_by(|a, b| b.explained.total_cmp(&a.explained));
    out
}

/// The best shape of an output as words, when one explains at least [`MIN_EXPLAINED`]; a
/// richer shape must add a tenth of the mean square to the offset to be preferred to it.
fn shape_words(o: &OutputDisagreement) -> Option<String> {
    let offset = o.shapes.iter().find(|s| s.kind == "offset")?;
    let best = o.shapes.first()?;
    let s = if best.kind != "offset" && best.explained - offset.explained < SHAPE_OVER_OFFSET {
        offset
    } else {
        best
    };
    if s.explained < MIN_EXPLAINED {
        return None;
    }
    let what = match s.kind {
        "offset" => format!("an offset of {:+.4e}", s.value),
        "gain" => format!("a gain error of {:+.1} %", 100.0 * s.value),
        "lag" => format!("a lag of {:.3} s", s.value),
        _ => format!(
            "a dead zone or backlash of ±{:.4e} with the direction of motion",
            s.value.abs()
        ),
    };
    Some(format!(
        "{what} on {} (explains {:.0} % of its residual)",
        o.output,
        100.0 * s.explained
    ))
}

fn describe(outputs: &[OutputDisagreement]) -> String {
    let where_: Vec<String> = outputs
        .iter()
        .map(|o| {
            let w = o
                .windows
                .iter()
                .max_by(|a, b| a.2.total_cmp(&b.2))
                .map(|(a, b, r)| format!(", worst over t = {a:.2}–{b:.2} s ({r:.1}×)"))
                .unwrap_or_default();
            format!("{} {:.1}× its noise level{w}", o.output, o.rmse_over_noise)
        })
        .collect();
    let shapes: Vec<String> = outputs.iter().filter_map(shape_words).collect();
    let mut text = format!(
        "A disagreement remains that no candidate explains: after the final fit, RMSE {}.",
        where_.join("; ")
    );
    if shapes.is_empty() {
        text += " No simple shape (offset, gain, lag, dead zone) explains half of it.";
    } else {
        text += &format!(" Its shape suggests {}.", shapes.join("; "));
    }
    text += " A sensor's lag, gain or zero error, a fixed parameter set wrong (--set), or an \
             effect that is not among the candidates can leave this; the residual plots show it.";
    text
}

#[cfg(test)]
mod tests {
    use super::shapes;

    fn grid(n: usize) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.004).collect();
        let y = t.iter().map(|t| libm::sin(2.0 * t) + 0.5).collect();
        (t, y)
    }

    fn best(t: &[f64], y: &[f64], measured: &[f64]) -> (&'static str, f64) {
        let e: Vec<f64> = measured.iter().zip(y).map(|(m, y)| m - y).collect();
        let s = &shapes(t, y, &e)[0];
        (s.kind, s.value)
    }

    #[test]
    fn a_gain_error_is_a_gain() {
        let (t, y) = grid(1000);
        let m: Vec<f64> = y.iter().map(|v| 1.05 * v).collect();
        let (kind, g) = best(&t, &y, &m);
        assert_eq!(kind, "gain");
        assert!((g - 0.05).abs() < 1e-9, "{g}");
    }

    #[test]
    fn a_first_order_lag_is_a_lag() {
        // τ ṁ + m = y integrated exactly for a piecewise-linear y (τ = 20 ms).
        let (t, y) = grid(1000);
        let tau = 0.02;
        let mut m = vec![y[0]; y.len()];
        for i in 1..y.len() {
            let h = t[i] - t[i - 1];
            let a = libm::exp(-h / tau);
            let slope = (y[i] - y[i - 1]) / h;
            m[i] = y[i] - tau * slope + a * (m[i - 1] - y[i - 1] + tau * slope);
        }
        let (kind, lag) = best(&t, &y, &m);
        assert_eq!(kind, "lag");
        assert!((lag - tau).abs() < 0.002, "{lag}");
    }

    #[test]
    fn a_zero_error_is_an_offset() {
        let (t, y) = grid(1000);
        let m: Vec<f64> = y.iter().map(|v| v + 0.1).collect();
        let e: Vec<f64> = m.iter().zip(&y).map(|(m, y)| m - y).collect();
        let s = shapes(&t, &y, &e);
        let offset = s.iter().find(|s| s.kind == "offset").unwrap();
        assert!((offset.value - 0.1).abs() < 1e-12 && offset.explained > 0.999);
    }
}
