//! The FMI model: parameters from the variable table, the state at the start time, stepping
//! with the controller's samples and delayed force changes hit exactly, outputs.

use crate::controller::{Controller, SampleInputs};
use crate::physics::Friction;
use crate::plant::{ix, Params, Plant, NOMINAL};
use crate::vars::V;
use fmu_core::{Model, ModelError, Values, ValuesMut, Variable};
use ode::SampleClock;
use serde::{Deserialize, Serialize};

/// Most controller samples one `fmi2DoStep` may span (a huge step is refused with a message
/// instead of hanging the importer).
pub const MAX_SAMPLES_PER_STEP: f64 = 2e5;

/// Everything needed to continue bit-identically (serialized by fmi2GetFMUstate).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Emps {
    pub(crate) par: Params,
    /// `(q, v, q_load, v_load)`, the first `par.dim()` in use.
    pub(crate) y: [f64; 4],
    pub(crate) ctrl: Controller,
    pub(crate) t0: f64,
    integ: ode::Integrator,
}

/// Every parameter from the variable table into SI [`Params`].
pub fn read_params(vars: &[f64]) -> Params {
    let v = Values(vars);
    let g = |x: V| v.real(x);
    let coulomb = v.effect(V::COULOMB_FRICTION_ENABLED, |_| {
        g(V::COULOMB_FRICTION_FORCE)
    });
    let positive = Friction {
        viscous: g(V::VISCOUS_FRICTION),
        coulomb: coulomb.unwrap_or(0.0),
    };
    let negative = v
        .effect(V::ASYMMETRIC_FRICTION_ENABLED, |_| Friction {
            viscous: g(V::ASYMMETRIC_FRICTION_VISCOUS_NEGATIVE),
            coulomb: g(V::ASYMMETRIC_FRICTION_COULOMB_NEGATIVE),
        })
        .unwrap_or(positive);
    Params {
        internal_controller: v.flag(V::INTERNAL_CONTROLLER),
        mass: g(V::MASS),
        offset: g(V::OFFSET),
        positive,
        negative,
        q0: g(V::Q0),
        v0: g(V::V0),
        load_mass: g(V::LOAD_MASS),
        kp: g(V::CONTROLLER_KP),
        kv: g(V::CONTROLLER_KV),
        drive_gain: g(V::DRIVE_GAIN_VAR),
        voltage_limit: g(V::VOLTAGE_LIMIT),
        period: g(V::CONTROLLER_PERIOD),
        smoothing: g(V::FRICTION_SMOOTHING),
        travel_mid: g(V::TRAVEL_MID),
        travel_half: g(V::TRAVEL_HALF),
        rtol: g(V::RTOL),
        atol: g(V::ATOL),
        flexibility: v.effect(V::FLEXIBILITY_ENABLED, |_| {
            (g(V::FLEXIBILITY_STIFFNESS), g(V::FLEXIBILITY_DAMPING_RATIO))
        }),
        backlash: v.effect(V::BACKLASH_ENABLED, |_| g(V::BACKLASH_WIDTH)),
        position_change: v.effect(V::POSITION_FRICTION_ENABLED, |_| {
            g(V::POSITION_FRICTION_CHANGE)
        }),
        delay: v.effect(V::CONTROLLER_DELAY_ENABLED, |_| g(V::CONTROLLER_DELAY_TIME)),
    }
}

/// Combinations the ranges cannot catch. Err names the parameters.
pub fn validate(p: &Params) -> Result<(), ModelError> {
    if p.two_mass() && p.load_mass >= 0.9 * p.mass {
        return Err(ModelError::parameters(
            &["load_mass", "mass"],
            format!(
                "load_mass ({} kg) must stay below 90 % of mass ({} kg): the motor side of \
                 the two-mass model keeps the rest",
                p.load_mass, p.mass
            ),
        ));
    }
    if let Some(d) = p.delay {
        if d > 2.0 * p.period {
            return Err(ModelError::parameters(
                &["controller_delay.time", "controller_period"],
                format!(
                    "a delay of {d} s exceeds two controller periods ({} s)",
                    p.period
                ),
            ));
        }
    }
    Ok(())
}

impl Emps {
    fn sample_inputs(vars: &[f64]) -> SampleInputs {
        let v = Values(vars);
        SampleInputs {
            qg: v.real(V::QG),
            force_pulse: v.real(V::FORCE_PULSE),
        }
    }

    /// The force acting now: the controller's, or in open loop the input force_measured.
    pub(crate) fn force(&self, vars: &[f64]) -> f64 {
        if self.par.internal_controller {
            self.ctrl.applied.unwrap_or(0.0)
        } else {
            Values(vars).real(V::FORCE_MEASURED)
        }
    }

    /// Take the sample due now (the encoder reads the position state).
    pub(crate) fn take_sample(&mut self, vars: &[f64], clock: SampleClock) -> bool {
        let before = self.ctrl.applied;
        let t_k = clock.time(self.ctrl.next_sample);
        self.ctrl
            .sample(&self.par, t_k, self.y[ix::Q], Self::sample_inputs(vars));
        before != self.ctrl.applied
    }

    pub(crate) fn write_outputs(&self, vars: &mut [f64]) {
        let force = self.force(vars);
        let q_load = if self.par.two_mass() {
            self.y[ix::Q_LOAD]
        } else {
            self.y[ix::Q]
        };
        let mut out = ValuesMut(vars);
        out.set(V::QM, self.y[ix::Q]);
        out.set(V::FORCE, force);
        out.set(V::VELOCITY, self.ctrl.velocity);
        out.set(V::VOLTAGE, self.ctrl.voltage);
        out.set(V::V_MOTOR, self.y[ix::V]);
        out.set(V::Q_LOAD, q_load);
        self.write_state_variables(vars);
    }

    /// Integrate `[t0, t1]` under the force acting now, positions relative to their value at `t0`.
    fn integrate(&mut self, vars: &[f64], t0: f64, t1: f64) -> Result<(), ModelError> {
        let n = self.par.dim();
        let off = self.y[ix::Q];
        self.y[ix::Q] = 0.0;
        if n == 4 {
            self.y[ix::Q_LOAD] -= off;
        }
        let plant = Plant {
            par: &self.par,
            force: self.force(vars),
            q_offset: off,
        };
        let res = self.integ.integrate(&plant, t0, t1, &mut self.y[..n]);
        self.y[ix::Q] += off;
        if n == 4 {
            self.y[ix::Q_LOAD] += off;
        }
        res.map_err(|e| ModelError::solver(t0, t1, e))
    }

    /// Where the integration from `tc` must stop on its way to `t_end`: the next sample or the
    /// next delayed force change, whichever comes first inside the step.
    fn next_stop(&self, clock: SampleClock, tc: f64, t_end: f64) -> f64 {
        let (mut t_next, _) = clock.stop_before(self.ctrl.next_sample, t_end);
        if let Some(at) = self.ctrl.next_release() {
            if at > tc + clock.tolerance() && at < t_next - clock.tolerance() {
                t_next = at;
            }
        }
        t_next
    }

    fn clock(&self, t: f64, h: f64) -> Result<SampleClock, ModelError> {
        let ts = self.par.period;
        if h / ts > MAX_SAMPLES_PER_STEP {
            return Err(ModelError::Step {
                t,
                h,
                reason: format!(
                    "spans {:.3e} controller samples (controller_period = {ts} s); at most \
                     {MAX_SAMPLES_PER_STEP:e} per step",
                    h / ts
                ),
            });
        }
        self.sample_clock()
    }

    pub(crate) fn sample_clock(&self) -> Result<SampleClock, ModelError> {
        SampleClock::new(self.t0, self.par.period).ok_or(ModelError::parameter(
            "controller_period",
            "must be finite and > 0",
        ))
    }
}

impl Model for Emps {
    const NAME: &'static str = "EMPS";
    const DESCRIPTION: &'static str = "Electro-mechanical positioning system (EMPS benchmark, Janot, Gautier, Brunot 2019): ball-screw axis with its logged 1 kHz cascade controller";
    const DEFAULT_STOP_TIME: f64 = 24.84;
    const EXPERIMENT_TOLERANCE: &'static [usize] = &[V::RTOL as usize, V::ATOL as usize];

    fn variables() -> &'static [Variable] {
        crate::vars::VARIABLES
    }

    fn documentation_html() -> String {
        crate::docs::html()
    }

    fn new() -> Self {
        Emps {
            par: Params::default(),
            y: [0.0; 4],
            ctrl: Controller::default(),
            t0: 0.0,
            integ: ode::Integrator::new(1e-6, NOMINAL[..2].iter().map(|n| 1e-6 * n).collect()),
        }
    }

    fn initialize(&mut self, vars: &mut [f64], start_time: f64) -> Result<(), ModelError> {
        let par = read_params(vars);
        validate(&par)?;
        let n = par.dim();
        self.integ = ode::Integrator::new(
            par.rtol,
            NOMINAL[..n].iter().map(|x| par.atol * x).collect(),
        );
        self.integ.set_max_steps(200_000);
        // The load starts where the motor side is, moving with it (the coupling relaxed).
        self.y = [par.q0, par.v0, par.q0, par.v0];
        self.ctrl = Controller::new(par.q0, par.v0, par.period);
        self.t0 = start_time;
        self.par = par;
        // The outputs at the start show sample 0 taken with the inputs of initialization; the
        // first step takes it again (from the same history) with the inputs set for that step.
        let kept = self.ctrl.clone();
        let clock = self.clock(start_time, 0.0)?;
        self.take_sample(vars, clock);
        self.write_outputs(vars);
        self.ctrl = kept;
        Ok(())
    }

    fn model_exchange() -> Option<fmu_core::MeVTable<Self>> {
        Some(fmu_core::MeVTable::of())
    }

    fn do_step(&mut self, vars: &mut [f64], t: f64, h: f64) -> Result<(), ModelError> {
        let clock = self.clock(t, h)?;
        let t_end = t + h;
        let mut tc = t;
        while tc < t_end {
            // The samples due at tc: at the start of the step with the inputs set at t (FMI
            // 2.0.4 section 4.2.1), inside it with the inputs held over the step. A sample at
            // t_end belongs to the next step, which starts there with its own inputs.
            let mut changed = false;
            while clock.is_due(self.ctrl.next_sample, tc) {
                changed |= self.take_sample(vars, clock);
            }
            changed |= self.ctrl.release_due(tc, clock.tolerance());
            if changed {
                // the force jumps: the step-size selection restarts
                self.integ.reset_step_size();
            }
            let t_next = self.next_stop(clock, tc, t_end);
            self.integrate(vars, tc, t_next)?;
            tc = t_next;
        }
        self.write_outputs(vars);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Emps;
    use crate::vars::{V, VARIABLES};
    use fmu_core::Model;

    fn start_vars() -> Vec<f64> {
        VARIABLES.iter().map(|v| v.start).collect()
    }

    fn run(m: &mut Emps, vars: &mut [f64], n: usize, h: f64, qg: impl Fn(f64) -> f64) {
        for k in 0..n {
            let t = k as f64 * h;
            vars[V::QG as usize] = qg(t);
            m.do_step(vars, t, h).unwrap();
        }
    }

    #[test]
    fn holds_a_reference_step() {
        // 1 mm step: the 20 Hz position loop settles within 0.5 s; friction leaves an error of
        // at most Fc / (gtau kv kp) = 20 / 1.371e6 m = 15 um (Coulomb force within the dead band)
        let mut vars = start_vars();
        vars[V::COULOMB_FRICTION_ENABLED as usize] = 1.0;
        vars[V::COULOMB_FRICTION_FORCE as usize] = 20.0;
        let mut m = Emps::new();
        m.initialize(&mut vars, 0.0).unwrap();
        run(&mut m, &mut vars, 1000, 1e-3, |_| 1e-3);
        let qm = vars[V::QM as usize];
        assert!((qm - 1e-3).abs() < 2e-5, "{qm}");
    }

    #[test]
    fn serde_roundtrip_continues_bit_identically() {
        let mut vars = start_vars();
        vars[V::CONTROLLER_DELAY_ENABLED as usize] = 1.0;
        vars[V::FLEXIBILITY_ENABLED as usize] = 1.0;
        let mut m = Emps::new();
        m.initialize(&mut vars, 0.0).unwrap();
        run(&mut m, &mut vars, 100, 1e-3, |t| 0.05 * t);
        let bytes = bincode::serialize(&m).unwrap();
        let mut vars2 = vars.clone();
        let mut m2: Emps = bincode::deserialize(&bytes).unwrap();
        for k in 100..200 {
            let t = k as f64 * 1e-3;
            vars[V::QG as usize] = 0.05 * t;
            vars2[V::QG as usize] = 0.05 * t;
            m.do_step(&mut vars, t, 1e-3).unwrap();
            m2.do_step(&mut vars2, t, 1e-3).unwrap();
        }
        for (a, b) in vars.iter().zip(&vars2) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn samples_independent_of_communication_step() {
        let mut out = vec![];
        for (h, n) in [(1e-3, 300), (2.5e-4, 1200), (5e-3, 60)] {
            let mut vars = start_vars();
            vars[V::CONTROLLER_DELAY_ENABLED as usize] = 1.0;
            let mut m = Emps::new();
            m.initialize(&mut vars, 0.0).unwrap();
            // a ramp held over each 5 ms (every step size sees the same reference)
            run(&mut m, &mut vars, n, h, |t| {
                0.02 * (t / 5e-3 + 1e-9).floor() * 5e-3
            });
            out.push(vars[V::QM as usize]);
        }
        assert!(
            (out[0] - out[1]).abs() < 1e-9 && (out[0] - out[2]).abs() < 1e-9,
            "{out:?}"
        );
    }

    #[test]
    fn ill_posed_is_refused() {
        let mut vars = start_vars();
        vars[V::BACKLASH_ENABLED as usize] = 1.0;
        vars[V::LOAD_MASS as usize] = 95.0;
        let err = Emps::new().initialize(&mut vars, 0.0).unwrap_err();
        assert!(err.names().contains(&"load_mass"), "{err}");
    }
}
