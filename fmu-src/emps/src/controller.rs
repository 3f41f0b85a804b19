//! The logged 1 kHz controller as a sampled system: at sample `k` (time `t0 + k Ts`) it reads the
//! encoder `qm(k)`, forms the filtered velocity from `qm(k)`, `qm(k-1)`, `qm(k-2)` and the cascade
//! law, saturates it and holds the force until the next sample (description eq. 6-7, sec. 2.2).
//! With `controller_delay` the held force acts `d` after its sample (a queue of at most three
//! outputs, `d <= 2 Ts`).

use crate::physics::{controller_velocity, controller_voltage};
use crate::plant::Params;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Inputs of one sample.
#[derive(Clone, Copy, Debug)]
pub struct SampleInputs {
    /// Reference position qg [m].
    pub qg: f64,
    /// Force pulse [N], added before the saturation.
    pub force_pulse: f64,
}

/// Discrete state of the controller.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Controller {
    /// Index of the next sample not yet taken (instants from `ode::SampleClock`).
    pub next_sample: u64,
    /// Encoder positions of the two samples before the next one: `[qm(k-2), qm(k-1)]`.
    pub history: [f64; 2],
    /// Velocity of the last sample [m/s].
    pub velocity: f64,
    /// Voltage of the last sample [V].
    pub voltage: f64,
    /// Forces sampled but not yet acting: (time they act, force).
    pub pending: VecDeque<(f64, f64)>,
    /// Force acting now [N] (None before the first sample).
    pub applied: Option<f64>,
}

impl Controller {
    /// Before sample 0 at rest or in steady motion: the encoder read `q0 - v0 Ts`, `q0 - 2 v0 Ts`.
    pub fn new(q0: f64, v0: f64, ts: f64) -> Self {
        Controller {
            history: [q0 - 2.0 * v0 * ts, q0 - v0 * ts],
            ..Default::default()
        }
    }

    /// Sample `next_sample` at time `t_k` with the encoder at `qm`: velocity and voltage held,
    /// the force queued to act at `t_k + d` (at once without delay). Returns the new force.
    pub fn sample(&mut self, par: &Params, t_k: f64, qm: f64, inp: SampleInputs) -> f64 {
        self.velocity = controller_velocity(qm, self.history[0], par.period);
        self.history = [self.history[1], qm];
        self.next_sample += 1;
        if !par.internal_controller {
            self.voltage = 0.0;
            return self.applied.unwrap_or(0.0);
        }
        let pulse_v = inp.force_pulse / par.drive_gain;
        self.voltage = controller_voltage(
            inp.qg,
            qm,
            self.velocity,
            par.kp,
            par.kv,
            pulse_v,
            par.voltage_limit,
        );
        let force = par.drive_gain * self.voltage;
        match par.delay {
            Some(d) if d > 0.0 => {
                self.applied.get_or_insert(force);
                self.pending.push_back((t_k + d, force));
            }
            _ => self.applied = Some(force),
        }
        force
    }

    /// Let every queued force due at `t` (within `tol`) act. Returns whether the force changed.
    pub fn release_due(&mut self, t: f64, tol: f64) -> bool {
        let before = self.applied;
        while let Some(&(at, f)) = self.pending.front() {
            if at > t + tol {
                break;
            }
            self.applied = Some(f);
            self.pending.pop_front();
        }
        before != self.applied
    }

    /// Time the next queued force acts, if any.
    pub fn next_release(&self) -> Option<f64> {
        self.pending.front().map(|&(at, _)| at)
    }
}

#[cfg(test)]
mod tests {
    use super::{Controller, SampleInputs};
    use crate::plant::Params;

    fn par(delay: Option<f64>) -> Params {
        Params {
            internal_controller: true,
            kp: 160.18,
            kv: 243.45,
            drive_gain: 35.15,
            voltage_limit: 10.0,
            period: 1e-3,
            delay,
            ..Default::default()
        }
    }

    #[test]
    fn steady_motion_history_gives_v0() {
        let p = par(None);
        let mut c = Controller::new(0.01, 0.05, 1e-3);
        let inp = SampleInputs {
            qg: 0.01,
            force_pulse: 0.0,
        };
        c.sample(&p, 0.0, 0.01, inp);
        assert!((c.velocity - 0.05).abs() < 1e-12);
        // kv (kp * 0 - 0.05) = -12.17 V: saturated
        assert_eq!(c.voltage, -10.0);
        assert_eq!(c.applied, Some(-351.5));
    }

    #[test]
    fn delayed_force_acts_later() {
        let p = par(Some(1.5e-3));
        let mut c = Controller::new(0.0, 0.0, 1e-3);
        let f0 = c.sample(
            &p,
            0.0,
            0.0,
            SampleInputs {
                qg: 1e-5,
                force_pulse: 0.0,
            },
        );
        let f1 = c.sample(
            &p,
            1e-3,
            0.0,
            SampleInputs {
                qg: 2e-5,
                force_pulse: 0.0,
            },
        );
        assert_eq!(c.applied, Some(f0));
        assert!(!c.release_due(1.4e-3, 1e-12));
        // sample 0's force acts from 1.5 ms: the same force as held since the start
        assert!(!c.release_due(1.5e-3, 1e-12));
        assert_eq!(c.next_release(), Some(1e-3 + 1.5e-3));
        assert!(c.release_due(2.5e-3, 1e-12));
        assert_eq!(c.applied, Some(f1));
    }
}
