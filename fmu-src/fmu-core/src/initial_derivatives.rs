//! `fmi2GetDirectionalDerivative` in Initialization Mode (FMI 2.0.4 section 2.1.9; FMI 3.0.2
//! section 2.2.11 for `fmi3GetDirectionalDerivative` and `fmi3GetAdjointDerivative`): the
//! unknowns are the Real `<InitialUnknowns>` (outputs, states and state derivatives with
//! `initial` approx or calculated, calculated parameters), the knowns the Real inputs and the
//! Real variables with `initial="exact"` (parameters, exact start values), section 2.2.8. The
//! model's initialization is a function of those knowns, `v_initialUnknowns = f_init(u, t0,
//! v_exact)`; its partial derivatives are central differences of the model's own
//! initialization, one-sided where one side of a known is refused (a value at the end of its
//! physical range).

use crate::instance::{Instance, Status};
use crate::variables::index_of;
use crate::{Causality, Initial, Model, VarType};
use fmi_types::schema::default_initial;

/// Relative step of the central differences: about the cube root of the machine epsilon, where
/// truncation and rounding errors of a central difference balance (as in Model Exchange).
const STEP: f64 = 6e-6;

/// The `initial` of a variable, the standard's default where the table gives none.
fn initial_of(v: &crate::Variable) -> Option<Initial> {
    v.initial.or(default_initial(v.causality, v.variability))
}

impl<M: Model> Instance<M> {
    /// Whether table position `i` is a state or a state derivative of the model.
    fn is_state_or_derivative(&self, i: usize) -> bool {
        self.me
            .is_some_and(|me| me.state_variables.iter().any(|&(x, d)| x == i || d == i))
    }

    /// Table positions of `vrs`: unknowns must be Real initial unknowns, knowns Real inputs or
    /// Real variables with `initial="exact"`.
    fn initial_roles(
        &mut self,
        func: &str,
        vrs: &[u32],
        known: bool,
    ) -> Result<Vec<usize>, Status> {
        let table = M::variables();
        let mut positions = Vec::with_capacity(vrs.len());
        for &vr in vrs {
            let Some(i) = index_of(table, vr) else {
                return Err(self.error(func, format!("unknown value reference {vr}")));
            };
            let v = &table[i];
            let initial = initial_of(v);
            let ok = v.vtype == VarType::Real
                && if known {
                    v.causality == Causality::Input || initial == Some(Initial::Exact)
                } else {
                    let calculated = matches!(initial, Some(Initial::Calculated | Initial::Approx));
                    ((v.causality == Causality::Output || self.is_state_or_derivative(i))
                        && calculated)
                        || v.causality == Causality::CalculatedParameter
                };
            if !ok {
                let what = if known {
                    "a Real input or a Real variable with initial=\"exact\""
                } else {
                    "a Real initial unknown"
                };
                let name = v.name;
                return Err(self.error(
                    func,
                    format!("in Initialization Mode '{name}' (value reference {vr}) is not {what}"),
                ));
            }
            positions.push(i);
        }
        Ok(positions)
    }

    /// The unknowns after the model's initialization with the known at position `known` moved
    /// by `delta` (every other value as the importer set it).
    fn initial_unknowns_at(
        &self,
        unknowns: &[usize],
        known: usize,
        delta: f64,
    ) -> Option<Vec<f64>> {
        let mut vars = self.vars.clone();
        vars[known] += delta;
        let (_, vars) = self.initialized(vars).ok()?;
        let values: Vec<f64> = unknowns.iter().map(|&i| vars[i]).collect();
        values.iter().all(|v| v.is_finite()).then_some(values)
    }

    /// One column `d(unknowns)/d(known)`: central, else one-sided, differences.
    fn initial_column(&self, unknowns: &[usize], known: usize) -> Option<Vec<f64>> {
        let value = self.vars[known];
        let h = STEP * if value == 0.0 { 1.0 } else { value.abs() };
        let hi = self.initial_unknowns_at(unknowns, known, h);
        let lo = self.initial_unknowns_at(unknowns, known, -h);
        let (a, b, width) = match (hi, lo) {
            (Some(a), Some(b)) => (a, b, 2.0 * h),
            (Some(a), None) => (a, self.initial_unknowns_at(unknowns, known, 0.0)?, h),
            (None, Some(b)) => (self.initial_unknowns_at(unknowns, known, 0.0)?, b, h),
            (None, None) => return None,
        };
        Some(a.iter().zip(&b).map(|(a, b)| (a - b) / width).collect())
    }

    /// `fmi2GetDirectionalDerivative` in Initialization Mode: `dz = J dv` of the initial
    /// unknowns with respect to the knowns (module documentation). Nothing changes; `dz` is
    /// written only on success.
    pub(crate) fn initial_directional_derivative(
        &mut self,
        func: &str,
        unknowns: &[u32],
        knowns: &[u32],
        dv: &[f64],
        dz: &mut [f64],
    ) -> Status {
        let (u, k) = match (
            self.initial_roles(func, unknowns, false),
            self.initial_roles(func, knowns, true),
        ) {
            (Ok(u), Ok(k)) => (u, k),
            (Err(s), _) | (_, Err(s)) => return s,
        };
        let mut out = vec![0.0; u.len()];
        for (&known, &v) in k.iter().zip(dv) {
            if v == 0.0 {
                continue;
            }
            let Some(column) = self.initial_column(&u, known) else {
                let name = M::variables()[known].name;
                return self.error(
                    func,
                    format!(
                        "the initialization fails on both sides of '{name}' = {}",
                        self.vars[known]
                    ),
                );
            };
            for (o, c) in out.iter_mut().zip(column) {
                *o += c * v;
            }
        }
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return self.error(
                func,
                format!("the derivative of unknown {} is not finite", unknowns[i]),
            );
        }
        dz.copy_from_slice(&out);
        Status::Ok
    }
}
