//! Adaptive, L-stable Rosenbrock integrator for stiff ODEs `y' = f(t, y)`, made to run inside
//! `fmi2DoStep` of stiff actuator models (hydraulic chamber pressures, motor currents).
//!
//! * Methods: Rodas5P (Steinebach 2023, order 5(4), default) and Rodas4 (Hairer & Wanner 1996,
//!   order 4(3)); both L-stable and stiffly accurate, with an embedded error estimate.
//!   See `README.md` for the measurement that chose the default.
//! * One LU decomposition of `W = I/(h gamma) - J` per step attempt, done in place by a small
//!   hand-written partial-pivoting Gaussian elimination on a column-major buffer (contiguous axpy
//!   inner loops for the 10-20 states of the actuator models); the Jacobian `J` is analytic when the system provides
//!   it, otherwise forward differences with scaled increments. After a rejected step the Jacobian
//!   (and `f(t, y)`, `df/dt`) of the same point is reused; only the LU is redone for the new `h`.
//! * Step-size control: Gustafsson predictive controller with safety factor and growth limits
//!   (Hairer & Wanner II, IV.8, eq. (8.21)); a restart after a discontinuity begins where the
//!   previous restart's first step ended up ([`Integrator::reset_step_size`]); a per-call attempt limit, a minimum step size and
//!   non-finite detection turn every failure into an [`OdeError`], never a panic or a hang.
//! * Deterministic: an [`Integrator`] is `Clone + Serialize + Deserialize`; a clone or a serde
//!   round trip continued from the same `y` produces bit-identical results (work buffers are not
//!   part of the state and carry nothing from one call to the next).
//! * No heap allocation inside [`Integrator::integrate`] once the buffers exist for the dimension.

mod clock;
pub mod math;
mod tableau;

pub use clock::{SampleClock, Segments};

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use tableau::{Tableau, RODAS4, RODAS5P};

/// A first-order ODE system `y' = f(t, y)` of fixed dimension.
pub trait OdeSystem {
    /// Number of states.
    fn dim(&self) -> usize;
    /// Right-hand side: write `f(t, y)` into `dydt` (both of length `dim()`).
    fn rhs(&self, t: f64, y: &[f64], dydt: &mut [f64]);
    /// Optional analytic Jacobian d(rhs)/dy into `jac` (dim x dim, `jac[(i, j)] = df_i/dy_j`);
    /// return false to let the integrator use finite differences.
    fn jacobian(&self, _t: f64, _y: &[f64], _jac: &mut DMatrix<f64>) -> bool {
        false
    }
    /// Return true when `f` does not depend on `t` explicitly; saves one rhs evaluation per step
    /// (otherwise `df/dt` is formed by a forward difference in `t`).
    fn autonomous(&self) -> bool {
        false
    }
    /// Number of trailing states that are quadratures: `y_k' = g_k(t, y_0..y_{m-1})` with no
    /// right-hand side depending on any of them (their Jacobian columns are zero). The
    /// integrator then decomposes only the leading `m x m` block of `W` and solves the quadrature
    /// rows by substitution, which is exact for this block-triangular `W` (it only saves work).
    /// Default 0. Declaring a state a quadrature while some `f_i` depends on it is a bug of the
    /// system: its coupling would be dropped from the stage equations.
    fn quadratures(&self) -> usize {
        0
    }
}

/// Failure of [`Integrator::integrate`]. `y` then holds the last accepted state (at `t`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OdeError {
    /// The step size fell below the resolution of `t` (tolerance impossible, or a singularity).
    #[error("ODE step size too small at t = {t}: h = {h:e}")]
    StepSizeTooSmall { t: f64, h: f64 },
    /// A NaN or infinity in the state, the rhs or the Jacobian that smaller steps cannot avoid.
    #[error("non-finite value (NaN or infinity) in the ODE state or right-hand side at t = {t}")]
    NonFinite { t: f64 },
    /// More step attempts than the per-call limit ([`Integrator::set_max_steps`]).
    #[error("too many ODE steps in one call, stopped at t = {t}")]
    TooManySteps { t: f64 },
    /// Bad arguments: dimension mismatch, negative tolerance, `t1 < t0`, non-finite times.
    #[error("invalid ODE integrator input: {0}")]
    InvalidInput(&'static str),
}

/// Cumulative work counters (over all calls since construction).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts (error too large, singular W or non-finite trial values).
    pub rejected: u64,
    /// Right-hand-side evaluations (including those for finite-difference Jacobians).
    pub rhs_evals: u64,
    /// Jacobian evaluations (analytic or finite-difference).
    pub jac_evals: u64,
    /// Of which by finite differences.
    pub fd_jacobians: u64,
    /// LU decompositions of W.
    pub lu_decomps: u64,
}

/// The Rosenbrock coefficient set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Method {
    /// Steinebach (2023), order 5 with embedded order 4, 8 stages.
    #[default]
    Rodas5P,
    /// Hairer & Wanner (1996), order 4 with embedded order 3, 6 stages.
    Rodas4,
}

impl Method {
    fn tableau(self) -> &'static Tableau {
        match self {
            Method::Rodas5P => &RODAS5P,
            Method::Rodas4 => &RODAS4,
        }
    }
}

/// Safety factor of the step-size controller.
const SAFETY: f64 = 0.9;
/// Largest step-size growth factor per accepted step.
const FAC_MAX: f64 = 6.0;
/// Smallest step-size reduction factor per step.
const FAC_MIN: f64 = 0.2;
/// Step-size reduction after a non-finite trial value or a singular W.
const FAC_FAIL: f64 = 0.25;
/// Consecutive non-finite trials tolerated before giving up with `NonFinite`.
const MAX_NONFINITE_TRIALS: u32 = 40;

/// Adaptive Rosenbrock integrator state: tolerances, options, step-size history and statistics.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Integrator {
    rtol: f64,
    atol: Vec<f64>,
    method: Method,
    max_steps: u64,
    /// Upper bound on h (None: unbounded; kept finite so JSON serialization works too).
    max_step: Option<f64>,
    /// Step size proposed for the next step (None: estimate one).
    h_next: Option<f64>,
    /// Predictive controller memory: last accepted step size and its error (0: none).
    h_acc: f64,
    err_acc: f64,
    /// Step size the error of the first accepted step after the last restart called for (0:
    /// none yet): where the next restart begins.
    #[serde(default)]
    h_restart: f64,
    stats: Stats,
    #[serde(skip)]
    work: Work,
}

impl Integrator {
    /// rtol: relative tolerance; atol: per-component absolute tolerance (len = dim).
    pub fn new(rtol: f64, atol: Vec<f64>) -> Self {
        Integrator {
            rtol,
            atol,
            method: Method::default(),
            max_steps: 100_000,
            max_step: None,
            h_next: None,
            h_acc: 0.0,
            err_acc: 0.0,
            h_restart: 0.0,
            stats: Stats::default(),
            work: Work::default(),
        }
    }

    /// Builder: choose the coefficient set.
    pub fn with_method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// The coefficient set in use.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Limit on step attempts (accepted + rejected) per `integrate` call (default 100 000).
    pub fn set_max_steps(&mut self, n: u64) {
        self.max_steps = n;
    }

    fn h_max(&self) -> f64 {
        self.max_step.unwrap_or(f64::INFINITY)
    }

    /// Upper bound on the internal step size (default: unbounded; a value <= 0, NaN or infinite
    /// removes the bound).
    pub fn set_max_step(&mut self, h: f64) {
        self.max_step = (h > 0.0 && h.is_finite()).then_some(h);
    }

    /// Change the tolerances (keeps the step-size history).
    pub fn set_tolerances(&mut self, rtol: f64, atol: Vec<f64>) {
        self.rtol = rtol;
        self.atol = atol;
    }

    /// Relative tolerance.
    pub fn rtol(&self) -> f64 {
        self.rtol
    }

    /// Per-component absolute tolerances.
    pub fn atol(&self) -> &[f64] {
        &self.atol
    }

    /// Step size the next call will try first (None after [`Self::reset_step_size`]).
    pub fn next_step_size(&self) -> Option<f64> {
        self.h_next
    }

    /// Restart the step-size selection (call after a discontinuity such as a controller sample
    /// update): the predictive controller's history is forgotten, and the next step begins at the
    /// size the error of the first step after the previous restart called for (at the estimate
    /// from `(t, y)` the first time). The estimate alone is `0.01 ||y|| / ||f||`, independent of
    /// the tolerance: in a stiff model it is far below what the tolerance allows, and growing back
    /// from it by at most `FAC_MAX` per step made every restart cost several steps, more the
    /// looser the tolerance (TwistedString at rtol 1e-3 took twice the steps of rtol 1e-6).
    pub fn reset_step_size(&mut self) {
        self.h_next = None;
        self.h_acc = 0.0;
        self.err_acc = 0.0;
    }

    /// Work counters accumulated since construction.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Integrate from t0 to exactly t1, y in place. Adaptive steps with error control; stiff-capable.
    ///
    /// On error `y` holds the last accepted state (the time is in the error).
    pub fn integrate<S: OdeSystem>(
        &mut self,
        sys: &S,
        t0: f64,
        t1: f64,
        y: &mut [f64],
    ) -> Result<(), OdeError> {
        self.integrate_observed(sys, t0, t1, y, |_, _| false)
            .map(|_| ())
    }

    /// [`Self::integrate`] with an observer called after every accepted step with the step's
    /// end `(t, y)`; when it returns true the integration stops there and the time reached is
    /// returned (otherwise `t1`). The next call continues with the step size the controller
    /// proposed. An observer that always returns false gives exactly the steps and results of
    /// [`Self::integrate`] (it is the same loop). Made for importers that check event
    /// indicators or an FMU's `completedIntegratorStep` after each step.
    ///
    /// On error `y` holds the last accepted state (the time is in the error).
    pub fn integrate_observed<S: OdeSystem>(
        &mut self,
        sys: &S,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        observe: impl FnMut(f64, &[f64]) -> bool,
    ) -> Result<f64, OdeError> {
        let n = sys.dim();
        if y.len() != n {
            return Err(OdeError::InvalidInput("y.len() != sys.dim()"));
        }
        if self.atol.len() != n {
            return Err(OdeError::InvalidInput("atol.len() != sys.dim()"));
        }
        if !(self.rtol >= 0.0 && self.rtol.is_finite()) {
            return Err(OdeError::InvalidInput("rtol must be finite and >= 0"));
        }
        if self.atol.iter().any(|a| !(*a >= 0.0 && a.is_finite())) {
            return Err(OdeError::InvalidInput("atol must be finite and >= 0"));
        }
        if !t0.is_finite() || !t1.is_finite() {
            return Err(OdeError::NonFinite { t: t0 });
        }
        if t1 < t0 {
            return Err(OdeError::InvalidInput("t1 < t0"));
        }
        if !all_finite(y) {
            return Err(OdeError::NonFinite { t: t0 });
        }
        if n == 0 || t1 == t0 {
            return Ok(t1);
        }
        let tab = self.method.tableau();
        self.work.ensure(n, tab.stages);
        let mut w = std::mem::take(&mut self.work);
        let r = self.run(sys, tab, &mut w, t0, t1, y, observe);
        self.work = w;
        r
    }

    /// The step loop (see the crate documentation).
    #[allow(clippy::too_many_arguments)]
    fn run<S: OdeSystem>(
        &mut self,
        sys: &S,
        tab: &Tableau,
        w: &mut Work,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        mut observe: impl FnMut(f64, &[f64]) -> bool,
    ) -> Result<f64, OdeError> {
        let n = y.len();
        let m = implicit_dim(sys, n);
        let mut t = t0;
        sys.rhs(t, y, &mut w.f0);
        self.stats.rhs_evals += 1;
        if !all_finite(&w.f0) {
            return Err(OdeError::NonFinite { t });
        }
        // A restart (no step proposed) begins at the step the error of the first step after the
        // previous restart called for; the first start of all at the estimate from (t, y).
        let mut restarting = false;
        let mut h = match self.h_next {
            Some(h) if h > 0.0 && h.is_finite() => h,
            _ => {
                restarting = true;
                if self.h_restart > 0.0 {
                    self.h_restart
                } else {
                    self.initial_step(y, &w.f0)
                }
            }
        };
        h = h.min(self.h_max());
        let mut need_jac = true;
        let mut attempts: u64 = 0;
        let mut last_rejected = false;
        let mut nonfinite_trials: u32 = 0;
        let q = 1.0 / tab.err_order as f64;

        loop {
            let remaining = t1 - t;
            // Smallest meaningful step: the resolution of t (a step below it cannot advance t).
            let hmin = (16.0 * f64::EPSILON * t.abs()).max(f64::MIN_POSITIVE);
            if remaining <= hmin {
                // Span below the resolution of t: one explicit Euler step is exact to rounding.
                axpy(remaining, &w.f0, y);
                if !all_finite(y) {
                    return Err(OdeError::NonFinite { t });
                }
                return Ok(t1);
            }
            if attempts >= self.max_steps {
                return Err(OdeError::TooManySteps { t });
            }
            attempts += 1;
            // Land exactly on t1 (stretch by up to 1 % rather than leave a sliver).
            let h_proposed = h;
            let last = t + 1.01 * h >= t1;
            if last {
                h = remaining;
            }
            if h < hmin || !h.is_finite() {
                return Err(OdeError::StepSizeTooSmall { t, h });
            }

            if need_jac {
                if !self.jacobian(sys, w, t, y) {
                    return Err(OdeError::NonFinite { t });
                }
                need_jac = false;
            }

            // W = I/(h gamma) - J, LU of its leading m x m block in place (the quadrature rows
            // below it are solved by substitution in `stages`).
            let inv_hg = 1.0 / (h * tab.gamma);
            form_w(w.jac.as_slice(), inv_hg, n, m, &mut w.w);
            self.stats.lu_decomps += 1;
            let ok = lu_in_place(&mut w.w, m, &mut w.piv, &mut w.dinv)
                && self.stages(sys, tab, w, t, h, y);
            if !ok {
                // Singular W or a NaN/inf in a stage: retry with a much smaller step.
                self.stats.rejected += 1;
                nonfinite_trials += 1;
                if nonfinite_trials > MAX_NONFINITE_TRIALS {
                    return Err(OdeError::NonFinite { t });
                }
                h *= FAC_FAIL;
                last_rejected = true;
                continue;
            }
            nonfinite_trials = 0;

            // Error estimate: the last stage, scaled RMS norm.
            let ks = &w.k[(tab.stages - 1) * n..tab.stages * n];
            let mut sum = 0.0;
            for i in 0..n {
                let sc = self.atol[i] + self.rtol * y[i].abs().max(w.ynew[i].abs());
                let e = ks[i] / sc;
                sum += e * e;
            }
            let err = (sum / n as f64).sqrt();
            // err may be NaN (0/0 with zero tolerances): treat as too large.
            let fac = if err.is_finite() {
                (math::pow(err, q) / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN)
            } else {
                1.0 / FAC_MIN
            };
            let mut h_new = h / fac;

            if err <= 1.0 {
                // Accepted.
                if self.h_acc > 0.0 {
                    // Gustafsson predictive controller (Hairer-Wanner II, IV.8, (8.21)).
                    let fac_g = ((self.h_acc / h) * math::pow(err * err / self.err_acc, q)
                        / SAFETY)
                        .clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
                    if fac_g.is_finite() {
                        h_new = h / fac.max(fac_g);
                    }
                }
                if restarting {
                    // What the elementary controller proposes after this step (growth capped).
                    self.h_restart = h / fac;
                    restarting = false;
                }
                self.h_acc = h;
                self.err_acc = err.max(1e-2);
                if last_rejected {
                    h_new = h_new.min(h);
                }
                last_rejected = false;
                self.stats.steps += 1;
                y.copy_from_slice(&w.ynew);
                t = if last { t1 } else { t + h };
                let stop = observe(t, y);
                if last {
                    // Do not let a final step shortened to hit t1 shrink the next call's
                    // first step: the controller proposed h_proposed before shortening.
                    if h < h_proposed {
                        h_new = h_new.max(h_proposed);
                    }
                    self.h_next = Some(h_new.min(self.h_max()));
                    return Ok(t1);
                }
                if stop {
                    self.h_next = Some(h_new.min(self.h_max()));
                    return Ok(t);
                }
                sys.rhs(t, y, &mut w.f0);
                self.stats.rhs_evals += 1;
                if !all_finite(&w.f0) {
                    return Err(OdeError::NonFinite { t });
                }
                need_jac = true;
                h = h_new.min(self.h_max());
                self.h_next = Some(h);
            } else {
                // Rejected: same point, keep J, f0, df/dt.
                self.stats.rejected += 1;
                h = h_new;
                last_rejected = true;
            }
        }
    }

    /// Initial step: `0.01 * ||y|| / ||f||` in the error norm (Hairer-Wanner I, II.4), 1e-6
    /// when either is tiny.
    fn initial_step(&self, y: &[f64], f0: &[f64]) -> f64 {
        let n = y.len() as f64;
        let (mut d0, mut d1) = (0.0, 0.0);
        for i in 0..y.len() {
            let sc = self.atol[i] + self.rtol * y[i].abs();
            let (ys, fs) = (y[i] / sc, f0[i] / sc);
            d0 += ys * ys;
            d1 += fs * fs;
        }
        let (d0, d1) = ((d0 / n).sqrt(), (d1 / n).sqrt());
        let h = if d0 < 1e-5 || d1 < 1e-5 || !d0.is_finite() || !d1.is_finite() {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h.max(1e-12)
    }

    /// Jacobian and `df/dt` at `(t, y)` (f0 = f(t, y) already in `w.f0`). Returns false if a value
    /// is not finite.
    fn jacobian<S: OdeSystem>(&mut self, sys: &S, w: &mut Work, t: f64, y: &[f64]) -> bool {
        let n = y.len();
        self.stats.jac_evals += 1;
        if !sys.jacobian(t, y, &mut w.jac) {
            // Forward differences, increment sqrt(eps) * max(|y_j|, atol_j / rtol).
            self.stats.fd_jacobians += 1;
            w.ytmp.copy_from_slice(y);
            let sqrt_eps = f64::EPSILON.sqrt();
            for (j, &yj) in y.iter().enumerate() {
                let typ = if self.rtol > 0.0 {
                    self.atol[j] / self.rtol
                } else {
                    self.atol[j]
                };
                let mut scale = yj.abs().max(typ);
                if !(scale > 0.0 && scale.is_finite()) {
                    scale = 1e-5;
                }
                w.ytmp[j] = yj + sqrt_eps * scale;
                let delta = w.ytmp[j] - yj; // exactly representable increment
                sys.rhs(t, &w.ytmp, &mut w.fu);
                self.stats.rhs_evals += 1;
                for i in 0..n {
                    w.jac[(i, j)] = (w.fu[i] - w.f0[i]) / delta;
                }
                w.ytmp[j] = yj;
            }
        }
        if w.jac.iter().any(|v| !v.is_finite()) {
            return false;
        }
        if sys.autonomous() {
            w.dfdt.iter_mut().for_each(|v| *v = 0.0);
        } else {
            let dt = (f64::EPSILON * t.abs().max(1e-5)).sqrt();
            let t_dt = t + dt;
            let dt = t_dt - t;
            sys.rhs(t_dt, y, &mut w.fu);
            self.stats.rhs_evals += 1;
            for i in 0..n {
                w.dfdt[i] = (w.fu[i] - w.f0[i]) / dt;
            }
            if !all_finite(&w.dfdt) {
                return false;
            }
        }
        true
    }

    /// All stages of one Rosenbrock step of size `h` from `(t, y)`; result in `w.ynew`, stage
    /// increments in `w.k`. Returns false if a stage value is not finite.
    fn stages<S: OdeSystem>(
        &mut self,
        sys: &S,
        tab: &Tableau,
        w: &mut Work,
        t: f64,
        h: f64,
        y: &[f64],
    ) -> bool {
        let n = y.len();
        let m = implicit_dim(sys, n);
        let inv_h = 1.0 / h;
        let hg = h * tab.gamma;
        for s in 0..tab.stages {
            // Stage argument u = y + sum_j a_sj k_j and rhs f(t + c_s h, u).
            if s == 0 {
                w.b.copy_from_slice(&w.f0);
            } else {
                w.u.copy_from_slice(y);
                for (j, &a) in tab.a[s].iter().enumerate() {
                    if a != 0.0 {
                        axpy(a, &w.k[j * n..(j + 1) * n], &mut w.u);
                    }
                }
                sys.rhs(t + tab.c[s] * h, &w.u, &mut w.b);
                self.stats.rhs_evals += 1;
            }
            // + d_s h df/dt + sum_j (C_sj / h) k_j
            let dh = tab.d[s] * h;
            let b = w.b.as_mut_slice();
            if dh != 0.0 {
                axpy(dh, &w.dfdt, b);
            }
            for (j, &c) in tab.cc[s].iter().enumerate() {
                axpy(c * inv_h, &w.k[j * n..(j + 1) * n], b);
            }
            // A non-finite right-hand side gives a non-finite solution (the solve propagates
            // NaN/inf to every component), and every later stage adds every earlier increment
            // through the C_sj sum (a zero coefficient included: 0 * NaN = NaN), so a non-finite
            // value anywhere reaches the last stage: one check there covers all stages.
            lu_solve(&w.w, m, &w.piv, &w.dinv, &mut b[..m]);
            // Quadrature rows of W k = b: k_i / (h gamma) - sum_{j<m} J_ij k_j = b_i.
            let jac = w.jac.as_slice();
            for i in m..n {
                let mut acc = b[i];
                for j in 0..m {
                    acc += jac[i + j * n] * b[j];
                }
                b[i] = hg * acc;
            }
            if s + 1 == tab.stages && !all_finite(b) {
                return false;
            }
            w.k[s * n..(s + 1) * n].copy_from_slice(b);
        }
        w.ynew.copy_from_slice(y);
        for (j, &bj) in tab.b.iter().enumerate() {
            axpy(bj, &w.k[j * n..(j + 1) * n], &mut w.ynew);
        }
        all_finite(&w.ynew)
    }
}

/// Work buffers, sized lazily for the system dimension; not part of the serialized state.
#[derive(Clone, Default)]
struct Work {
    n: usize,
    stages: usize,
    f0: Vec<f64>,
    fu: Vec<f64>,
    dfdt: Vec<f64>,
    u: Vec<f64>,
    ynew: Vec<f64>,
    ytmp: Vec<f64>,
    /// Stage increments k_0..k_{s-1}, stage-major (`k[s*n + i]`).
    k: Vec<f64>,
    jac: DMatrix<f64>,
    /// W and then its LU factors, column-major (`w[i + j*n]`).
    w: Vec<f64>,
    piv: Vec<usize>,
    /// Reciprocals of the diagonal of U.
    dinv: Vec<f64>,
    b: Vec<f64>,
}

impl std::fmt::Debug for Work {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Work {{ n: {}, stages: {} }}", self.n, self.stages)
    }
}

impl Work {
    /// (Re)allocate the buffers if the dimension or stage count changed.
    fn ensure(&mut self, n: usize, stages: usize) {
        if self.n == n && self.stages == stages && self.f0.len() == n {
            return;
        }
        *self = Work {
            n,
            stages,
            f0: vec![0.0; n],
            fu: vec![0.0; n],
            dfdt: vec![0.0; n],
            u: vec![0.0; n],
            ynew: vec![0.0; n],
            ytmp: vec![0.0; n],
            k: vec![0.0; n * stages],
            jac: DMatrix::zeros(n, n),
            w: vec![0.0; n * n],
            piv: vec![0; n],
            dinv: vec![0.0; n],
            b: vec![0.0; n],
        };
    }
}

/// Number of leading non-quadrature states of an `n`-state system (the block of `W` that is
/// decomposed; see [`OdeSystem::quadratures`]).
fn implicit_dim<S: OdeSystem>(sys: &S, n: usize) -> usize {
    n - sys.quadratures().min(n)
}

/// `y += a * x` (equal lengths).
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// True when every value is finite. Branch-free (an integer max over the exponent bits, which the
/// compiler vectorises): a value is NaN or infinite exactly when its exponent bits are all ones.
fn all_finite(v: &[f64]) -> bool {
    const EXP: u64 = 0x7ff0_0000_0000_0000;
    v.iter().fold(0u64, |m, x| m.max(x.to_bits() & EXP)) != EXP
}

/// Call `f(a, n, b...)` with `n` a compile-time constant for the small dimensions of the actuator
/// models (fully unrolled loops without remainder handling), otherwise with the runtime `n`. Up
/// to 18: the largest state vector of a model, HydraulicJoint's in Model Exchange, which the
/// host integrates. The constant changes no operation or its order, only the code around them.
macro_rules! specialise {
    ($n:expr, $f:ident($a:expr $(, $rest:expr)*)) => {
        match $n {
            4 => $f($a, 4 $(, $rest)*),
            5 => $f($a, 5 $(, $rest)*),
            6 => $f($a, 6 $(, $rest)*),
            7 => $f($a, 7 $(, $rest)*),
            8 => $f($a, 8 $(, $rest)*),
            9 => $f($a, 9 $(, $rest)*),
            10 => $f($a, 10 $(, $rest)*),
            11 => $f($a, 11 $(, $rest)*),
            12 => $f($a, 12 $(, $rest)*),
            13 => $f($a, 13 $(, $rest)*),
            14 => $f($a, 14 $(, $rest)*),
            15 => $f($a, 15 $(, $rest)*),
            16 => $f($a, 16 $(, $rest)*),
            17 => $f($a, 17 $(, $rest)*),
            18 => $f($a, 18 $(, $rest)*),
            n => $f($a, n $(, $rest)*),
        }
    };
}

/// The leading `m x m` block of `W = I/(h gamma) - J` (J column-major n x n) into the
/// column-major `w` (m x m).
fn form_w(jac: &[f64], inv_hg: f64, n: usize, m: usize, w: &mut [f64]) {
    let w = &mut w[..m * m];
    for (wc, jc) in w.chunks_exact_mut(m).zip(jac.chunks_exact(n)) {
        for (wi, &v) in wc.iter_mut().zip(&jc[..m]) {
            *wi = -v;
        }
    }
    for i in 0..m {
        w[i * m + i] += inv_hg;
    }
}

/// LU decomposition with partial pivoting in place (Golub & Van Loan, Algorithm 3.4.1, row
/// interchanges applied to whole rows as in LAPACK `dgetf2`) of the column-major n x n matrix `m`
/// (`m[i + j*n]`): afterwards the strict lower triangle holds the unit-lower factor L, the upper
/// triangle U, `dinv[i] = 1 / U_ii`, and `piv[i]` is the row swapped with row `i` at step `i`.
/// Every inner loop is a contiguous column update. Returns false for a zero or non-finite pivot.
fn lu_in_place(m: &mut [f64], n: usize, piv: &mut [usize], dinv: &mut [f64]) -> bool {
    specialise!(n, lu_in_place_n(m, piv, dinv))
}

/// Body of [`lu_in_place`]; inlined into [`specialise!`] so small `n` become constants.
#[inline(always)]
fn lu_in_place_n(m: &mut [f64], n: usize, piv: &mut [usize], dinv: &mut [f64]) -> bool {
    let m = &mut m[..n * n];
    let (piv, dinv) = (&mut piv[..n], &mut dinv[..n]);
    for i in 0..n {
        // Pivot: largest |m[r, i]| for r >= i (first one on ties).
        let col = &m[i * n..(i + 1) * n];
        let mut p = i;
        let mut best = col[i].abs();
        for (r, v) in col.iter().enumerate().skip(i + 1) {
            if v.abs() > best {
                best = v.abs();
                p = r;
            }
        }
        let diag = col[p];
        if diag == 0.0 || !diag.is_finite() {
            return false;
        }
        piv[i] = p;
        if p != i {
            for c in m.chunks_exact_mut(n) {
                c.swap(i, p);
            }
        }
        let inv = 1.0 / diag;
        dinv[i] = inv;
        let (left, right) = m.split_at_mut((i + 1) * n);
        let l = &mut left[i * n + i + 1..];
        for x in l.iter_mut() {
            *x *= inv;
        }
        for c in right.chunks_exact_mut(n) {
            let u = c[i];
            for (x, &li) in c[i + 1..].iter_mut().zip(l.iter()) {
                *x -= u * li;
            }
        }
    }
    true
}

/// Solve `LU x = P b` in place (factors from [`lu_in_place`]): row interchanges, forward
/// substitution with the unit-lower L, back substitution with U, both column-oriented (axpy).
fn lu_solve(lu: &[f64], n: usize, piv: &[usize], dinv: &[f64], b: &mut [f64]) {
    specialise!(n, lu_solve_n(lu, piv, dinv, b))
}

/// Body of [`lu_solve`]; inlined into [`specialise!`] so small `n` become constants.
#[inline(always)]
fn lu_solve_n(lu: &[f64], n: usize, piv: &[usize], dinv: &[f64], b: &mut [f64]) {
    let lu = &lu[..n * n];
    let (b, dinv) = (&mut b[..n], &dinv[..n]);
    for (i, &p) in piv[..n].iter().enumerate() {
        if p != i {
            b.swap(i, p);
        }
    }
    for (i, col) in lu.chunks_exact(n).enumerate() {
        let (head, tail) = b.split_at_mut(i + 1);
        let xi = head[i];
        for (x, &l) in tail.iter_mut().zip(&col[i + 1..]) {
            *x -= xi * l;
        }
    }
    for (i, col) in lu.chunks_exact(n).enumerate().rev() {
        let (head, tail) = b.split_at_mut(i);
        let xi = tail[0] * dinv[i];
        tail[0] = xi;
        for (x, &u) in head.iter_mut().zip(&col[..i]) {
            *x -= xi * u;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{all_finite, lu_in_place, lu_solve};
    use nalgebra::DMatrix;

    #[test]
    fn lu_matches_nalgebra() {
        use nalgebra::DVector;
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 1.0, 4.0, -1.0, 3.0, 2.0, 5.0, -7.0]);
        let rhs = DVector::from_vec(vec![1.0, -2.0, 3.0]);
        let expected = a.clone().lu().solve(&rhs).unwrap();
        let mut m = a.as_slice().to_vec(); // column-major
        let mut piv = vec![0; 3];
        let mut dinv = vec![0.0; 3];
        assert!(lu_in_place(&mut m, 3, &mut piv, &mut dinv));
        let mut x = rhs.clone();
        lu_solve(&m, 3, &piv, &dinv, x.as_mut_slice());
        for i in 0..3 {
            assert!((x[i] - expected[i]).abs() < 1e-14, "{x} vs {expected}");
        }
        let r = &a * &x - &rhs;
        assert!(r.norm() < 1e-13);
        let mut sing = vec![1.0, 2.0, 2.0, 4.0];
        assert!(!lu_in_place(&mut sing, 2, &mut piv[..2], &mut dinv[..2]));
        let mut nan = vec![f64::NAN, 1.0, 1.0, 1.0];
        assert!(!lu_in_place(&mut nan, 2, &mut piv[..2], &mut dinv[..2]));
        assert!(all_finite(&[1.0, -0.0, f64::MAX, f64::MIN_POSITIVE]));
        assert!(!all_finite(&[1.0, f64::NAN]));
        assert!(!all_finite(&[f64::NEG_INFINITY, 1.0]));
    }
}
