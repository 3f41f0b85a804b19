//! Experiment design: an input that would reveal a candidate effect the data at hand cannot.
//!
//! The gap workflow calls a candidate unrevealable when its *visibility*, the chi-square of the
//! change it makes to the measured outputs that a readjustment of the base parameters (and of
//! the effects already named) cannot absorb, `‖(I − J J⁺) (y_on − y_off)/σ‖²` over the training part, stays below what naming needs,
//! `min ΔBIC + k ln(N K)` (k effect parameters, N training samples, K outputs). Whether an
//! effect shows is a property of the experiment as much as of the model: a backlash shows only
//! where the transmitted torque reverses, a radius growth only at large twist. This module
//! predicts the same visibility for proposed experiments and returns the gentlest that shows
//! every effect with a margin, or else the one that shows them most:
//!
//! 1. Every input with a range (declared min/max, or one the user gives) is a design variable;
//!    an input without one, or one that changes no measured output, is held at its start value.
//! 2. Each effect is evaluated at its weakest setting, so an experiment that reveals it there
//!    reveals any stronger instance: the corner of its parameters' box the data at hand show
//!    least (`weakest_corners`; without data, every parameter at its min).
//! 3. An experiment is scored by `min over effects of visibility / needed`, capped at
//!    [`ENOUGH`]; the search tries signals within the data's envelope first, widest first, then
//!    beyond it, least excursion first, and keeps the first that reaches the cap; the linearisation
//!    uses the base parameters at their start values (or `--set` values), a finite-difference
//!    Jacobian of the measured outputs, and the noise model of the data at hand (each output's
//!    level and AR(1) correlation, fitted as the gap workflow fits them: a correlated output's
//!    samples count with their effective number) or a fraction of each output's range in that
//!    experiment.
//! 4. Search: each input alone runs through the signal library ([`signals`]) while the others
//!    rest at their start values; then, from the best, every other input runs through the
//!    library and levels (reached from the start value by a minimum-jerk move), one input after
//!    another (coordinate search).
//! 5. An experiment that reaches the margin is shrunk towards the inputs' start values, by the
//!    smallest common factor that still reaches it, no input below the data's excursion
//!    (bisection, `shrink`).
//!
//! The prediction is linear in the effect's change; the refit the gap workflow then runs is not,
//! so a design aims well above 1× and the test of a design is the gap run on data it produced.

pub mod signals;

use crate::lm::{Bounded, Coord};
use crate::policy::{ENOUGH, MAX_CORNER_PARAMS, MIN_SAMPLES, MIN_TRAIN_SAMPLES, SHRINK_STEPS};
use crate::sim::{Counted, GridModel, SimError};
use crate::spec::{self, ParamSpec};
use crate::workflow::{noise, regress, Data, GapError, InputError};
use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// An input the design may drive.
#[derive(Clone, Debug)]
pub struct InputSpec {
    pub name: String,
    pub start: f64,
    /// Range the design stays within; None: held at its start value.
    pub range: Option<(f64, f64)>,
    pub unit: String,
}

impl InputSpec {
    /// The start value, within the range where one is given: where every signal begins.
    fn rest_value(&self) -> f64 {
        self.range
            .map_or(self.start, |(lo, hi)| self.start.clamp(lo, hi))
    }
}

/// How the noise level of each measured output is known.
#[derive(Clone, Debug)]
pub enum Noise {
    /// The noise standard deviation of each measured output, white.
    Sigma(Vec<f64>),
    /// The measured outputs of the data at hand (in `outputs` order): the noise model is that of
    /// the gap workflow, fitted to their residual against the model at the given settings (the
    /// level and the AR(1) coefficient of each output; a chi-square then counts a correlated
    /// output's samples with their effective number, `(1 − ρ)/(1 + ρ)` per sample).
    Measured(Vec<Vec<f64>>),
    /// A fraction of each output's range in the experiment itself (a sensor scaled to what it
    /// measures).
    Fraction(f64),
}

/// What to design for.
#[derive(Clone, Debug)]
pub struct DesignConfig {
    /// Effects to reveal; None = every candidate of the model.
    pub effects: Option<Vec<String>>,
    /// Base parameters the gap workflow would calibrate; None = those tagged `[calibrate]` and
    /// the parameters of every effect switched on in `fixed`.
    pub fit: Option<Vec<String>>,
    /// Settings applied to every simulation (`--set`). Other parameters are never readjusted;
    /// a calibrated one keeps its role (the linearisation is at the given value).
    pub fixed: Vec<(String, f64)>,
    /// Time grid of the experiment (the communication points).
    pub time: Vec<f64>,
    pub inputs: Vec<InputSpec>,
    /// Names of the measured outputs.
    pub outputs: Vec<String>,
    pub noise: Noise,
    /// The inputs of the data at hand, to report how visible each effect is there.
    pub given: Option<Vec<(String, Vec<f64>)>>,
    /// Held-out fraction of the gap workflow (visibility counts the training part only).
    pub holdout: f64,
    /// The naming threshold of the gap workflow.
    pub min_delta_bic: f64,
}

/// One effect's predicted visibility.
#[derive(Clone, Debug, Serialize)]
pub struct EffectPrediction {
    pub effect: String,
    /// The setting it is evaluated at (its weakest).
    pub weakest: BTreeMap<String, f64>,
    /// Chi-square naming needs.
    pub needed: f64,
    /// Visibility in the data at hand (None without data, or when its simulation failed).
    pub given: Option<f64>,
    /// Visibility in the proposed experiment.
    pub designed: Option<f64>,
}

/// The proposed experiment.
#[derive(Clone, Debug, Serialize)]
pub struct Design {
    pub time: Vec<f64>,
    /// Every input's signal (held ones constant).
    pub inputs: Vec<(String, Vec<f64>)>,
    /// What each input does, e.g. "square 0 .. 402 rad (lower fifth), period 1.25 s".
    pub labels: Vec<(String, String)>,
    /// Inputs held at their start value, and why.
    pub held: Vec<(String, String)>,
    pub effects: Vec<EffectPrediction>,
    pub experiments: usize,
    pub simulations: usize,
}

impl Design {
    /// Whether every effect reaches the naming threshold in the proposed experiment.
    pub fn reveals_all(&self) -> bool {
        self.effects
            .iter()
            .all(|e| e.designed.is_some_and(|v| v >= e.needed))
    }
}

/// What the evaluation of experiments needs, resolved once.
#[derive(Clone)]
struct Plan {
    /// Settings of every simulation (fixed values).
    base: Vec<(usize, f64)>,
    /// Calibrated parameters: index, value, finite-difference step.
    calib: Vec<(usize, f64, f64)>,
    /// Per effect: its switch on and its weakest setting.
    effects: Vec<(String, Vec<(usize, f64)>)>,
    needed: Vec<f64>,
    out_idx: Vec<usize>,
    n_train: usize,
}

/// Design an experiment; `make` builds a simulator driven by the given inputs on the given grid.
pub fn design<S, F>(make: F, cfg: &DesignConfig) -> Result<Design, GapError>
where
    S: GridModel,
    F: Fn(&Data) -> Result<S, GapError> + Sync,
{
    check(cfg)?;
    let rest: Vec<(String, Vec<f64>)> = cfg
        .inputs
        .iter()
        .map(|i| (i.name.clone(), vec![i.start; cfg.time.len()]))
        .collect();
    let probe = make(&data_with(cfg, &rest))?;
    let mut plan = plan(probe.params(), probe.output_names(), cfg)?;
    let counter = std::sync::atomic::AtomicUsize::new(0);
    let given_inputs = cfg.given.as_ref().map(|g| {
        let mut inputs = rest.clone();
        for (n, v) in g {
            if let Some(slot) = inputs.iter_mut().find(|(m, _)| m == n) {
                slot.1 = v.clone();
            }
        }
        inputs
    });
    let levels = match (&cfg.noise, &given_inputs) {
        (Noise::Fraction(f), _) => Levels::Fraction(*f),
        (Noise::Sigma(s), _) => Levels::Fixed {
            sigma: s.clone(),
            weight: vec![1.0; s.len()],
        },
        (Noise::Measured(y), Some(inputs)) => {
            let sim = make(&data_with(cfg, inputs))?;
            let counted = Counted::new(&sim);
            let levels = measured_levels(&counted, &plan, y);
            counter.fetch_add(counted.count(), std::sync::atomic::Ordering::SeqCst);
            levels
        }
        (Noise::Measured(_), None) => unreachable!("checked: measured outputs come with inputs"),
    };
    let visible = |plan: &Plan, inputs: &[(String, Vec<f64>)]| -> Option<Vec<Option<f64>>> {
        let sim = make(&data_with(cfg, inputs)).ok()?;
        let counted = Counted::new(&sim);
        let v = visibilities(&counted, plan, &levels).ok();
        counter.fetch_add(counted.count(), std::sync::atomic::Ordering::SeqCst);
        v
    };
    if let Some(inputs) = &given_inputs {
        plan.effects = weakest_corners(probe.params(), &plan, |p| visible(p, inputs));
    }
    let eval = |inputs: &[(String, Vec<f64>)]| visible(&plan, inputs);
    let given = given_inputs.as_ref().and_then(|inputs| eval(inputs));
    let (held, active) = classify_inputs(cfg, &plan, &make, &rest, &counter)?;
    let search = search(cfg, &plan, &active, &rest, &eval)?;
    let effects = plan
        .effects
        .iter()
        .enumerate()
        .map(|(e, (name, set))| EffectPrediction {
            effect: name.clone(),
            weakest: set
                .iter()
                .skip(1)
                .map(|&(i, v)| (probe.params()[i].name.clone(), v))
                .collect(),
            needed: plan.needed[e],
            given: given.as_ref().and_then(|g| g[e]),
            designed: search.visibility[e],
        })
        .collect();
    Ok(Design {
        time: cfg.time.clone(),
        inputs: search.inputs,
        labels: search.labels,
        held,
        effects,
        experiments: search.experiments,
        simulations: counter.into_inner(),
    })
}

fn data_with(cfg: &DesignConfig, inputs: &[(String, Vec<f64>)]) -> Data {
    Data {
        time: cfg.time.clone(),
        inputs: inputs.to_vec(),
        outputs: Vec::new(),
    }
}

fn check(cfg: &DesignConfig) -> Result<(), GapError> {
    if cfg.time.len() < MIN_SAMPLES {
        return Err(InputError::ShortExperiment {
            got: cfg.time.len(),
            need: MIN_SAMPLES,
        }
        .into());
    }
    if cfg.outputs.is_empty() {
        return Err(InputError::NothingToDesignFor.into());
    }
    if let Noise::Measured(y) = &cfg.noise {
        if y.len() != cfg.outputs.len() || y.iter().any(|v| v.len() != cfg.time.len()) {
            return Err(InputError::MeasuredNoiseShape.into());
        }
        if cfg.given.is_none() {
            return Err(InputError::MeasuredNoiseWithoutInputs.into());
        }
    }
    if let Noise::Sigma(s) = &cfg.noise {
        if s.len() != cfg.outputs.len() || s.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(InputError::NoiseLevel.into());
        }
    }
    for i in &cfg.inputs {
        if let Some((lo, hi)) = i.range {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(InputError::InputRange {
                    input: i.name.clone(),
                    lo,
                    hi,
                }
                .into());
            }
        }
    }
    Ok(())
}

fn find(params: &[ParamSpec], name: &str) -> Result<usize, GapError> {
    params
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| InputError::NoParameter(name.to_string()).into())
}

/// Resolve names into indices: the fixed settings, the calibrated parameters with their
/// finite-difference steps, and each effect's weakest setting.
fn plan(params: &[ParamSpec], outputs: &[String], cfg: &DesignConfig) -> Result<Plan, GapError> {
    let mut base = Vec::new();
    for (n, v) in &cfg.fixed {
        base.push((find(params, n)?, *v));
    }
    let value = |i: usize| {
        base.iter()
            .rev()
            .find(|(j, _)| *j == i)
            .map_or(params[i].start, |&(_, v)| v)
    };
    let all = spec::find_effects(params);
    let calib_idx: Vec<usize> = match &cfg.fit {
        Some(names) => names
            .iter()
            .map(|n| find(params, n))
            .collect::<Result<_, _>>()?,
        None => {
            // The effects switched on (named by a gap run) are refitted with the base on the
            // new data: what they can absorb of the effect designed for does not show. A
            // fitted motor friction mimics most of a strand hysteresis: counted as fixed, the
            // hysteresis looked 21× visible in an experiment where the follow-up could not
            // name it.
            let mut idx = spec::default_calibration(params, &all);
            for e in all.iter().filter(|e| value(e.enabled) != 0.0) {
                idx.extend(
                    e.params
                        .iter()
                        .filter(|i| !idx.contains(i))
                        .copied()
                        .collect::<Vec<_>>(),
                );
            }
            idx
        }
    };
    // A calibrated parameter given with --set (a fitted value from a gap run) is linearised
    // there and still readjusted: the gap run on the new data calibrates it again.
    let calib = calib_idx
        .into_iter()
        .map(|i| {
            let p = &params[i];
            let v = value(i);
            // One thousandth of the parameter's fitting scale, towards the inside of its range
            // (the projection that follows does not depend on the columns' scale).
            let h = match Bounded::new(p.start, p.min, p.max).coord {
                Coord::Log => 1e-3 * v.abs().max(1e-300),
                Coord::Linear(s) => 1e-3 * s,
            };
            let (lo, hi) = (p.min.unwrap_or(f64::MIN), p.max.unwrap_or(f64::MAX));
            let h = if v + h > hi && v - h >= lo { -h } else { h };
            (i, v, h)
        })
        .collect();
    let chosen: Vec<&spec::EffectSpec> = match &cfg.effects {
        None => all.iter().collect(),
        Some(names) => names
            .iter()
            .map(|n| {
                all.iter()
                    .find(|e| &e.name == n)
                    .ok_or_else(|| InputError::NoCandidateNamed {
                        effect: n.clone(),
                        candidates: all.iter().map(|e| e.name.clone()).collect(),
                    })
            })
            .collect::<Result<_, _>>()?,
    };
    if chosen.is_empty() {
        return Err(InputError::NoCandidate.into());
    }
    let n = cfg.time.len();
    let n_train = ((n as f64) * (1.0 - cfg.holdout))
        .round()
        .clamp(MIN_TRAIN_SAMPLES, n as f64) as usize;
    let k = cfg.outputs.len();
    let effects: Vec<(String, Vec<(usize, f64)>)> = chosen
        .iter()
        .map(|e| {
            let mut set = vec![(e.enabled, 1.0)];
            set.extend(
                e.params
                    .iter()
                    .map(|&i| (i, params[i].min.unwrap_or(params[i].start))),
            );
            (e.name.clone(), set)
        })
        .collect();
    let needed = chosen
        .iter()
        .map(|e| cfg.min_delta_bic + e.params.len() as f64 * libm::log((n_train * k) as f64))
        .collect();
    let out_idx = cfg
        .outputs
        .iter()
        .map(|o| {
            outputs
                .iter()
                .position(|m| m == o)
                .ok_or_else(|| InputError::NoOutput(o.clone()))
        })
        .collect::<Result<_, _>>()?;
    Ok(Plan {
        base,
        calib,
        effects,
        needed,
        out_idx,
        n_train,
    })
}

/// Parameter settings of one simulation: (parameter index, value).
type Setting = Vec<(usize, f64)>;

/// Each effect's weakest setting: the corner of its parameters' box (each at its min or its
/// max) the data at hand show least. The weak end of a parameter is not always its min: a
/// spool's lag falls as its natural frequency rises, so "every parameter at its min" (400 rad/s,
/// damping 0.4) was the strong setting of a valve lag, and a design aimed there missed a
/// slower, better damped one. An effect with more than [`MAX_CORNER_PARAMS`] parameters, an
/// unbounded parameter or a failed simulation keeps every parameter at its min.
fn weakest_corners<F>(
    params: &[ParamSpec],
    plan: &Plan,
    visible: F,
) -> Vec<(String, Vec<(usize, f64)>)>
where
    F: Fn(&Plan) -> Option<Vec<Option<f64>>>,
{
    let corners = |set: &[(usize, f64)]| -> Option<Vec<Setting>> {
        let free = &set[1..];
        if free.is_empty() || free.len() > MAX_CORNER_PARAMS {
            return None;
        }
        let ends: Vec<(f64, f64)> = free
            .iter()
            .map(|&(i, _)| Some((params[i].min?, params[i].max?)))
            .collect::<Option<_>>()?;
        Some(
            (0..1usize << free.len())
                .map(|mask| {
                    let mut c = vec![set[0]];
                    for (b, (&(i, _), &(lo, hi))) in free.iter().zip(&ends).enumerate() {
                        c.push((i, if mask >> b & 1 == 0 { lo } else { hi }));
                    }
                    c
                })
                .collect(),
        )
    };
    let per_effect: Vec<Option<Vec<Setting>>> =
        plan.effects.iter().map(|(_, set)| corners(set)).collect();
    let mut probe = plan.clone();
    probe.effects = per_effect
        .iter()
        .zip(&plan.effects)
        .flat_map(|(c, (name, _))| {
            c.iter()
                .flatten()
                .map(move |set| (name.clone(), set.clone()))
        })
        .collect();
    let Some(vis) = (!probe.effects.is_empty())
        .then(|| visible(&probe))
        .flatten()
    else {
        return plan.effects.clone();
    };
    let mut k = 0;
    per_effect
        .iter()
        .zip(&plan.effects)
        .map(|(c, (name, set))| {
            let Some(c) = c else {
                return (name.clone(), set.clone());
            };
            let scored = &vis[k..k + c.len()];
            k += c.len();
            let weakest = scored
                .iter()
                .enumerate()
                .filter_map(|(j, v)| v.map(|v| (j, v)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match (weakest, scored.iter().all(Option::is_some)) {
                (Some((j, _)), true) => (name.clone(), c[j].clone()),
                _ => (name.clone(), set.clone()),
            }
        })
        .collect()
}

/// The measured outputs of one simulation over the training part.
fn measured<S: GridModel + ?Sized>(
    sim: &Counted<'_, S>,
    plan: &Plan,
    extra: &[(usize, f64)],
) -> Result<Vec<Vec<f64>>, SimError> {
    let mut set = plan.base.clone();
    set.extend(plan.calib.iter().map(|&(i, v, _)| (i, v)));
    set.extend_from_slice(extra);
    sim.measured(&set, plan.n_train, &plan.out_idx)
}

/// The noise of each measured output as the visibilities use it.
#[derive(Clone, Debug)]
enum Levels {
    /// A fraction of each output's range in the experiment, white.
    Fraction(f64),
    /// Standard deviation and effective samples per sample of each output.
    Fixed { sigma: Vec<f64>, weight: Vec<f64> },
}

/// The noise model of the data at hand (see [`Noise::Measured`]): the residual of the measured
/// outputs against the model at the plan's settings, in units of each output's second-difference
/// level, fitted as the gap workflow fits it. A failed simulation leaves the white
/// second-difference levels.
fn measured_levels<S: GridModel + ?Sized>(
    sim: &Counted<'_, S>,
    plan: &Plan,
    measured: &[Vec<f64>],
) -> Levels {
    let level: Vec<f64> = measured
        .iter()
        .map(|y| noise::difference_level(y))
        .collect();
    let white = Levels::Fixed {
        sigma: level.clone(),
        weight: vec![1.0; measured.len()],
    };
    let Ok(model) = self::measured(sim, plan, &[]) else {
        return white;
    };
    let fits: Vec<noise::NoiseFit> = measured
        .iter()
        .zip(&model)
        .zip(&level)
        .map(|((y, m), l)| {
            let r: Vec<f64> = y.iter().zip(m).map(|(a, b)| (a - b) / l).collect();
            noise::noise_fit(&r)
        })
        .collect();
    Levels::Fixed {
        sigma: fits.iter().zip(&level).map(|(f, l)| f.level * l).collect(),
        weight: fits.iter().map(|f| (1.0 - f.rho) / (1.0 + f.rho)).collect(),
    }
}

/// Each effect's visibility in one experiment (the simulator carries its inputs): the
/// chi-square, counted with each output's effective samples, of its change that the calibrated
/// parameters cannot absorb.
fn visibilities<S: GridModel + ?Sized>(
    sim: &Counted<'_, S>,
    plan: &Plan,
    levels: &Levels,
) -> Result<Vec<Option<f64>>, SimError> {
    let y0 = measured(sim, plan, &[])?;
    let (sigma, weight): (Vec<f64>, Vec<f64>) = match levels {
        Levels::Fixed { sigma, weight } => (sigma.clone(), weight.clone()),
        Levels::Fraction(f) => (
            y0.iter()
                .map(|y| {
                    let r = crate::stats::range(y);
                    if r > 0.0 {
                        f * r
                    } else {
                        f64::INFINITY // a flat output carries no information
                    }
                })
                .collect(),
            vec![1.0; y0.len()],
        ),
    };
    let weighted = |y: &[Vec<f64>]| -> Vec<f64> {
        let mut r = Vec::with_capacity(plan.n_train * y.len());
        for (k, yk) in y.iter().enumerate() {
            r.extend(yk.iter().zip(&y0[k]).map(|(a, b)| (a - b) / sigma[k]));
        }
        r
    };
    let cols: Vec<Vec<f64>> = plan
        .calib
        .iter()
        .map(|&(i, v, h)| {
            let y = measured(sim, plan, &[(i, v + h)])?;
            Ok(weighted(&y).into_iter().map(|d| d / h).collect())
        })
        .collect::<Result<_, SimError>>()?;
    let rows = plan.n_train * y0.len();
    let jac = DMatrix::from_fn(rows, cols.len(), |r, c| cols[c][r]);
    Ok(plan
        .effects
        .iter()
        .map(|(_, set)| {
            let d = weighted(&measured(sim, plan, set).ok()?);
            let res = regress(&jac, &d).0;
            let v: f64 = res
                .chunks(plan.n_train)
                .zip(&weight)
                .map(|(c, w)| w * crate::lm::sse(c))
                .sum();
            v.is_finite().then_some(v)
        })
        .collect())
}

/// Inputs the design drives (index into `cfg.inputs`) and those it holds, with the reason.
#[allow(clippy::type_complexity)]
fn classify_inputs<S, F>(
    cfg: &DesignConfig,
    plan: &Plan,
    make: &F,
    rest: &[(String, Vec<f64>)],
    counter: &std::sync::atomic::AtomicUsize,
) -> Result<(Vec<(String, String)>, Vec<usize>), GapError>
where
    S: GridModel,
    F: Fn(&Data) -> Result<S, GapError> + Sync,
{
    let run = |inputs: &[(String, Vec<f64>)]| -> Result<Vec<Vec<f64>>, GapError> {
        let sim = make(&data_with(cfg, inputs))?;
        counter.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        Ok(measured(&Counted::new(&sim), plan, &[])?)
    };
    let at_rest = run(rest)?;
    let mut held = Vec::new();
    let mut active = Vec::new();
    for (j, inp) in cfg.inputs.iter().enumerate() {
        let Some((lo, hi)) = inp.range else {
            held.push((
                inp.name.clone(),
                "no range declared (min/max); give one with --range NAME=LO:HI".to_string(),
            ));
            continue;
        };
        let sig = &signals::library(&cfg.time, lo, hi, inp.start, &inp.unit)[0];
        let mut inputs = rest.to_vec();
        inputs[j].1 = sig.values.clone();
        let moved = run(&inputs)
            .map(|y| {
                y.iter().zip(&at_rest).any(|(a, b)| {
                    let scale = b.iter().fold(0.0_f64, |m, x| m.max(x.abs())) + 1e-300;
                    a.iter().zip(b).any(|(x, z)| (x - z).abs() > 1e-9 * scale)
                })
            })
            .unwrap_or(true);
        if moved {
            active.push(j);
        } else {
            held.push((
                inp.name.clone(),
                "changes no measured output with these settings".to_string(),
            ));
        }
    }
    if active.is_empty() {
        return Err(InputError::NoDesignableInput { held }.into());
    }
    Ok((held, active))
}

/// The best experiment found and its visibilities.
struct Found {
    inputs: Vec<(String, Vec<f64>)>,
    labels: Vec<(String, String)>,
    visibility: Vec<Option<f64>>,
    experiments: usize,
}

/// `min over effects of visibility / needed`, capped at [`ENOUGH`] (a failed simulation scores
/// nothing). With the cap, the first experiment of the search order that reaches the margin
/// wins: the search tries the gentlest signals first ([`signals::gentlest_first`]).
fn objective(v: &[Option<f64>], needed: &[f64]) -> f64 {
    v.iter()
        .zip(needed)
        .map(|(v, n)| v.map_or(0.0, |v| v / n))
        .fold(f64::INFINITY, f64::min)
        .min(ENOUGH)
}

/// Coordinate search over the signal library (see the module documentation).
fn search<E>(
    cfg: &DesignConfig,
    plan: &Plan,
    active: &[usize],
    rest: &[(String, Vec<f64>)],
    eval: &E,
) -> Result<Found, GapError>
where
    E: Fn(&[(String, Vec<f64>)]) -> Option<Vec<Option<f64>>> + Sync,
{
    let envelope = envelopes(cfg);
    let lib = |j: usize, with_constants: bool| {
        let inp = &cfg.inputs[j];
        let (lo, hi) = inp.range.expect("active inputs have a range");
        let mut v = signals::library(&cfg.time, lo, hi, inp.start, &inp.unit);
        if with_constants {
            v.extend(signals::constants(&cfg.time, lo, hi, inp.start, &inp.unit));
        }
        signals::gentlest_first(v, inp.rest_value(), envelope[j])
    };
    // Stage 1: each input alone.
    let mut trials: Vec<(usize, signals::Signal)> = active
        .iter()
        .flat_map(|&j| lib(j, false).into_iter().map(move |s| (j, s)))
        .collect();
    // (chosen signals: input, label, values; visibilities; objective)
    type Best = (Vec<(usize, String, Vec<f64>)>, Vec<Option<f64>>, f64);
    let mut best: Option<Best> = None;
    let mut experiments = 0;
    let mut fixed: Vec<(usize, String, Vec<f64>)> = Vec::new();
    let mut remaining: Vec<usize> = active.to_vec();
    loop {
        let scored: Vec<Option<(Vec<Option<f64>>, f64)>> = trials
            .par_iter()
            .map(|(j, s)| {
                let mut inputs = rest.to_vec();
                for (k, _, v) in &fixed {
                    inputs[*k].1 = v.clone();
                }
                inputs[*j].1 = s.values.clone();
                eval(&inputs).map(|v| {
                    let o = objective(&v, &plan.needed);
                    (v, o)
                })
            })
            .collect();
        experiments += trials.len();
        // The first of the best (deterministic whatever the thread count).
        let pick = scored
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.as_ref().map(|(_, o)| (k, *o)))
            .fold(None, |acc: Option<(usize, f64)>, (k, o)| match acc {
                Some((_, b)) if b >= o => acc,
                _ => Some((k, o)),
            });
        let Some((k, o)) = pick else { break };
        if best.as_ref().is_some_and(|b| b.2 >= o) {
            break; // another input adds nothing to the best so far
        }
        let (j, s) = trials[k].clone();
        let mut chosen = fixed.clone();
        chosen.push((j, s.label.clone(), s.values.clone()));
        best = Some((chosen.clone(), scored[k].clone().expect("picked").0, o));
        fixed = chosen;
        remaining.retain(|&r| r != j);
        if remaining.is_empty() {
            break;
        }
        trials = remaining
            .iter()
            .flat_map(|&j| lib(j, true).into_iter().map(move |s| (j, s)))
            .collect();
    }
    let Some((chosen, visibility, score)) = best else {
        return Err(GapError::Simulation(SimError::Model(
            "every proposed experiment failed to simulate".into(),
        )));
    };
    let (chosen, visibility) = if score >= ENOUGH {
        let (c, v, n) = shrink(cfg, plan, rest, chosen, visibility, &envelope, eval);
        experiments += n;
        (c, v)
    } else {
        (chosen, visibility)
    };
    let mut inputs = rest.to_vec();
    let mut labels = Vec::new();
    for (j, label, v) in chosen {
        inputs[j].1 = v;
        labels.push((cfg.inputs[j].name.clone(), label));
    }
    Ok(Found {
        inputs,
        labels,
        visibility,
        experiments,
    })
}

/// Each input's excursion from its start value in the data at hand; without data (or for an
/// input the data do not carry), its whole range, so that every signal counts as within it.
fn envelopes(cfg: &DesignConfig) -> Vec<f64> {
    cfg.inputs
        .iter()
        .map(|inp| {
            let Some((lo, hi)) = inp.range else {
                return 0.0;
            };
            let start = inp.rest_value();
            let given = cfg
                .given
                .as_ref()
                .and_then(|g| g.iter().find(|(n, _)| *n == inp.name));
            match given {
                Some((_, v)) => signals::excursion(v, start),
                None => (hi - start).max(start - lo),
            }
        })
        .collect()
}

/// The gentlest version of an experiment that reaches [`ENOUGH`]: every driven input scaled
/// towards its start value by one factor `s`, the smallest found by bisection that still reaches
/// the margin, but no input below the excursion of the data at hand (`envelope`: an experiment
/// that barely moves lets the follow-up calibrate nothing). Visibility grows with the excursion
/// (a radius growth shows only at large twist, and fast), so the library's windows alone jump
/// from too little to far too much; the returned experiment always reached the margin (a factor
/// that missed it is never taken). Returns the signals, their visibilities and the experiments
/// tried.
#[allow(clippy::type_complexity)]
fn shrink<E>(
    cfg: &DesignConfig,
    plan: &Plan,
    rest: &[(String, Vec<f64>)],
    chosen: Vec<(usize, String, Vec<f64>)>,
    visibility: Vec<Option<f64>>,
    envelope: &[f64],
    eval: &E,
) -> (Vec<(usize, String, Vec<f64>)>, Vec<Option<f64>>, usize)
where
    E: Fn(&[(String, Vec<f64>)]) -> Option<Vec<Option<f64>>> + Sync,
{
    let start = |j: usize| cfg.inputs[j].rest_value();
    let scaled = |s: f64| -> Vec<(usize, String, Vec<f64>)> {
        chosen
            .iter()
            .map(|(j, label, v)| {
                let x0 = start(*j);
                let label = format!("{label}, scaled by {s:.3} towards {x0:.4}");
                (*j, label, v.iter().map(|x| x0 + s * (x - x0)).collect())
            })
            .collect()
    };
    let floor = chosen
        .iter()
        .map(|(j, _, v)| envelope[*j] / signals::excursion(v, start(*j)).max(f64::MIN_POSITIVE))
        .fold(0.0_f64, f64::max);
    if floor >= 1.0 {
        return (chosen, visibility, 0);
    }
    let (mut lo, mut hi) = (floor, 1.0);
    let mut best = (chosen.clone(), visibility);
    for _ in 0..SHRINK_STEPS {
        let mid = 0.5 * (lo + hi);
        let trial = scaled(mid);
        let mut inputs = rest.to_vec();
        for (j, _, v) in &trial {
            inputs[*j].1 = v.clone();
        }
        match eval(&inputs) {
            Some(v) if objective(&v, &plan.needed) >= ENOUGH => {
                hi = mid;
                best = (trial, v);
            }
            _ => lo = mid,
        }
    }
    (best.0, best.1, SHRINK_STEPS)
}

#[cfg(test)]
mod tests {
    use super::{design, objective, DesignConfig, InputSpec, Noise, ENOUGH};
    use crate::synthetic::{input, measure, Msd, Rng};
    use crate::workflow::{Data, GapError};

    /// The data's visibility of the lag (the synthetic model's input lag) under the noise model
    /// fitted from the measured outputs, and under their white second-difference levels.
    fn given_visibility(ar: f64) -> (f64, f64) {
        let (n, dt) = (800, 0.01);
        let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let mut rng = Rng::new(7);
        let u = input(&mut rng, n, dt);
        let msd = Msd::new(time.clone(), u.clone());
        let data = measure(&msd, &[], &mut rng, 0.01, ar, &[0, 1]);
        let cfg = |noise: Noise| DesignConfig {
            effects: Some(vec!["lag".into()]),
            fit: None,
            fixed: Vec::new(),
            time: time.clone(),
            inputs: vec![InputSpec {
                name: "u".into(),
                start: 0.0,
                range: Some((-5.0, 5.0)),
                unit: "N".into(),
            }],
            outputs: vec!["x".into(), "v".into()],
            noise,
            given: Some(data.inputs.clone()),
            holdout: 0.3,
            min_delta_bic: 10.0,
        };
        let make = |d: &Data| -> Result<Msd, GapError> {
            Ok(Msd::new(d.time.clone(), d.inputs[0].1.clone()))
        };
        let measured: Vec<Vec<f64>> = data.outputs.iter().map(|(_, y)| y.clone()).collect();
        let levels = measured
            .iter()
            .map(|y| crate::stats::noise_sigma(y))
            .collect();
        let with = |noise| design(make, &cfg(noise)).expect("design").effects[0].given;
        (
            with(Noise::Measured(measured)).expect("visibility"),
            with(Noise::Sigma(levels)).expect("visibility"),
        )
    }

    #[test]
    fn correlated_noise_counts_with_its_effective_samples() {
        // White noise: the fitted model is white at the second-difference level.
        let (fitted, white) = given_visibility(0.0);
        assert!((fitted / white - 1.0).abs() < 0.05, "{fitted} {white}");
        // AR(1) 0.9: the marginal level is about 4× the second-difference one and a sample
        // counts about 1/19: hundreds of times less visible than the white reading says.
        let (fitted, white) = given_visibility(0.9);
        assert!(fitted < white / 100.0, "{fitted} {white}");
    }

    #[test]
    fn an_experiment_scores_its_least_visible_effect_up_to_the_margin() {
        assert_eq!(objective(&[Some(30.0), Some(90.0)], &[10.0, 10.0]), 3.0);
        assert_eq!(objective(&[Some(3e4), Some(9e3)], &[10.0, 10.0]), ENOUGH);
        assert_eq!(objective(&[None, Some(900.0)], &[10.0, 10.0]), 0.0);
    }
}
