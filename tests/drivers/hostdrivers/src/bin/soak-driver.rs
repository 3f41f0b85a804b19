//! Soak run (issue 8, item 6), using the project's `host` crate: `--steps` communication steps of
//! `--h` seconds of one FMU with random piecewise-constant inputs inside their ranges (held for a
//! random 1..500 steps; xorshift64* generator, `--seed`). Every step must return fmi2OK and every
//! Real output must be finite. Balances, where the FMU exposes the needed outputs:
//!
//! - Oscillator (run with damping = 0): mechanical energy, `E = m v^2/2 + k x^2/2` is the output
//!   `energy`; with the force F held over a step, `E(t+h) - E(t) = F (x(t+h) - x(t))` exactly, so
//!   the accumulated residual measures only the solver error.
//! - HydraulicJoint: angular momentum of the link, paper eq. (1),
//!   `I (w_N - w_0) + b (theta_N - theta_0) - sum(tau_ext h) = R * integral (T_left - T_right) dt`
//!   with `I = link_inertia + load_mass load_radius^2`; the tension impulse comes from the
//!   trapezoidal rule on the communication grid, so this closes to the quadrature error O(h^2)
//!   (reported relative to the total impulse R * integral |T_left - T_right| dt).
//! - TwistedString: no balance; its outputs lack the load-side spring and guide forces of the
//!   momentum equation and the motor's electrical energy needs the current at a finer grid.
//!
//! `--bool NAME=0|1` sets a Boolean parameter before initialization (e.g. internal_controller=0
//! drives the valves/motor open loop with the random inputs: end stops, cavitation, saturation).
//!
//! usage: soak-driver [--steps N] [--h H] [--seed S] [--bool NAME=0|1]... FMU

use host::md::{Causality, VarKind};
use host::Fmu;

struct Rng(u64);
impl Rng {
    /// xorshift64* (Vigna 2016), uniform in [0, 1).
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Ranges for inputs the model description leaves unbounded (plausible operating ranges).
fn default_range(model: &str, input: &str) -> (f64, f64) {
    match (model, input) {
        ("HydraulicJoint", "theta_ref") => (-1.2, 1.2),
        ("HydraulicJoint", "tau_ext") => (-3.0, 3.0),
        ("TwistedString", "theta_motor_ref") => (0.0, 800.0),
        ("TwistedString", "F_load") => (-20.0, 20.0),
        ("TwistedString", "voltage") => (-24.0, 24.0),
        ("Oscillator", "force") => (-10.0, 10.0),
        _ => (-1.0, 1.0),
    }
}

fn fail(msg: String) -> ! {
    eprintln!("SOAK FAILED: {msg}");
    std::process::exit(1)
}

fn main() {
    let mut steps = 1_000_000usize;
    let mut h = 1e-3;
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut path = None;
    let mut bools: Vec<(String, bool)> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || {
            args.next()
                .unwrap_or_else(|| fail(format!("{a} needs a value")))
        };
        match a.as_str() {
            "--steps" => steps = val().parse().unwrap_or_else(|_| fail("bad --steps".into())),
            "--h" => h = val().parse().unwrap_or_else(|_| fail("bad --h".into())),
            "--seed" => seed = val().parse().unwrap_or_else(|_| fail("bad --seed".into())),
            "--bool" => {
                let v = val();
                let (n, b) = v
                    .split_once('=')
                    .unwrap_or_else(|| fail(format!("--bool {v}: expected NAME=0|1")));
                bools.push((n.to_string(), b == "1" || b == "true"));
            }
            _ => path = Some(a),
        }
    }
    let path = path
        .unwrap_or_else(|| fail("usage: soak-driver [--steps N] [--h H] [--seed S] FMU".into()));
    let fmu = Fmu::open(&path).unwrap_or_else(|e| fail(format!("cannot open {path}: {e}")));
    let md = fmu.model_description();
    let model = md.model_name.clone();
    let vr = |name: &str| md.variable(name).map(|v| v.value_reference);
    let param = |name: &str| -> f64 {
        md.variable(name)
            .and_then(|v| v.start.as_ref())
            .and_then(|s| s.as_f64())
            .unwrap_or_else(|| fail(format!("no start value for {name}")))
    };
    let inputs: Vec<(u32, f64, f64)> = md
        .model_variables
        .iter()
        .filter(|v| v.causality == Causality::Input && v.kind == VarKind::Real)
        .map(|v| {
            let (lo, hi) = match (v.min, v.max) {
                (Some(lo), Some(hi)) => (lo, hi),
                _ => default_range(&model, &v.name),
            };
            (v.value_reference, lo, hi)
        })
        .collect();
    let out_vars: Vec<&host::md::ScalarVariable> = md
        .model_variables
        .iter()
        .filter(|v| v.causality == Causality::Output && v.kind == VarKind::Real)
        .collect();
    let outs: Vec<u32> = out_vars.iter().map(|v| v.value_reference).collect();
    let pos = |name: &str| out_vars.iter().position(|v| v.name == name);

    let mut inst = fmu
        .instantiate("soak")
        .unwrap_or_else(|e| fail(format!("instantiate: {e}")));
    let e = |what: &str, r: host::Result<host::Status>| match r {
        Ok(host::Status::Ok) => {}
        Ok(s) => fail(format!("{what}: status {s:?}")),
        Err(err) => fail(format!("{what}: {err}")),
    };
    e("setup", inst.setup_experiment(None, 0.0, None));
    e("enter init", inst.enter_initialization_mode());
    for (name, b) in &bools {
        let v = vr(name).unwrap_or_else(|| fail(format!("no variable {name}")));
        e(&format!("set {name}"), inst.set_boolean(&[v], &[*b]));
    }
    if model == "Oscillator" {
        let d = vr("damping").unwrap();
        e("damping = 0", inst.set_real(&[d], &[0.0]));
    }
    e("exit init", inst.exit_initialization_mode());

    let mut rng = Rng(seed.max(1));
    let in_vrs: Vec<u32> = inputs.iter().map(|i| i.0).collect();
    let mut u: Vec<f64> = vec![0.0; inputs.len()];
    let mut hold = 0usize;
    let mut y = vec![0.0; outs.len()];
    let mut y0 = vec![0.0; outs.len()];
    e("get", inst.get_real(&outs, &mut y0));
    let mut prev = y0.clone();

    // balances
    let osc = (pos("energy"), pos("x"), vr("force"));
    let hj = (
        pos("omega"),
        pos("theta"),
        pos("T_left"),
        pos("T_right"),
        vr("tau_ext"),
    );
    let mut osc_residual = 0.0f64;
    let mut osc_scale = 0.0f64;
    let (mut impulse, mut impulse_abs, mut tau_impulse) = (0.0f64, 0.0f64, 0.0f64);
    let mut t_max_abs = vec![0.0f64; outs.len()];
    let started = std::time::Instant::now();
    let mut n_changes = 0usize;

    for k in 0..steps {
        if hold == 0 {
            for (j, (_, lo, hi)) in inputs.iter().enumerate() {
                u[j] = lo + (hi - lo) * rng.next();
            }
            hold = 1 + (rng.next() * 500.0) as usize;
            n_changes += 1;
            e("set inputs", inst.set_real(&in_vrs, &u));
        }
        hold -= 1;
        let t = k as f64 * h;
        match inst.do_step(t, h, true) {
            Ok(host::Status::Ok) => {}
            other => fail(format!("step {k} at t = {t}: {other:?}")),
        }
        e("get", inst.get_real(&outs, &mut y));
        if let Some(j) = y.iter().position(|x| !x.is_finite()) {
            fail(format!("step {k}: output {} = {}", out_vars[j].name, y[j]));
        }
        for (m, x) in t_max_abs.iter_mut().zip(&y) {
            *m = m.max(x.abs());
        }
        if let (Some(ie), Some(ix), Some(fv)) = osc {
            let f = u[in_vrs.iter().position(|&v| v == fv).unwrap()];
            osc_residual += (y[ie] - prev[ie]) - f * (y[ix] - prev[ix]);
            osc_scale = osc_scale.max(y[ie].abs());
        }
        if let (Some(_), Some(_), Some(il), Some(ir), Some(tv)) = hj {
            let tau = u[in_vrs.iter().position(|&v| v == tv).unwrap()];
            let d0 = prev[il] - prev[ir];
            let d1 = y[il] - y[ir];
            impulse += 0.5 * h * (d0 + d1);
            impulse_abs += 0.5 * h * (d0.abs() + d1.abs());
            tau_impulse += tau * h;
        }
        std::mem::swap(&mut prev, &mut y);
    }
    let y = prev;
    let secs = started.elapsed().as_secs_f64();
    println!(
        "{model}: {steps} steps of {h} s ({} s simulated), {n_changes} random input changes, all fmi2OK, all outputs finite ({secs:.1} s wall)",
        steps as f64 * h
    );
    if let (Some(ie), Some(_), Some(_)) = osc {
        let rel = osc_residual.abs() / osc_scale.max(f64::MIN_POSITIVE);
        println!(
            "  energy balance (damping 0): |sum dE - F dx| = {:.3e} J, relative to max E {:.3e} J: {rel:.3e}",
            osc_residual.abs(),
            osc_scale,
        );
        println!("BALANCE energy {rel:.6e}");
        let _ = ie;
    }
    if let (Some(iw), Some(ith), Some(_), Some(_), Some(_)) = hj {
        let inertia = param("link_inertia") + param("load_mass") * param("load_radius").powi(2);
        let b = param("link_damping");
        let r = param("pulley_radius");
        let lhs = inertia * (y[iw] - y0[iw]) + b * (y[ith] - y0[ith]) - tau_impulse;
        let rhs = r * impulse;
        let rel = (lhs - rhs).abs() / (r * impulse_abs).max(f64::MIN_POSITIVE);
        println!(
            "  link angular momentum balance, eq. (1): lhs {lhs:.6e}, R*integral(T_L - T_R) {rhs:.6e} N.m.s, residual relative to R*integral|T_L - T_R| = {rel:.3e} (trapezoid on the {h} s grid)"
        );
        println!("BALANCE momentum {rel:.6e}");
    }
    let _ = n_changes;
}
