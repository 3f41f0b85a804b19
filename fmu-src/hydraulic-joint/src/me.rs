//! Model Exchange: the plant's states for the importer's solver, the 40 Hz controller as time
//! events (documentation, 'Model Exchange').
//!
//! The state vector has a fixed length of 18 whatever the effects: the twelve base states
//! `theta, omega, x_L, v_L, p1_L, p2_L, x_R, v_R, p1_R, p2_R, V_supplied, V_returned`, then the
//! spools `xv_L, vv_L, xv_R, vv_R` (`valve_dynamics`) and the remembered piston speeds
//! `vm_L, vm_R` (`seal_friction`); a state of an effect that is off stays 0 with derivative 0.
//! The oil integrals are the totals since initialization (the Co-Simulation integrator restarts
//! them at each call and accumulates them in the model).
//!
//! Valve commands: with `internal_controller` the controller's output is held between its
//! samples `t0 + k/f`, each a time event at which the controller runs on the state there (as in
//! Co-Simulation); open loop the commands are the inputs `u_left`, `u_right` (saturated), which
//! act at once, so `u_valve_*` and `Q_*` depend on them directly.

use crate::controller::controller_update;
use crate::model::HydraulicJoint;
use crate::plant::{
    spool, Params, Plant, NOMINAL_BASE, NOMINAL_MEMORY, NOMINAL_SPOOL, TH, VRET, VSUP,
};
use crate::vars::V;
use fmu_core::{ModelError, ModelExchange, Values, ValuesMut};
use ode::SampleClock;

/// Length of the Model Exchange state vector.
pub const STATES: usize = 18;
/// Position of the spool states in the Model Exchange state vector.
const X_SPOOL: usize = 12;
/// Position of the remembered piston speeds in the Model Exchange state vector.
const X_MEMORY: usize = 16;
/// Length of the plant's state with every effect on.
const PLANT_MAX: usize = 18;

/// `(state, derivative)` positions in the table, in the order of the state vector.
const STATE_VARIABLES: [(usize, usize); STATES] = [
    (V::THETA as usize, V::DER_THETA as usize),
    (V::OMEGA as usize, V::DER_OMEGA as usize),
    (V::X_LEFT as usize, V::DER_X_LEFT as usize),
    (V::V_LEFT as usize, V::DER_V_LEFT as usize),
    (V::P1_LEFT as usize, V::DER_P1_LEFT as usize),
    (V::P2_LEFT as usize, V::DER_P2_LEFT as usize),
    (V::X_RIGHT as usize, V::DER_X_RIGHT as usize),
    (V::V_RIGHT as usize, V::DER_V_RIGHT as usize),
    (V::P1_RIGHT as usize, V::DER_P1_RIGHT as usize),
    (V::P2_RIGHT as usize, V::DER_P2_RIGHT as usize),
    (V::V_SUPPLIED as usize, V::DER_V_SUPPLIED as usize),
    (V::V_RETURNED as usize, V::DER_V_RETURNED as usize),
    (V::SPOOL_LEFT as usize, V::DER_SPOOL_LEFT as usize),
    (V::SPOOL_RATE_LEFT as usize, V::DER_SPOOL_RATE_LEFT as usize),
    (V::SPOOL_RIGHT as usize, V::DER_SPOOL_RIGHT as usize),
    (
        V::SPOOL_RATE_RIGHT as usize,
        V::DER_SPOOL_RATE_RIGHT as usize,
    ),
    (V::V_MEMORY_LEFT as usize, V::DER_V_MEMORY_LEFT as usize),
    (V::V_MEMORY_RIGHT as usize, V::DER_V_MEMORY_RIGHT as usize),
];

/// Outputs that follow an input at once in Model Exchange (open loop: the valve command is the
/// input; with the spool lag on only `u_valve_*` does, but the list is static).
const FEEDTHROUGH: &[(usize, &[usize])] = &[
    (V::U_VALVE_LEFT as usize, &[V::U_LEFT as usize]),
    (V::Q_LEFT as usize, &[V::U_LEFT as usize]),
    (V::U_VALVE_RIGHT as usize, &[V::U_RIGHT as usize]),
    (V::Q_RIGHT as usize, &[V::U_RIGHT as usize]),
];

/// What each derivative depends on (documentation, 'Model Exchange'), by the right-hand side of
/// `Plant::eval`: the link on the cable tensions (piston positions, angle, speed for the
/// capstan) and the torque; a piston's acceleration on its spring, pressures, speed, end stop
/// and seal memory; its pressures on its position, speed, pressures and valve opening (the
/// spool, or open loop the input); the oil integrals on all four pressures and both openings.
const fn piston_deps(i: usize) -> [[usize; 7]; 4] {
    let (x, v, p1, p2, sp, vm, u) = if i == 0 {
        (
            V::X_LEFT,
            V::V_LEFT,
            V::P1_LEFT,
            V::P2_LEFT,
            V::SPOOL_LEFT,
            V::V_MEMORY_LEFT,
            V::U_LEFT,
        )
    } else {
        (
            V::X_RIGHT,
            V::V_RIGHT,
            V::P1_RIGHT,
            V::P2_RIGHT,
            V::SPOOL_RIGHT,
            V::V_MEMORY_RIGHT,
            V::U_RIGHT,
        )
    };
    let (x, v, p1, p2, sp, vm, u) = (
        x as usize,
        v as usize,
        p1 as usize,
        p2 as usize,
        sp as usize,
        vm as usize,
        u as usize,
    );
    let th = V::THETA as usize;
    [
        [v, v, v, v, v, v, v],
        [th, x, v, p1, p2, vm, vm],
        [x, v, p1, p2, sp, u, u],
        [x, v, p1, p2, sp, u, u],
    ]
}
const PISTON_L: [[usize; 7]; 4] = piston_deps(0);
const PISTON_R: [[usize; 7]; 4] = piston_deps(1);
const DEP_THETA: &[usize] = &[V::OMEGA as usize];
const DEP_OMEGA: &[usize] = &[
    V::THETA as usize,
    V::OMEGA as usize,
    V::X_LEFT as usize,
    V::X_RIGHT as usize,
    V::TAU_EXT as usize,
];
const DEP_OIL: &[usize] = &[
    V::P1_LEFT as usize,
    V::P2_LEFT as usize,
    V::P1_RIGHT as usize,
    V::P2_RIGHT as usize,
    V::SPOOL_LEFT as usize,
    V::SPOOL_RIGHT as usize,
    V::U_LEFT as usize,
    V::U_RIGHT as usize,
];
const DEP_SPOOL_L: &[usize] = &[V::SPOOL_RATE_LEFT as usize];
const DEP_SPOOL_RATE_L: &[usize] = &[
    V::SPOOL_LEFT as usize,
    V::SPOOL_RATE_LEFT as usize,
    V::U_LEFT as usize,
];
const DEP_SPOOL_R: &[usize] = &[V::SPOOL_RATE_RIGHT as usize];
const DEP_SPOOL_RATE_R: &[usize] = &[
    V::SPOOL_RIGHT as usize,
    V::SPOOL_RATE_RIGHT as usize,
    V::U_RIGHT as usize,
];
const DEP_MEMORY_L: &[usize] = &[V::V_LEFT as usize, V::V_MEMORY_LEFT as usize];
const DEP_MEMORY_R: &[usize] = &[V::V_RIGHT as usize, V::V_MEMORY_RIGHT as usize];
/// Per state, the states and inputs its derivative depends on (repeats are written once).
const DERIVATIVE_DEPENDENCIES: [&[usize]; STATES] = [
    DEP_THETA,
    DEP_OMEGA,
    &PISTON_L[0],
    &PISTON_L[1],
    &PISTON_L[2],
    &PISTON_L[3],
    &PISTON_R[0],
    &PISTON_R[1],
    &PISTON_R[2],
    &PISTON_R[3],
    DEP_OIL,
    DEP_OIL,
    DEP_SPOOL_L,
    DEP_SPOOL_RATE_L,
    DEP_SPOOL_R,
    DEP_SPOOL_RATE_R,
    DEP_MEMORY_L,
    DEP_MEMORY_R,
];

/// Parameter groups (table positions) by the part of the model they enter, for the FMI 3.0
/// `<ModelStructure>` (FMI 3.0.2 section 2.4.8: parameters are knowns of the outputs and
/// derivatives; `Params::derive`, `Plant::piston`, `Plant::eval`). The valve command: open
/// loop the input, with `internal_controller` the controller's output, computed at its ticks
/// from its parameters, the pulley radius and the mean piston offset from mid-stroke (stroke),
/// and held.
const COMMAND: &[usize] = &[
    V::INTERNAL_CONTROLLER as usize,
    V::CONTROLLER_RATE as usize,
    V::CONTROLLER_GAIN as usize,
    V::CONTROLLER_SLOPE_EXTEND as usize,
    V::CONTROLLER_SLOPE_RETRACT as usize,
    V::CONTROLLER_DEADBAND_LOW as usize,
    V::CONTROLLER_DEADBAND_HIGH as usize,
    V::CONTROLLER_COCONTRACTION as usize,
    V::PULLEY_RADIUS as usize,
    V::STROKE as usize,
];
/// The spool's second-order lag between command and opening (`valve_dynamics`).
const SPOOL: &[usize] = &[
    V::VALVE_DYNAMICS_ENABLED as usize,
    V::VALVE_DYNAMICS_NATURAL_FREQUENCY as usize,
    V::VALVE_DYNAMICS_DAMPING_RATIO as usize,
];
/// The orifices, eq. (13)-(16): dead band (and overlap), coefficients, supply and return.
const ORIFICES: &[usize] = &[
    V::VALVE_USE_MEAN as usize,
    V::SUPPLY_PRESSURE as usize,
    V::RETURN_PRESSURE as usize,
    V::C1 as usize,
    V::C2 as usize,
    V::C3 as usize,
    V::C4 as usize,
    V::VALVE_FLOW_SCALE as usize,
    V::VALVE_DEADBAND_LOW as usize,
    V::VALVE_DEADBAND_HIGH as usize,
    V::VALVE_OVERLAP_ENABLED as usize,
    V::VALVE_OVERLAP_WIDTH as usize,
];
/// The oil's compressibility and density ratio (`entrained_air`).
const OIL: &[usize] = &[
    V::BULK_MODULUS as usize,
    V::ENTRAINED_AIR_ENABLED as usize,
    V::ENTRAINED_AIR_FRACTION as usize,
    V::ENTRAINED_AIR_POLYTROPIC_INDEX as usize,
];
/// The chamber volumes, eq. (7)-(12).
const CHAMBERS: &[usize] = &[
    V::STROKE as usize,
    V::PISTON_AREA as usize,
    V::ANNULUS_AREA as usize,
    V::DEAD_VOLUME_CAP as usize,
    V::DEAD_VOLUME_ROD as usize,
];
/// The cross-port leakage between the chambers.
const LEAKAGE: &[usize] = &[
    V::INTERNAL_LEAKAGE_ENABLED as usize,
    V::INTERNAL_LEAKAGE_COEFFICIENT as usize,
];
/// The series spring's tension: stiffness, pretension, rest position (mid-stroke), pulley.
const CABLE: &[usize] = &[
    V::CABLES_ATTACHED as usize,
    V::SPRING_STIFFNESS as usize,
    V::SPRING_PRETENSION as usize,
    V::STROKE as usize,
    V::PULLEY_RADIUS as usize,
];
/// The Bowden cable's capstan friction (between spring and joint).
const CAPSTAN: &[usize] = &[
    V::CABLE_FRICTION_ENABLED as usize,
    V::CABLE_FRICTION_MU as usize,
    V::BOWDEN_WRAP_ANGLE as usize,
];
/// The piston, eq. (6): areas, mass, damping, end stops, seal friction.
const PISTON: &[usize] = &[
    V::PISTON_AREA as usize,
    V::ANNULUS_AREA as usize,
    V::PISTON_MASS as usize,
    V::PISTON_DAMPING as usize,
    V::STROKE as usize,
    V::SEAL_FRICTION_ENABLED as usize,
    V::SEAL_FRICTION_COULOMB as usize,
    V::SEAL_FRICTION_BREAKAWAY_EXCESS as usize,
    V::SEAL_FRICTION_STRIBECK_VELOCITY as usize,
    V::SEAL_FRICTION_VISCOUS as usize,
];
/// The link, eq. (1): inertia with the payload, damping, pulley.
const LINK: &[usize] = &[
    V::LOAD_MASS as usize,
    V::LOAD_RADIUS as usize,
    V::LINK_INERTIA as usize,
    V::LINK_DAMPING as usize,
    V::PULLEY_RADIUS as usize,
];
/// The seal friction's memory of the piston speed.
const MEMORY: &[usize] = &[
    V::SEAL_FRICTION_ENABLED as usize,
    V::SEAL_FRICTION_MEMORY_TIME as usize,
];
/// The valve's opening and its flows: command, spool, orifices.
const P_FLOW: &[usize] = fmu_core::parameter_groups!(COMMAND, SPOOL, ORIFICES);
const P_PRESSURES: &[usize] =
    fmu_core::parameter_groups!(COMMAND, SPOOL, ORIFICES, OIL, CHAMBERS, LEAKAGE);
const P_OIL_TOTALS: &[usize] = fmu_core::parameter_groups!(COMMAND, SPOOL, ORIFICES, OIL);
const P_TENSION: &[usize] = fmu_core::parameter_groups!(CABLE, CAPSTAN);
const P_LINK: &[usize] = fmu_core::parameter_groups!(LINK, CABLE, CAPSTAN);
const P_PISTON: &[usize] = fmu_core::parameter_groups!(PISTON, CABLE);
const P_STORED: &[usize] = fmu_core::parameter_groups!(CHAMBERS, OIL);
const P_SPOOL_RATE: &[usize] = fmu_core::parameter_groups!(SPOOL, COMMAND);
const P_FORCE: &[usize] = &[V::PISTON_AREA as usize, V::ANNULUS_AREA as usize];
const P_SPOOL: &[usize] = &[V::VALVE_DYNAMICS_ENABLED as usize];

/// Per output and derivative, the parameters its value depends on under any setting of the
/// others (the states, the oil totals and `der(theta)`, `der(x_*)` depend on none).
const PARAMETER_DEPENDENCIES: &[(usize, &[usize])] = &[
    (V::F_LEFT as usize, P_FORCE),
    (V::F_RIGHT as usize, P_FORCE),
    (V::T_LEFT as usize, P_TENSION),
    (V::T_RIGHT as usize, P_TENSION),
    (V::U_VALVE_LEFT as usize, COMMAND),
    (V::U_VALVE_RIGHT as usize, COMMAND),
    (V::Q_LEFT as usize, P_FLOW),
    (V::Q_RIGHT as usize, P_FLOW),
    (V::V_STORED as usize, P_STORED),
    (V::DER_OMEGA as usize, P_LINK),
    (V::DER_V_LEFT as usize, P_PISTON),
    (V::DER_V_RIGHT as usize, P_PISTON),
    (V::DER_P1_LEFT as usize, P_PRESSURES),
    (V::DER_P2_LEFT as usize, P_PRESSURES),
    (V::DER_P1_RIGHT as usize, P_PRESSURES),
    (V::DER_P2_RIGHT as usize, P_PRESSURES),
    (V::DER_V_SUPPLIED as usize, P_OIL_TOTALS),
    (V::DER_V_RETURNED as usize, P_OIL_TOTALS),
    (V::DER_SPOOL_LEFT as usize, P_SPOOL),
    (V::DER_SPOOL_RIGHT as usize, P_SPOOL),
    (V::DER_SPOOL_RATE_LEFT as usize, P_SPOOL_RATE),
    (V::DER_SPOOL_RATE_RIGHT as usize, P_SPOOL_RATE),
    (V::DER_V_MEMORY_LEFT as usize, MEMORY),
    (V::DER_V_MEMORY_RIGHT as usize, MEMORY),
    (V::DER_THETA as usize, &[]),
    (V::DER_X_LEFT as usize, &[]),
    (V::DER_X_RIGHT as usize, &[]),
];

impl HydraulicJoint {
    /// Valve commands in Model Exchange: the held controller output, or the inputs open loop.
    fn me_commands(&self, vars: &[f64]) -> [f64; 2] {
        match &self.params {
            Some((p, _)) if !p.internal_controller => Self::open_loop_commands(vars),
            _ => self.u_held,
        }
    }

    /// Positions `(plant, state vector)` of the plant states present with the current effects
    /// (an iterator: the derivatives and states are asked for at every point, no allocation).
    fn state_map(&self) -> impl Iterator<Item = (usize, usize)> {
        let (base, spool_states, memory) = match &self.params {
            Some((_, d)) => (VSUP, if d.spool { 4 } else { 0 }, d.mem),
            None => (0, 0, None),
        };
        (0..base)
            .map(|i| (i, i))
            .chain((0..spool_states).map(|i| (spool(0) + i, X_SPOOL + i)))
            .chain(
                memory
                    .into_iter()
                    .flat_map(|m| (0..2).map(move |i| (m + i, X_MEMORY + i))),
            )
    }

    /// The controller's sample clock (`None` open loop or before initialization).
    fn clock(&self) -> Result<Option<SampleClock>, ModelError> {
        let Some((p, _)) = &self.params else {
            return Ok(None);
        };
        if !p.internal_controller {
            return Ok(None);
        }
        SampleClock::new(self.t0, 1.0 / p.controller_rate)
            .map(Some)
            .ok_or_else(|| {
                ModelError::parameter(
                    "controller_rate",
                    format!("{} Hz gives no sample period", p.controller_rate),
                )
            })
    }
}

impl ModelExchange for HydraulicJoint {
    const STATES: usize = STATES;

    fn state_variables() -> &'static [(usize, usize)] {
        &STATE_VARIABLES
    }

    fn output_feedthrough() -> &'static [(usize, &'static [usize])] {
        FEEDTHROUGH
    }

    fn derivative_dependencies() -> Option<&'static [&'static [usize]]> {
        Some(&DERIVATIVE_DEPENDENCIES)
    }

    fn parameter_dependencies() -> Option<&'static [(usize, &'static [usize])]> {
        Some(PARAMETER_DEPENDENCIES)
    }

    /// Every parameter read and derived again (as at initialization); the states and the held
    /// valve commands are kept.
    fn set_parameters(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let p = Params::read(vars);
        let d = p.derive()?;
        self.params = Some((p, d));
        Ok(())
    }

    fn states(&self, x: &mut [f64]) {
        x.fill(0.0);
        for (i, j) in self.state_map() {
            x[j] = self.y[i];
        }
        if self.params.is_some() {
            // the totals: the plant's VSUP, VRET of the last integration call are in `oil`
            x[VSUP] = self.oil[0];
            x[VRET] = self.oil[1];
        }
    }

    fn set_states(&mut self, x: &[f64]) {
        if self.params.is_none() {
            return;
        }
        for (i, j) in self.state_map() {
            self.y[i] = x[j];
        }
        self.oil = [x[VSUP], x[VRET]];
        self.y[VSUP] = 0.0;
        self.y[VRET] = 0.0;
    }

    fn nominals(&self, n: &mut [f64]) {
        n[..X_SPOOL].copy_from_slice(&NOMINAL_BASE);
        n[X_SPOOL..X_MEMORY].copy_from_slice(&NOMINAL_SPOOL);
        n[X_MEMORY..].copy_from_slice(&NOMINAL_MEMORY);
    }

    fn derivatives(&self, vars: &[f64], _t: f64, dx: &mut [f64]) -> Result<(), ModelError> {
        let Some((p, d)) = &self.params else {
            return Err(ModelError::NotInitialized);
        };
        let plant = Plant {
            p,
            d,
            u: self.me_commands(vars),
            tau_ext: Values(vars).real(V::TAU_EXT),
        };
        let mut dy = [0.0; PLANT_MAX];
        plant.eval(&self.y, &mut dy[..d.dim]);
        dx.fill(0.0);
        for (i, j) in self.state_map() {
            dx[j] = dy[i];
        }
        dx[VSUP] = dy[VSUP];
        dx[VRET] = dy[VRET];
        Ok(())
    }

    const PROVIDES_JACOBIAN: bool = true;

    /// The plant's analytic Jacobian (the one its own integrator uses), mapped to the state
    /// vector; the oil integrals are quadratures (their columns are 0).
    fn state_jacobian(&self, vars: &[f64], t: f64, jac: &mut [f64]) -> Result<(), ModelError> {
        let Some((p, d)) = &self.params else {
            return Err(ModelError::NotInitialized);
        };
        let plant = Plant {
            p,
            d,
            u: self.me_commands(vars),
            tau_ext: Values(vars).real(V::TAU_EXT),
        };
        let mut full = nalgebra::DMatrix::zeros(d.dim, d.dim);
        if !ode::OdeSystem::jacobian(&plant, t, &self.y, &mut full) {
            return Err(ModelError::parameters(
                &[],
                "the plant has no analytic Jacobian",
            ));
        }
        let map = || self.state_map().chain([(VSUP, VSUP), (VRET, VRET)]);
        jac.fill(0.0);
        for (pi, xi) in map() {
            for (pj, xj) in map() {
                jac[xi * STATES + xj] = full[(pi, pj)];
            }
        }
        Ok(())
    }

    fn me_outputs(&self, vars: &mut [f64], t: f64) {
        let tau = Values(vars).real(V::TAU_EXT);
        self.write_outputs_with(vars, self.me_commands(vars), tau);
        let (mut x, mut dx) = ([0.0; STATES], [0.0; STATES]);
        self.states(&mut x);
        let ok = self.derivatives(vars, t, &mut dx).is_ok();
        for (k, &(s, der)) in STATE_VARIABLES.iter().enumerate() {
            vars[s] = x[k];
            if ok {
                vars[der] = dx[k];
            }
        }
    }

    fn next_time_event(&self) -> Option<f64> {
        let clock = self.clock().ok()??;
        Some(clock.time(self.next_sample))
    }

    /// The controller sample due at `t` (at most one update, on the state at `t`, however many
    /// instants lie at or before it: as at the start of a Co-Simulation step).
    fn event_update(&mut self, vars: &mut [f64], t: f64) -> Result<bool, ModelError> {
        let Some(clock) = self.clock()? else {
            return Ok(false);
        };
        if !clock.is_due(self.next_sample, t) {
            return Ok(false);
        }
        let Some((p, _)) = &self.params else {
            return Ok(false);
        };
        let ctrl = p.controller();
        let theta_ref = Values(vars).real(V::THETA_REF);
        let (l, r) = controller_update(theta_ref, self.y[TH], self.mean_piston_offset(), &ctrl);
        self.next_sample = clock.after_due(self.next_sample, t);
        let changed = [l, r] != self.u_held;
        self.u_held = [l, r];
        let mut out = ValuesMut(vars);
        out.set(V::U_VALVE_LEFT, l);
        out.set(V::U_VALVE_RIGHT, r);
        Ok(changed)
    }
}

#[cfg(test)]
mod tests {
    use super::{STATES, X_SPOOL};
    use crate::model::HydraulicJoint;
    use crate::plant::{piston, OM, TH};
    use crate::vars::{V, VARIABLES};
    use fmu_core::{Model, ModelExchange};

    fn initialized(setup: impl Fn(&mut [f64])) -> (HydraulicJoint, Vec<f64>) {
        let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
        setup(&mut vars);
        let mut m = HydraulicJoint::new();
        m.initialize(&mut vars, 0.0).unwrap();
        (m, vars)
    }

    #[test]
    fn states_round_trip_with_every_effect() {
        let (mut m, vars) = initialized(|v| {
            v[V::VALVE_DYNAMICS_ENABLED as usize] = 1.0;
            v[V::SEAL_FRICTION_ENABLED as usize] = 1.0;
        });
        let x: Vec<f64> = (0..STATES).map(|i| 1.0 + i as f64).collect();
        m.set_states(&x);
        let mut back = [0.0; STATES];
        m.states(&mut back);
        assert_eq!(back.to_vec(), x);
        // the plant's right-hand side at the same state, mapped
        let mut dx = [0.0; STATES];
        m.derivatives(&vars, 0.0, &mut dx).unwrap();
        assert_eq!(dx[TH], x[OM]);
        assert_eq!(dx[piston(0)], x[piston(0) + 1]);
        assert_eq!(dx[X_SPOOL], x[X_SPOOL + 1]);
    }

    #[test]
    fn unused_states_stay_zero_with_derivative_zero() {
        let (m, vars) = initialized(|_| {});
        let mut x = [1.0; STATES];
        m.states(&mut x);
        assert!(x[X_SPOOL..].iter().all(|&v| v == 0.0));
        let mut dx = [1.0; STATES];
        m.derivatives(&vars, 0.0, &mut dx).unwrap();
        assert!(dx[X_SPOOL..].iter().all(|&v| v == 0.0));
        // at rest every derivative vanishes (the initial state is an equilibrium)
        assert!(dx.iter().all(|v| v.abs() < 1e-9), "{dx:?}");
    }

    #[test]
    fn controller_ticks_are_time_events() {
        let (mut m, mut vars) = initialized(|_| {});
        assert_eq!(m.next_time_event(), Some(0.0));
        vars[V::THETA_REF as usize] = 0.3;
        assert!(m.event_update(&mut vars, 0.0).unwrap());
        assert!(!m.event_update(&mut vars, 0.0).unwrap());
        assert_eq!(m.next_time_event(), Some(1.0 / 40.0));
        assert!(vars[V::U_VALVE_LEFT as usize] != 0.0);
        // not due before the tick: nothing changes
        assert!(!m.event_update(&mut vars, 0.02).unwrap());
        assert_eq!(m.next_time_event(), Some(1.0 / 40.0));
    }

    #[test]
    fn open_loop_has_no_time_events_and_follows_the_inputs() {
        let (m, mut vars) = initialized(|v| v[V::INTERNAL_CONTROLLER as usize] = 0.0);
        assert_eq!(m.next_time_event(), None);
        vars[V::U_LEFT as usize] = 12.0;
        m.me_outputs(&mut vars, 0.0);
        assert_eq!(vars[V::U_VALVE_LEFT as usize], 10.0);
        assert!(vars[V::Q_LEFT as usize] > 0.0);
    }

    /// The declared parameter dependencies name every parameter that moves an output or a
    /// derivative: every effect on, mid-motion, closed loop and open loop (valves open).
    #[test]
    fn declared_parameter_dependencies_cover_the_equations() {
        for internal in [1.0, 0.0] {
            let (mut m, mut vars) = initialized(|v| {
                for (i, var) in VARIABLES.iter().enumerate() {
                    if var.name.ends_with(".enabled") {
                        v[i] = 1.0;
                    }
                }
                v[V::INTERNAL_CONTROLLER as usize] = internal;
                v[V::THETA_REF as usize] = 0.3;
                v[V::U_LEFT as usize] = 4.0;
                v[V::U_RIGHT as usize] = -3.0;
            });
            for k in 0..60 {
                m.do_step(&mut vars, k as f64 * 1e-3, 1e-3).unwrap();
            }
            let problems = fmu_core::me::parameter_dependency_problems(&m, &vars, 0.06);
            assert!(problems.is_empty(), "{problems:#?}");
        }
    }
}
