//! Calibration of the base model: directly and over growing horizons ([`calibrate_base`]).

use super::{ensure_jacobian, fit_state, Ctx, FitOut, Limits, ModelState};
use crate::policy::{
    CALIBRATION_HORIZONS, CALIBRATION_ITERATIONS, CALIBRATION_REL_TOL, HORIZON_ANCHOR_MAX_CHI2,
    MIN_HORIZON_SAMPLES,
};
use crate::sim::{GridModel, SimError};
use serde::Serialize;

/// Which base calibration was kept ([`calibrate_base`]); in JSON `"direct"` or
/// `"growing horizons"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum CalibrationFit {
    #[serde(rename = "direct")]
    Direct,
    #[serde(rename = "growing horizons")]
    GrowingHorizons,
}

impl CalibrationFit {
    pub(super) fn label(self) -> &'static str {
        match self {
            CalibrationFit::Direct => "direct",
            CalibrationFit::GrowingHorizons => "growing horizons",
        }
    }
}

/// How the base model was calibrated ([`calibrate_base`]): chi-square (weighted sum of squares
/// over the training part) of the direct fit and of the growing-horizon fit, and which was kept.
#[derive(Clone, Debug, Serialize)]
pub struct Calibration {
    pub direct_chi2: f64,
    /// Each horizon of the growing-horizon fit: (samples, chi-square over them at its end); the
    /// last is the whole training part unless the first horizon could not be fitted well enough
    /// to go on.
    pub horizons: Vec<(usize, f64)>,
    pub chosen: CalibrationFit,
}

impl Calibration {
    /// One sentence for the report; `time`: the data's sample times, `train`: samples of the
    /// training part, `outputs`: measured outputs.
    pub fn text(&self, time: &[f64], train: usize, outputs: usize) -> String {
        let span = |n: usize| match (time.first(), time.get(n.max(1) - 1)) {
            (Some(a), Some(b)) => format!("{:.3} s", b - a),
            _ => format!("{n} samples"),
        };
        let direct = format!(
            "Base calibration: fitted directly over the training part (χ² = {:.1})",
            self.direct_chi2
        );
        match self.horizons.last() {
            None => format!("{direct}."),
            Some(&(n, chi2)) if n < train => format!(
                "{direct}; the growing-horizon fit was not continued: over its first horizon \
                 ({}) the model stays {:.1}× the noise level off the data (RMS), so that \
                 horizon gives no anchor.",
                span(n),
                (chi2 / (n * outputs.max(1)) as f64).sqrt()
            ),
            Some(&(_, chi2)) => format!(
                "{direct} and over growing horizons ({}; each fit starting from the previous \
                 one's values: χ² = {chi2:.1}); kept the {} fit.",
                self.horizons
                    .iter()
                    .map(|(n, _)| span(*n))
                    .collect::<Vec<_>>()
                    .join(", "),
                self.chosen.label()
            ),
        }
    }
}

/// Calibrate the base model (effects off) on the training part, directly from the values as
/// given and, where the model reproduces the start of the trace, over growing horizons: the
/// first quarter of the training part, then half, then all of it, each fit starting from the
/// previous one's values. The lower sum of squares wins.
///
/// Why the second: when a trajectory's phase is sensitive to the parameters (a feedback loop
/// near its stability limit, oscillating), an output-error cost over a long horizon has many
/// local minima: the model locks onto the data's oscillation a period early or late, and a
/// local descent cannot cross to the right one. Over a short horizon the trajectories have not
/// yet drifted apart, the cost is nearly quadratic and its minimum close to the truth; each
/// longer horizon then starts inside the right basin (continuation in the horizon, the idea of
/// multiple-shooting estimators: Bock 1983; Voss, Timmer & Kurths 2004).
///
/// The continuation rests on its first horizon: when the model misses even the start of the
/// trace by more than √2 × the noise (a strong effect missing from the start), that short fit
/// has nothing to anchor on and wanders; the direct fit, which stays nearer the values as given,
/// is kept. Horizons shorter than [`MIN_HORIZON_SAMPLES`] are skipped; the anchor is the first
/// one fitted.
/// `Config::calibration_horizons` false leaves only the direct fit (for before/after runs).
pub(super) fn calibrate_base<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st0: &ModelState,
) -> Result<(FitOut, Calibration), SimError> {
    // The Jacobian at the optimum is made only for the fit kept.
    let limits = Limits::new(CALIBRATION_ITERATIONS, CALIBRATION_REL_TOL).without_final_jacobian();
    let fit_base = |from: &ModelState, n: usize| fit_state(ctx, from, None, &[], n, limits);
    // The two calibrations are independent: run side by side (each is mostly one simulation at
    // a time, so together they keep two cores busy).
    let (direct, growing) = rayon::join(
        || fit_base(st0, ctx.n_train),
        || {
            ctx.calibration_horizons
                .then(|| grow_horizons(ctx, st0, &fit_base))
        },
    );
    let mut direct = direct?;
    let mut cal = Calibration {
        direct_chi2: direct.fit.sse,
        horizons: Vec::new(),
        chosen: CalibrationFit::Direct,
    };
    let Some((horizons, growing)) = growing else {
        ensure_jacobian(ctx, &mut direct, ctx.n_train);
        return Ok((direct, cal));
    };
    cal.horizons = horizons;
    let mut kept = match growing {
        Some(g) if g.fit.sse < direct.fit.sse => {
            cal.chosen = CalibrationFit::GrowingHorizons;
            g
        }
        _ => direct,
    };
    ensure_jacobian(ctx, &mut kept, ctx.n_train);
    Ok((kept, cal))
}

/// The growing-horizon fit of [`calibrate_base`]: each horizon's (samples, chi-square), and the
/// fit over the whole training part (None when the continuation stopped: a horizon could not be
/// fitted, a simulation failing at some trial values, or the first one gives no anchor).
fn grow_horizons<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st0: &ModelState,
    fit_base: &(dyn Fn(&ModelState, usize) -> Result<FitOut, SimError> + Sync),
) -> (Vec<(usize, f64)>, Option<FitOut>) {
    let k = ctx.out_idx.len();
    let mut horizons = Vec::new();
    let mut st = st0.clone();
    for frac in CALIBRATION_HORIZONS {
        let n_h = (ctx.n_train as f64 * frac) as usize;
        if n_h < MIN_HORIZON_SAMPLES {
            continue;
        }
        let Ok(f) = fit_base(&st, n_h) else {
            return (horizons, None);
        };
        let anchor = horizons.is_empty();
        horizons.push((n_h, f.fit.sse));
        if anchor && f.fit.sse > HORIZON_ANCHOR_MAX_CHI2 * (n_h * k) as f64 {
            return (horizons, None);
        }
        st = f.state;
    }
    let Ok(growing) = fit_base(&st, ctx.n_train) else {
        return (horizons, None);
    };
    horizons.push((ctx.n_train, growing.fit.sse));
    (horizons, Some(growing))
}

#[cfg(test)]
mod calibration_tests {
    use super::{Calibration, CalibrationFit};

    #[test]
    fn the_report_sentence_says_which_fit_was_kept_and_why() {
        let time: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        let mut cal = Calibration {
            direct_chi2: 5000.0,
            horizons: Vec::new(),
            chosen: CalibrationFit::Direct,
        };
        let t = cal.text(&time, 700, 2);
        assert!(t.contains("χ² = 5000.0") && !t.contains("horizon"), "{t}");
        // First horizon: 175 samples x 2 outputs at chi-square 1400 = 4 per sample, RMS 2x.
        cal.horizons = vec![(175, 1400.0)];
        let t = cal.text(&time, 700, 2);
        assert!(t.contains("not continued") && t.contains("1.740 s"), "{t}");
        assert!(t.contains("2.0× the noise level"), "{t}");
        cal.horizons = vec![(175, 350.0), (350, 700.0), (700, 1400.0)];
        cal.chosen = CalibrationFit::GrowingHorizons;
        let t = cal.text(&time, 700, 2);
        assert!(t.contains("1.740 s, 3.490 s, 6.990 s"), "{t}");
        assert!(
            t.contains("χ² = 1400.0") && t.ends_with("kept the growing horizons fit."),
            "{t}"
        );
    }
}
