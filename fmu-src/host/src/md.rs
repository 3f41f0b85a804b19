//! Typed `modelDescription.xml` of FMI 2.0 (FMI 2.0.4 standard, section 2.2) and its parser.
//!
//! The parser is strict about syntax (malformed XML, attributes that do not parse as their
//! schema type) and returns the first such error with its line. Semantic rules (allowed
//! causality/variability combinations, units declared, model structure complete) are not
//! enforced here: the `validate` crate reports them all as findings. What FMI 3.0 reads alike
//! (identity, variable attributes, lists) is in [`crate::md_common`].

use crate::error::{shown, HostError};
use crate::md_common::{self, dependencies_kind, list, reads_as, Dialect, TypeDefinition};
pub use crate::md_common::{Identity, Var, MAX_FALLBACK_RECORDED};
use crate::xml::{parse_real, Ancestors, Attrs, Doc, Visitor};

pub use fmi_types::{Causality, Initial, VarKind, Variability};

/// A start value, typed by the variable's type element.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub enum StartValue {
    /// Real start.
    Real(f64),
    /// Integer or Enumeration start.
    Integer(i64),
    /// Boolean start.
    Boolean(bool),
    /// String start.
    String(String),
}

impl StartValue {
    /// Numeric view (Booleans as 0/1); None for strings.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            StartValue::Real(v) => Some(*v),
            StartValue::Integer(v) => Some(*v as f64),
            StartValue::Boolean(b) => Some(if *b { 1.0 } else { 0.0 }),
            StartValue::String(_) => None,
        }
    }
}

/// One `<ScalarVariable>` (FMI 2.0.4 section 2.2.7).
pub type ScalarVariable = Var<Fmi2Attrs>;

/// What an FMI 2.0 `<ScalarVariable>` has beyond the attributes of [`Var`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Fmi2Attrs {
    /// Type element.
    pub kind: VarKind,
    /// True when `causality` was written.
    pub causality_given: bool,
    /// `canHandleMultipleSetPerTimeInstant`
    pub can_handle_multiple_set_per_time_instant: Option<bool>,
}

impl Dialect for Fmi2Attrs {
    type Causality = Causality;
    type Start = StartValue;
    type Ref = usize;
    const REF: &'static str = "an index";
    const LOCAL: Causality = Causality::Local;
    fn causality(s: &str) -> Option<Causality> {
        Causality::parse(s)
    }
    fn base(c: Causality) -> Causality {
        c
    }
}

/// `<DisplayUnit>` of a unit (FMI 2.0.4 section 2.2.2, FMI 3.0.2 section 2.4.3):
/// v_display = factor * v_unit + offset, or factor / v_unit when `inverse`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DisplayUnit {
    /// `name`
    pub name: String,
    /// `factor` (default 1)
    pub factor: f64,
    /// `offset` (default 0)
    pub offset: f64,
    /// `inverse` (FMI 3.0 only; default false)
    pub inverse: bool,
    /// Line of the tag.
    pub line: usize,
}

impl DisplayUnit {
    /// The `<DisplayUnit>` element `a`; `inverse` is read only when `fmi3`.
    pub(crate) fn read(doc: &Doc<'_>, a: &Attrs, fmi3: bool) -> Result<Self, HostError> {
        Ok(DisplayUnit {
            name: doc.required(a, "name")?,
            factor: doc.real(a, "factor")?.unwrap_or(1.0),
            offset: doc.real(a, "offset")?.unwrap_or(0.0),
            inverse: fmi3 && doc.boolean(a, "inverse")?.unwrap_or(false),
            line: a.line,
        })
    }
}

/// `<BaseUnit>`: exponents of the SI base units, value_SI = factor * value + offset.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct BaseUnit {
    /// Exponents of kg, m, s, A, K, mol, cd, rad.
    pub exponents: [i32; 8],
    /// `factor` (default 1)
    pub factor: f64,
    /// `offset` (default 0)
    pub offset: f64,
}

/// `<Unit>` of `<UnitDefinitions>`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Unit {
    /// `name`
    pub name: String,
    /// `<BaseUnit>` if given (read in FMI 2.0 descriptions).
    pub base_unit: Option<BaseUnit>,
    /// `<DisplayUnit>`s.
    pub display_units: Vec<DisplayUnit>,
    /// Line of the tag.
    pub line: usize,
}

impl Unit {
    /// The `<Unit>` element `a`, before its children.
    pub(crate) fn read(doc: &Doc<'_>, a: &Attrs) -> Result<Self, HostError> {
        Ok(Unit {
            name: doc.required(a, "name")?,
            base_unit: None,
            display_units: Vec::new(),
            line: a.line,
        })
    }
}

/// `<SimpleType>` of `<TypeDefinitions>`: its type element (None before it is read).
pub type SimpleType = TypeDefinition<Option<VarKind>>;

/// `<Category>` of `<LogCategories>`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LogCategory {
    /// `name`
    pub name: String,
    /// `description`
    pub description: Option<String>,
}

/// `<CoSimulation>` element with its capability flags (absent: false, FMI 2.0.4 section 4.3.1).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct CoSimulation {
    /// `modelIdentifier`
    pub model_identifier: String,
    /// `needsExecutionTool`
    pub needs_execution_tool: bool,
    /// `canHandleVariableCommunicationStepSize`
    pub can_handle_variable_communication_step_size: bool,
    /// `canInterpolateInputs`
    pub can_interpolate_inputs: bool,
    /// `maxOutputDerivativeOrder`
    pub max_output_derivative_order: u32,
    /// `canRunAsynchronuously` (sic, as spelled by the standard)
    pub can_run_asynchronuously: bool,
    /// `canBeInstantiatedOnlyOncePerProcess`
    pub can_be_instantiated_only_once_per_process: bool,
    /// `canNotUseMemoryManagementFunctions`
    pub can_not_use_memory_management_functions: bool,
    /// `canGetAndSetFMUstate`
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate`
    pub can_serialize_fmu_state: bool,
    /// `providesDirectionalDerivative`
    pub provides_directional_derivative: bool,
}

/// `<ModelExchange>` element with the capability flags the host reads (absent: false, FMI 2.0.4
/// section 3.3.1).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelExchange {
    /// `modelIdentifier`
    pub model_identifier: String,
    /// `providesDirectionalDerivative`
    pub provides_directional_derivative: bool,
    /// `completedIntegratorStepNotNeeded`
    pub completed_integrator_step_not_needed: bool,
    /// `canGetAndSetFMUstate`
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate`
    pub can_serialize_fmu_state: bool,
}

/// `<DefaultExperiment>`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DefaultExperiment {
    /// `startTime`
    pub start_time: Option<f64>,
    /// `stopTime`
    pub stop_time: Option<f64>,
    /// `tolerance`
    pub tolerance: Option<f64>,
    /// `stepSize`
    pub step_size: Option<f64>,
}

impl DefaultExperiment {
    /// The `<DefaultExperiment>` element `a` (the same four attributes in FMI 2.0.4 section
    /// 2.2.5 and FMI 3.0.2 section 2.4.6).
    pub(crate) fn read(doc: &Doc<'_>, a: &Attrs) -> Result<Self, HostError> {
        Ok(DefaultExperiment {
            start_time: doc.real(a, "startTime")?,
            stop_time: doc.real(a, "stopTime")?,
            tolerance: doc.real(a, "tolerance")?,
            step_size: doc.real(a, "stepSize")?,
        })
    }
}

/// `<Unknown>` of `<ModelStructure>`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Unknown {
    /// `index`: 1-based index into ModelVariables.
    pub index: usize,
    /// `dependencies` (None when absent: depends on everything).
    pub dependencies: Option<Vec<usize>>,
    /// `dependenciesKind`
    pub dependencies_kind: Option<Vec<String>>,
    /// Line of the tag.
    pub line: usize,
}

/// `<ModelStructure>`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelStructure {
    /// `<Outputs>`
    pub outputs: Vec<Unknown>,
    /// `<Derivatives>`
    pub derivatives: Vec<Unknown>,
    /// `<InitialUnknowns>`
    pub initial_unknowns: Vec<Unknown>,
    /// True when `<ModelStructure>` was present.
    pub present: bool,
}

/// The parsed `modelDescription.xml`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelDescription {
    /// The identity attributes, read as the description's own.
    #[serde(flatten)]
    pub identity: Identity,
    /// `guid`
    pub guid: String,
    /// `numberOfEventIndicators`
    pub number_of_event_indicators: Option<u32>,
    /// `<CoSimulation>` if present.
    pub co_simulation: Option<CoSimulation>,
    /// `<ModelExchange>` if present.
    pub model_exchange: Option<ModelExchange>,
    /// `<UnitDefinitions>`
    pub unit_definitions: Vec<Unit>,
    /// `<TypeDefinitions>`
    pub type_definitions: Vec<SimpleType>,
    /// `<LogCategories>`
    pub log_categories: Vec<LogCategory>,
    /// `<DefaultExperiment>`
    pub default_experiment: Option<DefaultExperiment>,
    /// `<ModelVariables>` in file order (index i+1 in ModelStructure).
    pub model_variables: Vec<ScalarVariable>,
    /// `<ModelStructure>`
    pub model_structure: ModelStructure,
}

reads_as!(ModelDescription => identity: Identity);

impl ModelDescription {
    /// Parses the text of a `modelDescription.xml`; `file` names it in errors.
    pub fn parse(xml: &str, file: &str) -> Result<Self, HostError> {
        Ok(crate::xml::read(xml, file, Parser::default())?.md)
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.model_variables.iter().find(|v| v.name == name)
    }

    /// The input a column called `name` sets: the variable itself when it is an input, else
    /// the input it is an alias of (FMI 2.0.4 section 2.2.7: variables of one base type with
    /// one value reference are aliases; an input's aliases cannot be set themselves).
    pub fn input_of(&self, name: &str) -> Option<&ScalarVariable> {
        let v = self.variable(name)?;
        if v.causality == Causality::Input {
            return Some(v);
        }
        self.with_causality(Causality::Input)
            .find(|i| i.value_reference == v.value_reference && same_base(i.kind, v.kind))
    }

    /// Variables with causality `c`, in file order.
    pub fn with_causality(&self, c: Causality) -> impl Iterator<Item = &ScalarVariable> {
        self.model_variables
            .iter()
            .filter(move |v| v.causality == c)
    }

    /// Names of the outputs in file order.
    pub fn output_names(&self) -> Vec<String> {
        self.with_causality(Causality::Output)
            .map(|v| v.name.clone())
            .collect()
    }

    /// Names recorded when none are asked for, by FMPy's rule (`simulate_fmu`,
    /// `_get_output_variables`): the outputs in file order; without outputs the continuous
    /// states (the variables `<Derivatives>` give the derivative of), at most
    /// [`MAX_FALLBACK_RECORDED`]; without those the first five variables but `time`. (FMPy's
    /// third rule, variability "local", matches no variable FMI 2.0 allows.)
    pub fn recorded_by_default(&self) -> Vec<String> {
        let vars = &self.model_variables;
        let nth = |i: usize| vars.get(i.checked_sub(1)?);
        let derivatives = self.model_structure.derivatives.iter();
        let states = derivatives.filter_map(|u| nth(nth(u.index)?.derivative?));
        md_common::recorded_by_default(self.output_names(), states, vars)
    }

    /// Names of the inputs in file order.
    pub fn input_names(&self) -> Vec<String> {
        self.with_causality(Causality::Input)
            .map(|v| v.name.clone())
            .collect()
    }

    /// The `<Unit>` called `name`.
    pub fn unit(&self, name: &str) -> Option<&Unit> {
        self.unit_definitions.iter().find(|u| u.name == name)
    }

    /// The `<SimpleType>` called `name`.
    pub fn simple_type(&self, name: &str) -> Option<&SimpleType> {
        self.type_definitions.iter().find(|t| t.name == name)
    }

    /// The unit of a Real variable: its own `unit`, else that of its declared type.
    pub fn effective_unit<'a>(&'a self, v: &'a ScalarVariable) -> Option<&'a str> {
        v.unit.as_deref().or_else(|| {
            v.declared_type
                .as_deref()
                .and_then(|t| self.simple_type(t))
                .and_then(|t| t.unit.as_deref())
        })
    }
}

#[derive(Default)]
struct Parser {
    md: ModelDescription,
    /// The open `<ScalarVariable>`, completed by its type element.
    current_var: Option<ScalarVariable>,
}

impl Visitor for Parser {
    fn element(&mut self, doc: &Doc<'_>, path: Ancestors<'_>, a: Attrs) -> Result<(), HostError> {
        let md = &mut self.md;
        match (
            path.last().map(String::as_str).unwrap_or(""),
            a.element.as_str(),
        ) {
            ("", _) => root(md, doc, &a)?,
            ("fmiModelDescription", "CoSimulation") => {
                md.co_simulation = Some(co_simulation(doc, &a)?)
            }
            ("fmiModelDescription", "ModelExchange") => {
                md.model_exchange = Some(model_exchange(doc, &a)?)
            }
            ("UnitDefinitions", "Unit") => md.unit_definitions.push(Unit::read(doc, &a)?),
            ("Unit", "BaseUnit") => {
                let b = base_unit(doc, &a)?;
                if let Some(u) = md.unit_definitions.last_mut() {
                    u.base_unit = Some(b);
                }
            }
            ("Unit", "DisplayUnit") => {
                let d = DisplayUnit::read(doc, &a, false)?;
                if let Some(u) = md.unit_definitions.last_mut() {
                    u.display_units.push(d);
                }
            }
            ("TypeDefinitions", "SimpleType") => md.type_definitions.push(SimpleType {
                name: doc.required(&a, "name")?,
                line: a.line,
                ..SimpleType::default()
            }),
            ("SimpleType", kind) => simple_type(md, doc, kind, &a)?,
            ("LogCategories", "Category") => md.log_categories.push(LogCategory {
                name: doc.required(&a, "name")?,
                description: a.text("description"),
            }),
            ("fmiModelDescription", "DefaultExperiment") => {
                md.default_experiment = Some(DefaultExperiment::read(doc, &a)?);
            }
            ("ModelVariables", "ScalarVariable") => {
                self.current_var = Some(scalar_variable(doc, &a)?)
            }
            ("ScalarVariable", kind) if VarKind::parse(kind).is_some() => {
                self.type_element(doc, &a)?
            }
            ("fmiModelDescription", "ModelStructure") => md.model_structure.present = true,
            (list @ ("Outputs" | "Derivatives" | "InitialUnknowns"), "Unknown") => {
                let u = unknown(doc, &a)?;
                let ms = &mut md.model_structure;
                match list {
                    "Outputs" => ms.outputs.push(u),
                    "Derivatives" => ms.derivatives.push(u),
                    _ => ms.initial_unknowns.push(u),
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn end(&mut self, path: Ancestors<'_>, name: &str) {
        if name == "ScalarVariable" && path.last().map(String::as_str) == Some("ModelVariables") {
            if let Some(v) = self.current_var.take() {
                self.md.model_variables.push(v);
            }
        }
    }
}

impl Parser {
    /// The type element (`<Real>`, ...) of the open variable: its kind, start and the
    /// attributes of [`Var::read_type`].
    fn type_element(&mut self, doc: &Doc<'_>, a: &Attrs) -> Result<(), HostError> {
        let Some(v) = self.current_var.as_mut() else {
            return Ok(());
        };
        v.kind = VarKind::parse(&a.element).unwrap_or(VarKind::Real);
        v.start = start_value(doc, v.kind, &v.name, a)?;
        v.read_type(doc, a)
    }
}

/// The attributes of `<fmiModelDescription>` (FMI 2.0.4 section 2.2.1).
fn root(md: &mut ModelDescription, doc: &Doc<'_>, a: &Attrs) -> Result<(), HostError> {
    md.identity = Identity::read(a);
    md.guid = a.text("guid").unwrap_or_default();
    md.number_of_event_indicators =
        doc.parse::<u32>(a, "numberOfEventIndicators", "an unsigned integer")?;
    Ok(())
}

/// The capability flag `key` of the interface element `a` (absent: false, FMI 2.0.4 sections
/// 3.3.1 and 4.3.1).
fn flag(doc: &Doc<'_>, a: &Attrs, key: &str) -> Result<bool, HostError> {
    Ok(doc.boolean(a, key)?.unwrap_or(false))
}

fn model_exchange(doc: &Doc<'_>, a: &Attrs) -> Result<ModelExchange, HostError> {
    let model_identifier = doc.required(a, "modelIdentifier")?;
    let f = |key| flag(doc, a, key);
    Ok(ModelExchange {
        model_identifier,
        provides_directional_derivative: f("providesDirectionalDerivative")?,
        completed_integrator_step_not_needed: f("completedIntegratorStepNotNeeded")?,
        can_get_and_set_fmu_state: f("canGetAndSetFMUstate")?,
        can_serialize_fmu_state: f("canSerializeFMUstate")?,
    })
}

fn co_simulation(doc: &Doc<'_>, a: &Attrs) -> Result<CoSimulation, HostError> {
    let model_identifier = doc.required(a, "modelIdentifier")?;
    let f = |key| flag(doc, a, key);
    Ok(CoSimulation {
        model_identifier,
        needs_execution_tool: f("needsExecutionTool")?,
        can_handle_variable_communication_step_size: f("canHandleVariableCommunicationStepSize")?,
        can_interpolate_inputs: f("canInterpolateInputs")?,
        can_run_asynchronuously: f("canRunAsynchronuously")?,
        can_be_instantiated_only_once_per_process: f("canBeInstantiatedOnlyOncePerProcess")?,
        can_not_use_memory_management_functions: f("canNotUseMemoryManagementFunctions")?,
        can_get_and_set_fmu_state: f("canGetAndSetFMUstate")?,
        can_serialize_fmu_state: f("canSerializeFMUstate")?,
        provides_directional_derivative: f("providesDirectionalDerivative")?,
        max_output_derivative_order: doc
            .parse::<u32>(a, "maxOutputDerivativeOrder", "an unsigned integer")?
            .unwrap_or(0),
    })
}

/// `<BaseUnit>`: the exponents of kg, m, s, A, K, mol, cd, rad, a factor and an offset
/// (FMI 2.0.4 section 2.2.2).
fn base_unit(doc: &Doc<'_>, a: &Attrs) -> Result<BaseUnit, HostError> {
    let mut b = BaseUnit {
        factor: doc.real(a, "factor")?.unwrap_or(1.0),
        offset: doc.real(a, "offset")?.unwrap_or(0.0),
        ..Default::default()
    };
    for (e, k) in b
        .exponents
        .iter_mut()
        .zip(["kg", "m", "s", "A", "K", "mol", "cd", "rad"])
    {
        *e = doc.parse::<i32>(a, k, "an integer")?.unwrap_or(0);
    }
    Ok(b)
}

/// The type element of the open `<SimpleType>` (FMI 2.0.4 section 2.2.3).
fn simple_type(
    md: &mut ModelDescription,
    doc: &Doc<'_>,
    kind: &str,
    a: &Attrs,
) -> Result<(), HostError> {
    let kind = VarKind::parse(kind).ok_or_else(|| {
        doc.err(
            a.line,
            format!(
                "<SimpleType> has unknown type element <{}>",
                shown(kind, 40)
            ),
        )
    })?;
    let (min, max) = (doc.real(a, "min")?, doc.real(a, "max")?);
    if let Some(t) = md.type_definitions.last_mut() {
        t.ty = Some(kind);
        t.unit = a.text("unit");
        t.display_unit = a.text("displayUnit");
        (t.min, t.max) = (min, max);
    }
    Ok(())
}

/// A `<ScalarVariable>` before its type element.
fn scalar_variable(doc: &Doc<'_>, a: &Attrs) -> Result<ScalarVariable, HostError> {
    let more = Fmi2Attrs {
        kind: VarKind::Real,
        causality_given: a.get("causality").is_some(),
        can_handle_multiple_set_per_time_instant: None,
    };
    let mut v = ScalarVariable::read(doc, a, Variability::Continuous, more)?;
    v.can_handle_multiple_set_per_time_instant =
        doc.boolean(a, "canHandleMultipleSetPerTimeInstant")?;
    Ok(v)
}

/// The `start` of a type element of `kind` of the variable `name` (both quoted in an error
/// shortened, as every text of the file is).
fn start_value(
    doc: &Doc<'_>,
    kind: VarKind,
    name: &str,
    a: &Attrs,
) -> Result<Option<StartValue>, HostError> {
    let Some(s) = a.get("start") else {
        return Ok(None);
    };
    let bad = |what| {
        let (who, start) = (shown(name, 60), shown(s, 40));
        doc.err(
            a.line,
            format!("variable '{who}': start=\"{start}\" is not {what}"),
        )
    };
    Ok(Some(match kind {
        VarKind::Real => StartValue::Real(parse_real(s).ok_or_else(|| bad("a real number"))?),
        VarKind::Integer | VarKind::Enumeration => {
            StartValue::Integer(s.trim().parse::<i64>().map_err(|_| bad("an integer"))?)
        }
        VarKind::Boolean => StartValue::Boolean(doc.boolean(a, "start")?.unwrap_or(false)),
        VarKind::String => StartValue::String(s.to_string()),
    }))
}

/// An `<Unknown>` of `<ModelStructure>` (FMI 2.0.4 section 2.2.8).
fn unknown(doc: &Doc<'_>, a: &Attrs) -> Result<Unknown, HostError> {
    let bad = |t: &str| {
        let t = shown(t, 40);
        format!("<Unknown> dependencies entry \"{t}\" is not an index")
    };
    Ok(Unknown {
        index: doc.parsed::<usize>(a, "index", "an index")?,
        dependencies: list(doc, a, "dependencies", bad)?,
        dependencies_kind: dependencies_kind(a),
        line: a.line,
    })
}

/// One base type for aliasing (FMI 2.0.4 section 2.2.7): an Enumeration's values are Integers.
fn same_base(a: VarKind, b: VarKind) -> bool {
    let base = |k| match k {
        VarKind::Enumeration => VarKind::Integer,
        k => k,
    };
    base(a) == base(b)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::{Causality, Initial, ModelDescription, StartValue, VarKind, Variability};

    pub(crate) const SAMPLE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Osc" guid="{1234}" description="A &amp; B"
  variableNamingConvention="structured" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="Osc" canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUstate="true" canSerializeFMUstate="true"/>
  <UnitDefinitions>
    <Unit name="rad"><BaseUnit rad="1"/><DisplayUnit name="deg" factor="57.29577951308232"/></Unit>
    <Unit name="m/s2"><BaseUnit m="1" s="-2"/></Unit>
  </UnitDefinitions>
  <LogCategories><Category name="logAll" description="everything"/></LogCategories>
  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.001"/>
  <ModelVariables>
    <ScalarVariable name="time" valueReference="0" causality="independent" variability="continuous"><Real/></ScalarVariable>
    <ScalarVariable name="x" valueReference="1" causality="output" initial="exact"
       description="position"><Real start="1" unit="rad" displayUnit="deg"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="2" causality="parameter" variability="fixed">
      <Real start="2.5" min="0" max="INF"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="3" causality="input"><Real start="0" unit="m/s2"/></ScalarVariable>
    <ScalarVariable name="on" valueReference="4" causality="parameter" variability="fixed"><Boolean start="true"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="5" causality="parameter" variability="tunable"><Integer start="-3" min="-5" max="5"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="2" dependencies="" /></Outputs>
    <InitialUnknowns></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#;

    #[test]
    fn parses_every_part_of_a_description() {
        let md = ModelDescription::parse(SAMPLE, "md.xml").unwrap();
        assert_eq!(md.fmi_version, "2.0");
        assert_eq!(md.model_name, "Osc");
        assert_eq!(md.guid, "{1234}");
        assert_eq!(md.description.as_deref(), Some("A & B"));
        let cs = md.co_simulation.as_ref().unwrap();
        assert_eq!(cs.model_identifier, "Osc");
        assert!(cs.can_handle_variable_communication_step_size);
        assert!(cs.can_get_and_set_fmu_state && cs.can_serialize_fmu_state);
        assert!(!cs.can_interpolate_inputs);
        assert_eq!(md.unit_definitions.len(), 2);
        let rad = md.unit("rad").unwrap();
        assert_eq!(rad.base_unit.as_ref().unwrap().exponents[7], 1);
        assert_eq!(rad.display_units[0].name, "deg");
        assert!((rad.display_units[0].factor - 57.29577951308232).abs() < 1e-12);
        assert_eq!(
            md.unit("m/s2")
                .unwrap()
                .base_unit
                .as_ref()
                .unwrap()
                .exponents[..3],
            [0, 1, -2]
        );
        assert_eq!(md.log_categories[0].name, "logAll");
        assert_eq!(
            md.default_experiment.as_ref().unwrap().step_size,
            Some(0.001)
        );
        assert_eq!(md.model_variables.len(), 6);
        let x = md.variable("x").unwrap();
        assert_eq!(x.value_reference, 1);
        assert_eq!(x.causality, Causality::Output);
        assert_eq!(x.variability, Variability::Continuous);
        assert!(!x.variability_given);
        assert_eq!(x.initial, Some(Initial::Exact));
        assert_eq!(x.start, Some(StartValue::Real(1.0)));
        assert_eq!(x.unit.as_deref(), Some("rad"));
        assert_eq!(x.display_unit.as_deref(), Some("deg"));
        assert_eq!(x.line, 14);
        let k = md.variable("k").unwrap();
        assert_eq!(k.max, Some(f64::INFINITY));
        assert_eq!(k.effective_initial(), Some(Initial::Exact));
        assert_eq!(md.variable("u").unwrap().effective_initial(), None);
        assert_eq!(
            md.variable("on").unwrap().start,
            Some(StartValue::Boolean(true))
        );
        let n = md.variable("n").unwrap();
        assert_eq!(
            (n.kind, n.start.clone(), n.min, n.max),
            (
                VarKind::Integer,
                Some(StartValue::Integer(-3)),
                Some(-5.0),
                Some(5.0)
            )
        );
        assert!(md.model_structure.present);
        assert_eq!(md.model_structure.outputs.len(), 1);
        assert_eq!(md.model_structure.outputs[0].index, 2);
        assert_eq!(md.model_structure.outputs[0].dependencies, Some(vec![]));
        assert_eq!(md.output_names(), vec!["x"]);
        assert_eq!(md.input_names(), vec!["u"]);
    }

    fn err_of(xml: &str) -> String {
        ModelDescription::parse(xml, "md.xml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn malformed_xml_is_an_error_with_line() {
        let e = err_of("<fmiModelDescription fmiVersion=\"2.0\">\n<ModelVariables>\n</Oops>\n</fmiModelDescription>");
        assert!(e.starts_with("md.xml:3:1: malformed XML"), "{e}");
    }

    #[test]
    fn wrong_root_and_empty_are_errors() {
        assert!(err_of("<foo/>").contains("root element is <foo>"));
        assert!(err_of("").contains("no <fmiModelDescription>"));
    }

    #[test]
    fn bad_attribute_values_are_errors_naming_them() {
        let e = err_of("<fmiModelDescription>\n<ModelVariables>\n<ScalarVariable name=\"a\" valueReference=\"-1\"><Real/></ScalarVariable></ModelVariables></fmiModelDescription>");
        assert!(
            e.starts_with("md.xml:3:") && e.contains("valueReference"),
            "{e}"
        );
        let e = err_of("<fmiModelDescription><ModelVariables><ScalarVariable name=\"a\" valueReference=\"1\" causality=\"outptu\"><Real/></ScalarVariable></ModelVariables></fmiModelDescription>");
        assert!(e.contains("unknown causality \"outptu\""), "{e}");
        let e = err_of("<fmiModelDescription><ModelVariables><ScalarVariable name=\"a\" valueReference=\"1\"><Real start=\"x1\"/></ScalarVariable></ModelVariables></fmiModelDescription>");
        assert!(e.contains("start=\"x1\" is not a real number"), "{e}");
        let e = err_of("<fmiModelDescription><CoSimulation modelIdentifier=\"a\" canGetAndSetFMUstate=\"yes\"/></fmiModelDescription>");
        assert!(
            e.contains("canGetAndSetFMUstate=\"yes\" is not a boolean"),
            "{e}"
        );
        let e = err_of("<fmiModelDescription><CoSimulation/></fmiModelDescription>");
        assert!(
            e.contains("lacks the required attribute modelIdentifier"),
            "{e}"
        );
        let e = err_of("<fmiModelDescription><ModelVariables><ScalarVariable valueReference=\"1\"><Real/></ScalarVariable></ModelVariables></fmiModelDescription>");
        assert!(e.contains("lacks the required attribute name"), "{e}");
    }
}
