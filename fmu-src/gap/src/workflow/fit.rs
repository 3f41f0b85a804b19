//! The fitting context of a run: the data, the noise model, the settings of a model state, the
//! weighted residual, and fits of a state's parameters by [`lm`].

use super::{GapError, InputError};
use crate::lm::{self, Bounded, LmOptions, Problem};
use crate::policy::{
    CONVERGED_DECREASE, FINAL_ITERATIONS, FINAL_REL_TOL, LM_ABS_TOL, POLISH_ITERATIONS,
    POLISH_REL_TOL,
};
use crate::sim::{Counted, GridModel, SimError};
use crate::spec::{EffectSpec, ParamSpec};
use indicatif::ProgressBar;
use std::time::Instant;

/// A model configuration: parameter values that are set for a simulation.
#[derive(Clone, Debug)]
pub(super) struct ModelState {
    /// Named effects (indices into the effect list).
    pub(super) named: Vec<usize>,
    /// Fitted parameter indices and their current values.
    pub(super) idx: Vec<usize>,
    pub(super) val: Vec<f64>,
}

impl ModelState {
    /// The same named effects and fitted parameters with other values (same order as `idx`).
    pub(super) fn with_values(&self, val: Vec<f64>) -> ModelState {
        debug_assert_eq!(val.len(), self.idx.len());
        ModelState {
            named: self.named.clone(),
            idx: self.idx.clone(),
            val,
        }
    }

    /// The same with its base parameters (those of `st0`) at `st0`'s values, when it lists them
    /// first.
    pub(super) fn with_base(&self, st0: &ModelState) -> Option<ModelState> {
        let k = st0.idx.len();
        (self.idx.len() >= k && self.idx[..k] == st0.idx[..]).then(|| {
            let mut v = self.val.clone();
            v[..k].copy_from_slice(&st0.val);
            self.with_values(v)
        })
    }
}

pub(super) struct Ctx<'a, S: GridModel + ?Sized> {
    pub(super) sim: Counted<'a, S>,
    pub(super) params: Vec<ParamSpec>,
    pub(super) effects: Vec<EffectSpec>,
    pub(super) fixed: Vec<(usize, f64)>,
    pub(super) out_idx: Vec<usize>,
    pub(super) meas: Vec<Vec<f64>>,
    /// Per measured output: the noise level (marginal standard deviation) and the AR(1)
    /// coefficient of the noise (0: white), see `noise`.
    pub(super) sigma: Vec<f64>,
    pub(super) rho: Vec<f64>,
    /// Per measured output: its offset is estimated (`Config::offsets`).
    pub(super) offset: Vec<bool>,
    pub(super) n: usize,
    pub(super) n_train: usize,
    /// ΔBIC an effect needs to be named (`Config::min_delta_bic`).
    pub(super) min_delta_bic: f64,
    /// `Config::calibration_horizons`, `Config::profile_restart`, `Config::trace`.
    pub(super) calibration_horizons: bool,
    pub(super) profile_restart: bool,
    pub(super) trace: bool,
    pub(super) pb: ProgressBar,
    pub(super) t0: Instant,
}

impl<S: GridModel + ?Sized> Ctx<'_, S> {
    /// Progress message; with `Config::trace` also a line on stderr with the elapsed time and
    /// the simulation count (for profiling).
    pub(super) fn stage(&self, msg: String) {
        if self.trace {
            eprintln!(
                "[gap {:7.2} s, {:4} sims, {:7.2} s simulating] {msg}",
                self.t0.elapsed().as_secs_f64(),
                self.sim.count(),
                self.sim.busy_s()
            );
        }
        self.pb.set_message(msg);
    }

    pub(super) fn settings(
        &self,
        st: &ModelState,
        extra_on: Option<usize>,
        extra: &[(usize, f64)],
    ) -> Vec<(usize, f64)> {
        let mut s = self.fixed.clone();
        for &e in st.named.iter().chain(extra_on.iter()) {
            s.push((self.effects[e].enabled, 1.0));
        }
        s.extend(st.idx.iter().copied().zip(st.val.iter().copied()));
        s.extend_from_slice(extra);
        s
    }

    /// The chi-square drop naming effect `e` needs on the training part: `min ΔBIC + (effect
    /// parameters) ln N_eff`, N_eff the effective samples of all outputs under the noise model
    /// (its visibility, counted in effective samples too, is measured against this).
    pub(super) fn visibility_needed(&self, e: usize) -> f64 {
        let n_eff: f64 = self
            .sample_weights()
            .iter()
            .map(|w| w * self.n_train as f64)
            .sum();
        self.min_delta_bic + self.effects[e].params.len() as f64 * libm::log(n_eff.max(1.0))
    }

    /// Effective samples per sample of each measured output's noise: `(1 − ρ)/(1 + ρ)` for its
    /// AR(1) coefficient ρ (the variance of a mean of AR(1) noise over many samples), 1 for
    /// white noise.
    pub(super) fn sample_weights(&self) -> Vec<f64> {
        self.rho.iter().map(|r| (1.0 - r) / (1.0 + r)).collect()
    }

    /// Simulate and return the measured outputs only, first `n` samples.
    pub(super) fn measured_outputs(
        &self,
        set: &[(usize, f64)],
        n: usize,
    ) -> Result<Vec<Vec<f64>>, SimError> {
        self.sim.measured(set, n, &self.out_idx)
    }

    /// Weighted residual stacked by output over samples `0..n`; an output whose offset is
    /// estimated has it removed as estimated over the fitted samples (`0..min(n, n_train)`:
    /// over the training part when a training fit is carried to the whole trace).
    pub(super) fn residual(&self, y: &[Vec<f64>], n: usize) -> Vec<f64> {
        self.residual_est(y, n, n.min(self.n_train))
    }

    /// [`Ctx::residual`] with the offsets estimated over samples `0..n_est`.
    ///
    /// An offset enters linearly: with `r_i = (y_i − m_i) / σ` the least-squares offset is the
    /// mean of `r` over the fitted samples, so it is eliminated in closed form (variable
    /// projection, Golub & Pereyra 1973) and the fits, their Jacobians and the ΔBIC see the
    /// residual with its mean removed.
    pub(super) fn residual_est(&self, y: &[Vec<f64>], n: usize, n_est: usize) -> Vec<f64> {
        let mut r = Vec::with_capacity(n * y.len());
        for (k, yk) in y.iter().enumerate() {
            r.extend((0..n).map(|i| (yk[i] - self.meas[k][i]) / self.sigma[k]));
        }
        self.remove_offsets(&mut r, n, n_est);
        r
    }

    /// Subtract from each offset output's block of `v` (stacked by output, `n` per output) its
    /// mean over the first `n_est` samples.
    pub(super) fn remove_offsets(&self, v: &mut [f64], n: usize, n_est: usize) {
        let n_est = n_est.clamp(1, n.max(1));
        for (k, _) in self.offset.iter().enumerate().filter(|(_, on)| **on) {
            let Some(block) = v.get_mut(k * n..(k + 1) * n) else {
                continue;
            };
            let mean = block[..n_est].iter().sum::<f64>() / n_est as f64;
            block.iter_mut().for_each(|x| *x -= mean);
        }
    }

    /// The offset of output `k` (measured − model, physical units) for model outputs `y_k`,
    /// estimated over samples `0..n_est`; 0 for an output whose offset is not estimated.
    pub(super) fn offset_of(&self, k: usize, y_k: &[f64], n_est: usize) -> f64 {
        if !self.offset[k] {
            return 0.0;
        }
        let n_est = n_est.clamp(1, y_k.len().max(1));
        (0..n_est).map(|i| self.meas[k][i] - y_k[i]).sum::<f64>() / n_est as f64
    }

    /// The model's measured outputs `y` as the data see them: each with its offset, estimated
    /// over samples `0..n_est`, added.
    pub(super) fn with_offsets(&self, y: Vec<Vec<f64>>, n_est: usize) -> Vec<Vec<f64>> {
        y.into_iter()
            .enumerate()
            .map(|(k, yk)| {
                let b = self.offset_of(k, &yk, n_est);
                yk.into_iter().map(|v| v + b).collect()
            })
            .collect()
    }
}

pub(super) struct FitProblem<'c, 'a, S: GridModel + ?Sized> {
    pub(super) ctx: &'c Ctx<'a, S>,
    /// Settings that stay constant in this fit.
    pub(super) base: Vec<(usize, f64)>,
    pub(super) idx: Vec<usize>,
    pub(super) n: usize,
}

impl<'c, 'a, S: GridModel + ?Sized> FitProblem<'c, 'a, S> {
    /// The problem a fit of `f`'s parameters over `n` samples solves: its effects on, nothing
    /// held.
    pub(super) fn of(ctx: &'c Ctx<'a, S>, f: &FitOut, n: usize) -> Self {
        let effects_on = ModelState {
            named: f.state.named.clone(),
            idx: Vec::new(),
            val: Vec::new(),
        };
        FitProblem {
            ctx,
            base: ctx.settings(&effects_on, None, &[]),
            idx: f.state.idx.clone(),
            n,
        }
    }
}

impl<S: GridModel + ?Sized> Problem for FitProblem<'_, '_, S> {
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
        let mut set = self.base.clone();
        set.extend(self.idx.iter().copied().zip(p.iter().copied()));
        let y = self.ctx.measured_outputs(&set, self.n)?;
        // Offsets estimated over the samples this fit uses (the whole trace in the final fit).
        Ok(self.ctx.residual_est(&y, self.n, self.n))
    }
}

pub(super) fn bounds_of(params: &[ParamSpec], idx: &[usize]) -> Vec<Bounded> {
    idx.iter()
        .map(|&i| Bounded::new(params[i].start, params[i].min, params[i].max))
        .collect()
}

pub(super) fn find_param(params: &[ParamSpec], name: &str) -> Result<usize, GapError> {
    params
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| InputError::NoParameter(name.to_string()).into())
}

pub(super) struct FitOut {
    pub(super) state: ModelState,
    pub(super) fit: lm::LmFit,
    pub(super) bounds: Vec<Bounded>,
}

/// How far one fit may go: iterations, the relative stopping tolerance, and the sum of squares
/// below which it must be able to come to be worth continuing (`lm::LmOptions::futile_above`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Limits {
    pub(super) max_iter: usize,
    pub(super) rel_tol: f64,
    pub(super) futile_above: Option<f64>,
    /// `lm::LmOptions::final_jacobian`.
    pub(super) final_jacobian: bool,
    /// `lm::LmOptions::converged_below`.
    pub(super) converged_below: Option<f64>,
}

impl Limits {
    pub(super) const fn new(max_iter: usize, rel_tol: f64) -> Self {
        Limits {
            max_iter,
            rel_tol,
            futile_above: None,
            final_jacobian: true,
            converged_below: None,
        }
    }

    /// The same limits, stopping only where the remaining Gauss–Newton step predicts a decrease
    /// below `decrease` (`lm::LmOptions::converged_below`).
    pub(super) const fn converged_below(self, decrease: f64) -> Self {
        Limits {
            converged_below: Some(decrease),
            ..self
        }
    }

    /// The same limits for a fit whose Jacobian is not read, or made later by
    /// [`ensure_jacobian`] only if the fit is kept.
    pub(super) const fn without_final_jacobian(self) -> Self {
        Limits {
            final_jacobian: false,
            ..self
        }
    }

    /// The same limits, giving up once the sum of squares cannot come below `target`.
    pub(super) fn futile_above(self, target: f64) -> Self {
        Limits {
            futile_above: Some(target),
            ..self
        }
    }
}

/// Limits of the final fit of the chosen model on the whole trace, whose values and intervals
/// are reported: it stops only where the Gauss–Newton step left predicts less than
/// [`CONVERGED_DECREASE`].
pub(super) const FINAL_LIMITS: Limits =
    Limits::new(FINAL_ITERATIONS, FINAL_REL_TOL).converged_below(CONVERGED_DECREASE);

/// Limits of the polish of a named candidate's refit on the training part, against which the
/// next round's candidates are compared.
pub(super) const POLISH_LIMITS: Limits = Limits::new(POLISH_ITERATIONS, POLISH_REL_TOL);

pub(super) fn fit_state<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &ModelState,
    extra_on: Option<usize>,
    extra: &[(usize, f64)],
    n: usize,
    limits: Limits,
) -> Result<FitOut, SimError> {
    fit_state_holding(ctx, st, extra_on, extra, &[], n, limits)
}

/// [`fit_state`] with the settings `held` applied and kept constant (a profile fit: the base
/// parameters fitted with an effect's parameters held at given values).
pub(super) fn fit_state_holding<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &ModelState,
    extra_on: Option<usize>,
    extra: &[(usize, f64)],
    held: &[(usize, f64)],
    n: usize,
    limits: Limits,
) -> Result<FitOut, SimError> {
    let mut idx = st.idx.clone();
    let mut p0 = st.val.clone();
    for &(i, v) in extra {
        idx.push(i);
        p0.push(v);
    }
    let empty = ModelState {
        named: st.named.clone(),
        idx: Vec::new(),
        val: Vec::new(),
    };
    let problem = FitProblem {
        ctx,
        base: ctx.settings(&empty, extra_on, held),
        idx: idx.clone(),
        n,
    };
    let bounds = bounds_of(&ctx.params, &idx);
    let opts = LmOptions {
        max_iter: limits.max_iter,
        rel_tol: limits.rel_tol,
        abs_tol: LM_ABS_TOL,
        trace: ctx.trace,
        futile_above: limits.futile_above,
        converged_below: limits.converged_below,
        final_jacobian: limits.final_jacobian,
        ..Default::default()
    };
    let fit = lm::levenberg_marquardt(&problem, &bounds, &p0, opts, &|| ctx.pb.tick())?;
    let mut named = st.named.clone();
    if let Some(e) = extra_on {
        named.push(e);
    }
    Ok(FitOut {
        state: ModelState {
            named,
            idx,
            val: fit.p.clone(),
        },
        fit,
        bounds,
    })
}

/// The finite-difference Jacobian at the optimum of `f` (a fit of `fit_state` over `n`
/// samples, effects in `f.state.named` on, nothing held) if it ended without one: the values
/// the fit would have ended with.
pub(super) fn ensure_jacobian<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, f: &mut FitOut, n: usize) {
    if f.fit.jac_fresh {
        return;
    }
    let problem = FitProblem::of(ctx, f, n);
    lm::refresh_jacobian(
        &problem,
        &f.bounds,
        &mut f.fit,
        LmOptions::default().fd_step,
    );
}
