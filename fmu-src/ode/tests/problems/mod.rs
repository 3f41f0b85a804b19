//! Test problems shared by the integration tests and the benchmark (`bench/`).
//! The same equations are written in `scripts/reference.py`, which computes the SciPy reference
//! values stored in `tests/data/reference.json`.
// Closed-form references use the platform libm, independent of the `libm` crate the solver
// uses (workspace clippy.toml).
#![allow(clippy::disallowed_methods)]
#![allow(dead_code)]

use nalgebra::DMatrix;
use ode::OdeSystem;

/// Dahlquist test equation `y' = -k y`, exact solution `y0 exp(-k t)`.
pub struct Dahlquist {
    pub k: f64,
}

impl OdeSystem for Dahlquist {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt[0] = -self.k * y[0];
    }
    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut DMatrix<f64>) -> bool {
        jac[(0, 0)] = -self.k;
        true
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Prothero-Robinson-type forced problem `y' = -k (y - cos t)`; exact solution
/// `y = k^2/(k^2+1) (cos t + sin(t)/k) + (y0 - k^2/(k^2+1)) exp(-k t)`.
/// Tests the `d_i h df/dt` terms (non-autonomous rhs). `analytic` selects the Jacobian path.
pub struct Forced {
    pub k: f64,
    pub analytic: bool,
}

impl Forced {
    pub fn exact(&self, y0: f64, t: f64) -> f64 {
        let k = self.k;
        let a = k * k / (k * k + 1.0);
        a * (t.cos() + t.sin() / k) + (y0 - a) * (-k * t).exp()
    }
}

impl OdeSystem for Forced {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt[0] = -self.k * (y[0] - t.cos());
    }
    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut DMatrix<f64>) -> bool {
        jac[(0, 0)] = -self.k;
        self.analytic
    }
}

/// Van der Pol oscillator, unscaled: `y1' = y2`, `y2' = mu (1 - y1^2) y2 - y1`
/// (`y1'' - mu (1 - y1^2) y1' + y1 = 0`).
pub struct VanDerPol {
    pub mu: f64,
    pub analytic: bool,
}

impl OdeSystem for VanDerPol {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt[0] = y[1];
        dydt[1] = self.mu * (1.0 - y[0] * y[0]) * y[1] - y[0];
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut DMatrix<f64>) -> bool {
        jac[(0, 0)] = 0.0;
        jac[(0, 1)] = 1.0;
        jac[(1, 0)] = -2.0 * self.mu * y[0] * y[1] - 1.0;
        jac[(1, 1)] = self.mu * (1.0 - y[0] * y[0]);
        self.analytic
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Van der Pol in the scaled form of the IVP test set (Mazzia & Magherini, problem VDPOL):
/// `y1' = y2`, `y2' = ((1 - y1^2) y2 - y1) / eps`, eps = 1e-6, t in [0, 2], y0 = (2, 0).
pub struct VanDerPolScaled {
    pub eps: f64,
}

impl OdeSystem for VanDerPolScaled {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        dydt[0] = y[1];
        dydt[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / self.eps;
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut DMatrix<f64>) -> bool {
        jac[(0, 0)] = 0.0;
        jac[(0, 1)] = 1.0;
        jac[(1, 0)] = (-2.0 * y[0] * y[1] - 1.0) / self.eps;
        jac[(1, 1)] = (1.0 - y[0] * y[0]) / self.eps;
        true
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Robertson chemical kinetics (Hairer & Wanner II, eq. IV.1.3; IVP test set ROBER).
pub struct Robertson {
    pub analytic: bool,
}

impl OdeSystem for Robertson {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        let r1 = 0.04 * y[0];
        let r2 = 1e4 * y[1] * y[2];
        let r3 = 3e7 * y[1] * y[1];
        dydt[0] = -r1 + r2;
        dydt[1] = r1 - r2 - r3;
        dydt[2] = r3;
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut DMatrix<f64>) -> bool {
        j[(0, 0)] = -0.04;
        j[(0, 1)] = 1e4 * y[2];
        j[(0, 2)] = 1e4 * y[1];
        j[(1, 0)] = 0.04;
        j[(1, 1)] = -1e4 * y[2] - 6e7 * y[1];
        j[(1, 2)] = -1e4 * y[1];
        j[(2, 0)] = 0.0;
        j[(2, 1)] = 6e7 * y[1];
        j[(2, 2)] = 0.0;
        self.analytic
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Hydraulic cylinder driven by a 4/3 servo valve (stand-in for the HydraulicJoint chambers):
/// states `[x (m), v (m/s), pA (Pa), pB (Pa)]`.
///
/// ```text
/// x' = v
/// v' = (A (pA - pB) - b v + F_stop(x, v)) / m
/// pA' = beta / (V0 + A x)       (QA - A v)
/// pB' = beta / (V0 + A (L - x)) (QB + A v)
/// QA = Kv (u+ sq(ps - pA) - u- sq(pA - pt)),  QB = Kv (u- sq(ps - pB) - u+ sq(pB - pt))
/// sq(dp) = dp / (dp^2 + dp_lam^2)^(1/4)    (turbulent orifice sign(dp) sqrt|dp|, laminar near 0)
/// F_stop = k_c max(-x, 0) - k_c max(x - L, 0) - d_c v [x < 0 or x > L]   (penalty end stops)
/// ```
/// Spool `u(t) = sin(2 pi f t)` (`square = false`) or the discontinuous `sign(sin(2 pi f t))`.
/// Stiffness: beta / V0 * Kv / sqrt(dp_lam) = 4e4 1/s, end stop k_c / m = 1e7 1/s^2.
pub struct Hydraulic {
    pub square: bool,
    pub freq: f64,
}

pub const HYD_M: f64 = 10.0;
pub const HYD_A: f64 = 5e-4;
pub const HYD_L: f64 = 0.1;
pub const HYD_V0: f64 = 1e-5;
pub const HYD_BETA: f64 = 1e9;
pub const HYD_PS: f64 = 1e7;
pub const HYD_PT: f64 = 1e5;
pub const HYD_KV: f64 = 4e-8;
pub const HYD_DPLAM: f64 = 1e4;
pub const HYD_B: f64 = 200.0;
pub const HYD_KC: f64 = 1e8;
pub const HYD_DC: f64 = 1e4;
pub const HYD_Y0: [f64; 4] = [0.05, 0.0, 5e6, 5e6];

impl Hydraulic {
    pub fn spool(&self, t: f64) -> f64 {
        let s = (2.0 * std::f64::consts::PI * self.freq * t).sin();
        if self.square {
            if s > 0.0 {
                1.0
            } else if s < 0.0 {
                -1.0
            } else {
                0.0
            }
        } else {
            s
        }
    }
}

fn sq(dp: f64) -> f64 {
    dp / (dp * dp + HYD_DPLAM * HYD_DPLAM).powf(0.25)
}

pub fn hydraulic_rhs(u: f64, y: &[f64], dydt: &mut [f64]) {
    let (x, v, pa, pb) = (y[0], y[1], y[2], y[3]);
    let up = u.max(0.0);
    let um = (-u).max(0.0);
    let qa = HYD_KV * (up * sq(HYD_PS - pa) - um * sq(pa - HYD_PT));
    let qb = HYD_KV * (um * sq(HYD_PS - pb) - up * sq(pb - HYD_PT));
    let mut f_stop = HYD_KC * (-x).max(0.0) - HYD_KC * (x - HYD_L).max(0.0);
    if !(0.0..=HYD_L).contains(&x) {
        f_stop -= HYD_DC * v;
    }
    dydt[0] = v;
    dydt[1] = (HYD_A * (pa - pb) - HYD_B * v + f_stop) / HYD_M;
    dydt[2] = HYD_BETA / (HYD_V0 + HYD_A * x) * (qa - HYD_A * v);
    dydt[3] = HYD_BETA / (HYD_V0 + HYD_A * (HYD_L - x)) * (qb + HYD_A * v);
}

impl OdeSystem for Hydraulic {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, t: f64, y: &[f64], dydt: &mut [f64]) {
        hydraulic_rhs(self.spool(t), y, dydt);
    }
}

/// Hydraulic cylinder with the spool held constant over the call (as inside fmi2DoStep).
pub struct HydraulicHeld {
    pub u: f64,
}

impl OdeSystem for HydraulicHeld {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, _t: f64, y: &[f64], dydt: &mut [f64]) {
        hydraulic_rhs(self.u, y, dydt);
    }
    fn autonomous(&self) -> bool {
        true
    }
}

/// Absolute tolerance scales (nominal values) of the hydraulic states.
pub const HYD_NOMINAL: [f64; 4] = [0.1, 0.1, 1e7, 1e7];

/// DC motor with regularised Coulomb friction (stand-in for the TwistedString drive):
/// states `[i (A), w (rad/s), theta (rad)]`.
///
/// ```text
/// L i' = V - R i - Ke w
/// J w' = Kt i - b w - tau_c tanh(w / w_s)
/// theta' = w
/// ```
/// Electrical time constant L/R = 0.1 ms; friction stiffness tau_c / (J w_s) = 5e5 1/s.
pub struct DcMotor {
    /// Voltage amplitude (V) of `V(t) = amp sin(2 pi f t)` (when `held` is None).
    pub amp: f64,
    pub freq: f64,
    /// Voltage held constant over the call (controller output), overrides the sine.
    pub held: Option<f64>,
    pub analytic: bool,
}

pub const DC_L: f64 = 1e-4;
pub const DC_R: f64 = 1.0;
pub const DC_K: f64 = 0.05;
pub const DC_J: f64 = 1e-5;
pub const DC_B: f64 = 1e-5;
pub const DC_TAUC: f64 = 5e-3;
pub const DC_WS: f64 = 1e-3;
pub const DC_NOMINAL: [f64; 3] = [10.0, 100.0, 10.0];

impl DcMotor {
    pub fn voltage(&self, t: f64) -> f64 {
        match self.held {
            Some(v) => v,
            None => self.amp * (2.0 * std::f64::consts::PI * self.freq * t).sin(),
        }
    }
}

impl OdeSystem for DcMotor {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let (i, w) = (y[0], y[1]);
        dydt[0] = (self.voltage(t) - DC_R * i - DC_K * w) / DC_L;
        dydt[1] = (DC_K * i - DC_B * w - DC_TAUC * (w / DC_WS).tanh()) / DC_J;
        dydt[2] = w;
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut DMatrix<f64>) -> bool {
        let w = y[1];
        let sech2 = 1.0 - (w / DC_WS).tanh().powi(2);
        j.fill(0.0);
        j[(0, 0)] = -DC_R / DC_L;
        j[(0, 1)] = -DC_K / DC_L;
        j[(1, 0)] = DC_K / DC_J;
        j[(1, 1)] = (-DC_B - DC_TAUC * sech2 / DC_WS) / DC_J;
        j[(2, 1)] = 1.0;
        self.analytic
    }
    fn autonomous(&self) -> bool {
        self.held.is_some()
    }
}

/// Scaled max-norm error `max_i |y_i - ref_i| / (atol_i + rtol |ref_i|)` with the given scales.
pub fn scaled_err(y: &[f64], reference: &[f64], nominal: &[f64]) -> f64 {
    y.iter()
        .zip(reference)
        .zip(nominal)
        .map(|((a, b), s)| (a - b).abs() / s)
        .fold(0.0, f64::max)
}
