//! What the FMI 2.0 and FMI 3.0 description readers ([`crate::md`], [`crate::fmi3::md`]) read
//! the same way: the identity attributes of `<fmiModelDescription>`, the attributes of a
//! variable (FMI 2.0.4 section 2.2.7, FMI 3.0.2 section 2.4.7) and of its type, the lists of
//! indices or value references (`<ModelStructure>`, `clocks`) and FMPy's choice of the
//! variables recorded by default. What a version adds to a variable is its [`Dialect`], the
//! `more` part of [`Var`].

use crate::error::{shown, HostError};
use crate::xml::{Attrs, Doc};
use fmi_types::{Initial, Variability};
use std::fmt::Debug;
use std::str::FromStr;

/// `Deref` and `DerefMut` of `$t` to its field `$field`, whose fields then read as `$t`'s own
/// (with one type parameter `$g`: after `where`).
macro_rules! reads_as {
    ($t:ty => $field:ident: $target:ty $(, where $g:ident: $bound:path)?) => {
        impl$(<$g: $bound>)? std::ops::Deref for $t {
            type Target = $target;
            fn deref(&self) -> &$target {
                &self.$field
            }
        }
        impl$(<$g: $bound>)? std::ops::DerefMut for $t {
            fn deref_mut(&mut self) -> &mut $target {
                &mut self.$field
            }
        }
    };
}
pub(crate) use reads_as;

/// The attributes of `<fmiModelDescription>` that both versions define alike (FMI 2.0.4
/// section 2.2.1, FMI 3.0.2 section 2.4.1); each version's description reads them as its own.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Identity {
    /// `fmiVersion`
    pub fmi_version: String,
    /// `modelName`
    pub model_name: String,
    /// `description`
    pub description: Option<String>,
    /// `author`
    pub author: Option<String>,
    /// `version`
    pub version: Option<String>,
    /// `generationTool`
    pub generation_tool: Option<String>,
    /// `generationDateAndTime`
    pub generation_date_and_time: Option<String>,
    /// `variableNamingConvention`
    pub variable_naming_convention: Option<String>,
}

impl Identity {
    /// The attributes of the root element `a` (absent names and version: empty, which
    /// `validate` reports).
    pub(crate) fn read(a: &Attrs) -> Self {
        Identity {
            fmi_version: a.text("fmiVersion").unwrap_or_default(),
            model_name: a.text("modelName").unwrap_or_default(),
            description: a.text("description"),
            author: a.text("author"),
            version: a.text("version"),
            generation_tool: a.text("generationTool"),
            generation_date_and_time: a.text("generationDateAndTime"),
            variable_naming_convention: a.text("variableNamingConvention"),
        }
    }
}

/// A type definition: FMI 2.0's `<SimpleType>` with its type element (FMI 2.0.4 section 2.2.3),
/// FMI 3.0's `<Float64Type>`, `<EnumerationType>`, ... (FMI 3.0.2 section 2.4.4); `T` is the
/// base type.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct TypeDefinition<T> {
    /// `name`
    pub name: String,
    /// The base type.
    pub ty: T,
    /// `unit`
    pub unit: Option<String>,
    /// `displayUnit` (Real, Float types)
    pub display_unit: Option<String>,
    /// `min`
    pub min: Option<f64>,
    /// `max`
    pub max: Option<f64>,
    /// `<Item name value>` of an FMI 3.0 `<EnumerationType>` (not read in FMI 2.0).
    pub items: Vec<(String, i64)>,
    /// Line of the tag.
    pub line: usize,
}

/// What the variables of one FMI version have beyond [`Var`]'s attributes, and the types of the
/// attributes in which the versions differ.
pub trait Dialect: Clone + Debug + PartialEq + serde::Serialize {
    /// `causality` (FMI 3.0.2 section 2.4.7.4 adds `structuralParameter`).
    type Causality: Copy + Debug + PartialEq + serde::Serialize;
    /// `start` (FMI 2.0: one value; FMI 3.0: a buffer, row-major for arrays).
    type Start: Clone + Debug + PartialEq + serde::Serialize;
    /// What `derivative` names (FMI 2.0: the 1-based index of the state; FMI 3.0: its value
    /// reference).
    type Ref: Copy + Debug + PartialEq + serde::Serialize + FromStr;
    /// The type `Ref` in an error message.
    const REF: &'static str;
    /// `local`, the default causality of both versions.
    const LOCAL: Self::Causality;
    /// Parses the spelling of a causality.
    fn causality(s: &str) -> Option<Self::Causality>;
    /// The FMI 2.0 causality whose default `initial` this one has (a structural parameter's is
    /// that of a parameter, FMI 3.0.2 section 2.4.7.5).
    fn base(c: Self::Causality) -> fmi_types::Causality;
}

/// One variable of `<ModelVariables>`: the attributes both versions give it, and the version's
/// own (`more`, whose fields read as the variable's own through `Deref`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Var<D: Dialect> {
    /// `name`
    pub name: String,
    /// `valueReference`
    pub value_reference: u32,
    /// `description`
    pub description: Option<String>,
    /// `causality` (default local applied)
    pub causality: D::Causality,
    /// `variability` (default applied: FMI 2.0 continuous; FMI 3.0 continuous for Float32 and
    /// Float64, discrete otherwise)
    pub variability: Variability,
    /// True when `variability` was written.
    pub variability_given: bool,
    /// `initial` as written (None when absent).
    pub initial: Option<Initial>,
    /// `declaredType`
    pub declared_type: Option<String>,
    /// `start`
    pub start: Option<D::Start>,
    /// `min` (numeric types)
    pub min: Option<f64>,
    /// `max` (numeric types)
    pub max: Option<f64>,
    /// `nominal` (Real, Float types)
    pub nominal: Option<f64>,
    /// `unit` (Real, Float types)
    pub unit: Option<String>,
    /// `displayUnit` (Real, Float types)
    pub display_unit: Option<String>,
    /// `quantity`
    pub quantity: Option<String>,
    /// `derivative`: the state this is the derivative of.
    pub derivative: Option<D::Ref>,
    /// Line of the variable's tag in the file.
    pub line: usize,
    /// What the version adds.
    #[serde(flatten)]
    pub more: D,
}

reads_as!(Var<D> => more: D, where D: Dialect);

impl<D: Dialect> Var<D> {
    /// The variable element `a` with its name, valueReference, description, causality,
    /// variability (`variability` when absent) and initial; the type's attributes come from
    /// [`Self::read_type`].
    pub(crate) fn read(
        doc: &Doc<'_>,
        a: &Attrs,
        variability: Variability,
        more: D,
    ) -> Result<Self, HostError> {
        let name = doc.required(a, "name")?;
        let who = shown(&name, 60);
        let vr = doc.required(a, "valueReference")?;
        let value_reference = vr.trim().parse::<u32>().map_err(|_| {
            let vr = shown(&vr, 40);
            let m = format!(
                "variable '{who}': valueReference=\"{vr}\" is not an unsigned 32-bit integer"
            );
            doc.err(a.line, m)
        })?;
        let causality = spelled(doc, a, &who, "causality", D::causality)?;
        let given = spelled(doc, a, &who, "variability", Variability::parse)?;
        Ok(Var {
            description: a.text("description"),
            causality: causality.unwrap_or(D::LOCAL),
            variability: given.unwrap_or(variability),
            variability_given: given.is_some(),
            initial: spelled(doc, a, &who, "initial", Initial::parse)?,
            declared_type: None,
            start: None,
            min: None,
            max: None,
            nominal: None,
            unit: None,
            display_unit: None,
            quantity: None,
            derivative: None,
            line: a.line,
            name,
            value_reference,
            more,
        })
    }

    /// The attributes of the variable's type (FMI 2.0: on the type element; FMI 3.0: on the
    /// variable element): declaredType, quantity, unit, displayUnit, min, max, nominal and
    /// derivative.
    pub(crate) fn read_type(&mut self, doc: &Doc<'_>, a: &Attrs) -> Result<(), HostError> {
        self.min = doc.real(a, "min")?;
        self.max = doc.real(a, "max")?;
        self.nominal = doc.real(a, "nominal")?;
        self.derivative = doc.parse::<D::Ref>(a, "derivative", D::REF)?;
        self.declared_type = a.text("declaredType");
        self.unit = a.text("unit");
        self.display_unit = a.text("displayUnit");
        self.quantity = a.text("quantity");
        Ok(())
    }

    /// The effective `initial`: as written, else the default of FMI 2.0.4 table 2.2.7 and
    /// FMI 3.0.2 section 2.4.7.5 (exact for constants and (structural) parameters, calculated
    /// for calculated parameters, outputs and locals, none for inputs and the independent
    /// variable).
    pub fn effective_initial(&self) -> Option<Initial> {
        let c = D::base(self.causality);
        self.initial
            .or_else(|| fmi_types::schema::default_initial(c, self.variability))
    }

    /// The same variable in the dialect `E`: its causality, start and derivative converted by
    /// the caller, `more` given.
    pub fn convert<E: Dialect>(
        &self,
        causality: E::Causality,
        start: Option<E::Start>,
        derivative: Option<E::Ref>,
        more: E,
    ) -> Var<E> {
        Var {
            name: self.name.clone(),
            value_reference: self.value_reference,
            description: self.description.clone(),
            causality,
            variability: self.variability,
            variability_given: self.variability_given,
            initial: self.initial,
            declared_type: self.declared_type.clone(),
            start,
            min: self.min,
            max: self.max,
            nominal: self.nominal,
            unit: self.unit.clone(),
            display_unit: self.display_unit.clone(),
            quantity: self.quantity.clone(),
            derivative,
            line: self.line,
            more,
        }
    }
}

/// The enumeration attribute `key` of the variable `who` read by `parse` (None when absent).
fn spelled<T>(
    doc: &Doc<'_>,
    a: &Attrs,
    who: &str,
    key: &str,
    parse: impl Fn(&str) -> Option<T>,
) -> Result<Option<T>, HostError> {
    let bad = |o: &str| format!("variable '{who}': unknown {key} \"{}\"", shown(o, 40));
    doc.read_with(a, key, parse, bad)
}

/// The whitespace-separated list `key` (None when absent); `bad` gives the message for an
/// entry that does not parse as `T`.
pub(crate) fn list<T: FromStr>(
    doc: &Doc<'_>,
    a: &Attrs,
    key: &str,
    bad: impl Fn(&str) -> String,
) -> Result<Option<Vec<T>>, HostError> {
    let entry = |t: &str| t.parse::<T>().map_err(|_| doc.err(a.line, bad(t)));
    let entries = |s: &str| s.split_whitespace().map(entry).collect();
    a.get(key).map(entries).transpose()
}

/// How many states, or variables, FMPy records at most for an FMU without outputs.
pub const MAX_FALLBACK_RECORDED: usize = 5;

/// Names recorded when none are asked for, by FMPy's rule (`simulate_fmu`,
/// `_get_output_variables`): the `outputs`; without outputs the continuous `states` (those
/// `<ModelStructure>` lists the derivatives of), at most [`MAX_FALLBACK_RECORDED`]; without
/// those the first five `variables` but `time` (the name of the time column).
pub(crate) fn recorded_by_default<'a, D: Dialect + 'a>(
    outputs: Vec<String>,
    states: impl Iterator<Item = &'a Var<D>>,
    variables: &'a [Var<D>],
) -> Vec<String> {
    if !outputs.is_empty() {
        return outputs;
    }
    let name = |v: &Var<D>| v.name.clone();
    let states: Vec<String> = states.take(MAX_FALLBACK_RECORDED).map(name).collect();
    if !states.is_empty() {
        return states;
    }
    let first = variables.iter().take(MAX_FALLBACK_RECORDED);
    first.filter(|v| v.name != "time").map(name).collect()
}

/// The list `dependenciesKind` of a `<ModelStructure>` element (None when absent).
pub(crate) fn dependencies_kind(a: &Attrs) -> Option<Vec<String>> {
    let s = a.get("dependenciesKind")?;
    Some(s.split_whitespace().map(str::to_string).collect())
}
