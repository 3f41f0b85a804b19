//! Records the fit never saw (`gap --validate C.csv`): the error of the calibrated base model and
//! of the final model on each, per measured output (RMS, the largest error and when it occurs,
//! the tenth of the record where the final model misses most).
//!
//! Neither model is refitted: every parameter keeps the value the gap run gave it. Only the
//! state the record begins in is the record's own: where the FMU exposes its initial state
//! (`[initial]` parameters not set by `--set`), it is estimated on the record for each model
//! (bounded Levenberg–Marquardt on the residual weighted by the record's noise levels, the
//! data's second differences), as the gap run estimates each fitted record's.

use crate::lm::{self, Bounded, LmOptions, Problem};
use crate::sim::{select_outputs, GridModel, SimError};
use crate::spec;
use crate::workflow::noise::difference_level;
use crate::workflow::{Data, GapError, GapResult, InputError};
use serde::Serialize;
use std::collections::BTreeMap;

/// Tenths of the record searched for the worst window.
const WINDOWS: usize = 10;

/// The errors of the base and final models on one output of a record not fitted.
#[derive(Clone, Debug, Serialize)]
pub struct ValidationErrors {
    /// The record's white noise level of this output (second differences).
    pub noise_white: f64,
    pub rmse_base: f64,
    pub rmse_final: f64,
    pub max_base: f64,
    /// Record time of the base model's largest error [s].
    pub max_base_at_s: f64,
    pub max_final: f64,
    /// Record time of the final model's largest error [s].
    pub max_final_at_s: f64,
    /// The tenth of the record where the final model's RMS error is largest: start and end
    /// [s], RMS error there.
    pub worst_window_final: (f64, f64, f64),
}

/// One output over a record not fitted: measured, base and final model.
#[derive(Clone, Debug, Default)]
pub struct ValidationTrace {
    pub name: String,
    pub measured: Vec<f64>,
    pub base: Vec<f64>,
    pub final_model: Vec<f64>,
}

/// The two models on a record not fitted.
#[derive(Clone, Debug, Serialize)]
pub struct Validation {
    /// The record's file (as given).
    pub data: String,
    pub samples: usize,
    /// The initial state estimated on the record for the base and the final model.
    pub initial_state_base: BTreeMap<String, f64>,
    pub initial_state_final: BTreeMap<String, f64>,
    pub outputs: BTreeMap<String, ValidationErrors>,
    #[serde(skip)]
    pub time: Vec<f64>,
    #[serde(skip)]
    pub traces: Vec<ValidationTrace>,
}

/// The settings of the base model and of the final model of `res` in the parameters of `sim`
/// (names not of the model, such as another record's initial state `<name>@r`, are left out).
pub fn model_settings(sim: &(impl GridModel + ?Sized), res: &GapResult) -> [Vec<(usize, f64)>; 2] {
    let params = sim.params();
    let idx = |name: &str| params.iter().position(|p| p.name == name);
    let known = |m: &BTreeMap<String, f64>| -> Vec<(usize, f64)> {
        m.iter()
            .filter_map(|(k, v)| idx(k).map(|i| (i, *v)))
            .collect()
    };
    let mut base = known(&res.fixed);
    base.extend(known(&res.base_values));
    let mut fin = known(&res.fixed);
    for e in &res.named {
        fin.extend(idx(&format!("{e}.enabled")).map(|i| (i, 1.0)));
    }
    let values = res.parameters.iter().map(|(k, e)| (k.clone(), e.value));
    fin.extend(known(&values.collect()));
    [base, fin]
}

/// The weighted residual of a record for a model's settings with the initial state `p` at
/// `initial`.
struct InitialState<'a, S: GridModel + ?Sized> {
    sim: &'a S,
    settings: &'a [(usize, f64)],
    initial: &'a [usize],
    out_idx: &'a [usize],
    meas: &'a [Vec<f64>],
    sigma: &'a [f64],
}

impl<S: GridModel + ?Sized> InitialState<'_, S> {
    fn outputs(&self, p: &[f64]) -> Result<Vec<Vec<f64>>, SimError> {
        let mut set = self.settings.to_vec();
        set.extend(self.initial.iter().copied().zip(p.iter().copied()));
        let n = self.meas.first().map_or(0, Vec::len);
        select_outputs(self.sim, self.sim.simulate(&set, n)?, n, self.out_idx)
    }
}

impl<S: GridModel + ?Sized> Problem for InitialState<'_, S> {
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
        let y = self.outputs(p)?;
        Ok(y.iter()
            .zip(self.meas)
            .zip(self.sigma)
            .flat_map(|((m, d), s)| m.iter().zip(d).map(move |(a, b)| (a - b) / s))
            .collect())
    }
}

/// The base and final models of `res` on the record `data` of `sim` (named `name`).
pub fn validate<S: GridModel + ?Sized>(
    sim: &S,
    data: &Data,
    name: &str,
    res: &GapResult,
) -> Result<Validation, GapError> {
    let names = sim.output_names();
    let out_idx = data
        .outputs
        .iter()
        .map(|(o, _)| {
            names
                .iter()
                .position(|s| s == o)
                .ok_or_else(|| InputError::NoOutput(o.clone()))
        })
        .collect::<Result<Vec<usize>, InputError>>()?;
    let meas: Vec<Vec<f64>> = data.outputs.iter().map(|(_, y)| y.clone()).collect();
    let sigma: Vec<f64> = meas.iter().map(|y| difference_level(y)).collect();
    let params = sim.params();
    let [base, fin] = model_settings(sim, res);
    let initial: Vec<usize> = spec::initial_state(params)
        .into_iter()
        .filter(|i| !res.fixed.contains_key(&params[*i].name))
        .collect();
    let mut fitted = Vec::new();
    for settings in [&base, &fin] {
        let problem = InitialState {
            sim,
            settings,
            initial: &initial,
            out_idx: &out_idx,
            meas: &meas,
            sigma: &sigma,
        };
        let p = fit_initial(&problem, params, &initial)?;
        let y = problem.outputs(&p)?;
        let state: BTreeMap<String, f64> = initial
            .iter()
            .zip(&p)
            .map(|(&i, &v)| (params[i].name.clone(), v))
            .collect();
        fitted.push((state, y));
    }
    let (state_final, y_final) = fitted.pop().unwrap_or_default();
    let (state_base, y_base) = fitted.pop().unwrap_or_default();
    let mut outputs = BTreeMap::new();
    let mut traces = Vec::new();
    for (k, (o, y)) in data.outputs.iter().enumerate() {
        outputs.insert(
            o.clone(),
            output_errors(&data.time, y, &y_base[k], &y_final[k], sigma[k]),
        );
        traces.push(ValidationTrace {
            name: o.clone(),
            measured: y.clone(),
            base: y_base[k].clone(),
            final_model: y_final[k].clone(),
        });
    }
    Ok(Validation {
        data: name.to_string(),
        samples: data.time.len(),
        initial_state_base: state_base,
        initial_state_final: state_final,
        outputs,
        time: data.time.clone(),
        traces,
    })
}

/// The initial state that fits the record best (the parameters' start values when there are
/// none to estimate).
fn fit_initial<S: GridModel + ?Sized>(
    problem: &InitialState<'_, S>,
    params: &[crate::spec::ParamSpec],
    initial: &[usize],
) -> Result<Vec<f64>, GapError> {
    let p0: Vec<f64> = initial.iter().map(|&i| params[i].start).collect();
    if initial.is_empty() {
        return Ok(p0);
    }
    let bounds: Vec<Bounded> = initial
        .iter()
        .map(|&i| Bounded::new(params[i].start, params[i].min, params[i].max))
        .collect();
    let opts = LmOptions {
        abs_tol: 1.0,
        final_jacobian: false,
        ..LmOptions::default()
    };
    let fit = lm::levenberg_marquardt(problem, &bounds, &p0, opts, &|| {})?;
    Ok(fit.p)
}

/// RMS and largest errors of the two models on one output, when the largest occur, and the
/// tenth of the record where the final model misses most.
fn output_errors(
    time: &[f64],
    measured: &[f64],
    base: &[f64],
    fin: &[f64],
    noise_white: f64,
) -> ValidationErrors {
    let (rmse_base, max_base) = crate::records::errors(measured, base);
    let (rmse_final, max_final) = crate::records::errors(measured, fin);
    let at_max = |m: &[f64]| {
        let i = m
            .iter()
            .zip(measured)
            .map(|(a, b)| (a - b).abs())
            .enumerate()
            .fold(
                (0, -1.0),
                |best, (i, d)| if d > best.1 { (i, d) } else { best },
            )
            .0;
        time.get(i).copied().unwrap_or(f64::NAN)
    };
    let n = measured.len();
    let worst_window_final = (0..WINDOWS)
        .filter_map(|w| {
            let (a, b) = (w * n / WINDOWS, ((w + 1) * n / WINDOWS).min(n));
            (b > a).then(|| {
                let (rms, _) = crate::records::errors(&measured[a..b], &fin[a..b]);
                (time[a], time[b - 1], rms)
            })
        })
        .fold((f64::NAN, f64::NAN, -1.0), |best, w| {
            if w.2 > best.2 {
                w
            } else {
                best
            }
        });
    ValidationErrors {
        noise_white,
        rmse_base,
        rmse_final,
        max_base,
        max_base_at_s: at_max(base),
        max_final,
        max_final_at_s: at_max(fin),
        worst_window_final,
    }
}
