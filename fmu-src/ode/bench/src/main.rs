//! Accuracy vs work: `ode` (Rodas5P, Rodas4) against `differential-equations` 0.6 (Radau IIA
//! order 5 `radau5`, and its adaptive BDF) on the crate's test problems.
//! Run from the repository root (see fmu-src/ode/README.md):
//!   CARGO_TARGET_DIR=target/ode-bench cargo run --release --manifest-path fmu-src/ode/bench/Cargo.toml
//! Every rhs call (including finite-difference Jacobian columns) is counted by a wrapper, so the
//! "rhs" column is comparable between the libraries.

#[path = "../../tests/problems/mod.rs"]
#[allow(dead_code)]
mod problems;

use differential_equations::prelude::{
    BackwardDifferentiationFormula, ImplicitRungeKutta, Matrix as DeMatrix, IVP, ODE,
};
use ode::{Integrator, Method, OdeSystem};
use problems::*;
use std::cell::Cell;
use std::time::Instant;

/// Wraps an `OdeSystem` as a `differential_equations::ODE` on `[f64; N]`, counting rhs calls.
struct De<'a, S: OdeSystem, const N: usize> {
    sys: &'a S,
    analytic: bool,
    calls: Cell<u64>,
}

impl<S: OdeSystem, const N: usize> ODE<f64, [f64; N]> for De<'_, S, N> {
    fn diff(&self, t: f64, y: &[f64; N], dydt: &mut [f64; N]) {
        self.calls.set(self.calls.get() + 1);
        self.sys.rhs(t, y, dydt);
    }
    fn jacobian(&self, t: f64, y: &[f64; N], j: &mut DeMatrix<f64>) {
        let mut m = nalgebra::DMatrix::zeros(N, N);
        if self.analytic && self.sys.jacobian(t, y, &mut m) {
            for r in 0..N {
                for c in 0..N {
                    j[(r, c)] = m[(r, c)];
                }
            }
        } else {
            // Same forward differences as the library default, counted.
            let mut f0 = [0.0; N];
            self.diff(t, y, &mut f0);
            for c in 0..N {
                let mut yp = *y;
                let d = f64::EPSILON.sqrt() * y[c].abs().max(1.0);
                yp[c] += d;
                let mut f1 = [0.0; N];
                self.diff(t, &yp, &mut f1);
                for r in 0..N {
                    j[(r, c)] = (f1[r] - f0[r]) / d;
                }
            }
        }
    }
}

/// Counts rhs calls of our integrator too (the stats also do; this cross-checks them).
struct Counted<'a, S: OdeSystem> {
    sys: &'a S,
    calls: Cell<u64>,
}

impl<S: OdeSystem> OdeSystem for Counted<'_, S> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }
    fn rhs(&self, t: f64, y: &[f64], d: &mut [f64]) {
        self.calls.set(self.calls.get() + 1);
        self.sys.rhs(t, y, d)
    }
    fn jacobian(&self, t: f64, y: &[f64], j: &mut nalgebra::DMatrix<f64>) -> bool {
        self.sys.jacobian(t, y, j)
    }
    fn autonomous(&self) -> bool {
        self.sys.autonomous()
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Solver {
    Ours(Method),
    Radau5,
    Bdf,
}

impl Solver {
    fn name(self) -> &'static str {
        match self {
            Solver::Ours(Method::Rodas5P) => "ode Rodas5P",
            Solver::Ours(Method::Rodas4) => "ode Rodas4",
            Solver::Radau5 => "diffeq radau5",
            Solver::Bdf => "diffeq BDF",
        }
    }
}

struct Outcome {
    y: Vec<f64>,
    rhs: u64,
    steps: u64,
    jac: u64,
    lu: u64,
    secs: f64,
    err: Option<String>,
}

/// Solve from t0 to t1 in `segments` equal calls (1 = one call), timing the whole run.
fn run<S: OdeSystem, const N: usize>(
    solver: Solver,
    sys: &S,
    analytic: bool,
    y0: [f64; N],
    t1: f64,
    segments: usize,
    rtol: f64,
    atol: &[f64],
) -> Outcome {
    // Wall time: the minimum over repetitions (robust against other load on the machine).
    let reps_budget = 0.3; // seconds of repetitions for the timing
    let mut reps = 0u32;
    let start = Instant::now();
    let mut best = f64::INFINITY;
    let mut last = None;
    while reps < 3 || (start.elapsed().as_secs_f64() < reps_budget && reps < 200) {
        reps += 1;
        let t_rep = Instant::now();
        let mut y = y0;
        let rhs;
        let mut steps = 0;
        let (mut jac, mut lu) = (0, 0);
        let mut failure = None;
        match solver {
            Solver::Ours(m) => {
                let c = Counted { sys, calls: Cell::new(0) };
                let mut ig = Integrator::new(rtol, atol.to_vec()).with_method(m);
                ig.set_max_steps(1_000_000);
                for k in 0..segments {
                    let ta = t1 * k as f64 / segments as f64;
                    let tb = t1 * (k + 1) as f64 / segments as f64;
                    if let Err(e) = ig.integrate(&c, ta, tb, &mut y) {
                        failure = Some(e.to_string());
                        break;
                    }
                }
                assert_eq!(c.calls.get(), ig.stats().rhs_evals, "stats count rhs calls");
                rhs = c.calls.get();
                steps = ig.stats().steps;
                jac = ig.stats().jac_evals;
                lu = ig.stats().lu_decomps;
            }
            Solver::Radau5 | Solver::Bdf => {
                let de: De<S, N> = De { sys, analytic, calls: Cell::new(0) };
                for k in 0..segments {
                    let ta = t1 * k as f64 / segments as f64;
                    let tb = t1 * (k + 1) as f64 / segments as f64;
                    let r = if solver == Solver::Radau5 {
                        let method = ImplicitRungeKutta::radau5()
                            .rtol(rtol)
                            .atol(atol.to_vec())
                            .max_steps(10_000_000);
                        IVP::ode(&de, ta, tb, y).method(method).solve()
                    } else {
                        let method = BackwardDifferentiationFormula::adaptive()
                            .rtol(rtol)
                            .atol(atol.to_vec())
                            .max_steps(10_000_000);
                        IVP::ode(&de, ta, tb, y).method(method).solve()
                    };
                    match r {
                        Ok(sol) => {
                            steps += sol.steps.accepted as u64;
                            jac += sol.evals.jacobian as u64;
                            lu += sol.evals.decompositions as u64;
                            y = *sol.y.last().unwrap();
                        }
                        Err(e) => {
                            let msg = format!("{e:?}");
                            failure = Some(msg.chars().take(60).collect());
                            break;
                        }
                    }
                }
                rhs = de.calls.get();
            }
        }
        best = best.min(t_rep.elapsed().as_secs_f64());
        last = Some((y, rhs, steps, jac, lu, failure));
    }
    let (y, rhs, steps, jac, lu, err) = last.unwrap();
    Outcome { y: y.to_vec(), rhs, steps, jac, lu, secs: best, err }
}

fn reference(key: &str) -> Vec<f64> {
    let v: serde_json::Value =
        serde_json::from_str(include_str!("../../tests/data/reference.json")).unwrap();
    let e = &v[key];
    let src = if e["published"].is_array() { "published" } else { "scipy" };
    e[src].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

#[allow(clippy::too_many_arguments)]
fn table<S: OdeSystem, const N: usize>(
    title: &str,
    sys: &S,
    analytic: bool,
    y0: [f64; N],
    t1: f64,
    segments: usize,
    nominal: &[f64],
    reference: &[f64],
    tols: &[f64],
    solvers: &[Solver],
) {
    println!("\n### {title}\n");
    println!("| solver | rtol | scaled error | rhs evals | Jacobians | LU | steps | time (ms) |");
    println!("|---|---|---|---|---|---|---|---|");
    for &tol in tols {
        let atol: Vec<f64> = nominal.iter().map(|s| tol * s).collect();
        for &solver in solvers {
            let o = run(solver, sys, analytic, y0, t1, segments, tol, &atol);
            let err = match &o.err {
                Some(msg) => format!("failed: {}", msg.replace('|', "/")),
                None => format!("{:.1e}", scaled_err(&o.y, reference, nominal)),
            };
            println!(
                "| {} | {tol:.0e} | {err} | {} | {} | {} | {} | {:.3} |",
                solver.name(),
                o.rhs,
                o.jac,
                o.lu,
                o.steps,
                o.secs * 1e3
            );
        }
    }
}

fn main() {
    let all = [
        Solver::Ours(Method::Rodas5P),
        Solver::Ours(Method::Rodas4),
        Solver::Radau5,
        Solver::Bdf,
    ];
    let tols = [1e-3, 1e-5, 1e-7, 1e-9];
    // Scaled error: max_i |y_i - ref_i| / nominal_i (nominal = |ref| floor for the classic problems).
    let vdp_ref = reference("vdp_mu1000_t2000");
    table(
        "Van der Pol mu = 1000, t in [0, 2000], analytic Jacobian (reference: IVP test set VDPOL)",
        &VanDerPol { mu: 1000.0, analytic: true },
        true,
        [2.0, 0.0],
        2000.0,
        1,
        &[1.0, 1e-3],
        &vdp_ref,
        &tols,
        &all,
    );
    let rob_ref = reference("robertson_t1e+11");
    table(
        "Robertson, t in [0, 1e11], analytic Jacobian (reference: IVP test set ROBER)",
        &Robertson { analytic: true },
        true,
        [1.0, 0.0, 0.0],
        1e11,
        1,
        &[1.0, 1e-4, 1.0],
        &rob_ref,
        &tols,
        &all,
    );
    let hyd_ref = reference("hydraulic_sine_f2_t0.5");
    table(
        "Hydraulic cylinder (stiff, orifice, sine spool), t in [0, 0.5], finite-difference Jacobian",
        &Hydraulic { square: false, freq: 2.0 },
        false,
        HYD_Y0,
        0.5,
        1,
        &HYD_NOMINAL,
        &hyd_ref,
        &tols,
        &all,
    );
    let dc_ref = reference("dcmotor_sine_t0.5");
    table(
        "DC motor (L/R = 0.1 ms, tanh friction), t in [0, 0.5], analytic Jacobian",
        &DcMotor { amp: 12.0, freq: 5.0, held: None, analytic: true },
        true,
        [0.0; 3],
        0.5,
        1,
        &DC_NOMINAL,
        &dc_ref,
        &tols,
        &all,
    );
    let sq_ref = reference("hydraulic_square_f0.8_t2.2");
    table(
        "FMU use: hydraulic, square-wave spool into both end stops, 2200 calls of 1 ms (t in [0, 2.2]), FD Jacobian",
        &Hydraulic { square: true, freq: 0.8 },
        false,
        HYD_Y0,
        2.2,
        2200,
        &HYD_NOMINAL,
        &sq_ref,
        &[1e-4, 1e-6, 1e-8],
        &all,
    );
}
