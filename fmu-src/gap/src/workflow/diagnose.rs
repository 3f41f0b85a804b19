//! Diagnosis of a round: where and when the residuals exceed the noise.

use super::noise;
use super::{Ctx, Data, Diagnosis, OutputDiagnosis};
use crate::policy::{
    DIAGNOSIS_WINDOWS, LJUNG_BOX_LAGS, MAX_XCORR_LAG, NOISE_RMS_RATIO, REGION_BINS, WHITE_P,
};
use crate::sim::GridModel;
use crate::stats;
use rayon::iter::{IntoParallelRefIterator, ParallelIterator};

pub(super) fn errors(meas: &[f64], model: &[f64]) -> (f64, f64) {
    let e: Vec<f64> = model.iter().zip(meas).map(|(a, b)| a - b).collect();
    (stats::rms(&e), stats::max_abs(&e))
}

/// Diagnose the residual of the current model over the whole trace.
pub(super) fn diagnose<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    data: &Data,
    all_out: &[Vec<f64>],
    names: &[String],
) -> Diagnosis {
    let n = ctx.n;
    let mut vars: Vec<(String, &[f64])> = data
        .inputs
        .iter()
        .map(|(s, v)| (s.clone(), &v[..n]))
        .collect();
    for (k, name) in names.iter().enumerate() {
        if let Some(v) = all_out.get(k) {
            if v.len() >= n && stats::range(&v[..n]) > 0.0 {
                vars.push((name.clone(), &v[..n]));
            }
        }
    }
    let mut outs = Vec::new();
    let mut consistent = true;
    for (k, &oi) in ctx.out_idx.iter().enumerate() {
        let oname = names[oi].clone();
        let b = ctx.offset_of(k, &all_out[oi][..n], n.min(ctx.n_train));
        let r: Vec<f64> = (0..n)
            .map(|i| (all_out[oi][i] + b - ctx.meas[k][i]) / ctx.sigma[k])
            .collect();
        let ratio = stats::rms(&r);
        let nw = DIAGNOSIS_WINDOWS.min(n / 20).max(1);
        let win: Vec<f64> = (0..nw)
            .map(|w| stats::rms(&r[w * n / nw..(w + 1) * n / nw]))
            .collect();
        let (wi, wr) = win
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
        let t0 = data.time[wi * n / nw];
        let t1 = data.time[((wi + 1) * n / nw).min(n) - 1];
        // Whiteness of the innovations under the output's noise model (the residual itself
        // for white noise): correlated noise alone is no misfit.
        let innov = noise::innovations(&r, ctx.rho[k]);
        let (_, lb_p) = stats::ljung_box(&innov, LJUNG_BOX_LAGS);
        let rho1 = stats::autocorr(&innov, 1);
        let max_lag = (n / 20).clamp(1, MAX_XCORR_LAG);
        let input_xcorr = data
            .inputs
            .iter()
            .filter(|(_, u)| stats::range(&u[..n]) > 0.0)
            .map(|(name, u)| {
                let (lag, c) = stats::max_cross_corr(&r, &u[..n], max_lag);
                (name.clone(), lag, c)
            })
            .max_by(|a, b| {
                a.2.abs()
                    .partial_cmp(&b.2.abs())
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
        let region = vars
            .par_iter()
            .map(|(name, v)| {
                let (bins, eta2) = stats::region_bins(&r, v, REGION_BINS);
                (name.clone(), bins, eta2)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .max_by(|a, b| a.2.partial_cmp(&b.2).unwrap_or(std::cmp::Ordering::Equal));
        let white = lb_p > WHITE_P;
        let ok = ratio <= NOISE_RMS_RATIO && white;
        consistent &= ok;
        let mut text = format!(
            "{oname}: residual RMS {:.2}× its noise level (σ = {:.3e}); worst over t = {:.2}–{:.2} s ({:.2}×)",
            ratio, ctx.sigma[k], t0, t1, wr
        );
        text += &if white {
            format!("; residual white (Ljung–Box p = {lb_p:.2})")
        } else {
            format!(
                "; residual not white (Ljung–Box p = {lb_p:.1e}, lag-1 autocorrelation {rho1:.2})"
            )
        };
        if let Some((u, lag, c)) = &input_xcorr {
            text += &format!("; cross-correlation with input {u}: {c:.2} at lag {lag} samples");
        }
        let mut region_variable = None;
        let mut region_bins = Vec::new();
        if let Some((name, bins, eta2)) = region {
            if let Some(b) = bins.iter().max_by(|a, b| {
                a.mean
                    .abs()
                    .partial_cmp(&b.mean.abs())
                    .unwrap_or(std::cmp::Ordering::Equal)
            }) {
                text += &format!(
                    "; by operating region the residual depends most on {name} (η² = {eta2:.2}): mean {:+.2}σ for {name} in [{:.3e}, {:.3e}]",
                    b.mean, b.lo, b.hi
                );
            }
            region_variable = Some((name, eta2));
            region_bins = bins;
        }
        outs.push(OutputDiagnosis {
            output: oname,
            noise_sigma: ctx.sigma[k],
            rmse_over_noise: ratio,
            worst_window: (t0, t1, wr),
            window_rmse_over_noise: win,
            ljung_box_p: lb_p,
            lag1_autocorr: rho1,
            input_xcorr,
            region_variable,
            region_bins,
            text,
        });
    }
    let text = if consistent {
        "Residuals are consistent with noise: every output within 1.2× its noise level and white."
            .to_string()
    } else {
        let worst = outs.iter().max_by(|a, b| {
            a.rmse_over_noise
                .partial_cmp(&b.rmse_over_noise)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        match worst {
            Some(w) => format!(
                "The model disagrees most on {} ({:.2}× noise), worst over t = {:.2}–{:.2} s{}.",
                w.output,
                w.rmse_over_noise,
                w.worst_window.0,
                w.worst_window.1,
                w.region_variable
                    .as_ref()
                    .map(|(v, e)| format!(", organised by {v} (η² = {e:.2})"))
                    .unwrap_or_default()
            ),
            None => String::new(),
        }
    };
    Diagnosis {
        consistent_with_noise: consistent,
        outputs: outs,
        text,
    }
}
