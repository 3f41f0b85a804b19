//! The scalar variables of an FMI 3.0 description in the FMI 2.0 shape, for the code that only
//! names, ranges and describes variables (CSV columns of `gap` and `design`, `--set`, the
//! candidate effects and `[calibrate]` tags): one vocabulary for both versions there, the
//! values themselves always going through the FMI 3.0 calls.
//!
//! Mapped: Float32/Float64 -> Real, Int8..UInt32 -> Integer, Boolean, String, Enumeration, with
//! parameters, inputs, outputs and locals (a structural parameter is left out: it sizes arrays,
//! it is no model quantity to calibrate). Left out: arrays, Int64/UInt64 (beyond the FMI 2.0
//! Integer range), Binary and Clock.

use super::md::{Causality3, DefaultExperiment3, ModelDescription3, Variable3};
use super::value::Type3;
use crate::md::{
    Causality, CoSimulation, DefaultExperiment, ModelDescription, ScalarVariable, StartValue,
    VarKind,
};

/// The FMI 2.0-shaped view of `md` (see the module documentation).
pub fn fmi2_view(md: &ModelDescription3) -> ModelDescription {
    ModelDescription {
        fmi_version: md.fmi_version.clone(),
        model_name: md.model_name.clone(),
        guid: md.instantiation_token.clone(),
        description: md.description.clone(),
        generation_tool: md.generation_tool.clone(),
        co_simulation: md.co_simulation.as_ref().map(|c| CoSimulation {
            model_identifier: c.model_identifier.clone(),
            ..Default::default()
        }),
        default_experiment: md.default_experiment.as_ref().map(DefaultExperiment::from),
        model_variables: md.variables.iter().filter_map(|v| scalar(md, v)).collect(),
        ..Default::default()
    }
}

/// FMI 3.0.2 gives `<DefaultExperiment>` the four attributes of FMI 2.0.4: a plain copy.
impl From<&DefaultExperiment3> for DefaultExperiment {
    fn from(experiment: &DefaultExperiment3) -> Self {
        DefaultExperiment {
            start_time: experiment.start_time,
            stop_time: experiment.stop_time,
            tolerance: experiment.tolerance,
            step_size: experiment.step_size,
        }
    }
}

fn scalar(md: &ModelDescription3, v: &Variable3) -> Option<ScalarVariable> {
    if v.is_array() {
        return None;
    }
    let kind = match v.ty {
        Type3::Float32 | Type3::Float64 => VarKind::Real,
        Type3::Int8
        | Type3::UInt8
        | Type3::Int16
        | Type3::UInt16
        | Type3::Int32
        | Type3::UInt32 => VarKind::Integer,
        Type3::Boolean => VarKind::Boolean,
        Type3::String => VarKind::String,
        Type3::Enumeration => VarKind::Enumeration,
        Type3::Int64 | Type3::UInt64 | Type3::Binary | Type3::Clock => return None,
    };
    let causality = match v.causality {
        Causality3::Parameter => Causality::Parameter,
        Causality3::CalculatedParameter => Causality::CalculatedParameter,
        Causality3::Input => Causality::Input,
        Causality3::Output => Causality::Output,
        Causality3::Local => Causality::Local,
        Causality3::Independent => Causality::Independent,
        Causality3::StructuralParameter => return None,
    };
    let start = v.start.as_ref().and_then(|s| match kind {
        VarKind::Real => s.number(0).map(StartValue::Real),
        VarKind::Integer | VarKind::Enumeration => {
            s.number(0).map(|x| StartValue::Integer(x as i64))
        }
        VarKind::Boolean => s.number(0).map(|x| StartValue::Boolean(x != 0.0)),
        VarKind::String => Some(StartValue::String(s.text(0))),
    });
    let declared = v
        .declared_type
        .as_deref()
        .and_then(|t| md.type_definitions.iter().find(|d| d.name == t));
    Some(ScalarVariable {
        name: v.name.clone(),
        value_reference: v.value_reference,
        description: v.description.clone(),
        causality,
        causality_given: true,
        variability: v.variability,
        variability_given: v.variability_given,
        initial: v.initial,
        can_handle_multiple_set_per_time_instant: None,
        kind,
        declared_type: None,
        start,
        min: v.min.or(declared.and_then(|d| d.min)),
        max: v.max.or(declared.and_then(|d| d.max)),
        nominal: v.nominal,
        unit: v
            .unit
            .clone()
            .or_else(|| declared.and_then(|d| d.unit.clone())),
        display_unit: v.display_unit.clone(),
        quantity: v.quantity.clone(),
        derivative: None,
        line: v.line,
    })
}

#[cfg(test)]
mod tests {
    use super::fmi2_view;
    use crate::fmi3::md::ModelDescription3;
    use crate::md::{StartValue, VarKind};

    #[test]
    fn scalars_map_to_fmi2_kinds_and_arrays_and_wide_types_are_left_out() {
        let xml = r#"<fmiModelDescription fmiVersion="3.0" instantiationToken="t">
          <CoSimulation modelIdentifier="m"/>
          <TypeDefinitions><Float64Type name="Torque" unit="N.m" min="0" max="5"/></TypeDefinitions>
          <ModelVariables>
            <Float64 name="k" valueReference="1" causality="parameter" variability="fixed" start="2" description="[calibrate] gain"/>
            <Boolean name="fx.enabled" valueReference="2" causality="parameter" variability="fixed" start="false"/>
            <Float64 name="fx.torque" valueReference="3" causality="parameter" variability="fixed" start="1" declaredType="Torque"/>
            <Int8 name="mode" valueReference="4" causality="input" start="-1"/>
            <Float32 name="y" valueReference="5" causality="output"/>
            <Int64 name="big" valueReference="6" causality="output"/>
            <Float64 name="v" valueReference="7" causality="output"><Dimension start="2"/></Float64>
            <UInt64 name="n" valueReference="8" causality="structuralParameter" variability="fixed" start="2"/>
          </ModelVariables></fmiModelDescription>"#;
        let md = ModelDescription3::parse(xml, "md.xml").unwrap();
        let view = fmi2_view(&md);
        let names: Vec<&str> = view
            .model_variables
            .iter()
            .map(|v| v.name.as_str())
            .collect();
        assert_eq!(names, ["k", "fx.enabled", "fx.torque", "mode", "y"]);
        let t = view.variable("fx.torque").unwrap();
        assert_eq!(
            (t.kind, t.min, t.max, t.unit.as_deref()),
            (VarKind::Real, Some(0.0), Some(5.0), Some("N.m"))
        );
        let e = view.variable("fx.enabled").unwrap();
        assert_eq!(
            (e.kind, e.start.clone()),
            (VarKind::Boolean, Some(StartValue::Boolean(false)))
        );
        assert_eq!(
            view.variable("mode").unwrap().start,
            Some(StartValue::Integer(-1))
        );
        assert_eq!(view.output_names(), ["y"]);
        assert_eq!(view.guid, "t");
    }
}
