//! The attribute groups the FMI 2.0 and FMI 3.0 schemas declare alike (the same names, types and
//! use in `fmi2*.xsd` and `fmi3*.xsd`), written once; each version's table (`fmi2.rs`,
//! `fmi3.rs`) adds what only it declares and names its own schema files.

use super::model::{opt_attr, req_attr, Attr, Ty, INT, UINT};

pub(crate) const B: Ty = Ty::Boolean;
pub(crate) const D: Ty = Ty::Double;
pub(crate) const N: Ty = Ty::Normalized;
pub(crate) const S: Ty = Ty::String;

/// The attributes of `<fmiModelDescription>` that describe the model, after `fmiVersion`,
/// `modelName` and the version's token.
pub(crate) const ROOT_INFO: &[Attr] = &[
    opt_attr("description", S),
    opt_attr("author", S),
    opt_attr("version", N),
    opt_attr("copyright", S),
    opt_attr("license", S),
    opt_attr("generationTool", N),
    opt_attr("generationDateAndTime", Ty::DateTime),
    opt_attr(
        "variableNamingConvention",
        Ty::Enum(&["flat", "structured"]),
    ),
];

/// The first attributes of an interface element (`<ModelExchange>`, `<CoSimulation>`, ...).
pub(crate) const INTERFACE_BASE: &[Attr] = &[
    req_attr("modelIdentifier", N),
    opt_attr("needsExecutionTool", B),
    opt_attr("canBeInstantiatedOnlyOncePerProcess", B),
];

/// `<BaseUnit>`: the exponents of the SI base units and of rad, a factor and an offset.
pub(crate) const BASE_UNIT_ATTRS: &[Attr] = &[
    opt_attr("kg", INT),
    opt_attr("m", INT),
    opt_attr("s", INT),
    opt_attr("A", INT),
    opt_attr("K", INT),
    opt_attr("mol", INT),
    opt_attr("cd", INT),
    opt_attr("rad", INT),
    opt_attr("factor", D),
    opt_attr("offset", D),
];

/// `<DisplayUnit>`: its name, factor and offset.
pub(crate) const DISPLAY_UNIT_ATTRS: &[Attr] = &[
    req_attr("name", N),
    opt_attr("factor", D),
    opt_attr("offset", D),
];

/// A required name (`<Unit>`; FMI 2.0: `<File>`, `<Tool>`).
pub(crate) const NAME: &[Attr] = &[req_attr("name", N)];

/// A required name and a description (`<Category>`, `<SimpleType>`, FMI 3.0 type definitions
/// and `<Alias>`).
pub(crate) const NAMED: &[Attr] = &[req_attr("name", N), opt_attr("description", S)];

/// `<DefaultExperiment>`.
pub(crate) const DEFAULT_EXPERIMENT_ATTRS: &[Attr] = &[
    opt_attr("startTime", D),
    opt_attr("stopTime", D),
    opt_attr("tolerance", D),
    opt_attr("stepSize", D),
];

/// The quantity and units of a real type or variable (FMI 3.0: Float32 and Float64).
pub(crate) const REAL_UNITS: &[Attr] = &[
    opt_attr("quantity", N),
    opt_attr("unit", N),
    opt_attr("displayUnit", N),
    opt_attr("relativeQuantity", B),
    opt_attr("unbounded", B),
];

/// The quantity of an integer or enumeration type or variable.
pub(crate) const QUANTITY: &[Attr] = &[opt_attr("quantity", N)];

/// The range of an FMI 2.0 Integer or an FMI 3.0 Int32.
pub(crate) const INT_RANGE: &[Attr] = &[opt_attr("min", INT), opt_attr("max", INT)];

/// The range and nominal value of an FMI 2.0 Real or an FMI 3.0 Float64.
pub(crate) const DOUBLE_RANGE: &[Attr] = &[
    opt_attr("min", D),
    opt_attr("max", D),
    opt_attr("nominal", D),
];

pub(crate) const DECLARED_TYPE: &[Attr] = &[opt_attr("declaredType", N)];
/// An enumeration variable must name its type.
pub(crate) const TYPED: &[Attr] = &[req_attr("declaredType", N)];

/// The name, value reference and description of every variable.
pub(crate) const VARIABLE_ID: &[Attr] = &[
    req_attr("name", N),
    req_attr("valueReference", UINT),
    opt_attr("description", S),
];

/// The values of `causality`: FMI 2.0 has the first six, FMI 3.0 all seven.
pub(crate) const CAUSALITIES: [&str; 7] = [
    "parameter",
    "calculatedParameter",
    "input",
    "output",
    "local",
    "independent",
    "structuralParameter",
];

pub(crate) const VARIABILITY: Ty =
    Ty::Enum(&["constant", "fixed", "tunable", "discrete", "continuous"]);

pub(crate) const INITIAL: Ty = Ty::Enum(&["exact", "approx", "calculated"]);

/// `dependenciesKind` values (FMI 2.0.4 section 2.2.8, FMI 3.0.2 section 2.4.8).
const KIND: Ty = Ty::Enum(&["dependent", "constant", "fixed", "tunable", "discrete"]);

/// The dependencies of an unknown of `<ModelStructure>`, after the attribute naming it.
pub(crate) const DEPENDENCIES: &[Attr] = &[
    opt_attr("dependencies", Ty::List(&UINT)),
    opt_attr("dependenciesKind", Ty::List(&KIND)),
];
