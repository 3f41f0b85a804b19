//! Directional and adjoint derivatives of [`Instance`] in both interfaces: the model's analytic
//! state Jacobian (kept for the current point, [`JacobianCache`]) for derivatives with respect
//! to states, central differences of the model's equations for the other knowns.

use crate::instance::{Instance, Status};
use crate::machine::{Checked, MachineState};
use crate::{MeVTable, Model};

/// What a variable of a directional derivative is, by its position in the state vector.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Role {
    /// The state `x_k` (a known) or the derivative `dx_k` (an unknown).
    State(usize),
    /// An input (a known) or an output (an unknown): a position in the table.
    Variable(usize),
    /// A Real parameter (a known, FMI 3.0 only): a position in the table.
    Parameter(usize),
}

/// The knowns a directional derivative accepts outside Initialization Mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Knowns {
    /// The states and the inputs (FMI 2.0.4 section 3.2.1).
    StatesAndInputs,
    /// The states, the inputs and the Real parameters (FMI 3.0.2 section 2.4.8: parameters are
    /// knowns of `<Output>` and `<ContinuousStateDerivative>`, and a listed known "is a valid
    /// input" of `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative`).
    WithParameters,
}

/// Relative step of the central differences of [`Instance::get_directional_derivative`] for
/// what the analytic Jacobian does not cover: about the cube root of the machine epsilon, where
/// truncation and rounding errors of a central difference balance.
const CENTRAL_STEP: f64 = 6e-6;

impl<M: Model> Instance<M> {
    /// The Model Exchange table for a directional derivative in either interface: Model
    /// Exchange at the current time and states, Co-Simulation at the communication point, where
    /// the instance holds the plant's states and the unknowns of `<ModelStructure>` (outputs and
    /// state derivatives) have the same knowns (inputs and states; FMI 2.0.4 sections 2.1.9 and
    /// 2.2.8, FMI 3.0.2 section 2.2.11). A logged error when the model has no Jacobian.
    fn derivative_table(&mut self, func: &str) -> Result<MeVTable<M>, Status> {
        match self.me.filter(|me| me.provides_jacobian) {
            Some(me) => Ok(me),
            None => Err(self.error(
                func,
                "not provided (providesDirectionalDerivative=\"false\")",
            )),
        }
    }

    /// Positions of `vrs` with their roles: unknowns are derivatives or outputs, knowns states
    /// or inputs (FMI 2.0.4 section 3.2.1, fmi2GetDirectionalDerivative in Model Exchange), and
    /// with [`Knowns::WithParameters`] Real parameters.
    fn roles(
        &mut self,
        func: &str,
        me: &MeVTable<M>,
        vrs: &[u32],
        known: Option<Knowns>,
        roles: &mut Vec<Role>,
    ) -> Result<(), Status> {
        let table = M::variables();
        roles.clear();
        for &vr in vrs {
            let Some(i) = crate::variables::index_of(table, vr) else {
                return Err(self.error(func, format!("unknown value reference {vr}")));
            };
            let k =
                me.state_variables
                    .iter()
                    .position(|&(x, d)| if known.is_some() { x == i } else { d == i });
            let causality = if known.is_some() {
                crate::Causality::Input
            } else {
                crate::Causality::Output
            };
            let parameter = known == Some(Knowns::WithParameters)
                && table[i].causality == crate::Causality::Parameter
                && table[i].vtype == crate::VarType::Real;
            match k {
                Some(k) => roles.push(Role::State(k)),
                None if table[i].causality == causality => roles.push(Role::Variable(i)),
                None if parameter => roles.push(Role::Parameter(i)),
                None => {
                    let what = match known {
                        Some(Knowns::StatesAndInputs) => "a state or an input",
                        Some(Knowns::WithParameters) => "a state, an input or a Float64 parameter",
                        None => "a derivative or an output",
                    };
                    let name = table[i].name;
                    return Err(self.error(
                        func,
                        format!("'{name}' (value reference {vr}) is not {what}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The unknowns' values at the current time with the known `j` moved by `delta`.
    fn unknowns_at(
        &self,
        me: &MeVTable<M>,
        unknowns: &[Role],
        known: Role,
        delta: f64,
    ) -> Result<Vec<f64>, crate::ModelError> {
        let mut model = self.model.clone();
        let mut vars = self.vars.clone();
        match known {
            Role::State(k) => {
                let mut x = vec![0.0; me.states];
                (me.get_states)(&model, &mut x);
                x[k] += delta;
                (me.set_states)(&mut model, &x);
            }
            Role::Variable(i) => vars[i] += delta,
            Role::Parameter(i) => {
                vars[i] += delta;
                (me.set_parameters)(&mut model, &vars)?;
            }
        }
        let mut dx = vec![0.0; me.states];
        (me.derivatives)(&model, &vars, self.time, &mut dx)?;
        (me.outputs)(&model, &mut vars, self.time);
        Ok(unknowns
            .iter()
            .map(|u| match *u {
                Role::State(k) => dx[k],
                // an unknown is never a parameter (`roles`)
                Role::Variable(i) | Role::Parameter(i) => vars[i],
            })
            .collect())
    }

    /// The current value of a known and its step for a central difference.
    fn central_step(&self, me: &MeVTable<M>, known: Role) -> f64 {
        let (value, scale) = match known {
            Role::State(k) => {
                let mut x = vec![0.0; me.states];
                let mut n = vec![1.0; me.states];
                (me.get_states)(&self.model, &mut x);
                (me.nominals)(&self.model, &mut n);
                (x[k], n[k])
            }
            Role::Variable(i) | Role::Parameter(i) => (self.vars[i], 1.0),
        };
        CENTRAL_STEP * value.abs().max(scale)
    }

    /// `d(unknowns)/d(parameter i)` by differences of the model's own evaluation with the
    /// parameter moved (on a copy: [`crate::ModelExchange::set_parameters`]): central with a
    /// step [`CENTRAL_STEP`] times the parameter's magnitude (its range's width, else 1, at
    /// 0); at an end of its range, or where the model refuses one side, the one-sided
    /// difference of second order `(4 (f(p + h) - f(p)) - (f(p + 2h) - f(p))) / 2h` into the
    /// range (exactly 0 where the unknown does not move).
    fn parameter_column(
        &self,
        me: &MeVTable<M>,
        unknowns: &[Role],
        i: usize,
    ) -> Result<Vec<f64>, crate::ModelError> {
        let v = &M::variables()[i];
        let value = self.vars[i];
        let (lo, hi) = (
            v.min.unwrap_or(f64::NEG_INFINITY),
            v.max.unwrap_or(f64::INFINITY),
        );
        let width = hi - lo;
        let scale = if value != 0.0 {
            value.abs()
        } else if width.is_finite() && width > 0.0 {
            width
        } else {
            1.0
        };
        let h = CENTRAL_STEP * scale;
        let at = |delta: f64| self.unknowns_at(me, unknowns, Role::Parameter(i), delta);
        let up = (value + 2.0 * h <= hi).then(|| at(h)).and_then(Result::ok);
        let down = (value - 2.0 * h >= lo).then(|| at(-h)).and_then(Result::ok);
        let one_sided = |sign: f64| -> Result<Vec<f64>, crate::ModelError> {
            let (f0, f1, f2) = (at(0.0)?, at(sign * h)?, at(sign * 2.0 * h)?);
            Ok(f0
                .iter()
                .zip(f1.iter().zip(&f2))
                .map(|(a, (b, c))| sign * (4.0 * (b - a) - (c - a)) / (2.0 * h))
                .collect())
        };
        match (up, down) {
            (Some(a), Some(b)) => Ok(a.iter().zip(&b).map(|(a, b)| (a - b) / (2.0 * h)).collect()),
            (Some(_), None) => one_sided(1.0),
            (None, Some(_)) => one_sided(-1.0),
            (None, None) => {
                // neither side usable: the model's own message from a central step
                at(h)?;
                at(-h)?;
                Err(crate::ModelError::parameter(
                    v.name,
                    format!("its range [{lo}, {hi}] is too narrow for a difference quotient"),
                ))
            }
        }
    }

    /// The model's state Jacobian at the current time, states and variable values: the cached
    /// one when it was computed at exactly these (bit for bit) and nothing changed the model
    /// since ([`JacobianCache`]), else computed now and cached. `Err` holds the model's message.
    fn state_jacobian(&mut self, me: &MeVTable<M>) -> Result<(), crate::ModelError> {
        self.jacobian.ensure(me, &self.model, &self.vars, self.time)
    }

    /// The roles of the unknowns into `scratch.unknown_roles`: kept from the last call when it
    /// named the same value references (the table is static, so a role never changes).
    fn unknown_roles(
        &mut self,
        func: &str,
        me: &MeVTable<M>,
        unknowns: &[u32],
        scratch: &mut Scratch,
    ) -> Result<(), Status> {
        if scratch.unknowns == unknowns {
            return Ok(());
        }
        scratch.unknowns.clear();
        self.roles(func, me, unknowns, None, &mut scratch.unknown_roles)?;
        scratch.unknowns.extend_from_slice(unknowns);
        scratch.unknown_rows.clear();
        for role in &scratch.unknown_roles {
            match *role {
                Role::State(i) => scratch.unknown_rows.push(i),
                Role::Variable(_) | Role::Parameter(_) => {
                    scratch.unknown_rows.clear();
                    break;
                }
            }
        }
        Ok(())
    }

    /// The roles of the knowns into `scratch.known_roles`; a known that is a state is found
    /// among the states' value references (the common case: an importer's Jacobian columns).
    fn known_roles(
        &mut self,
        func: &str,
        me: &MeVTable<M>,
        knowns: &[u32],
        allowed: Knowns,
        scratch: &mut Scratch,
    ) -> Result<(), Status> {
        if scratch.state_references.len() != me.states {
            let table = M::variables();
            scratch.state_references = me
                .state_variables
                .iter()
                .map(|&(x, _)| table[x].value_reference)
                .collect();
        }
        scratch.known_roles.clear();
        for vr in knowns {
            match scratch.state_references.iter().position(|r| r == vr) {
                Some(k) => scratch.known_roles.push(Role::State(k)),
                None => {
                    return self.roles(func, me, knowns, Some(allowed), &mut scratch.known_roles)
                }
            }
        }
        Ok(())
    }

    /// `out = J dv` (see [`Instance::get_directional_derivative`]) with the state Jacobian (when
    /// needed) already in `self.jacobian`. `rows`: the unknowns' positions in the state vector
    /// when every unknown is a derivative (else empty).
    fn directional(
        &self,
        me: &MeVTable<M>,
        (u_roles, rows): (&[Role], &[usize]),
        k_roles: &[Role],
        dv: &[f64],
        out: &mut [f64],
    ) -> Result<(), crate::ModelError> {
        let n = me.states;
        let jac = &self.jacobian.jac;
        out.fill(0.0);
        if u_roles.is_empty() {
            return Ok(());
        }
        for (&known, &v) in k_roles.iter().zip(dv) {
            if v == 0.0 {
                continue;
            }
            if let (Role::State(j), false) = (known, rows.is_empty()) {
                // every unknown a derivative: a column of the state Jacobian
                for (o, &i) in out.iter_mut().zip(rows) {
                    *o += jac[i * n + j] * v;
                }
                continue;
            }
            if let Role::Parameter(i) = known {
                let column = self.parameter_column(me, u_roles, i)?;
                for (o, c) in out.iter_mut().zip(column) {
                    *o += c * v;
                }
                continue;
            }
            let analytic = |u: &Role| match (*u, known) {
                (Role::State(i), Role::State(j)) => Some(jac[i * n + j]),
                _ => None,
            };
            let h = self.central_step(me, known);
            let hi = self.unknowns_at(me, u_roles, known, h)?;
            let lo = self.unknowns_at(me, u_roles, known, -h)?;
            for ((o, u), (a, b)) in out.iter_mut().zip(u_roles).zip(hi.iter().zip(&lo)) {
                *o += analytic(u).unwrap_or((a - b) / (2.0 * h)) * v;
            }
        }
        Ok(())
    }

    /// The directional derivative of FMI 2.0 (Model Exchange and Co-Simulation): `dz = J dv` for
    /// the unknowns (derivatives, outputs) with respect to the knowns (states, inputs) at the
    /// current time, states and inputs (in Co-Simulation: the communication point). Derivatives
    /// with respect to states come from the model's analytic
    /// Jacobian, computed once per point ([`JacobianCache`]: an importer asking one column per
    /// call pays for one Jacobian, not one per column); every other entry is a central
    /// difference of the model's equations (step [`CENTRAL_STEP`] times the known's magnitude
    /// or nominal). Nothing observable changes; `dz` is written only on success.
    pub fn get_directional_derivative(
        &mut self,
        call: Checked,
        unknowns: &[u32],
        knowns: &[u32],
        dv: &[f64],
        dz: &mut [f64],
    ) -> Status {
        self.directional_derivative(call, Knowns::StatesAndInputs, (unknowns, knowns, dv, dz))
    }

    /// The adjoint derivative (FMI 3.0.2 section 3.2.4): `sensitivity = seed^T J`, one column
    /// `J e_j` of [`Instance::directional_derivative`] per known `j`:
    /// `sensitivity_j = sum_i seed_i J_ij` (the state Jacobian is evaluated once for all columns
    /// and kept while the point does not change). Nothing is written unless every column
    /// succeeds.
    pub fn adjoint_derivative(
        &mut self,
        call: Checked,
        (unknowns, knowns, seed, sensitivity): (&[u32], &[u32], &[f64], &mut [f64]),
    ) -> Status {
        if let Some(v) = seed.iter().find(|v| !v.is_finite()) {
            return self.error(call.name, format!("seed holds {v}, not a finite number"));
        }
        let mut column = vec![0.0; unknowns.len()];
        let mut out = vec![0.0; knowns.len()];
        for (o, &known) in out.iter_mut().zip(knowns) {
            let args = (unknowns, &[known][..], &[1.0][..], &mut column[..]);
            let s = self.directional_derivative(call, Knowns::WithParameters, args);
            if s != Status::Ok {
                return s;
            }
            *o = column.iter().zip(seed).map(|(j, v)| j * v).sum();
        }
        sensitivity.copy_from_slice(&out);
        Status::Ok
    }

    /// [`Instance::get_directional_derivative`] for the call `call` with the `knowns` its
    /// FMI version allows outside Initialization Mode (there the knowns are the Real inputs and
    /// `initial="exact"` variables in both versions). A parameter's column is a difference of
    /// the model's evaluation with the parameter moved, on a copy of the model: the instance's
    /// values stay bit for bit as they were.
    pub fn directional_derivative(
        &mut self,
        call: Checked,
        knowns_allowed: Knowns,
        (unknowns, knowns, dv, dz): (&[u32], &[u32], &[f64], &mut [f64]),
    ) -> Status {
        let func = call.name;
        let me = match self.derivative_table(func) {
            Ok(me) => me,
            Err(s) => return s,
        };
        if let Some(v) = dv.iter().find(|v| !v.is_finite()) {
            return self.error(func, format!("dvKnown holds {v}, not a finite number"));
        }
        if self.state == MachineState::InitializationMode {
            return self.initial_directional_derivative(func, unknowns, knowns, dv, dz);
        }
        // The buffers are reused from call to call (no allocation per call).
        let mut scratch = std::mem::take(&mut self.jacobian.scratch);
        let status = self.directional_with(
            func,
            &me,
            knowns_allowed,
            (unknowns, knowns, dv, dz),
            &mut scratch,
        );
        self.jacobian.scratch = scratch;
        status
    }

    /// The body of [`Instance::get_directional_derivative`] after its checks of the state and
    /// the seed.
    fn directional_with(
        &mut self,
        func: &str,
        me: &MeVTable<M>,
        knowns_allowed: Knowns,
        (unknowns, knowns, dv, dz): (&[u32], &[u32], &[f64], &mut [f64]),
        scratch: &mut Scratch,
    ) -> Status {
        if let Err(s) = self.unknown_roles(func, me, unknowns, scratch) {
            return s;
        }
        if let Err(s) = self.known_roles(func, me, knowns, knowns_allowed, scratch) {
            return s;
        }
        let (u_roles, k_roles) = (&scratch.unknown_roles, &scratch.known_roles);
        self.refresh_me_outputs();
        if k_roles.iter().any(|k| matches!(k, Role::State(_)))
            && u_roles.iter().any(|u| matches!(u, Role::State(_)))
        {
            if let Err(e) = self.state_jacobian(me) {
                return self.error(func, format!("at t = {}: {e}", self.time));
            }
        }
        scratch.out.resize(u_roles.len(), 0.0);
        let unknowns_found = (u_roles.as_slice(), scratch.unknown_rows.as_slice());
        if let Err(e) = self.directional(me, unknowns_found, k_roles, dv, &mut scratch.out) {
            return self.error(func, format!("at t = {}: {e}", self.time));
        }
        if let Some(i) = scratch.out.iter().position(|v| !v.is_finite()) {
            return self.error(
                func,
                format!("the derivative of unknown {} is not finite", unknowns[i]),
            );
        }
        dz.copy_from_slice(&scratch.out);
        Status::Ok
    }
}

/// The model's state Jacobian at one point, so that the `STATES` directional derivatives an
/// importer asks for one Jacobian (one unit seed per state, FMI 2.0.4 section 3.2.1 and FMI
/// 3.0.2 section 3.2.4 both take one seed vector per call) cost one evaluation of
/// [`crate::ModelExchange::state_jacobian`] instead of `STATES`.
///
/// It can never be stale: a lookup hits only when the time, every continuous state and every
/// variable value are bit for bit those the Jacobian was computed at, and the instance
/// [`clear`](JacobianCache::clear)s it at every change of the model's hidden (discrete) state
/// besides: set time, states and values, event updates, initialization, reset, tuning, steps
/// and FMU-state restores. The Jacobian is a pure function of `(model, vars, t)` (the trait's
/// contract), so a hit returns the very bits a new evaluation would.
#[derive(Clone, Debug, Default)]
pub struct JacobianCache {
    /// Whether `jac` holds the Jacobian at the key below.
    valid: bool,
    /// The key: time (bits), states, variable values.
    time: u64,
    states: Vec<f64>,
    vars: Vec<f64>,
    /// Row-major `STATES x STATES`.
    jac: Vec<f64>,
    /// Scratch for the current states.
    x: Vec<f64>,
    /// Buffers of [`Instance::get_directional_derivative`] (not part of the key).
    scratch: Scratch,
}

/// Buffers reused by every directional derivative call.
#[derive(Clone, Debug, Default)]
struct Scratch {
    /// The last unknowns' value references and their roles (static: a role never changes).
    unknowns: Vec<u32>,
    unknown_roles: Vec<Role>,
    /// Their positions in the state vector when all are derivatives, else empty.
    unknown_rows: Vec<usize>,
    /// The value references of the states, in the order of the state vector.
    state_references: Vec<u32>,
    known_roles: Vec<Role>,
    /// `dz` before it is checked.
    out: Vec<f64>,
}

/// Bitwise equality of two slices (`0.0` and `-0.0` differ; a NaN equals its own bits): their
/// bytes compared (`memcmp`), as this runs at every directional derivative call.
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && bytes(a) == bytes(b)
}

/// The bytes of `v` in memory.
fn bytes(v: &[f64]) -> &[u8] {
    // SAFETY: an f64 is 8 initialized bytes without padding, u8 has alignment 1, and the
    // returned slice borrows `v` for its whole length in bytes.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), std::mem::size_of_val(v)) }
}

impl JacobianCache {
    /// Forget the Jacobian: the model changed.
    pub fn clear(&mut self) {
        self.valid = false;
    }

    /// Make `jac` the state Jacobian of `model` at `(vars, t)`; computed only on a miss. On
    /// failure the cache is left empty.
    fn ensure<M>(
        &mut self,
        me: &MeVTable<M>,
        model: &M,
        vars: &[f64],
        t: f64,
    ) -> Result<(), crate::ModelError> {
        self.x.resize(me.states, 0.0);
        (me.get_states)(model, &mut self.x);
        if self.valid
            && self.time == t.to_bits()
            && same_bits(&self.x, &self.states)
            && same_bits(vars, &self.vars)
        {
            return Ok(());
        }
        self.valid = false;
        // zeroed, as a fresh buffer would be: a model may write only its nonzero entries
        self.jac.resize(me.states * me.states, 0.0);
        self.jac.fill(0.0);
        (me.state_jacobian)(model, vars, t, &mut self.jac)?;
        self.time = t.to_bits();
        self.states.clone_from(&self.x);
        self.vars.clear();
        self.vars.extend_from_slice(vars);
        self.valid = true;
        Ok(())
    }
}
