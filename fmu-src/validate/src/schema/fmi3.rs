//! The FMI 3.0 model-description schema as a table: every element of `fmiModelDescription`
//! with its attributes (types, enumerations, required ones) and its children in order with
//! their multiplicity. FMI 3.0.2 section 2.4: `modelDescription.xml` is "in XML format as
//! specified by the XML schema file `fmi3ModelDescription.xsd`" (and the files it includes);
//! each declaration names the file that holds it. Written from the standard's tables of
//! section 2.4 and checked against the schema files (tests/test_schema_validate.py compares
//! verdicts). `terminalsAndIcons.xml` and `buildDescription.xml` are other files, not checked
//! here.

use super::common::{
    B, BASE_UNIT_ATTRS, CAUSALITIES, D, DECLARED_TYPE, DEFAULT_EXPERIMENT_ATTRS, DEPENDENCIES,
    DISPLAY_UNIT_ATTRS, DOUBLE_RANGE, INITIAL, INTERFACE_BASE, INT_RANGE, N, NAME, NAMED, QUANTITY,
    REAL_UNITS, ROOT_INFO, S, TYPED, VARIABILITY, VARIABLE_ID,
};
use super::model::{
    any, choice, column, elem, empty, list, many, one, opt, opt_attr, parent, req_attr, seq,
    unbounded, Attr, Content, Elem, Particle, Schema, Ty, BYTE, INT, LONG, SHORT, UBYTE, UINT,
    ULONG, USHORT,
};

const MD: &str = "fmi3ModelDescription.xsd";

/// The FMI 3.0 schema.
pub(crate) static SCHEMA: Schema = Schema {
    cite: "FMI 3.0.2 §2.4",
    root: &ROOT,
    globals: &[&ROOT, &ANNOTATIONS],
};

/// Content of at most one `<Annotations>`, the child most FMI 3.0 elements may have.
const ANNOTATED: Content = Content::Elements(opt(one(&ANNOTATIONS)));

const F: Ty = Ty::Float;

/// `fmiVersion`: "3[.](0|[1-9][0-9]*)([.](0|[1-9][0-9]*))?(-.+)?" (major 3, a minor, an optional
/// patch, an optional suffix after `-`), as fmi3ModelDescription.xsd restricts it.
fn is_fmi3_version(v: &str) -> bool {
    fn number(s: &str) -> Option<&str> {
        let end = s.bytes().take_while(u8::is_ascii_digit).count();
        match &s[..end] {
            "" => None,
            n if n.len() > 1 && n.starts_with('0') => Some(&s[1..]),
            _ => Some(&s[end..]),
        }
    }
    let Some(rest) = v.strip_prefix("3.").and_then(number) else {
        return false;
    };
    let rest = match rest.strip_prefix('.') {
        Some(patch) => match number(patch) {
            Some(r) => r,
            None => return false,
        },
        None => rest,
    };
    rest.is_empty() || rest.strip_prefix('-').is_some_and(|s| !s.is_empty())
}

// --- fmiModelDescription (section 2.4.1) -----------------------------------------------------

const ROOT_ID: &[Attr] = &[
    req_attr(
        "fmiVersion",
        Ty::Pattern(
            is_fmi3_version,
            "3[.](0|[1-9][0-9]*)([.](0|[1-9][0-9]*))?(-.+)?",
        ),
    ),
    req_attr("modelName", S),
    req_attr("instantiationToken", N),
];

static ROOT: Elem = parent(
    "fmiModelDescription",
    MD,
    &[ROOT_ID, ROOT_INFO],
    &[
        seq(&INTERFACES),
        opt(one(&UNIT_DEFINITIONS)),
        opt(one(&TYPE_DEFINITIONS)),
        opt(one(&LOG_CATEGORIES)),
        opt(one(&DEFAULT_EXPERIMENT)),
        // the model: its variables and their structure
        seq(&[one(&MODEL_VARIABLES), one(&MODEL_STRUCTURE)]),
        opt(one(&ANNOTATIONS)),
    ],
);

/// The interfaces, each optional. A sequence within a sequence reads as its particles in place
/// (`content.rs` builds the same automaton), so children may be grouped by what they are.
static INTERFACES: [Particle; 3] = [
    opt(one(&MODEL_EXCHANGE)),
    opt(one(&CO_SIMULATION)),
    opt(one(&SCHEDULED_EXECUTION)),
];

// --- Annotations (section 2.4.1): the content of an <Annotation> is free ---------------------

const ANN: &str = "fmi3Annotation.xsd";
static ANNOTATIONS: Elem = list("Annotations", ANN, &ANNOTATION);
const ANNOTATION_ATTRS: &[Attr] = &[req_attr("type", N)];
static ANNOTATION: Elem = elem(
    "Annotation",
    ANN,
    &[ANNOTATION_ATTRS],
    Content::Mixed(unbounded(opt(any()))),
);

// --- ModelExchange, CoSimulation, ScheduledExecution (sections 2.4.2, 3.4, 4.4, 5.4) ---------

const IFACE: &str = "fmi3InterfaceType.xsd";

const INTERFACE: &[Attr] = &[
    opt_attr("canGetAndSetFMUState", B),
    opt_attr("canSerializeFMUState", B),
    opt_attr("providesDirectionalDerivatives", B),
    opt_attr("providesAdjointDerivatives", B),
    opt_attr("providesPerElementDependencies", B),
];
const ME_ATTRS: &[Attr] = &[
    opt_attr("needsCompletedIntegratorStep", B),
    opt_attr("providesEvaluateDiscreteStates", B),
];
const CO_SIMULATION_ATTRS: &[Attr] = &[
    opt_attr("canHandleVariableCommunicationStepSize", B),
    opt_attr("fixedInternalStepSize", D),
    opt_attr("maxOutputDerivativeOrder", UINT),
    opt_attr("recommendedIntermediateInputSmoothness", INT),
    opt_attr("providesIntermediateUpdate", B),
    opt_attr("mightReturnEarlyFromDoStep", B),
    opt_attr("canReturnEarlyAfterIntermediateUpdate", B),
    opt_attr("hasEventMode", B),
    opt_attr("providesEvaluateDiscreteStates", B),
];

/// An interface element with the attribute groups `attrs`, further ones allowed
/// (`xs:anyAttribute`).
const fn interface(name: &'static str, attrs: &'static [&'static [Attr]]) -> Elem {
    let any_attribute = true;
    Elem {
        any_attribute,
        ..elem(name, IFACE, attrs, ANNOTATED)
    }
}

static MODEL_EXCHANGE: Elem = interface("ModelExchange", &[INTERFACE_BASE, INTERFACE, ME_ATTRS]);
static CO_SIMULATION: Elem = interface(
    "CoSimulation",
    &[INTERFACE_BASE, INTERFACE, CO_SIMULATION_ATTRS],
);
static SCHEDULED_EXECUTION: Elem = interface("ScheduledExecution", &[INTERFACE_BASE, INTERFACE]);

// --- UnitDefinitions (section 2.4.3) ---------------------------------------------------------

const UNIT_XSD: &str = "fmi3Unit.xsd";
static UNIT_DEFINITIONS: Elem = list("UnitDefinitions", MD, &UNIT);
static UNIT_CHILDREN: [Particle; 3] = [
    opt(one(&BASE_UNIT)),
    many(&DISPLAY_UNIT),
    opt(one(&ANNOTATIONS)),
];
static UNIT: Elem = parent("Unit", UNIT_XSD, &[NAME], &UNIT_CHILDREN);
static BASE_UNIT: Elem = empty("BaseUnit", UNIT_XSD, &[BASE_UNIT_ATTRS]);
const INVERSE: &[Attr] = &[opt_attr("inverse", B)];
static DISPLAY_UNIT: Elem = elem(
    "DisplayUnit",
    UNIT_XSD,
    &[DISPLAY_UNIT_ATTRS, INVERSE],
    ANNOTATED,
);

// --- attribute groups shared by types and variables (fmi3AttributeGroups.xsd) ----------------

const FLOAT32: &[Attr] = &[
    opt_attr("min", F),
    opt_attr("max", F),
    opt_attr("nominal", F),
];
const INT8: &[Attr] = &[opt_attr("min", BYTE), opt_attr("max", BYTE)];
const UINT8: &[Attr] = &[opt_attr("min", UBYTE), opt_attr("max", UBYTE)];
const INT16: &[Attr] = &[opt_attr("min", SHORT), opt_attr("max", SHORT)];
const UINT16: &[Attr] = &[opt_attr("min", USHORT), opt_attr("max", USHORT)];
const UINT32: &[Attr] = &[opt_attr("min", UINT), opt_attr("max", UINT)];
const INT64: &[Attr] = &[opt_attr("min", LONG), opt_attr("max", LONG)];
const UINT64: &[Attr] = &[opt_attr("min", ULONG), opt_attr("max", ULONG)];
const REAL_VARIABLE: &[Attr] = &[opt_attr("derivative", UINT), opt_attr("reinit", B)];
const CLOCK: &[Attr] = &[
    opt_attr("canBeDeactivated", B),
    opt_attr("priority", UINT),
    req_attr(
        "intervalVariability",
        Ty::Enum(host::fmi3::md::INTERVAL_VARIABILITIES),
    ),
    opt_attr("intervalDecimal", F),
    opt_attr("shiftDecimal", F),
    opt_attr("supportsFraction", B),
    opt_attr("resolution", ULONG),
    opt_attr("intervalCounter", ULONG),
    opt_attr("shiftCounter", ULONG),
];

// --- TypeDefinitions (section 2.4.4) ---------------------------------------------------------

const TYPE: &str = "fmi3Type.xsd";

/// Each type with its type definition and its variable element, in the schemas' order.
const TYPES: [[&Elem; 2]; 15] = [
    [&FLOAT32_TYPE, &FLOAT32_VAR],
    [&FLOAT64_TYPE, &FLOAT64_VAR],
    [&INT8_TYPE, &INT8_VAR],
    [&UINT8_TYPE, &UINT8_VAR],
    [&INT16_TYPE, &INT16_VAR],
    [&UINT16_TYPE, &UINT16_VAR],
    [&INT32_TYPE, &INT32_VAR],
    [&UINT32_TYPE, &UINT32_VAR],
    [&INT64_TYPE, &INT64_VAR],
    [&UINT64_TYPE, &UINT64_VAR],
    [&BOOLEAN_TYPE, &BOOLEAN_VAR],
    [&STRING_TYPE, &STRING_VAR],
    [&BINARY_TYPE, &BINARY_VAR],
    [&ENUMERATION_TYPE, &ENUMERATION_VAR],
    [&CLOCK_TYPE, &CLOCK_VAR],
];
static TYPE_CHOICE: [Particle; 15] = column(&TYPES, 0);
static VARIABLE_CHOICE: [Particle; 15] = column(&TYPES, 1);

static TYPE_DEFINITIONS: Elem = elem(
    "TypeDefinitions",
    MD,
    &[],
    Content::Elements(unbounded(choice(&TYPE_CHOICE))),
);

const fn type_def(name: &'static str, attrs: &'static [&'static [Attr]]) -> Elem {
    elem(name, TYPE, attrs, ANNOTATED)
}

static FLOAT32_TYPE: Elem = type_def("Float32Type", &[NAMED, REAL_UNITS, FLOAT32]);
static FLOAT64_TYPE: Elem = type_def("Float64Type", &[NAMED, REAL_UNITS, DOUBLE_RANGE]);
static INT8_TYPE: Elem = type_def("Int8Type", &[NAMED, QUANTITY, INT8]);
static UINT8_TYPE: Elem = type_def("UInt8Type", &[NAMED, QUANTITY, UINT8]);
static INT16_TYPE: Elem = type_def("Int16Type", &[NAMED, QUANTITY, INT16]);
static UINT16_TYPE: Elem = type_def("UInt16Type", &[NAMED, QUANTITY, UINT16]);
static INT32_TYPE: Elem = type_def("Int32Type", &[NAMED, QUANTITY, INT_RANGE]);
static UINT32_TYPE: Elem = type_def("UInt32Type", &[NAMED, QUANTITY, UINT32]);
static INT64_TYPE: Elem = type_def("Int64Type", &[NAMED, QUANTITY, INT64]);
static UINT64_TYPE: Elem = type_def("UInt64Type", &[NAMED, QUANTITY, UINT64]);
static BOOLEAN_TYPE: Elem = type_def("BooleanType", &[NAMED]);
static STRING_TYPE: Elem = type_def("StringType", &[NAMED]);
static CLOCK_TYPE: Elem = type_def("ClockType", &[NAMED, CLOCK]);

const BINARY: &[Attr] = &[
    opt_attr("mimeType", N),
    opt_attr("maxSize", Ty::NonNegativeInteger),
];

static BINARY_TYPE: Elem = type_def("BinaryType", &[NAMED, BINARY]);

static ENUMERATION_TYPE: Elem = elem(
    "EnumerationType",
    TYPE,
    &[NAMED, QUANTITY, INT64],
    Content::Elements(seq(&[opt(one(&ANNOTATIONS)), unbounded(one(&ITEM))])),
);

static ITEM: Elem = elem(
    "Item",
    TYPE,
    &[&[
        req_attr("name", N),
        req_attr("value", LONG),
        opt_attr("description", S),
    ]],
    ANNOTATED,
);

// --- LogCategories (2.4.5) and DefaultExperiment (2.4.6) -------------------------------------

static LOG_CATEGORIES: Elem = list("LogCategories", MD, &CATEGORY);
static CATEGORY: Elem = elem("Category", MD, &[NAMED], ANNOTATED);
static DEFAULT_EXPERIMENT: Elem = elem(
    "DefaultExperiment",
    MD,
    &[DEFAULT_EXPERIMENT_ATTRS],
    ANNOTATED,
);

// --- ModelVariables (section 2.4.7) ----------------------------------------------------------

const VAR: &str = "fmi3Variable.xsd";

static MODEL_VARIABLES: Elem = elem(
    "ModelVariables",
    MD,
    &[],
    Content::Elements(unbounded(choice(&VARIABLE_CHOICE))),
);

/// The attributes of every variable after [`VARIABLE_ID`] (fmi3AbstractVariable).
const VARIABLE: &[Attr] = &[
    opt_attr("causality", Ty::Enum(&CAUSALITIES)),
    opt_attr("variability", VARIABILITY),
    opt_attr("canHandleMultipleSetPerTimeInstant", B),
    opt_attr("clocks", Ty::List(&UINT)),
];
/// The attributes of a variable that can be an array (fmi3ArrayableVariable).
const ARRAYABLE: &[Attr] = &[
    opt_attr("intermediateUpdate", B),
    opt_attr("previous", UINT),
];
const INITIAL_ATTR: &[Attr] = &[opt_attr("initial", INITIAL)];

/// The children of an array-capable variable: annotations, dimensions, aliases.
static ARRAY_CHILDREN: [Particle; 3] = [opt(one(&ANNOTATIONS)), many(&DIMENSION), many(&ALIAS)];
/// The children of a Float32 or Float64 variable: its aliases may have a display unit.
static FLOAT_CHILDREN: [Particle; 3] =
    [opt(one(&ANNOTATIONS)), many(&DIMENSION), many(&FLOAT_ALIAS)];
/// The children of a String or Binary variable: its start values are `<Start>` elements.
const fn start_children(start: &'static Elem) -> [Particle; 4] {
    [
        opt(one(&ANNOTATIONS)),
        many(&DIMENSION),
        many(start),
        many(&ALIAS),
    ]
}
static STRING_CHILDREN: [Particle; 4] = start_children(&STRING_START);
static BINARY_CHILDREN: [Particle; 4] = start_children(&BINARY_START);

/// A typed array-capable variable (fmi3ArrayableVariable): the attributes of every variable,
/// of an array, `declaredType` and `initial`, then the groups `$own`; the children `$children`.
macro_rules! arrayable {
    ($name:literal, [$($own:expr),*], $children:expr) => {
        elem(
            $name,
            VAR,
            &[VARIABLE_ID, VARIABLE, ARRAYABLE, DECLARED_TYPE, INITIAL_ATTR, $($own),*],
            Content::Elements(seq(&$children)),
        )
    };
}

/// `start`: one value of type `$item` per array element.
macro_rules! start {
    ($item:expr) => {
        &[opt_attr("start", Ty::List(&$item))]
    };
}

static FLOAT32_VAR: Elem = arrayable!(
    "Float32",
    [REAL_UNITS, FLOAT32, start!(F), REAL_VARIABLE],
    FLOAT_CHILDREN
);
static FLOAT64_VAR: Elem = arrayable!(
    "Float64",
    [REAL_UNITS, DOUBLE_RANGE, start!(D), REAL_VARIABLE],
    FLOAT_CHILDREN
);
static INT8_VAR: Elem = arrayable!("Int8", [QUANTITY, INT8, start!(BYTE)], ARRAY_CHILDREN);
static UINT8_VAR: Elem = arrayable!("UInt8", [QUANTITY, UINT8, start!(UBYTE)], ARRAY_CHILDREN);
static INT16_VAR: Elem = arrayable!("Int16", [QUANTITY, INT16, start!(SHORT)], ARRAY_CHILDREN);
static UINT16_VAR: Elem = arrayable!("UInt16", [QUANTITY, UINT16, start!(USHORT)], ARRAY_CHILDREN);
static INT32_VAR: Elem = arrayable!("Int32", [QUANTITY, INT_RANGE, start!(INT)], ARRAY_CHILDREN);
static UINT32_VAR: Elem = arrayable!("UInt32", [QUANTITY, UINT32, start!(UINT)], ARRAY_CHILDREN);
static INT64_VAR: Elem = arrayable!("Int64", [QUANTITY, INT64, start!(LONG)], ARRAY_CHILDREN);
static UINT64_VAR: Elem = arrayable!("UInt64", [QUANTITY, UINT64, start!(ULONG)], ARRAY_CHILDREN);
static BOOLEAN_VAR: Elem = arrayable!("Boolean", [start!(B)], ARRAY_CHILDREN);
static STRING_VAR: Elem = arrayable!("String", [], STRING_CHILDREN);
static STRING_START: Elem = empty("Start", VAR, &[&[opt_attr("value", S)]]);
static BINARY_VAR: Elem = arrayable!("Binary", [BINARY], BINARY_CHILDREN);
static BINARY_START: Elem = empty("Start", VAR, &[&[opt_attr("value", Ty::HexBinary)]]);

/// An enumeration variable must name its type (fmi3MandatorilyTypedArrayableVariable).
static ENUMERATION_VAR: Elem = elem(
    "Enumeration",
    VAR,
    &[
        VARIABLE_ID,
        VARIABLE,
        ARRAYABLE,
        TYPED,
        INITIAL_ATTR,
        QUANTITY,
        INT64,
        start!(LONG),
    ],
    Content::Elements(seq(&ARRAY_CHILDREN)),
);

/// A clock: typed, not an array, no `initial` (fmi3TypedVariable).
static CLOCK_VAR: Elem = elem(
    "Clock",
    VAR,
    &[VARIABLE_ID, VARIABLE, DECLARED_TYPE, CLOCK],
    Content::Elements(seq(&[opt(one(&ANNOTATIONS)), many(&ALIAS)])),
);

static DIMENSION: Elem = empty(
    "Dimension",
    VAR,
    &[&[opt_attr("start", ULONG), opt_attr("valueReference", UINT)]],
);

static ALIAS: Elem = empty("Alias", VAR, &[NAMED]);
static FLOAT_ALIAS: Elem = empty("Alias", VAR, &[NAMED, &[opt_attr("displayUnit", N)]]);

// --- ModelStructure (section 2.4.8) ----------------------------------------------------------

const DEP: &str = "fmi3VariableDependency.xsd";

static MODEL_STRUCTURE: Elem = elem(
    "ModelStructure",
    MD,
    &[],
    Content::Elements(seq(&[
        many(&OUTPUT),
        many(&CONTINUOUS_STATE_DERIVATIVE),
        many(&CLOCKED_STATE),
        many(&INITIAL_UNKNOWN),
        many(&EVENT_INDICATOR),
    ])),
);

const UNKNOWN: &[&[Attr]] = &[&[req_attr("valueReference", UINT)], DEPENDENCIES];

const fn unknown(name: &'static str) -> Elem {
    elem(name, DEP, UNKNOWN, ANNOTATED)
}

static OUTPUT: Elem = unknown("Output");
static CONTINUOUS_STATE_DERIVATIVE: Elem = unknown("ContinuousStateDerivative");
static CLOCKED_STATE: Elem = unknown("ClockedState");
static INITIAL_UNKNOWN: Elem = unknown("InitialUnknown");
static EVENT_INDICATOR: Elem = unknown("EventIndicator");
