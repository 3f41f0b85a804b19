//! Typed `modelDescription.xml` of FMI 3.0 (FMI 3.0.2 section 2.4) and its parser.
//!
//! Why the host's own quick-xml parser rather than the `fmi-schema` crate (rust-fmi, which reads
//! FMI 2.0 and 3.0 into serde structures through `hard_xml`):
//! - `validate` reports each finding with the line of its element; `hard_xml`'s structures keep
//!   no positions, and its strict mode refuses the whole file at the first unknown attribute or
//!   element, where a validator wants every problem of the file, each located.
//! - Hostile input is bounded the same way for both versions (the 64 MiB limit before reading,
//!   values checked against their type's range, every message naming file, line and attribute
//!   with the offending text cut short): with `fmi-schema` the FMI 3.0 path would answer
//!   malformed input with another crate's messages.
//! - The host already owns an FMI 2.0 parser on the same reader ([`crate::xml`]); a second
//!   dependency tree (`hard_xml`, `xmlparser`, `fmi-schema`'s own release cycle, a 0.x API) for
//!   the same job would add maintenance without removing any.
//!
//! Like the FMI 2.0 parser, this one is strict about syntax (malformed XML, attributes that do
//! not parse as their type, start values outside their type's range) and leaves the semantic
//! rules (combinations of causality and variability, complete `<ModelStructure>`) to `validate`.
//! What it reads as FMI 2.0 does is in [`crate::md_common`].

use super::value::{Type3, Values};
use crate::error::HostError;
use crate::md_common::{
    self, dependencies_kind, list, reads_as, Dialect, Identity, TypeDefinition, Var,
};
use crate::xml::{Ancestors, Attrs, Doc, Visitor};
use std::borrow::Cow;

pub use fmi_types::{Initial, Variability};

/// `causality` of an FMI 3.0 variable: the causality of the version-neutral view.
pub use crate::view::Causality as Causality3;

/// `<Dimension>` of an array variable: a fixed size or a structural parameter's value.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Dimension {
    /// `start`: the fixed size.
    pub start: Option<u64>,
    /// `valueReference` of the structural parameter (or constant) giving the size.
    pub value_reference: Option<u32>,
    /// Line of the tag.
    pub line: usize,
}

/// One variable of `<ModelVariables>` (FMI 3.0.2 section 2.4.7).
pub type Variable3 = Var<Fmi3Attrs>;

/// What an FMI 3.0 variable has beyond the attributes of [`Var`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Fmi3Attrs {
    /// The type element.
    pub ty: Type3,
    /// `clocks`: value references of the clocks this variable belongs to.
    pub clocks: Vec<u32>,
    /// `<Dimension>`s in order (empty: a scalar).
    pub dimensions: Vec<Dimension>,
    /// `intervalVariability` (Clock)
    pub interval_variability: Option<String>,
    /// `intervalDecimal` (Clock)
    pub interval_decimal: Option<f64>,
    /// `shiftDecimal` (Clock)
    pub shift_decimal: Option<f64>,
    /// Its `<Alias>` elements: other names of the same value (FMI 3.0.2 section 2.4.7.4).
    pub aliases: Vec<Alias3>,
}

impl Fmi3Attrs {
    /// A scalar of type `ty`, in no clock, without aliases.
    pub fn new(ty: Type3) -> Self {
        Fmi3Attrs {
            ty,
            clocks: Vec::new(),
            dimensions: Vec::new(),
            interval_variability: None,
            interval_decimal: None,
            shift_decimal: None,
            aliases: Vec::new(),
        }
    }
}

impl Dialect for Fmi3Attrs {
    type Causality = Causality3;
    type Start = Values;
    type Ref = u32;
    const REF: &'static str = "a value reference";
    const LOCAL: Causality3 = Causality3::Local;
    fn causality(s: &str) -> Option<Causality3> {
        Causality3::parse(s)
    }
    /// The same spelling; a structural parameter is a parameter.
    fn base(c: Causality3) -> fmi_types::Causality {
        fmi_types::Causality::parse(c.as_str()).unwrap_or(fmi_types::Causality::Parameter)
    }
}

/// `<Alias>` of a variable (FMI 3.0.2 section 2.4.7.4): a name, unique among variables and
/// aliases, for the same value reference, with its own description and display unit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Alias3 {
    /// `name`
    pub name: String,
    /// `description`
    pub description: Option<String>,
    /// `displayUnit` (Float types)
    pub display_unit: Option<String>,
    /// Line of the tag.
    pub line: usize,
}

impl Variable3 {
    /// True for an array (it has `<Dimension>`s).
    pub fn is_array(&self) -> bool {
        !self.dimensions.is_empty()
    }
}

/// An interface element (`<ModelExchange>`, `<CoSimulation>`, `<ScheduledExecution>`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Interface3 {
    /// `modelIdentifier`
    pub model_identifier: String,
    /// Capability flags written, with their values (e.g. `canGetAndSetFMUState`).
    pub flags: Vec<(String, bool)>,
    /// `fixedInternalStepSize` (CoSimulation)
    pub fixed_internal_step_size: Option<f64>,
    /// `maxOutputDerivativeOrder` (CoSimulation)
    pub max_output_derivative_order: Option<u32>,
    /// Line of the tag.
    pub line: usize,
}

impl Interface3 {
    /// The value of a capability flag (default false).
    pub fn flag(&self, name: &str) -> bool {
        self.flags.iter().any(|(n, v)| n == name && *v)
    }
}

/// The boolean capability flags of the interface elements (FMI 3.0.2 section 2.4.5).
const INTERFACE_FLAGS: [&str; 14] = [
    "needsExecutionTool",
    "canBeInstantiatedOnlyOncePerProcess",
    "canGetAndSetFMUState",
    "canSerializeFMUState",
    "providesDirectionalDerivatives",
    "providesAdjointDerivatives",
    "providesPerElementDependencies",
    "needsCompletedIntegratorStep",
    "providesEvaluateDiscreteStates",
    "canHandleVariableCommunicationStepSize",
    "hasEventMode",
    "providesIntermediateUpdate",
    "mightReturnEarlyFromDoStep",
    "canReturnEarlyAfterIntermediateUpdate",
];

/// The values of a Clock's `intervalVariability` (FMI 3.0.2 section 2.4.7.6, table "Overview of
/// Clock types"), which the schema also lists.
pub const INTERVAL_VARIABILITIES: &[&str] = &[
    "constant",
    "fixed",
    "tunable",
    "changing",
    "countdown",
    "triggered",
];

/// A type definition (`<Float64Type>`, `<EnumerationType>`, ...).
pub type TypeDefinition3 = TypeDefinition<Type3>;

/// `<Unit>` of `<UnitDefinitions>`: FMI 3.0.2 section 2.4.3 gives it the elements of FMI 2.0.4.
pub type Unit3 = crate::md::Unit;

/// `<DisplayUnit>` of a `<Unit>`, with FMI 3.0's `inverse`.
pub type DisplayUnit3 = crate::md::DisplayUnit;

/// An element of `<ModelStructure>`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Unknown3 {
    /// `valueReference`
    pub value_reference: u32,
    /// `dependencies` (None when absent: depends on everything).
    pub dependencies: Option<Vec<u32>>,
    /// `dependenciesKind`
    pub dependencies_kind: Option<Vec<String>>,
    /// Line of the tag.
    pub line: usize,
}

/// `<ModelStructure>`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelStructure3 {
    /// `<Output>`
    pub outputs: Vec<Unknown3>,
    /// `<ContinuousStateDerivative>`
    pub continuous_state_derivatives: Vec<Unknown3>,
    /// `<ClockedState>`
    pub clocked_states: Vec<Unknown3>,
    /// `<InitialUnknown>`
    pub initial_unknowns: Vec<Unknown3>,
    /// `<EventIndicator>`
    pub event_indicators: Vec<Unknown3>,
}

/// `<DefaultExperiment>`: FMI 3.0.2 gives it the four attributes of FMI 2.0.4.
pub type DefaultExperiment3 = crate::md::DefaultExperiment;

/// The parsed FMI 3.0 `modelDescription.xml`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelDescription3 {
    /// The identity attributes, read as the description's own.
    #[serde(flatten)]
    pub identity: Identity,
    /// `instantiationToken`
    pub instantiation_token: String,
    /// `<ModelExchange>`
    pub model_exchange: Option<Interface3>,
    /// `<CoSimulation>`
    pub co_simulation: Option<Interface3>,
    /// `<ScheduledExecution>`
    pub scheduled_execution: Option<Interface3>,
    /// `<UnitDefinitions>`
    pub units: Vec<Unit3>,
    /// `<TypeDefinitions>`
    pub type_definitions: Vec<TypeDefinition3>,
    /// `<LogCategories>` names.
    pub log_categories: Vec<String>,
    /// `<DefaultExperiment>`
    pub default_experiment: Option<DefaultExperiment3>,
    /// `<ModelVariables>` in file order.
    pub variables: Vec<Variable3>,
    /// `<ModelStructure>`
    pub model_structure: ModelStructure3,
}

/// An array whose shape cannot be known, or is too large.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A `<Dimension valueReference>` naming no integer variable with a start value.
    #[error(
        "'{variable}': <Dimension valueReference=\"{value_reference}\"> (line {line}) refers to \
         no integer variable with a start value"
    )]
    NoSize {
        /// The array variable.
        variable: String,
        /// The value reference its dimension names.
        value_reference: u32,
        /// Line of the `<Dimension>`.
        line: usize,
    },
    /// A `<Dimension>` with neither attribute.
    #[error("'{variable}': <Dimension> (line {line}) has neither start nor valueReference")]
    NoDimension {
        /// The array variable.
        variable: String,
        /// Line of the `<Dimension>`.
        line: usize,
    },
    /// More elements than [`MAX_ARRAY_ELEMENTS`].
    #[error("'{variable}' would have more than {MAX_ARRAY_ELEMENTS} elements")]
    TooLarge {
        /// The array variable.
        variable: String,
    },
}

/// Most elements one array variable may have, counted from its fixed dimensions or its
/// structural parameters' start values: far above any real model, far below what exhausts
/// memory when the host allocates the buffers to read it.
pub const MAX_ARRAY_ELEMENTS: u64 = 1 << 24;

reads_as!(ModelDescription3 => identity: Identity);

impl ModelDescription3 {
    /// Parses the text of an FMI 3.0 `modelDescription.xml`; `file` names it in errors.
    pub fn parse(xml: &str, file: &str) -> Result<Self, HostError> {
        Ok(crate::xml::read(xml, file, Parser3::default())?.md)
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&Variable3> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// The description as a simulation sees it, as FMPy's `read_model_description` makes it:
    /// every `<Alias>` one more variable after those of the file, a copy of its variable with
    /// the alias's name (and description and display unit where it gives them), so that an
    /// alias is recorded, set and named in a CSV like any variable. Borrowed when there is none.
    pub fn with_aliases(&self) -> Cow<'_, ModelDescription3> {
        if self.variables.iter().all(|v| v.aliases.is_empty()) {
            return Cow::Borrowed(self);
        }
        let mut md = self.clone();
        let aliases: Vec<Variable3> = self
            .variables
            .iter()
            .flat_map(|v| v.aliases.iter().map(move |a| (v, a)))
            .map(|(v, a)| {
                let mut alias = v.clone();
                alias.name = a.name.clone();
                alias.description = a.description.clone().or_else(|| v.description.clone());
                alias.display_unit = a.display_unit.clone().or_else(|| v.display_unit.clone());
                alias.aliases = Vec::new();
                alias.line = a.line;
                alias
            })
            .collect();
        md.variables.extend(aliases);
        Cow::Owned(md)
    }

    /// The variable with value reference `vr` (FMI 3.0 value references are unique).
    pub fn by_vr(&self, vr: u32) -> Option<&Variable3> {
        self.variables.iter().find(|v| v.value_reference == vr)
    }

    /// Names recorded when none are asked for, by FMPy's rule as for FMI 2.0
    /// ([`crate::md::ModelDescription::recorded_by_default`]): the outputs (aliases included
    /// after [`Self::with_aliases`]), else at most five continuous states (the variables the
    /// `<ContinuousStateDerivative>` entries are the derivatives of), else the first five
    /// variables but `time`.
    pub fn recorded_by_default(&self) -> Vec<String> {
        let outputs = self.with_causality(Causality3::Output);
        // an output clock has no value between events (FMI 3.0.2 section 2.2.8.2)
        let outputs = outputs
            .filter(|v| v.ty != Type3::Clock)
            .map(|v| v.name.clone());
        let derivatives = self.model_structure.continuous_state_derivatives.iter();
        let states =
            derivatives.filter_map(|u| self.by_vr(self.by_vr(u.value_reference)?.derivative?));
        md_common::recorded_by_default(outputs.collect(), states, &self.variables)
    }

    /// Variables with causality `c`, in file order.
    pub fn with_causality(&self, c: Causality3) -> impl Iterator<Item = &Variable3> {
        self.variables.iter().filter(move |v| v.causality == c)
    }

    /// The shape of `v` from the start values of its dimensions (structural parameters at their
    /// start values); empty for a scalar. Err names a dimension that refers to no integer
    /// variable with a start, or a size beyond [`MAX_ARRAY_ELEMENTS`].
    pub fn shape(&self, v: &Variable3) -> Result<Vec<usize>, ShapeError> {
        self.shape_with(v, &|vr| self.start_size(vr))
    }

    /// [`shape`](Self::shape) with the sizes of structural parameters from `size_of` (their
    /// values after `--set`, or as the FMU reports them).
    pub fn shape_with(
        &self,
        v: &Variable3,
        size_of: &dyn Fn(u32) -> Option<u64>,
    ) -> Result<Vec<usize>, ShapeError> {
        let mut total: u64 = 1;
        let mut shape = Vec::with_capacity(v.dimensions.len());
        for d in &v.dimensions {
            let n = match (d.start, d.value_reference) {
                (Some(n), _) => n,
                (None, Some(vr)) => size_of(vr).ok_or_else(|| ShapeError::NoSize {
                    variable: v.name.clone(),
                    value_reference: vr,
                    line: d.line,
                })?,
                (None, None) => {
                    return Err(ShapeError::NoDimension {
                        variable: v.name.clone(),
                        line: d.line,
                    })
                }
            };
            total = total.saturating_mul(n);
            if total > MAX_ARRAY_ELEMENTS {
                return Err(ShapeError::TooLarge {
                    variable: v.name.clone(),
                });
            }
            shape.push(n as usize);
        }
        Ok(shape)
    }

    /// The start value of the integer variable `vr`, as an array size.
    fn start_size(&self, vr: u32) -> Option<u64> {
        let v = self.by_vr(vr)?;
        if !v.ty.is_integer() || v.is_array() {
            return None;
        }
        let x = v.start.as_ref()?.number(0)?;
        (x >= 0.0).then_some(x as u64)
    }
}

#[derive(Default)]
struct Parser3 {
    md: ModelDescription3,
    /// The variable whose element is open (children: Dimension, Start, Alias).
    current: Option<Variable3>,
}

impl Visitor for Parser3 {
    fn element(&mut self, doc: &Doc<'_>, path: Ancestors<'_>, a: Attrs) -> Result<(), HostError> {
        let parent = path.last().map(String::as_str).unwrap_or("");
        match (parent, a.element.as_str()) {
            ("", _) => self.root(doc, &a)?,
            (
                "fmiModelDescription",
                kind @ ("ModelExchange" | "CoSimulation" | "ScheduledExecution"),
            ) => {
                let i = interface(doc, &a)?;
                let slot = match kind {
                    "ModelExchange" => &mut self.md.model_exchange,
                    "CoSimulation" => &mut self.md.co_simulation,
                    _ => &mut self.md.scheduled_execution,
                };
                *slot = Some(i);
            }
            ("UnitDefinitions", "Unit") => self.md.units.push(Unit3::read(doc, &a)?),
            ("Unit", "DisplayUnit") => {
                let d = DisplayUnit3::read(doc, &a, true)?;
                if let Some(u) = self.md.units.last_mut() {
                    u.display_units.push(d);
                }
            }
            ("TypeDefinitions", kind) => self.type_definition(doc, kind, &a)?,
            ("EnumerationType", "Item") => {
                let name = doc.required(&a, "name")?;
                let value = doc.parsed::<i64>(&a, "value", "an integer")?;
                if let Some(t) = self.md.type_definitions.last_mut() {
                    t.items.push((name, value));
                }
            }
            ("LogCategories", "Category") => self.md.log_categories.push(doc.required(&a, "name")?),
            ("fmiModelDescription", "DefaultExperiment") => {
                self.md.default_experiment = Some(DefaultExperiment3::read(doc, &a)?);
            }
            ("ModelVariables", kind) => self.variable(doc, kind, &a)?,
            (_, "Dimension") if path.len() >= 2 && path[path.len() - 2] == "ModelVariables" => {
                let d = Dimension {
                    start: doc.parse::<u64>(&a, "start", "an unsigned integer")?,
                    value_reference: doc.parse::<u32>(&a, "valueReference", "a value reference")?,
                    line: a.line,
                };
                if let Some(v) = self.current.as_mut() {
                    v.dimensions.push(d);
                }
            }
            (kind @ ("String" | "Binary"), "Start")
                if path.len() >= 2 && path[path.len() - 2] == "ModelVariables" =>
            {
                let text = doc.required(&a, "value")?;
                let ty = Type3::parse(kind).unwrap_or(Type3::String);
                let one = Values::parse(ty, &text)
                    .map_err(|e| doc.err(a.line, format!("<Start value=\"...\">: {e}")))?;
                if let Some(v) = self.current.as_mut() {
                    match v.start.as_mut() {
                        Some(s) => s.extend_from(&one),
                        None => v.start = Some(one),
                    }
                }
            }
            (_, "Alias") if path.len() >= 2 && path[path.len() - 2] == "ModelVariables" => {
                let alias = Alias3 {
                    name: doc.required(&a, "name")?,
                    description: a.text("description"),
                    display_unit: a.text("displayUnit"),
                    line: a.line,
                };
                if let Some(v) = self.current.as_mut() {
                    v.aliases.push(alias);
                }
            }
            ("ModelStructure", kind) => self.unknown(doc, kind, &a)?,
            _ => {}
        }
        Ok(())
    }

    fn end(&mut self, path: Ancestors<'_>, name: &str) {
        if path.last().map(String::as_str) == Some("ModelVariables") && Type3::parse(name).is_some()
        {
            if let Some(v) = self.current.take() {
                self.md.variables.push(v);
            }
        }
    }
}

impl Parser3 {
    fn root(&mut self, doc: &Doc<'_>, a: &Attrs) -> Result<(), HostError> {
        self.md.identity = Identity::read(a);
        self.md.instantiation_token = doc.required(a, "instantiationToken")?;
        Ok(())
    }

    fn type_definition(&mut self, doc: &Doc<'_>, kind: &str, a: &Attrs) -> Result<(), HostError> {
        let Some(ty) = Type3::parse_definition(kind) else {
            return Err(doc.unknown_child("TypeDefinitions", a));
        };
        self.md.type_definitions.push(TypeDefinition3 {
            name: doc.required(a, "name")?,
            ty,
            unit: a.text("unit"),
            display_unit: a.text("displayUnit"),
            min: doc.real(a, "min")?,
            max: doc.real(a, "max")?,
            items: Vec::new(),
            line: a.line,
        });
        Ok(())
    }

    fn variable(&mut self, doc: &Doc<'_>, kind: &str, a: &Attrs) -> Result<(), HostError> {
        let Some(ty) = Type3::parse(kind) else {
            return Err(doc.unknown_child("ModelVariables", a));
        };
        let variability = if ty.is_float() {
            Variability::Continuous
        } else {
            Variability::Discrete
        };
        let more = Fmi3Attrs {
            interval_variability: a.text("intervalVariability"),
            ..Fmi3Attrs::new(ty)
        };
        let mut v = Variable3::read(doc, a, variability, more)?;
        let who = crate::error::shown(&v.name, 60);
        // Numeric and Boolean starts are an attribute; String and Binary starts are <Start>
        // children, read when they come.
        v.start = match (ty, a.get("start")) {
            (Type3::String | Type3::Binary | Type3::Clock, _) | (_, None) => None,
            (_, Some(s)) => Some(
                Values::parse(ty, s)
                    .map_err(|e| doc.err(a.line, format!("variable '{who}': start: {e}")))?,
            ),
        };
        let bad = |_: &str| format!("variable '{who}': clocks is not a list of value references");
        v.clocks = list(doc, a, "clocks", bad)?.unwrap_or_default();
        v.read_type(doc, a)?;
        v.interval_decimal = doc.real(a, "intervalDecimal")?;
        v.shift_decimal = doc.real(a, "shiftDecimal")?;
        self.current = Some(v);
        Ok(())
    }

    fn unknown(&mut self, doc: &Doc<'_>, kind: &str, a: &Attrs) -> Result<(), HostError> {
        let ms = &mut self.md.model_structure;
        let to = match kind {
            "Output" => &mut ms.outputs,
            "ContinuousStateDerivative" => &mut ms.continuous_state_derivatives,
            "ClockedState" => &mut ms.clocked_states,
            "InitialUnknown" => &mut ms.initial_unknowns,
            "EventIndicator" => &mut ms.event_indicators,
            _ => return Err(doc.unknown_child("ModelStructure", a)),
        };
        let bad = |_: &str| format!("<{kind}> dependencies is not a list of value references");
        to.push(Unknown3 {
            value_reference: doc.parsed::<u32>(a, "valueReference", "a value reference")?,
            dependencies: list(doc, a, "dependencies", bad)?,
            dependencies_kind: dependencies_kind(a),
            line: a.line,
        });
        Ok(())
    }
}

fn interface(doc: &Doc<'_>, a: &Attrs) -> Result<Interface3, HostError> {
    let mut flags = Vec::new();
    for key in INTERFACE_FLAGS {
        if let Some(v) = doc.boolean(a, key)? {
            flags.push((key.to_string(), v));
        }
    }
    Ok(Interface3 {
        model_identifier: doc.required(a, "modelIdentifier")?,
        flags,
        fixed_internal_step_size: doc.real(a, "fixedInternalStepSize")?,
        max_output_derivative_order: doc.parse::<u32>(
            a,
            "maxOutputDerivativeOrder",
            "an unsigned integer",
        )?,
        line: a.line,
    })
}

#[cfg(test)]
mod tests {
    use super::{Causality3, Initial, ModelDescription3, Variability};
    use crate::fmi3::value::{Type3, Values};

    const SAMPLE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="M" instantiationToken="{abc}">
  <CoSimulation modelIdentifier="M" canHandleVariableCommunicationStepSize="true"
    fixedInternalStepSize="0.1" hasEventMode="false"/>
  <ScheduledExecution modelIdentifier="M"/>
  <TypeDefinitions>
    <EnumerationType name="Color"><Item name="red" value="1"/><Item name="blue" value="2"/></EnumerationType>
  </TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.5"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <UInt64 name="n" valueReference="1" causality="structuralParameter" variability="tunable" start="3"/>
    <Float64 name="A" valueReference="2" causality="parameter" variability="tunable" start="1 2 3 4 5 6">
      <Dimension start="2"/>
      <Dimension valueReference="1"/>
    </Float64>
    <Float32 name="f" valueReference="3" causality="input" start="0.5"/>
    <Int8 name="i8" valueReference="4" causality="output" min="-3" max="3"/>
    <Boolean name="b" valueReference="5" causality="input" start="true"/>
    <String name="s" valueReference="6" causality="parameter" variability="fixed"><Start value="a b"/></String>
    <Binary name="bin" valueReference="7" causality="input"><Start value="0aff"/></Binary>
    <Enumeration name="c" valueReference="8" declaredType="Color" causality="output"/>
    <Clock name="clk" valueReference="9" causality="input" intervalVariability="triggered"/>
    <Float64 name="x" valueReference="10" clocks="9"/>
    <Float64 name="der(x)" valueReference="11" derivative="10"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="4" dependencies="3 5"/>
    <ContinuousStateDerivative valueReference="11"/>
    <InitialUnknown valueReference="4"/>
  </ModelStructure>
</fmiModelDescription>
"#;

    #[test]
    fn parses_every_part_of_an_fmi3_description() {
        let md = ModelDescription3::parse(SAMPLE, "md.xml").unwrap();
        assert_eq!(md.fmi_version, "3.0");
        assert_eq!(md.instantiation_token, "{abc}");
        let cs = md.co_simulation.as_ref().unwrap();
        assert_eq!(cs.model_identifier, "M");
        assert!(cs.flag("canHandleVariableCommunicationStepSize"));
        assert!(!cs.flag("hasEventMode") && !cs.flag("canGetAndSetFMUState"));
        assert_eq!(cs.fixed_internal_step_size, Some(0.1));
        assert!(md.scheduled_execution.is_some() && md.model_exchange.is_none());
        assert_eq!(
            md.type_definitions[0].items,
            vec![("red".to_string(), 1), ("blue".to_string(), 2)]
        );
        assert_eq!(md.variables.len(), 12);
        let a = md.variable("A").unwrap();
        assert_eq!(a.ty, Type3::Float64);
        assert_eq!(a.dimensions.len(), 2);
        assert_eq!(md.shape(a).unwrap(), vec![2, 3]);
        assert_eq!(
            a.start,
            Some(Values::Float64(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]))
        );
        let n = md.variable("n").unwrap();
        assert_eq!(n.causality, Causality3::StructuralParameter);
        assert_eq!(n.effective_initial(), Some(Initial::Exact));
        let f = md.variable("f").unwrap();
        assert_eq!(
            (f.variability, f.start.clone()),
            (Variability::Continuous, Some(Values::Float32(vec![0.5])))
        );
        let i8v = md.variable("i8").unwrap();
        assert_eq!(
            (i8v.variability, i8v.min, i8v.max),
            (Variability::Discrete, Some(-3.0), Some(3.0))
        );
        assert_eq!(i8v.effective_initial(), Some(Initial::Calculated));
        assert_eq!(
            md.variable("s").unwrap().start,
            Some(Values::String(vec!["a b".into()]))
        );
        assert_eq!(
            md.variable("bin").unwrap().start,
            Some(Values::Binary(vec![vec![10, 255]]))
        );
        assert_eq!(
            md.variable("c").unwrap().declared_type.as_deref(),
            Some("Color")
        );
        let clk = md.variable("clk").unwrap();
        assert_eq!(
            (clk.ty, clk.interval_variability.as_deref()),
            (Type3::Clock, Some("triggered"))
        );
        assert_eq!(md.variable("x").unwrap().clocks, vec![9]);
        assert_eq!(md.variable("der(x)").unwrap().derivative, Some(10));
        assert_eq!(md.model_structure.outputs[0].dependencies, Some(vec![3, 5]));
        assert_eq!(md.model_structure.continuous_state_derivatives.len(), 1);
        assert_eq!(md.model_structure.initial_unknowns[0].line, 30);
        assert_eq!(md.variable("A").unwrap().line, 13);
    }

    fn err_of(xml: &str) -> String {
        ModelDescription3::parse(xml, "md.xml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn bad_values_are_errors_naming_line_and_attribute() {
        let head =
            "<fmiModelDescription fmiVersion=\"3.0\" instantiationToken=\"t\">\n<ModelVariables>\n";
        let e = err_of(&format!(
            "{head}<Int8 name=\"a\" valueReference=\"1\" start=\"200\"/></ModelVariables></fmiModelDescription>"
        ));
        assert!(
            e.starts_with("md.xml:3:") && e.contains("outside the range of Int8"),
            "{e}"
        );
        let e = err_of(&format!(
            "{head}<Float64 name=\"a\" valueReference=\"-1\"/></ModelVariables></fmiModelDescription>"
        ));
        assert!(e.contains("valueReference"), "{e}");
        let e = err_of(&format!(
            "{head}<Real name=\"a\" valueReference=\"1\"/></ModelVariables></fmiModelDescription>"
        ));
        assert!(e.contains("unknown element <Real>"), "{e}");
        let e = err_of(&format!(
            "{head}<Float64 name=\"a\" valueReference=\"1\" causality=\"outptu\"/></ModelVariables></fmiModelDescription>"
        ));
        assert!(e.contains("unknown causality \"outptu\""), "{e}");
        let e = err_of(&format!(
            "{head}<Binary name=\"a\" valueReference=\"1\"><Start value=\"xyz\"/></Binary></ModelVariables></fmiModelDescription>"
        ));
        assert!(e.contains("hexadecimal"), "{e}");
        let e = err_of("<fmiModelDescription fmiVersion=\"3.0\"/>");
        assert!(e.contains("instantiationToken"), "{e}");
        let e = err_of("<fmiModelDescription fmiVersion=\"3.0\" instantiationToken=\"t\"><CoSimulation modelIdentifier=\"M\" hasEventMode=\"maybe\"/></fmiModelDescription>");
        assert!(e.contains("hasEventMode=\"maybe\" is not a boolean"), "{e}");
    }

    #[test]
    fn array_sizes_are_bounded_and_dimensions_must_resolve() {
        let xml = r#"<fmiModelDescription fmiVersion="3.0" instantiationToken="t"><ModelVariables>
            <UInt64 name="n" valueReference="1" causality="structuralParameter" variability="fixed" start="100000000"/>
            <Float64 name="big" valueReference="2" causality="output"><Dimension valueReference="1"/><Dimension start="1000"/></Float64>
            <Float64 name="dangling" valueReference="3" causality="output"><Dimension valueReference="99"/></Float64>
            </ModelVariables></fmiModelDescription>"#;
        let md = ModelDescription3::parse(xml, "md.xml").unwrap();
        let e = md
            .shape(md.variable("big").unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("more than"), "{e}");
        let e = md
            .shape(md.variable("dangling").unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("valueReference=\"99\""), "{e}");
    }

    #[test]
    fn aliases_become_variables_after_those_of_the_file() {
        let xml = SAMPLE.replace(
            r#"<Int8 name="i8" valueReference="4" causality="output" min="-3" max="3"/>"#,
            r#"<Int8 name="i8" valueReference="4" causality="output" min="-3" max="3">
      <Alias name="i8_alias" description="second name"/><Alias name="i8_b"/>
    </Int8>"#,
        );
        let md = ModelDescription3::parse(&xml, "md.xml").unwrap();
        let names: Vec<&str> = md.variables.iter().map(|v| v.name.as_str()).collect();
        assert!(
            !names.contains(&"i8_alias"),
            "the file's variables stay as written"
        );
        assert_eq!(md.variable("i8").unwrap().aliases.len(), 2);
        let seen = md.with_aliases();
        let n = md.variables.len();
        assert_eq!(seen.variables.len(), n + 2);
        let alias = &seen.variables[n];
        assert_eq!(
            (alias.name.as_str(), alias.value_reference),
            ("i8_alias", 4)
        );
        assert_eq!(alias.causality, Causality3::Output);
        assert_eq!(alias.description.as_deref(), Some("second name"));
        assert_eq!(seen.variables[n + 1].name, "i8_b");
        assert_eq!(seen.by_vr(4).unwrap().name, "i8");
        let plain = ModelDescription3::parse(SAMPLE, "md.xml").unwrap();
        assert!(matches!(
            plain.with_aliases(),
            std::borrow::Cow::Borrowed(_)
        ));
    }
}
