//! One view of a model description of either FMI version: the model's identity, its interfaces,
//! its default experiment and its variables with name, value reference, type, causality,
//! variability, initial, start, range, unit, description and (FMI 3.0) array dimensions.
//!
//! The two parsers ([`crate::md`], [`crate::fmi3::md`]) read the XML of their version, which
//! `validate` checks clause by clause; code that only names, ranges and sets variables (the
//! CLI's `--set` and CSV columns, `gap`, `design`, `bench`) reads this view instead. The version
//! differences are in [`from_fmi2`] (the FMI 2.0 types as their FMI 3.0 counterparts: Real is
//! Float64, Integer is Int32) and in [`Variable::scalar_kind`] (which variables the FMI 2.0
//! vocabulary of those commands can name).

use crate::fmi3::md::{Fmi3Attrs, Interface3, ModelDescription3, Variable3};
use crate::fmi3::value::Values;
use crate::kind::FmiVersion;
use crate::md::{ModelDescription, ScalarVariable, StartValue};
use crate::md_common::TypeDefinition;

pub use crate::fmi3::value::Type3 as ValueType;
pub use crate::md::DefaultExperiment;
pub use effects::Problem as EffectProblem;
pub use fmi_types::{Initial, VarKind, Variability};

fmi_types::xml_enum! {
    /// `causality` of a variable (FMI 3.0.2 section 2.4.7.4, which adds `structuralParameter` to
    /// the six of FMI 2.0.4 section 2.2.7; default `local`).
    Causality {
        /// structuralParameter
        StructuralParameter = "structuralParameter",
        /// parameter
        Parameter = "parameter",
        /// calculatedParameter
        CalculatedParameter = "calculatedParameter",
        /// input
        Input = "input",
        /// output
        Output = "output",
        /// local
        Local = "local",
        /// independent
        Independent = "independent",
    }
}

impl From<fmi_types::Causality> for Causality {
    /// The same spelling: FMI 3.0 keeps the six causalities of FMI 2.0.
    fn from(c: fmi_types::Causality) -> Self {
        Causality::parse(c.as_str()).unwrap_or(Causality::Local)
    }
}

/// The model identifiers of the interfaces the FMU offers.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Interfaces {
    /// `<ModelExchange modelIdentifier>`
    pub model_exchange: Option<String>,
    /// `<CoSimulation modelIdentifier>`
    pub co_simulation: Option<String>,
    /// `<ScheduledExecution modelIdentifier>` (FMI 3.0 only).
    pub scheduled_execution: Option<String>,
}

/// One variable of `<ModelVariables>` as the FMI 3.0 variable it is or stands for (FMI 2.0:
/// Real as Float64, Integer as Int32), its `min`, `max` and `unit` those of its declared type
/// where it gives none.
pub type Variable = Variable3;

impl Variable3 {
    /// The FMI 2.0 kind of a scalar model quantity: what `--set`, the CSV columns, `gap` and
    /// `design` name and range. None for arrays, for the types beyond FMI 2.0 (Int64 and UInt64
    /// exceed its Integer range; Binary, Clock) and for structural parameters (they size arrays,
    /// they are no model quantity to calibrate).
    pub fn scalar_kind(&self) -> Option<VarKind> {
        if self.is_array() || self.causality == Causality::StructuralParameter {
            return None;
        }
        match self.ty {
            ValueType::Float32 | ValueType::Float64 => Some(VarKind::Real),
            ValueType::Int8
            | ValueType::UInt8
            | ValueType::Int16
            | ValueType::UInt16
            | ValueType::Int32
            | ValueType::UInt32 => Some(VarKind::Integer),
            ValueType::Boolean => Some(VarKind::Boolean),
            ValueType::String => Some(VarKind::String),
            ValueType::Enumeration => Some(VarKind::Enumeration),
            ValueType::Int64 | ValueType::UInt64 | ValueType::Binary | ValueType::Clock => None,
        }
    }

    /// The first start value as a number (Booleans 0/1); None for text or no start.
    pub fn start_number(&self) -> Option<f64> {
        self.start.as_ref()?.number(0)
    }
}

/// A model description of either version (see the module documentation).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModelView {
    /// The FMI version the file declares.
    pub fmi_version: FmiVersion,
    /// `modelName`
    pub model_name: String,
    /// `instantiationToken` (FMI 2.0: `guid`)
    pub instantiation_token: String,
    /// `description`
    pub description: Option<String>,
    /// `generationTool`
    pub generation_tool: Option<String>,
    /// The interfaces offered.
    pub interfaces: Interfaces,
    /// `<DefaultExperiment>`
    pub default_experiment: Option<DefaultExperiment>,
    /// `<ModelVariables>` in file order.
    pub variables: Vec<Variable>,
}

impl ModelView {
    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// The variables with a [`Variable::scalar_kind`], in file order.
    pub fn scalars(&self) -> impl Iterator<Item = &Variable> {
        self.variables.iter().filter(|v| v.scalar_kind().is_some())
    }

    /// The scalar variable called `name` (see [`Variable::scalar_kind`]).
    pub fn scalar(&self, name: &str) -> Option<&Variable> {
        self.scalars().find(|v| v.name == name)
    }

    /// The scalar input a column called `name` sets: the variable itself when it is an input,
    /// else the input of its type and value reference it is an alias of (FMI 2.0.4 section
    /// 2.2.7; FMI 3.0 aliases are `<Alias>` elements, see `ModelDescription3::with_aliases`).
    pub fn input_of(&self, name: &str) -> Option<&Variable> {
        let v = self.scalar(name)?;
        if v.causality == Causality::Input {
            return Some(v);
        }
        self.scalars_with(Causality::Input)
            .find(|i| i.value_reference == v.value_reference && i.scalar_kind() == v.scalar_kind())
    }

    /// Scalar variables with causality `c`, in file order.
    pub fn scalars_with(&self, c: Causality) -> impl Iterator<Item = &Variable> {
        self.scalars().filter(move |v| v.causality == c)
    }

    /// Names of the scalar outputs in file order.
    pub fn output_names(&self) -> Vec<String> {
        self.scalars_with(Causality::Output)
            .map(|v| v.name.clone())
            .collect()
    }

    /// Names of the scalar inputs in file order.
    pub fn input_names(&self) -> Vec<String> {
        self.scalars_with(Causality::Input)
            .map(|v| v.name.clone())
            .collect()
    }

    /// The departures of the scalar parameters from the candidate-effect convention
    /// ([`effects`]), each with the variable it is at (None: the description as a
    /// whole).
    pub fn effect_problems(&self) -> Vec<(Option<&Variable>, EffectProblem)> {
        let parameters: Vec<(&Variable, VarKind)> = self
            .scalars_with(Causality::Parameter)
            .filter_map(|v| Some((v, v.scalar_kind()?)))
            .collect();
        let params: Vec<effects::Param<'_>> = parameters
            .iter()
            .map(|&(v, kind)| effects::Param {
                name: &v.name,
                kind,
                variability: v.variability,
                start: v.start_number(),
                min: v.min,
                max: v.max,
                has_unit: v.unit.is_some(),
                description: v.description.as_deref().unwrap_or(""),
            })
            .collect();
        effects::scan(&params)
            .problems
            .into_iter()
            .map(|(i, problem)| (i.map(|i| parameters[i].0), problem))
            .collect()
    }
}

impl From<&ModelDescription> for ModelView {
    fn from(md: &ModelDescription) -> Self {
        from_fmi2(md)
    }
}

impl From<&ModelDescription3> for ModelView {
    fn from(md: &ModelDescription3) -> Self {
        from_fmi3(md)
    }
}

/// The view of an FMI 2.0 description.
pub fn from_fmi2(md: &ModelDescription) -> ModelView {
    let cs = md
        .co_simulation
        .as_ref()
        .map(|c| c.model_identifier.clone());
    ModelView {
        fmi_version: FmiVersion::Fmi2,
        model_name: md.model_name.clone(),
        instantiation_token: md.guid.clone(),
        description: md.description.clone(),
        generation_tool: md.generation_tool.clone(),
        interfaces: Interfaces {
            model_exchange: md
                .model_exchange
                .as_ref()
                .map(|m| m.model_identifier.clone()),
            co_simulation: cs,
            scheduled_execution: None,
        },
        default_experiment: md.default_experiment.clone(),
        variables: md
            .model_variables
            .iter()
            .map(|v| variable_of_fmi2(md, v))
            .collect(),
    }
}

/// An FMI 2.0 variable as its FMI 3.0 counterpart; `derivative` becomes the value reference of
/// the state.
fn variable_of_fmi2(md: &ModelDescription, v: &ScalarVariable) -> Variable {
    let ty = match v.kind {
        VarKind::Real => ValueType::Float64,
        VarKind::Integer => ValueType::Int32,
        VarKind::Boolean => ValueType::Boolean,
        VarKind::String => ValueType::String,
        VarKind::Enumeration => ValueType::Enumeration,
    };
    let state = |i: usize| Some(md.model_variables.get(i.checked_sub(1)?)?.value_reference);
    let start = v.start.as_ref().map(start_of_fmi2);
    let view = v.convert(
        v.causality.into(),
        start,
        v.derivative.and_then(state),
        Fmi3Attrs::new(ty),
    );
    with_declared(view, &md.type_definitions)
}

/// An FMI 2.0 start value as a one-element buffer of its FMI 3.0 type. The FMI 2.0 Integer is
/// 32 bits; a start beyond that range (which `validate` reports) is kept whole as Int64.
fn start_of_fmi2(start: &StartValue) -> Values {
    match start {
        StartValue::Real(x) => Values::Float64(vec![*x]),
        StartValue::Integer(x) => match i32::try_from(*x) {
            Ok(small) => Values::Int32(vec![small]),
            Err(_) => Values::Int64(vec![*x]),
        },
        StartValue::Boolean(b) => Values::Boolean(vec![*b]),
        StartValue::String(s) => Values::String(vec![s.clone()]),
    }
}

/// The view of an FMI 3.0 description.
pub fn from_fmi3(md: &ModelDescription3) -> ModelView {
    let identifier = |i: &Option<Interface3>| i.as_ref().map(|i| i.model_identifier.clone());
    let variable = |v: &Variable3| with_declared(v.clone(), &md.type_definitions);
    ModelView {
        fmi_version: FmiVersion::Fmi3,
        model_name: md.model_name.clone(),
        instantiation_token: md.instantiation_token.clone(),
        description: md.description.clone(),
        generation_tool: md.generation_tool.clone(),
        interfaces: Interfaces {
            model_exchange: identifier(&md.model_exchange),
            co_simulation: identifier(&md.co_simulation),
            scheduled_execution: identifier(&md.scheduled_execution),
        },
        default_experiment: md.default_experiment.clone(),
        variables: md.variables.iter().map(variable).collect(),
    }
}

/// `v` with the `min`, `max` and `unit` of its declared type (one of `types`, either version's)
/// where it gives none.
fn with_declared<T>(mut v: Variable, types: &[TypeDefinition<T>]) -> Variable {
    let name = v.declared_type.as_deref();
    if let Some(d) = types.iter().find(|d| Some(d.name.as_str()) == name) {
        v.min = v.min.or(d.min);
        v.max = v.max.or(d.max);
        v.unit = v.unit.take().or_else(|| d.unit.clone());
    }
    v
}

#[cfg(test)]
mod tests {
    use super::{Causality, ModelView, ValueType, VarKind};
    use crate::fmi3::md::ModelDescription3;
    use crate::fmi3::value::Values;
    use crate::md::ModelDescription;

    #[test]
    fn fmi3_scalars_have_fmi2_kinds_and_arrays_and_wide_types_have_none() {
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
        let view = ModelView::from(&ModelDescription3::parse(xml, "md.xml").unwrap());
        let names: Vec<&str> = view.scalars().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["k", "fx.enabled", "fx.torque", "mode", "y"]);
        assert_eq!(view.variables.len(), 8);
        assert!(view.variable("v").unwrap().is_array());
        let t = view.scalar("fx.torque").unwrap();
        assert_eq!(
            (t.scalar_kind(), t.min, t.max, t.unit.as_deref()),
            (Some(VarKind::Real), Some(0.0), Some(5.0), Some("N.m"))
        );
        let e = view.scalar("fx.enabled").unwrap();
        assert_eq!(
            (e.scalar_kind(), e.start_number()),
            (Some(VarKind::Boolean), Some(0.0))
        );
        assert_eq!(view.scalar("mode").unwrap().start_number(), Some(-1.0));
        assert_eq!(view.output_names(), ["y"]);
        assert_eq!(view.instantiation_token, "t");
        assert_eq!(view.interfaces.co_simulation.as_deref(), Some("m"));
    }

    #[test]
    fn fmi2_variables_take_their_fmi3_types() {
        let md = ModelDescription::parse(crate::md::tests::SAMPLE, "md.xml").unwrap();
        let view = ModelView::from(&md);
        assert_eq!(view.scalars().count(), md.model_variables.len());
        let x = view.scalar("x").unwrap();
        assert_eq!(
            (x.ty, x.causality, x.unit.as_deref(), x.line),
            (ValueType::Float64, Causality::Output, Some("rad"), 14)
        );
        let n = view.scalar("n").unwrap();
        assert_eq!(
            (n.ty, n.start.clone(), n.min, n.max),
            (
                ValueType::Int32,
                Some(Values::Int32(vec![-3])),
                Some(-5.0),
                Some(5.0)
            )
        );
        assert_eq!(view.input_names(), ["u"]);
        assert_eq!(view.instantiation_token, "{1234}");
        assert_eq!(
            view.default_experiment.as_ref().unwrap().step_size,
            Some(0.001)
        );
    }

    #[test]
    fn an_fmi2_variable_takes_range_and_unit_its_declared_type_gives_and_it_does_not() {
        let xml = r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g">
          <TypeDefinitions><SimpleType name="Torque"><Real unit="N.m" min="0" max="5"/></SimpleType></TypeDefinitions>
          <ModelVariables>
            <ScalarVariable name="a" valueReference="1" causality="parameter" variability="fixed"><Real declaredType="Torque" start="1"/></ScalarVariable>
            <ScalarVariable name="b" valueReference="2" causality="parameter" variability="fixed"><Real declaredType="Torque" start="1" max="2" unit="kN.m"/></ScalarVariable>
          </ModelVariables></fmiModelDescription>"#;
        let view = ModelView::from(&ModelDescription::parse(xml, "md.xml").unwrap());
        let range = |name| {
            let v = view.scalar(name).unwrap();
            (v.min, v.max, v.unit.clone())
        };
        assert_eq!(range("a"), (Some(0.0), Some(5.0), Some("N.m".into())));
        assert_eq!(range("b"), (Some(0.0), Some(2.0), Some("kN.m".into())));
    }
}
