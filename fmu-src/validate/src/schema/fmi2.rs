//! The FMI 2.0 model-description schema as a table: every element of `fmiModelDescription`
//! with its attributes (types, enumerations, required ones) and its children in order with
//! their multiplicity. FMI 2.0.4 section 2.2: "The normative definition are the above
//! mentioned schema files" (`fmi2ModelDescription.xsd` and its helper files); each declaration
//! names the file that holds it. Written from the standard's tables of sections 2.2.1 to 2.2.8
//! and checked against the schema files (tests/test_schema_validate.py compares verdicts).

use super::common::{
    B, BASE_UNIT_ATTRS, CAUSALITIES, D, DECLARED_TYPE, DEFAULT_EXPERIMENT_ATTRS, DEPENDENCIES,
    DISPLAY_UNIT_ATTRS, DOUBLE_RANGE, INITIAL, INTERFACE_BASE, INT_RANGE, N, NAME, NAMED, QUANTITY,
    REAL_UNITS, ROOT_INFO, S, TYPED, VARIABILITY, VARIABLE_ID,
};
use super::model::{
    any, at_most, choice, elem, empty, list, many, one, opt, opt_attr, parent, req_attr, seq,
    unbounded, Attr, Content, Elem, Particle, Schema, Ty, INT, UINT,
};

const MD: &str = "fmi2ModelDescription.xsd";

/// The FMI 2.0 schema.
pub(crate) static SCHEMA: Schema = Schema {
    cite: "FMI 2.0.4 §2.2",
    root: &ROOT,
    globals: &[&ROOT],
};

/// `xs:anyType`: any attributes and any content.
const fn any_type(name: &'static str, xsd: &'static str) -> Elem {
    let any_attribute = true;
    Elem {
        any_attribute,
        ..elem(name, xsd, &[], Content::AnyType)
    }
}

// --- fmiModelDescription (section 2.2.1) ---------------------------------------------------

const ROOT_ID: &[Attr] = &[
    req_attr("fmiVersion", Ty::Fixed("2.0")),
    req_attr("modelName", S),
    req_attr("guid", N),
];

static ROOT: Elem = parent(
    "fmiModelDescription",
    MD,
    &[
        ROOT_ID,
        ROOT_INFO,
        &[opt_attr("numberOfEventIndicators", UINT)],
    ],
    &[
        // a sequence of an optional ModelExchange and an optional CoSimulation, at most twice
        at_most(
            seq(&[opt(one(&MODEL_EXCHANGE)), opt(one(&CO_SIMULATION))]),
            2,
        ),
        opt(one(&UNIT_DEFINITIONS)),
        opt(one(&TYPE_DEFINITIONS)),
        opt(one(&LOG_CATEGORIES)),
        opt(one(&DEFAULT_EXPERIMENT)),
        opt(one(&VENDOR_ANNOTATIONS)),
        one(&MODEL_VARIABLES),
        one(&MODEL_STRUCTURE),
    ],
);

// --- ModelExchange (section 3.3.1) and CoSimulation (section 4.3.1) -------------------------

const INTERFACE: &[Attr] = &[
    opt_attr("canNotUseMemoryManagementFunctions", B),
    opt_attr("canGetAndSetFMUstate", B),
    opt_attr("canSerializeFMUstate", B),
    opt_attr("providesDirectionalDerivative", B),
];
const CO_SIMULATION_ATTRS: &[Attr] = &[
    opt_attr("canHandleVariableCommunicationStepSize", B),
    opt_attr("canInterpolateInputs", B),
    opt_attr("maxOutputDerivativeOrder", UINT),
    // the spelling of the standard
    opt_attr("canRunAsynchronuously", B),
];
const ME_ATTRS: &[Attr] = &[opt_attr("completedIntegratorStepNotNeeded", B)];

static MODEL_EXCHANGE: Elem = parent(
    "ModelExchange",
    MD,
    &[INTERFACE_BASE, INTERFACE, ME_ATTRS],
    &SOURCES,
);
static CO_SIMULATION: Elem = parent(
    "CoSimulation",
    MD,
    &[INTERFACE_BASE, INTERFACE, CO_SIMULATION_ATTRS],
    &SOURCES,
);
static SOURCES: [Particle; 1] = [opt(one(&SOURCE_FILES))];
static SOURCE_FILES: Elem = list("SourceFiles", MD, &FILE);
static FILE: Elem = empty("File", MD, &[NAME]);

// --- UnitDefinitions (section 2.2.2) ---------------------------------------------------------

const UNIT_XSD: &str = "fmi2Unit.xsd";
static UNIT_DEFINITIONS: Elem = list("UnitDefinitions", MD, &UNIT);
static UNIT_CHILDREN: [Particle; 2] = [opt(one(&BASE_UNIT)), many(&DISPLAY_UNIT)];
static UNIT: Elem = parent("Unit", UNIT_XSD, &[NAME], &UNIT_CHILDREN);
static BASE_UNIT: Elem = empty("BaseUnit", UNIT_XSD, &[BASE_UNIT_ATTRS]);
static DISPLAY_UNIT: Elem = empty("DisplayUnit", UNIT_XSD, &[DISPLAY_UNIT_ATTRS]);

// --- TypeDefinitions (section 2.2.3) and ModelVariables (section 2.2.7) ---------------------

const TYPE: &str = "fmi2Type.xsd";
const SV: &str = "fmi2ScalarVariable.xsd";

static TYPE_DEFINITIONS: Elem = list("TypeDefinitions", MD, &SIMPLE_TYPE);
static SIMPLE_TYPE: Elem = elem(
    "SimpleType",
    TYPE,
    &[NAMED],
    Content::Elements(choice(&[
        one(&TYPE_REAL),
        one(&TYPE_INTEGER),
        one(&TYPE_BOOLEAN),
        one(&TYPE_STRING),
        one(&TYPE_ENUMERATION),
    ])),
);

// the attributes a type and a variable share: fmi2AttributeGroups.xsd
static TYPE_REAL: Elem = empty("Real", TYPE, &[REAL_UNITS, DOUBLE_RANGE]);
static TYPE_INTEGER: Elem = empty("Integer", TYPE, &[QUANTITY, INT_RANGE]);
// declared without a type: xs:anyType
static TYPE_BOOLEAN: Elem = any_type("Boolean", TYPE);
static TYPE_STRING: Elem = any_type("String", TYPE);
static TYPE_ENUMERATION: Elem = parent("Enumeration", TYPE, &[QUANTITY], &[unbounded(one(&ITEM))]);
const ITEM_ATTRS: &[Attr] = &[
    req_attr("name", N),
    req_attr("value", INT),
    opt_attr("description", S),
];
static ITEM: Elem = empty("Item", TYPE, &[ITEM_ATTRS]);

static MODEL_VARIABLES: Elem = list("ModelVariables", MD, &SCALAR_VARIABLE);
const SCALAR_VARIABLE_ATTRS: &[Attr] = &[
    opt_attr("causality", Ty::Enum(CAUSALITIES.split_at(6).0)),
    opt_attr("variability", VARIABILITY),
    opt_attr("initial", INITIAL),
    opt_attr("canHandleMultipleSetPerTimeInstant", B),
];
static SCALAR_VARIABLE: Elem = parent(
    "ScalarVariable",
    SV,
    &[VARIABLE_ID, SCALAR_VARIABLE_ATTRS],
    &[
        choice(&[
            one(&VAR_REAL),
            one(&VAR_INTEGER),
            one(&VAR_BOOLEAN),
            one(&VAR_STRING),
            one(&VAR_ENUMERATION),
        ]),
        opt(one(&SV_ANNOTATIONS)),
    ],
);

const REAL_VARIABLE: &[Attr] = &[
    opt_attr("start", D),
    opt_attr("derivative", UINT),
    opt_attr("reinit", B),
];
static VAR_REAL: Elem = empty(
    "Real",
    SV,
    &[DECLARED_TYPE, REAL_UNITS, DOUBLE_RANGE, REAL_VARIABLE],
);
const INTEGER_START: &[Attr] = &[opt_attr("start", INT)];
static VAR_INTEGER: Elem = empty(
    "Integer",
    SV,
    &[DECLARED_TYPE, QUANTITY, INT_RANGE, INTEGER_START],
);
static VAR_BOOLEAN: Elem = empty("Boolean", SV, &[DECLARED_TYPE, &[opt_attr("start", B)]]);
static VAR_STRING: Elem = empty("String", SV, &[DECLARED_TYPE, &[opt_attr("start", S)]]);
static VAR_ENUMERATION: Elem = empty(
    "Enumeration",
    SV,
    &[TYPED, QUANTITY, INT_RANGE, INTEGER_START],
);

// --- LogCategories (2.2.4), DefaultExperiment (2.2.5), VendorAnnotations (2.2.6) ------------

const ANN: &str = "fmi2Annotation.xsd";
static LOG_CATEGORIES: Elem = list("LogCategories", MD, &CATEGORY);
static CATEGORY: Elem = empty("Category", MD, &[NAMED]);
static DEFAULT_EXPERIMENT: Elem = empty("DefaultExperiment", MD, &[DEFAULT_EXPERIMENT_ATTRS]);
static VENDOR_ANNOTATIONS: Elem = list("VendorAnnotations", ANN, &TOOL);
static SV_ANNOTATIONS: Elem = list("Annotations", ANN, &TOOL);
/// A tool's annotation: at most one element of any content (`xs:any`, `minOccurs="0"`).
static TOOL: Elem = elem("Tool", ANN, &[NAME], Content::Elements(opt(any())));

// --- ModelStructure (section 2.2.8) ----------------------------------------------------------

const DEP: &str = "fmi2VariableDependency.xsd";
const UNKNOWN_ATTRS: &[&[Attr]] = &[&[req_attr("index", UINT)], DEPENDENCIES];
static MODEL_STRUCTURE_CHILDREN: [Particle; 3] = [
    opt(one(&OUTPUTS)),
    opt(one(&DERIVATIVES)),
    opt(one(&INITIAL_UNKNOWNS)),
];
static MODEL_STRUCTURE: Elem = parent("ModelStructure", MD, &[], &MODEL_STRUCTURE_CHILDREN);
static OUTPUTS: Elem = list("Outputs", MD, &UNKNOWN);
static DERIVATIVES: Elem = list("Derivatives", MD, &UNKNOWN);
static UNKNOWN: Elem = empty("Unknown", DEP, UNKNOWN_ATTRS);
static INITIAL_UNKNOWNS: Elem = list("InitialUnknowns", MD, &INITIAL_UNKNOWN);
static INITIAL_UNKNOWN: Elem = empty("Unknown", MD, UNKNOWN_ATTRS);
