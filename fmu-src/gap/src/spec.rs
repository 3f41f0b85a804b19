//! What the workflow knows about a model: its parameters and the candidate effects found from the
//! effect naming convention: a Boolean parameter `<effect>.enabled` plus Real
//! parameters `<effect>.<name>`; base parameters calibrated by default carry the description tag
//! `[calibrate]`.

use fmi_types::{VarKind, Variability};
use serde::Serialize;

/// Type of a parameter as declared in the model description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ParamKind {
    Real,
    Integer,
    Boolean,
}

/// One settable parameter of the model.
#[derive(Clone, Debug, Serialize)]
pub struct ParamSpec {
    pub name: String,
    pub kind: ParamKind,
    /// Start value (Booleans as 0.0 / 1.0).
    pub start: f64,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub unit: String,
    pub description: String,
}

impl ParamSpec {
    /// A Real parameter.
    pub fn real(
        name: &str,
        start: f64,
        min: Option<f64>,
        max: Option<f64>,
        unit: &str,
        description: &str,
    ) -> Self {
        ParamSpec {
            name: name.to_string(),
            kind: ParamKind::Real,
            start,
            min,
            max,
            unit: unit.to_string(),
            description: description.to_string(),
        }
    }

    /// A Boolean parameter.
    pub fn flag(name: &str, start: bool, description: &str) -> Self {
        ParamSpec {
            name: name.to_string(),
            kind: ParamKind::Boolean,
            start: if start { 1.0 } else { 0.0 },
            min: None,
            max: None,
            unit: String::new(),
            description: description.to_string(),
        }
    }
}

/// A candidate effect: its switch and its Real parameters (indices into the parameter list).
#[derive(Clone, Debug, Serialize)]
pub struct EffectSpec {
    pub name: String,
    pub enabled: usize,
    pub params: Vec<usize>,
}

/// The candidate-effect convention read from a parameter list (one reading shared with the
/// exporter and the validator: [`effects`]).
pub fn convention(params: &[ParamSpec]) -> effects::Convention {
    let scanned: Vec<effects::Param> = params
        .iter()
        .map(|p| effects::Param {
            name: &p.name,
            kind: match p.kind {
                ParamKind::Real => VarKind::Real,
                ParamKind::Integer => VarKind::Integer,
                ParamKind::Boolean => VarKind::Boolean,
            },
            // Only settable parameters reach the workflow; their variability is not kept.
            variability: Variability::Fixed,
            start: Some(p.start),
            min: p.min,
            max: p.max,
            has_unit: !p.unit.is_empty(),
            description: &p.description,
        })
        .collect();
    effects::scan(&scanned)
}

/// The effects of a parameter list, found by the naming convention. A Boolean `<e>.enabled`
/// defines effect `<e>`; every Real parameter named `<e>.<something>` belongs to it. Effects are
/// returned in declaration order of their switch.
pub fn find_effects(params: &[ParamSpec]) -> Vec<EffectSpec> {
    convention(params)
        .effects
        .into_iter()
        .map(|e| EffectSpec {
            name: e.name,
            enabled: e.switch,
            params: e.params,
        })
        .collect()
}

/// Indices of the parameters tagged `[calibrate]` that belong to no effect.
pub fn default_calibration(params: &[ParamSpec], _effects: &[EffectSpec]) -> Vec<usize> {
    convention(params).calibrate
}

/// Indices of the initial-state parameters: Real, tagged `[initial]`, with a range, in no
/// effect. The workflow estimates them with the base parameters.
pub fn initial_state(params: &[ParamSpec]) -> Vec<usize> {
    convention(params).initial
}

#[cfg(test)]
mod tests {
    use super::{default_calibration, find_effects, ParamSpec};

    #[test]
    fn effects_follow_the_naming_convention() {
        let params = vec![
            ParamSpec::real(
                "load_mass",
                2.0,
                Some(0.0),
                Some(20.0),
                "kg",
                "[calibrate] mass",
            ),
            ParamSpec::flag("seal_friction.enabled", false, "switch"),
            ParamSpec::real(
                "seal_friction.coulomb",
                50.0,
                Some(5.0),
                Some(500.0),
                "N",
                "Coulomb",
            ),
            ParamSpec::real(
                "seal_friction.viscous",
                500.0,
                Some(10.0),
                Some(5000.0),
                "N.s/m",
                "viscous",
            ),
            ParamSpec::flag("internal_controller", true, "not an effect"),
            ParamSpec::flag("valve_overlap.enabled", false, "switch"),
            ParamSpec::real(
                "valve_overlap.width",
                0.1,
                Some(0.01),
                Some(1.0),
                "1",
                "[calibrate] width",
            ),
            ParamSpec::real(
                "seal_friction_like",
                1.0,
                None,
                None,
                "1",
                "[calibrate] not a member",
            ),
        ];
        let e = find_effects(&params);
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].name, "seal_friction");
        assert_eq!(e[0].params, vec![2, 3]);
        assert_eq!(e[1].name, "valve_overlap");
        assert_eq!(e[1].params, vec![6]);
        // An effect parameter is never a base calibration parameter, even when tagged.
        assert_eq!(default_calibration(&params, &e), vec![0, 7]);
    }
}
