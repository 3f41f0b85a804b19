//! Setup: check the data against the model and resolve the configuration into indices (outputs
//! compared, known settings, candidate effects, parameters to calibrate and their starts).

use super::verdict::convention_warnings;
use super::{find_param, Config, Data, GapError, InputError};
use crate::policy::MIN_SAMPLES;
use crate::sim::GridModel;
use crate::spec::{self, EffectSpec, ParamKind, ParamSpec};

/// The run's inputs resolved against the model.
pub(super) struct Setup {
    pub(super) params: Vec<ParamSpec>,
    /// Output names of the model.
    pub(super) names: Vec<String>,
    /// Samples.
    pub(super) n: usize,
    /// Model output index of each data output column.
    pub(super) out_idx: Vec<usize>,
    /// Known settings (`--set`): parameter index and value.
    pub(super) fixed: Vec<(usize, f64)>,
    /// Candidate effects (those switched by `--set` excluded).
    pub(super) effects: Vec<EffectSpec>,
    /// Parameters to calibrate and their values as given.
    pub(super) fit_idx: Vec<usize>,
    /// The initial-state parameters (`[initial]`) not set and not among them: estimated only
    /// when the record does not begin in the model's initial state (`start`).
    pub(super) initial_idx: Vec<usize>,
    pub(super) fit_start: Vec<f64>,
    /// Departures from the candidate-effect convention ([`convention_warnings`]).
    pub(super) convention_warnings: Vec<String>,
    /// Per data output column: its offset is estimated (`Config::offsets`).
    pub(super) offset: Vec<bool>,
}

/// Resolves `cfg` against the model and checks `data`; a usage error names what does not fit.
pub(super) fn setup<S: GridModel + ?Sized>(
    sim: &S,
    data: &Data,
    cfg: &Config,
) -> Result<Setup, GapError> {
    let params = sim.params().to_vec();
    let names = sim.output_names().to_vec();
    let n = data.time.len();
    if n < MIN_SAMPLES {
        return Err(InputError::TooFewSamples {
            got: n,
            need: MIN_SAMPLES,
        }
        .into());
    }
    if data.outputs.is_empty() {
        return Err(InputError::NoOutputColumn.into());
    }
    let mut out_idx = Vec::new();
    for (name, v) in &data.outputs {
        let k = names
            .iter()
            .position(|s| s == name)
            .ok_or_else(|| InputError::NoOutput(name.clone()))?;
        if v.len() != n {
            return Err(InputError::ColumnLength {
                column: name.clone(),
                values: v.len(),
                times: n,
            }
            .into());
        }
        out_idx.push(k);
    }
    for name in &cfg.offsets {
        if !data.outputs.iter().any(|(s, _)| s == name) {
            return Err(InputError::OffsetNotMeasured {
                output: name.clone(),
                measured: data.outputs.iter().map(|(s, _)| s.clone()).collect(),
            }
            .into());
        }
    }
    let offset: Vec<bool> = data
        .outputs
        .iter()
        .map(|(s, _)| cfg.offsets.contains(s))
        .collect();
    let mut fixed = Vec::new();
    for (name, v) in &cfg.fixed {
        fixed.push((find_param(&params, name)?, *v));
    }
    let all_effects = spec::find_effects(&params);
    let fixed_has = |i: usize| fixed.iter().any(|(j, _)| *j == i);
    let effects: Vec<EffectSpec> = match &cfg.effects {
        Some(list) => {
            let mut v = Vec::new();
            for name in list {
                let e = all_effects
                    .iter()
                    .find(|e| &e.name == name)
                    .ok_or_else(|| InputError::NoEffect(name.clone()))?;
                v.push(e.clone());
            }
            v
        }
        None => all_effects.clone(),
    };
    // Effects switched by --set are part of the given model, not candidates; their parameters
    // set by --set are fixed.
    let effects: Vec<EffectSpec> = effects
        .into_iter()
        .filter(|e| !fixed_has(e.enabled))
        .map(|mut e| {
            e.params.retain(|&i| !fixed_has(i));
            e
        })
        .collect();
    let fit_idx: Vec<usize> = match &cfg.fit {
        Some(list) => {
            let mut v = Vec::new();
            for name in list {
                let i = find_param(&params, name)?;
                if params[i].kind != ParamKind::Real {
                    return Err(InputError::NotReal(name.clone()).into());
                }
                v.push(i);
            }
            v
        }
        None => spec::default_calibration(&params, &all_effects),
    };
    let fit_idx: Vec<usize> = fit_idx.into_iter().filter(|&i| !fixed_has(i)).collect();
    let convention_warnings = convention_warnings(&params, cfg.fit.is_some());
    if fit_idx.is_empty() && effects.is_empty() {
        return Err(InputError::NothingToDo {
            departures: convention_warnings,
        }
        .into());
    }
    // The initial state the FMU exposes, estimated when the record needs it (`start`), unless
    // set or already fitted.
    let initial_idx: Vec<usize> = spec::initial_state(&params)
        .into_iter()
        .filter(|&i| !fixed_has(i) && !fit_idx.contains(&i))
        .collect();
    let mut fit_start = Vec::new();
    for &i in &fit_idx {
        fit_start.push(params[i].start);
    }
    Ok(Setup {
        params,
        names,
        n,
        out_idx,
        fixed,
        effects,
        fit_idx,
        initial_idx,
        fit_start,
        convention_warnings,
        offset,
    })
}
