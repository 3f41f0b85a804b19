//! Model Exchange formulation of the twisted-string actuator (documentation section
//! "Model Exchange"): the importer's solver integrates the plant and the continuous current and
//! speed PI loops; the sampled position loop is a time event at every tick `t0 + k Ts`.
//!
//! State vector `x` (fixed dimension [`STATES`], the largest over all effect settings):
//! 0 current, 1 theta_motor (absolute: unlike `do_step`, which integrates it relative to the
//! start of each interval, an importer's solver sees one state for the whole run), 2 omega_motor,
//! 3 p, 4 v_load, 5 current_integral z_i, 6 speed_integral z_w, 7 E_electrical,
//! 8 E_dissipated, 9 E_string_kinematic, 10 backlash_position delta, 11 omega_twist (10 and 11
//! with `gear_backlash`, else derivative 0), 12 W_external. The derivatives are those of
//! [`Plant::eval`], the right-hand side `do_step` integrates; the energy integrals are ordinary
//! states (`E_dissipated` = the plant's loss integral + `E_string_kinematic`, `W_external` =
//! int F_load v dt).
//!
//! Non-smooth terms of the right-hand side and how each is handled:
//! * slack strings, gear-flank contact, the flank that cannot pull: [`smooth_pos`] (C-infinity);
//! * gearhead efficiency direction, Coulomb motor friction, inter-strand friction: `tanh`
//!   (C-infinity);
//! * PI output limits (current limit, supply voltage) and clamping anti-windup: continuous
//!   (Lipschitz) by construction ([`crate::controller::pi_integrator_rate`] fades linearly);
//! * `radius_growth` `r0 (1 + g |theta_t| / 2 pi)`: the twist arc and its slope are continuous
//!   (C1), so is the right-hand side;
//! * `string_compliance` free length `a1 |theta_M|` (eq. 10): its rate `a1 sign(theta_M)` enters
//!   the strand stretch rate and thereby the string damping force, which jumps when the twist
//!   crosses zero. The one true discontinuity: event indicator 0 is the twist angle while
//!   `string_compliance` is on (constant 1 otherwise);
//! * encoder quantisation, position band and speed-limit clamp: evaluated at the time events only.

use crate::model::{validate, TwistedString};
use crate::plant::{ix, Aux, Inputs, Params, Plant, DIM};
use crate::vars::{V, VARIABLES};
use fmu_core::{ModelError, ModelExchange, ValuesMut};
use ode::SampleClock;

#[cfg(doc)]
use crate::physics::smooth_pos;

/// Number of continuous states.
pub const STATES: usize = 13;

/// Index names of the Model Exchange state vector.
pub mod sx {
    pub const I: usize = 0;
    pub const THETA: usize = 1;
    pub const OMEGA: usize = 2;
    pub const P: usize = 3;
    pub const V: usize = 4;
    pub const ZI: usize = 5;
    pub const ZW: usize = 6;
    pub const E_EL: usize = 7;
    pub const E_DISS: usize = 8;
    pub const E_KIN: usize = 9;
    pub const DELTA: usize = 10;
    pub const OMEGA_T: usize = 11;
    pub const W_EXT: usize = 12;
}

/// `(state, derivative)` value references in the order of `x` (the table is numbered densely, so
/// a variable's position is its value reference; a unit test holds this).
pub static STATE_VARIABLES: [(usize, usize); STATES] = [
    (V::CURRENT as usize, V::DER_CURRENT as usize),
    (V::THETA_MOTOR as usize, V::DER_THETA_MOTOR as usize),
    (V::OMEGA_MOTOR as usize, V::DER_OMEGA_MOTOR as usize),
    (V::P as usize, V::DER_P as usize),
    (V::V_LOAD as usize, V::DER_V_LOAD as usize),
    (
        V::CURRENT_INTEGRAL as usize,
        V::DER_CURRENT_INTEGRAL as usize,
    ),
    (V::SPEED_INTEGRAL as usize, V::DER_SPEED_INTEGRAL as usize),
    (V::E_ELECTRICAL as usize, V::DER_E_ELECTRICAL as usize),
    (V::E_DISSIPATED as usize, V::DER_E_DISSIPATED as usize),
    (
        V::E_STRING_KINEMATIC as usize,
        V::DER_E_STRING_KINEMATIC as usize,
    ),
    (
        V::BACKLASH_POSITION as usize,
        V::DER_BACKLASH_POSITION as usize,
    ),
    (V::OMEGA_TWIST as usize, V::DER_OMEGA_TWIST as usize),
    (V::W_EXTERNAL as usize, V::DER_W_EXTERNAL as usize),
];

const I: usize = V::CURRENT as usize;
const TH: usize = V::THETA_MOTOR as usize;
const OM: usize = V::OMEGA_MOTOR as usize;
const P: usize = V::P as usize;
const VL: usize = V::V_LOAD as usize;
const ZI: usize = V::CURRENT_INTEGRAL as usize;
const ZW: usize = V::SPEED_INTEGRAL as usize;
const DL: usize = V::BACKLASH_POSITION as usize;
const WT: usize = V::OMEGA_TWIST as usize;
const VOLTAGE: usize = V::VOLTAGE as usize;
const F_LOAD: usize = V::F_LOAD as usize;
/// The armature voltage: the current PI (i, omega, z_i, z_w) or the input.
const DEP_VOLTAGE: &[usize] = &[I, OM, ZI, ZW, VOLTAGE];
/// What the strings and the gear depend on: twist (theta, delta), its rate (omega or omega_t),
/// the load position and speed (stretch and its rate).
const DEP_MECHANICS: &[usize] = &[TH, OM, P, VL, DL, WT];

/// Per state, in the order of `x`: the states and inputs (table positions) its derivative
/// depends on under any parameter setting, read off [`Plant::eval`]. The set point enters at
/// the position loop's samples only, so no derivative depends on it.
static DERIVATIVE_DEPENDENCIES: [&[usize]; STATES] = [
    DEP_VOLTAGE,
    &[OM],
    &[I, TH, OM, P, VL, DL, WT],
    &[VL],
    &[TH, OM, P, VL, DL, WT, F_LOAD],
    &[I, OM, ZI, ZW],
    &[OM, ZW],
    DEP_VOLTAGE,
    &[I, TH, OM, P, VL, DL, WT],
    DEP_MECHANICS,
    &[OM, WT],
    DEP_MECHANICS,
    &[VL, F_LOAD],
];

/// The state vector `x` from the plant state `y` and the external work.
pub fn pack(y: &[f64; DIM], w_external: f64) -> [f64; STATES] {
    let mut x = [0.0; STATES];
    x[..ix::E_LOSS].copy_from_slice(&y[..ix::E_LOSS]);
    x[sx::E_DISS] = y[ix::E_LOSS] + y[ix::E_KIN];
    x[sx::E_KIN] = y[ix::E_KIN];
    x[sx::DELTA] = y[ix::DELTA];
    x[sx::OMEGA_T] = y[ix::OMEGA_T];
    x[sx::W_EXT] = w_external;
    x
}

/// The plant state `y` and the external work from the state vector `x` (inverse of [`pack`]).
pub fn unpack(x: &[f64]) -> ([f64; DIM], f64) {
    let mut y = [0.0; DIM];
    y[..ix::E_LOSS].copy_from_slice(&x[..sx::E_DISS]);
    y[ix::E_LOSS] = x[sx::E_DISS] - x[sx::E_KIN];
    y[ix::E_KIN] = x[sx::E_KIN];
    y[ix::DELTA] = x[sx::DELTA];
    y[ix::OMEGA_T] = x[sx::OMEGA_T];
    (y, x[sx::W_EXT])
}

/// `dx/dt` from the plant's right-hand side at `x` (an effect's unused states get 0).
pub fn rates(par: &Params, inp: Inputs, x: &[f64], dx: &mut [f64]) {
    let (y, _) = unpack(x);
    let aux = Plant { par, inp }.eval(&y);
    state_rates(&aux, y[ix::V], inp.f_load, dx);
}

/// `dx/dt` from the plant's quantities `aux` at load speed `v`.
fn state_rates(aux: &Aux, v: f64, f_load: f64, dx: &mut [f64]) {
    dx[..ix::E_LOSS].copy_from_slice(&aux.dy[..ix::E_LOSS]);
    dx[sx::E_DISS] = aux.p_loss + aux.p_kin;
    dx[sx::E_KIN] = aux.p_kin;
    dx[sx::DELTA] = aux.dy[ix::DELTA];
    dx[sx::OMEGA_T] = aux.dy[ix::OMEGA_T];
    dx[sx::W_EXT] = f_load * v;
}

/// `d(dx/dt)/dx` (row r = equation of state r, column c = state c): the plant's analytic
/// Jacobian [`Plant::jacobian_rows`] carried through the linear state maps, `J_x = P J_y U` with
/// `x = P y` ([`pack`]) and `y = U x` ([`unpack`]), plus the row of `W_external`,
/// `d(F_load v)/dv = F_load`.
pub fn jacobian(par: &Params, inp: Inputs, x: &[f64]) -> [[f64; STATES]; STATES] {
    let (y, _) = unpack(x);
    let jy = Plant { par, inp }.jacobian_rows(&y);
    // columns: d f_i / d x_c = sum_j J_y[i][j] U[j][c]
    let g: [[f64; STATES]; DIM] = std::array::from_fn(|i| {
        let r = &jy[i];
        let mut row = [0.0; STATES];
        row[..ix::E_LOSS].copy_from_slice(&r[..ix::E_LOSS]);
        row[sx::E_DISS] = r[ix::E_LOSS];
        row[sx::E_KIN] = r[ix::E_KIN] - r[ix::E_LOSS];
        row[sx::DELTA] = r[ix::DELTA];
        row[sx::OMEGA_T] = r[ix::OMEGA_T];
        row
    });
    // rows: dx_r = sum_i P[r][i] f_i
    let mut j = [[0.0; STATES]; STATES];
    j[..ix::E_LOSS].copy_from_slice(&g[..ix::E_LOSS]);
    for c in 0..STATES {
        j[sx::E_DISS][c] = g[ix::E_LOSS][c] + g[ix::E_KIN][c];
    }
    j[sx::E_KIN] = g[ix::E_KIN];
    j[sx::DELTA] = g[ix::DELTA];
    j[sx::OMEGA_T] = g[ix::OMEGA_T];
    j[sx::W_EXT][sx::V] = inp.f_load;
    j
}

/// Parameter groups (table positions) by the part of the model they enter, for the FMI 3.0
/// `<ModelStructure>` (FMI 3.0.2 section 2.4.8: parameters are knowns of the outputs and
/// derivatives; `Plant::eval`). The twist angle at the gearhead output: the gear ratio, with
/// `gear_backlash` less the position in the gap.
const GEAR: &[usize] = &[V::GEAR_RATIO as usize, V::GEAR_BACKLASH_ENABLED as usize];
/// The helix (eq. 9): string radius and its growth with the twist.
const HELIX: &[usize] = &[
    V::STRING_RADIUS as usize,
    V::RADIUS_GROWTH_ENABLED as usize,
    V::RADIUS_GROWTH_PER_TURN as usize,
];
/// The strings' tension: length, stiffness, damping, the compliance law (eq. 10).
const STRING: &[usize] = &[
    V::STRING_LENGTH as usize,
    V::STRING_STIFFNESS as usize,
    V::STRING_DAMPING as usize,
    V::STRING_COMPLIANCE_ENABLED as usize,
    V::STRING_COMPLIANCE_A1 as usize,
    V::STRING_COMPLIANCE_A2 as usize,
    V::STRING_COMPLIANCE_A3 as usize,
];
/// The gearhead output with `gear_backlash`: the gap and the flanks.
const BACKLASH: &[usize] = &[
    V::GEAR_BACKLASH_ENABLED as usize,
    V::GEAR_BACKLASH_ANGLE as usize,
    V::GEAR_RATIO as usize,
];
/// Friction on the motor side: gear efficiency, motor friction; inter-strand friction.
const FRICTION: &[usize] = &[
    V::GEAR_EFFICIENCY as usize,
    V::MOTOR_FRICTION_ENABLED as usize,
    V::MOTOR_FRICTION_COULOMB as usize,
    V::MOTOR_FRICTION_VISCOUS as usize,
    V::TWIST_HYSTERESIS_ENABLED as usize,
    V::TWIST_HYSTERESIS_FRICTION_COEFFICIENT as usize,
];
/// The armature circuit.
const ARMATURE: &[usize] = &[
    V::MOTOR_RESISTANCE as usize,
    V::MOTOR_INDUCTANCE as usize,
    V::BACK_EMF_CONSTANT as usize,
    V::TORQUE_CONSTANT as usize,
];
/// The sampled position loop: encoder, P law with its band, speed limit, period (its speed set
/// point is computed at the ticks and held).
const POSITION: &[usize] = &[
    V::INTERNAL_CONTROLLER as usize,
    V::CONTROLLER_POSITION_P as usize,
    V::CONTROLLER_POSITION_BAND as usize,
    V::CONTROLLER_POSITION_PERIOD as usize,
    V::SPEED_LIMIT as usize,
    V::ENCODER_CPT as usize,
];
/// The continuous current and speed PI loops and their limits (or open loop the input).
const CASCADE: &[usize] = &[
    V::CONTROLLER_CURRENT_P as usize,
    V::CONTROLLER_CURRENT_TI as usize,
    V::CONTROLLER_SPEED_P as usize,
    V::CONTROLLER_SPEED_TI as usize,
    V::CURRENT_LIMIT as usize,
    V::SUPPLY_VOLTAGE as usize,
];
/// The load: mass, return spring (its free length is the string length), guide.
const LOAD: &[usize] = &[
    V::LOAD_MASS as usize,
    V::SPRING_STIFFNESS as usize,
    V::SPRING_PRELOAD as usize,
    V::GUIDE_DAMPING as usize,
    V::STRING_LENGTH as usize,
];
const P_ALPHA: &[usize] = fmu_core::parameter_groups!(GEAR, HELIX);
const P_STRINGS: &[usize] = fmu_core::parameter_groups!(GEAR, HELIX, STRING);
const P_F_STRING: &[usize] =
    fmu_core::parameter_groups!(GEAR, HELIX, STRING, [V::STRING_COUNT as usize]);
const P_MECHANICS: &[usize] = fmu_core::parameter_groups!(GEAR, HELIX, STRING, BACKLASH, FRICTION);
const P_MOTOR: &[usize] = fmu_core::parameter_groups!(
    GEAR,
    HELIX,
    STRING,
    BACKLASH,
    FRICTION,
    [V::TORQUE_CONSTANT as usize, V::ROTOR_INERTIA as usize]
);
const P_LOAD: &[usize] = fmu_core::parameter_groups!(GEAR, HELIX, STRING, LOAD);
const P_VOLTAGE: &[usize] = fmu_core::parameter_groups!(POSITION, CASCADE);
const P_CURRENT: &[usize] = fmu_core::parameter_groups!(POSITION, CASCADE, ARMATURE);
const P_LOSSES: &[usize] = fmu_core::parameter_groups!(
    GEAR,
    HELIX,
    STRING,
    BACKLASH,
    FRICTION,
    ARMATURE,
    [V::GUIDE_DAMPING as usize]
);
const P_STORED: &[usize] = fmu_core::parameter_groups!(
    GEAR,
    HELIX,
    STRING,
    BACKLASH,
    LOAD,
    [V::MOTOR_INDUCTANCE as usize, V::ROTOR_INERTIA as usize]
);
const P_MEASURED: &[usize] = &[
    V::INTERNAL_CONTROLLER as usize,
    V::ENCODER_CPT as usize,
    V::CONTROLLER_POSITION_PERIOD as usize,
];

/// Per output and derivative, the parameters its value depends on under any setting of the
/// others (the states, `der(theta_motor)`, `der(p)` and `der(W_external)` depend on none).
static PARAMETER_DEPENDENCIES: &[(usize, &[usize])] = &[
    (V::THETA_TWIST as usize, GEAR),
    (V::TAU_MOTOR as usize, &[V::TORQUE_CONSTANT as usize]),
    (V::F_STRING as usize, P_F_STRING),
    (V::F_TANGENTIAL as usize, P_STRINGS),
    (V::ALPHA as usize, P_ALPHA),
    (V::TRANSMISSION_RATIO as usize, P_STRINGS),
    (V::STIFFNESS as usize, P_STRINGS),
    (V::F_AXIAL as usize, P_STRINGS),
    (V::VOLTAGE_MOTOR as usize, P_VOLTAGE),
    (V::OMEGA_REF as usize, POSITION),
    (V::THETA_MOTOR_MEASURED as usize, P_MEASURED),
    (V::E_STORED as usize, P_STORED),
    (V::DER_CURRENT as usize, P_CURRENT),
    (V::DER_OMEGA_MOTOR as usize, P_MOTOR),
    (V::DER_V_LOAD as usize, P_LOAD),
    (V::DER_CURRENT_INTEGRAL as usize, P_VOLTAGE),
    (V::DER_SPEED_INTEGRAL as usize, P_VOLTAGE),
    (V::DER_E_ELECTRICAL as usize, P_VOLTAGE),
    (V::DER_E_DISSIPATED as usize, P_LOSSES),
    (V::DER_E_STRING_KINEMATIC as usize, P_STRINGS),
    (V::DER_BACKLASH_POSITION as usize, BACKLASH),
    (V::DER_OMEGA_TWIST as usize, P_MECHANICS),
    (V::DER_THETA_MOTOR as usize, &[]),
    (V::DER_P as usize, &[]),
];

/// Write the states that are not outputs and every `der(...)` variable (shared by Model
/// Exchange and Co-Simulation, where they are informative locals).
pub(crate) fn write_state_variables(out: &mut ValuesMut, y: &[f64; DIM], aux: &Aux, f_load: f64) {
    out.set(V::CURRENT_INTEGRAL, y[ix::ZI]);
    out.set(V::SPEED_INTEGRAL, y[ix::ZW]);
    out.set(V::BACKLASH_POSITION, y[ix::DELTA]);
    out.set(V::OMEGA_TWIST, y[ix::OMEGA_T]);
    let mut dx = [0.0; STATES];
    state_rates(aux, y[ix::V], f_load, &mut dx);
    for (&(_, d), r) in STATE_VARIABLES.iter().zip(dx) {
        out.0[d] = r;
    }
}

/// Event indicator: the twist angle while `string_compliance` is on (its free length has a kink
/// at zero twist), else the constant 1 (no state event).
pub fn twist_indicator(par: &Params, y: &[f64; DIM]) -> f64 {
    if par.string_compliance.is_none() {
        return 1.0;
    }
    // the twist angle exactly as Plant::eval forms it
    match par.gear_backlash {
        None => y[ix::THETA] / par.gear_ratio,
        Some(_) => y[ix::THETA] / par.gear_ratio - y[ix::DELTA],
    }
}

impl TwistedString {
    /// The sample clock of the position loop, when the internal controller runs.
    fn clock(&self) -> Option<SampleClock> {
        if self.par.internal_controller {
            SampleClock::new(self.t0, self.par.controller_position_period)
        } else {
            None
        }
    }
}

impl ModelExchange for TwistedString {
    const STATES: usize = STATES;
    const EVENT_INDICATORS: usize = 1;

    fn state_variables() -> &'static [(usize, usize)] {
        &STATE_VARIABLES
    }

    fn derivative_dependencies() -> Option<&'static [&'static [usize]]> {
        Some(&DERIVATIVE_DEPENDENCIES)
    }

    fn parameter_dependencies() -> Option<&'static [(usize, &'static [usize])]> {
        Some(PARAMETER_DEPENDENCIES)
    }

    /// Every parameter read and checked again (as at initialization); the states, the
    /// controller's held set point and the encoder reading are kept.
    fn set_parameters(&mut self, vars: &[f64]) -> Result<(), ModelError> {
        let par = Params::read(vars);
        validate(&par)?;
        self.par = par;
        Ok(())
    }

    fn states(&self, x: &mut [f64]) {
        x.copy_from_slice(&pack(&self.y, self.w_external));
    }

    fn set_states(&mut self, x: &[f64]) {
        (self.y, self.w_external) = unpack(x);
    }

    /// The plant's nominals (those `do_step` scales its absolute tolerances with); 1 J for
    /// `E_dissipated` and `W_external`.
    /// The `nominal` each state's variable declares (vars.rs, where each is reasoned), as the
    /// description gives it: the importer's scale, apart from the internal solver's
    /// [`crate::plant::NOMINAL`], which Co-Simulation keeps.
    fn nominals(&self, n: &mut [f64]) {
        for (n, &(s, _)) in n.iter_mut().zip(&STATE_VARIABLES) {
            *n = VARIABLES[s].nominal.unwrap_or(1.0);
        }
    }

    fn derivatives(&self, vars: &[f64], _t: f64, dx: &mut [f64]) -> Result<(), ModelError> {
        let x = pack(&self.y, self.w_external);
        rates(&self.par, self.make_inputs(vars), &x, dx);
        Ok(())
    }

    fn me_outputs(&self, vars: &mut [f64], _t: f64) {
        let inp = self.make_inputs(vars);
        self.write_outputs(vars, inp);
    }

    /// The next position-loop sample `t0 + k Ts` (none in open loop).
    fn next_time_event(&self) -> Option<f64> {
        self.clock().map(|c| c.time(self.pos.next_sample))
    }

    /// Every position-loop sample due at `t` (as `do_step` takes them): the encoder angle and
    /// the new speed set point, held until the next sample.
    fn event_update(&mut self, vars: &mut [f64], t: f64) -> Result<bool, ModelError> {
        let Some(clock) = self.clock() else {
            return Ok(false);
        };
        let theta_ref = vars[V::THETA_MOTOR_REF as usize];
        let before = (self.pos.omega_ref, self.theta_meas);
        while clock.is_due(self.pos.next_sample, t) {
            self.position_sample(theta_ref);
        }
        let changed = before != (self.pos.omega_ref, self.theta_meas);
        if changed {
            let inp = self.make_inputs(vars);
            self.write_outputs(vars, inp);
        }
        Ok(changed)
    }

    const PROVIDES_JACOBIAN: bool = true;

    /// The plant's analytic Jacobian through the state maps ([`jacobian`]).
    fn state_jacobian(&self, vars: &[f64], _t: f64, jac: &mut [f64]) -> Result<(), ModelError> {
        let x = pack(&self.y, self.w_external);
        let j = jacobian(&self.par, self.make_inputs(vars), &x);
        for (out, row) in jac.chunks_exact_mut(STATES).zip(&j) {
            out.copy_from_slice(row);
        }
        Ok(())
    }

    fn event_indicators(&self, _vars: &[f64], _t: f64, z: &mut [f64]) {
        z[0] = twist_indicator(&self.par, &self.y);
    }
}

#[cfg(test)]
mod tests {
    use super::{jacobian, pack, rates, sx, unpack, STATES, STATE_VARIABLES};
    use crate::model::TwistedString;
    use crate::physics::GRAVITY;
    use crate::plant::{with_every_effect, Inputs, Params, DIM, NOMINAL};
    use crate::vars::{V, VARIABLES};
    use fmu_core::{Model, ModelExchange};

    #[test]
    fn pack_unpack_roundtrip() {
        let y: [f64; DIM] = std::array::from_fn(|k| 0.37 * k as f64 - 1.1);
        let x = pack(&y, 2.5);
        let (y2, w) = unpack(&x);
        assert_eq!(w, 2.5);
        for k in 0..DIM {
            assert!((y[k] - y2[k]).abs() <= 1e-15 * y[k].abs().max(1.0), "{k}");
        }
    }

    #[test]
    fn state_variables_are_consistent() {
        for &(s, d) in &STATE_VARIABLES {
            // the table is numbered densely: position in the table = value reference
            assert_eq!(VARIABLES[s].value_reference as usize, s);
            assert_eq!(VARIABLES[d].value_reference as usize, d);
            assert_eq!(
                VARIABLES[d].name,
                format!("der({})", VARIABLES[s].name),
                "{s} {d}"
            );
        }
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let mut par = Params::read(&VARIABLES.iter().map(|v| v.start).collect::<Vec<_>>());
        for all in [false, true] {
            if all {
                par = with_every_effect(&par, 1f64.to_radians());
            }
            let inp = Inputs {
                theta_ref: 0.0,
                voltage: 5.0,
                f_load: 12.0,
                omega_ref: 200.0,
                theta_offset: 0.0,
            };
            // taut strings near 100 N at 600 rad of motor angle, output on the +b/2 flank
            let th = 600.0;
            let a = crate::physics::twist_arc(th / 19.2, par.string_radius, 0.0).0;
            let p = (0.0899f64.powi(2) - a * a).sqrt();
            let mut x = [
                0.4, th, 300.0, p, -0.004, 2e-4, 3.0, 1.0, 0.8, 0.1, 0.0, 15.0, 0.2,
            ];
            if all {
                x[sx::DELTA] = 0.5 * 1f64.to_radians() + 1e-4;
            }
            let nominal = pack(&NOMINAL, 1.0);
            let jac = jacobian(&par, inp, &x);
            let mut f0 = [0.0; STATES];
            rates(&par, inp, &x, &mut f0);
            // per row, the largest change over one nominal of any state: the scale under which
            // a partial is roundoff of the differences
            let row_scale: [f64; STATES] = std::array::from_fn(|r| {
                (0..STATES)
                    .map(|c| (jac[r][c] * nominal[c]).abs())
                    .fold(0.0, f64::max)
            });
            for c in 0..STATES {
                let h = 1e-6 * nominal[c].max(1e-2 * x[c].abs());
                let (mut xp, mut xm) = (x, x);
                xp[c] += h;
                xm[c] -= h;
                let (mut fp, mut fm) = ([0.0; STATES], [0.0; STATES]);
                rates(&par, inp, &xp, &mut fp);
                rates(&par, inp, &xm, &mut fm);
                for r in 0..STATES {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    let an = jac[r][c];
                    let noise = 1e3 * f64::EPSILON * f0[r].abs().max(fp[r].abs()) / h;
                    assert!(
                        (fd - an).abs()
                            <= 1e-4 * fd.abs().max(an.abs())
                                + noise
                                + 1e-7 * row_scale[r] / nominal[c]
                                + 1e-8,
                        "all {all}: d f{r}/d x{c}: analytic {an} vs differences {fd}"
                    );
                }
            }
        }
    }

    /// The ME system for the `ode` integrator: the model's right-hand side at fixed inputs.
    struct MeSystem<'a> {
        par: &'a Params,
        inp: Inputs,
    }

    impl ode::OdeSystem for MeSystem<'_> {
        fn dim(&self) -> usize {
            STATES
        }
        fn rhs(&self, _t: f64, x: &[f64], dx: &mut [f64]) {
            rates(self.par, self.inp, x, dx);
        }
        fn autonomous(&self) -> bool {
            true
        }
    }

    /// The declared parameter dependencies name every parameter that moves an output or a
    /// derivative: every effect on, mid-motion under load, closed loop and open loop.
    #[test]
    fn declared_parameter_dependencies_cover_the_equations() {
        for internal in [1.0, 0.0] {
            let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
            for (i, var) in VARIABLES.iter().enumerate() {
                if var.name.ends_with(".enabled") {
                    vars[i] = 1.0;
                }
            }
            vars[V::INTERNAL_CONTROLLER as usize] = internal;
            vars[V::VOLTAGE as usize] = 6.0;
            let mut m = TwistedString::new();
            m.initialize(&mut vars, 0.0).unwrap();
            for k in 0..100 {
                inputs_at(k as f64 * 1e-3, &mut vars);
                m.do_step(&mut vars, k as f64 * 1e-3, 1e-3).unwrap();
            }
            let problems = fmu_core::me::parameter_dependency_problems(&m, &vars, 0.1);
            assert!(problems.is_empty(), "{problems:#?}");
        }
    }

    fn start_vars(effects: &[V], tol: f64) -> Vec<f64> {
        let mut vars: Vec<f64> = VARIABLES.iter().map(|v| v.start).collect();
        for e in effects {
            vars[*e as usize] = 1.0;
        }
        vars[V::RTOL as usize] = tol;
        vars[V::ATOL as usize] = tol;
        vars[V::LOAD_MASS as usize] = 54.0 / GRAVITY;
        vars
    }

    /// The set point and load of the comparison run at `t`: a twist to 900 rad, an extra load,
    /// back to 300 rad.
    fn inputs_at(t: f64, vars: &mut [f64]) {
        vars[V::THETA_MOTOR_REF as usize] = if t < 0.6 { 900.0 } else { 300.0 };
        vars[V::F_LOAD as usize] = if t < 0.3 { 0.0 } else { 20.0 };
    }

    const OUTPUTS: [V; 7] = [
        V::P,
        V::THETA_MOTOR,
        V::OMEGA_MOTOR,
        V::CURRENT,
        V::E_ELECTRICAL,
        V::E_DISSIPATED,
        V::W_EXTERNAL,
    ];

    /// Co-Simulation: `do_step` with 1 ms communication steps; outputs every 1 ms.
    fn run_cs(effects: &[V], tol: f64, n: usize) -> Vec<Vec<f64>> {
        run_cs_with(effects, tol, n, 1e-3, inputs_at, Points::Exact)
    }

    /// How an importer reaches its communication points (nominally `k h`).
    #[derive(Clone, Copy, Debug)]
    enum Points {
        /// `k h` exactly.
        Exact,
        /// `h + h + ...`: a rounding after the sample instants (for `h` = 1 ms).
        Summed,
        /// `k h` moved by `s k h` (|s| 1e-13, well inside the clock's 1e-9 Ts): a rounding
        /// before (`s < 0`) or after the sample instants.
        Skewed(f64),
    }

    impl Points {
        fn all(self, h: f64, n: usize) -> Vec<f64> {
            let mut sum = 0.0;
            (0..=n)
                .map(|k| {
                    let exact = k as f64 * h;
                    let t = match self {
                        Points::Exact => exact,
                        Points::Summed => sum,
                        Points::Skewed(s) => exact * (1.0 + s),
                    };
                    sum += h;
                    t
                })
                .collect()
        }
    }

    /// Co-Simulation: `do_step` from each communication point to the next (`points`, nominally
    /// `k h`), the inputs `inputs(k h)` set at each point; outputs at the end of each step.
    fn run_cs_with(
        effects: &[V],
        tol: f64,
        n: usize,
        h: f64,
        inputs: fn(f64, &mut [f64]),
        points: Points,
    ) -> Vec<Vec<f64>> {
        let mut vars = start_vars(effects, tol);
        let mut m = TwistedString::new();
        m.initialize(&mut vars, 0.0).unwrap();
        let mut out = vec![];
        for (k, w) in points.all(h, n).windows(2).enumerate() {
            // the inputs of point k (a rounding of its time must not move an input's jump)
            inputs(k as f64 * h, &mut vars);
            m.do_step(&mut vars, w[0], w[1] - w[0]).unwrap();
            out.push(OUTPUTS.iter().map(|v| vars[*v as usize]).collect());
        }
        out
    }

    /// Model Exchange through the trait, integrated by `ode` between time events (the importer's
    /// part): outputs every 1 ms before the event there (the left limit), then the inputs at that
    /// instant, the event update at each tick, integrate to the next.
    fn run_me(effects: &[V], tol: f64, n: usize) -> Vec<Vec<f64>> {
        run_me_with(effects, tol, n, 1e-3, inputs_at)
    }

    /// Model Exchange as [`run_me`], outputs and input changes every `h`.
    fn run_me_with(
        effects: &[V],
        tol: f64,
        n: usize,
        h: f64,
        inputs_at: fn(f64, &mut [f64]),
    ) -> Vec<Vec<f64>> {
        let mut vars = start_vars(effects, tol);
        let mut m = TwistedString::new();
        m.initialize(&mut vars, 0.0).unwrap();
        let mut nominal = [0.0; STATES];
        m.nominals(&mut nominal);
        let mut integ = ode::Integrator::new(tol, nominal.iter().map(|n| tol * n).collect());
        let mut x = [0.0; STATES];
        let mut out = vec![];
        let mut t = 0.0;
        inputs_at(t, &mut vars);
        for k in 1..=n {
            let t_out = k as f64 * h;
            loop {
                // the samples due at t, with the inputs set at t (as do_step takes a sample at
                // the start of a step)
                while m.event_update(&mut vars, t).unwrap() {}
                let t_next = m.next_time_event().map_or(t_out, |te| te.min(t_out));
                m.states(&mut x);
                let sys = MeSystem {
                    par: &m.par,
                    inp: m.make_inputs(&vars),
                };
                integ.reset_step_size();
                integ.integrate(&sys, t, t_next, &mut x).unwrap();
                m.set_states(&x);
                t = t_next;
                if t >= t_out - 1e-12 {
                    break;
                }
            }
            m.me_outputs(&mut vars, t);
            out.push(OUTPUTS.iter().map(|v| vars[*v as usize]).collect());
            inputs_at(t, &mut vars);
        }
        out
    }

    /// Largest difference per output over the run.
    fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<f64> {
        let mut d = vec![0.0f64; OUTPUTS.len()];
        for (ra, rb) in a.iter().zip(b) {
            for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
                d[k] = d[k].max((x - y).abs());
            }
        }
        d
    }

    #[test]
    fn me_reproduces_co_simulation() {
        for effects in [
            vec![],
            vec![
                V::STRING_COMPLIANCE_ENABLED,
                V::TWIST_HYSTERESIS_ENABLED,
                V::MOTOR_FRICTION_ENABLED,
                V::GEAR_BACKLASH_ENABLED,
                V::RADIUS_GROWTH_ENABLED,
            ],
        ] {
            let n = 1000;
            let cs = run_cs(&effects, 1e-8, n);
            let me = run_me(&effects, 1e-8, n);
            let d = max_diff(&cs, &me);
            eprintln!("effects {effects:?}: max |ME - CS| {OUTPUTS:?} = {d:?}");
            // the run moves: up to 900 rad and back toward 300 rad
            let theta_max = cs.iter().map(|r| r[1]).fold(0.0, f64::max);
            assert!(
                theta_max > 500.0 && cs[n - 1][1] < 0.9 * theta_max,
                "{theta_max}"
            );
            // p [m], theta [rad], omega [rad/s], i [A], energies [J]: the solvers' tolerance
            // (1e-8 of the nominals 1 cm, 1 rad, 10 rad/s, 1 A, 1 J) times the ~1e3 steps
            let bound = [1e-9, 1e-5, 1e-3, 1e-5, 1e-6, 1e-6, 1e-6];
            for (k, (dk, bk)) in d.iter().zip(bound).enumerate() {
                assert!(*dk < bk, "{:?}: {dk:e} >= {bk:e}", OUTPUTS[k]);
            }
        }
    }

    /// A set point ramping at 400 rad/s from 0.05 s (the motor follows it, below the speed
    /// limit), F_load stepping at 0.2 s.
    fn ramp_at(t: f64, vars: &mut [f64]) {
        vars[V::THETA_MOTOR_REF as usize] = 400.0 * (t - 0.05).max(0.0);
        vars[V::F_LOAD as usize] = if t < 0.2 { 0.0 } else { 20.0 };
    }

    /// A sample at a communication point is taken at the start of the step from there, with
    /// the inputs set there, in Co-Simulation as in Model Exchange (the time event sees the
    /// inputs at its instant), so a moving set point gives the same trace in both: communication
    /// steps of 1 ms (every end a sample), 0.25 ms (every fourth), 2.5 ms (samples inside the
    /// steps held at the step's input, as Model Exchange holding its inputs between the same
    /// points) and 1 ms points a rounding before or after the samples (summed, or moved by
    /// 1e-13 relative): each counts as on the sample.
    /// Taking the sample at the end of the step with that step's input lagged the set point
    /// by one sample: theta_motor 0.38 rad and omega_motor 3.5 rad/s apart at 1 ms steps.
    #[test]
    fn cs_takes_a_sample_at_a_communication_point_with_the_new_inputs() {
        for (h, points) in [
            (1e-3f64, Points::Exact),
            (2.5e-4, Points::Exact),
            (2.5e-3, Points::Exact),
            (1e-3, Points::Summed),
            (1e-3, Points::Skewed(-1e-13)),
            (1e-3, Points::Skewed(1e-13)),
        ] {
            let n = (0.4 / h).round() as usize;
            let cs = run_cs_with(&[], 1e-8, n, h, ramp_at, points);
            let me = run_me_with(&[], 1e-8, n, h, ramp_at);
            let d = max_diff(&cs, &me);
            eprintln!("h {h:e} {points:?}: max |ME - CS| {OUTPUTS:?} = {d:?}");
            // the run moves: the motor follows the set point (140 rad at the end) with the P
            // law's lag of 400 / 8.75 = 46 rad
            assert!(cs[n - 1][1] > 80.0, "{}", cs[n - 1][1]);
            let bound = [1e-9, 1e-5, 1e-3, 1e-5, 1e-6, 1e-6, 1e-6];
            for (k, (dk, bk)) in d.iter().zip(bound).enumerate() {
                assert!(*dk < bk, "h {h}: {:?}: {dk:e} >= {bk:e}", OUTPUTS[k]);
            }
        }
    }
}
