//! The FMI 2.0 model-description schema as a table: every element of `fmiModelDescription`
//! with its attributes (types, enumerations, required ones) and its children in order with
//! their multiplicity. FMI 2.0.4 section 2.2: "The normative definition are the above
//! mentioned schema files" (`fmi2ModelDescription.xsd` and its helper files); each declaration
//! names the file that holds it. Written from the standard's tables of sections 2.2.1 to 2.2.8
//! and checked against the schema files (tests/test_schema_validate.py compares verdicts).

use super::model::{
    at_most, choice, many, one, opt, opt_attr, req_attr, seq, unbounded, Attr, Content, Elem,
    Schema, Ty, INT, UINT,
};

const MD: &str = "fmi2ModelDescription.xsd";
const SV: &str = "fmi2ScalarVariable.xsd";
const TYPE: &str = "fmi2Type.xsd";
const UNIT_XSD: &str = "fmi2Unit.xsd";
const DEP: &str = "fmi2VariableDependency.xsd";
const ANN: &str = "fmi2Annotation.xsd";

/// The FMI 2.0 schema.
pub(crate) static SCHEMA: Schema = Schema {
    cite: "FMI 2.0.4 §2.2",
    root: &ROOT,
    globals: &[&ROOT],
};

const fn elem(
    name: &'static str,
    xsd: &'static str,
    attrs: &'static [&'static [Attr]],
    content: Content,
) -> Elem {
    Elem {
        name,
        xsd,
        attrs,
        any_attribute: false,
        content,
    }
}

/// `xs:anyType`: any attributes and any content.
const fn any_type(name: &'static str, xsd: &'static str) -> Elem {
    Elem {
        name,
        xsd,
        attrs: &[],
        any_attribute: true,
        content: Content::AnyType,
    }
}

const B: Ty = Ty::Boolean;
const D: Ty = Ty::Double;
const N: Ty = Ty::Normalized;
const S: Ty = Ty::String;

// --- fmiModelDescription (section 2.2.1) ---------------------------------------------------

static ROOT: Elem = elem(
    "fmiModelDescription",
    MD,
    &[&[
        req_attr("fmiVersion", Ty::Fixed("2.0")),
        req_attr("modelName", S),
        req_attr("guid", N),
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
        opt_attr("numberOfEventIndicators", UINT),
    ]],
    Content::Elements(seq(&[
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
    ])),
);

// --- ModelExchange (section 3.3.1) and CoSimulation (section 4.3.1) -------------------------

const INTERFACE: &[Attr] = &[
    req_attr("modelIdentifier", N),
    opt_attr("needsExecutionTool", B),
    opt_attr("canBeInstantiatedOnlyOncePerProcess", B),
    opt_attr("canNotUseMemoryManagementFunctions", B),
    opt_attr("canGetAndSetFMUstate", B),
    opt_attr("canSerializeFMUstate", B),
    opt_attr("providesDirectionalDerivative", B),
];

static MODEL_EXCHANGE: Elem = elem(
    "ModelExchange",
    MD,
    &[
        INTERFACE,
        &[opt_attr("completedIntegratorStepNotNeeded", B)],
    ],
    Content::Elements(opt(one(&SOURCE_FILES))),
);

static CO_SIMULATION: Elem = elem(
    "CoSimulation",
    MD,
    &[
        INTERFACE,
        &[
            opt_attr("canHandleVariableCommunicationStepSize", B),
            opt_attr("canInterpolateInputs", B),
            opt_attr("maxOutputDerivativeOrder", UINT),
            // the spelling of the standard
            opt_attr("canRunAsynchronuously", B),
        ],
    ],
    Content::Elements(opt(one(&SOURCE_FILES))),
);

static SOURCE_FILES: Elem = elem(
    "SourceFiles",
    MD,
    &[],
    Content::Elements(unbounded(one(&FILE))),
);

static FILE: Elem = elem("File", MD, &[&[req_attr("name", N)]], Content::Empty);

// --- UnitDefinitions (section 2.2.2) ---------------------------------------------------------

static UNIT_DEFINITIONS: Elem = elem(
    "UnitDefinitions",
    MD,
    &[],
    Content::Elements(unbounded(one(&UNIT))),
);

static UNIT: Elem = elem(
    "Unit",
    UNIT_XSD,
    &[&[req_attr("name", N)]],
    Content::Elements(seq(&[opt(one(&BASE_UNIT)), many(&DISPLAY_UNIT)])),
);

static BASE_UNIT: Elem = elem(
    "BaseUnit",
    UNIT_XSD,
    &[&[
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
    ]],
    Content::Empty,
);

static DISPLAY_UNIT: Elem = elem(
    "DisplayUnit",
    UNIT_XSD,
    &[&[
        req_attr("name", N),
        opt_attr("factor", D),
        opt_attr("offset", D),
    ]],
    Content::Empty,
);

// --- TypeDefinitions (section 2.2.3) ---------------------------------------------------------

/// The attributes a Real type and a Real variable share (fmi2AttributeGroups.xsd).
const REAL_ATTRS: &[Attr] = &[
    opt_attr("quantity", N),
    opt_attr("unit", N),
    opt_attr("displayUnit", N),
    opt_attr("relativeQuantity", B),
    opt_attr("min", D),
    opt_attr("max", D),
    opt_attr("nominal", D),
    opt_attr("unbounded", B),
];

/// The attributes an Integer type and an Integer variable share.
const INTEGER_ATTRS: &[Attr] = &[
    opt_attr("quantity", N),
    opt_attr("min", INT),
    opt_attr("max", INT),
];

static TYPE_DEFINITIONS: Elem = elem(
    "TypeDefinitions",
    MD,
    &[],
    Content::Elements(unbounded(one(&SIMPLE_TYPE))),
);

static SIMPLE_TYPE: Elem = elem(
    "SimpleType",
    TYPE,
    &[&[req_attr("name", N), opt_attr("description", S)]],
    Content::Elements(choice(&[
        one(&TYPE_REAL),
        one(&TYPE_INTEGER),
        one(&TYPE_BOOLEAN),
        one(&TYPE_STRING),
        one(&TYPE_ENUMERATION),
    ])),
);

static TYPE_REAL: Elem = elem("Real", TYPE, &[REAL_ATTRS], Content::Empty);
static TYPE_INTEGER: Elem = elem("Integer", TYPE, &[INTEGER_ATTRS], Content::Empty);
// declared without a type: xs:anyType
static TYPE_BOOLEAN: Elem = any_type("Boolean", TYPE);
static TYPE_STRING: Elem = any_type("String", TYPE);

static TYPE_ENUMERATION: Elem = elem(
    "Enumeration",
    TYPE,
    &[&[opt_attr("quantity", N)]],
    Content::Elements(unbounded(one(&ITEM))),
);

static ITEM: Elem = elem(
    "Item",
    TYPE,
    &[&[
        req_attr("name", N),
        req_attr("value", INT),
        opt_attr("description", S),
    ]],
    Content::Empty,
);

// --- LogCategories (2.2.4), DefaultExperiment (2.2.5), VendorAnnotations (2.2.6) ------------

static LOG_CATEGORIES: Elem = elem(
    "LogCategories",
    MD,
    &[],
    Content::Elements(unbounded(one(&CATEGORY))),
);

static CATEGORY: Elem = elem(
    "Category",
    MD,
    &[&[req_attr("name", N), opt_attr("description", S)]],
    Content::Empty,
);

static DEFAULT_EXPERIMENT: Elem = elem(
    "DefaultExperiment",
    MD,
    &[&[
        opt_attr("startTime", D),
        opt_attr("stopTime", D),
        opt_attr("tolerance", D),
        opt_attr("stepSize", D),
    ]],
    Content::Empty,
);

static VENDOR_ANNOTATIONS: Elem = elem(
    "VendorAnnotations",
    ANN,
    &[],
    Content::Elements(unbounded(one(&TOOL))),
);

/// A tool's annotation: at most one element of any content (`xs:any`, `minOccurs="0"`).
static TOOL: Elem = elem(
    "Tool",
    ANN,
    &[&[req_attr("name", N)]],
    Content::Elements(opt(super::model::any())),
);

// --- ModelVariables (section 2.2.7) ----------------------------------------------------------

static MODEL_VARIABLES: Elem = elem(
    "ModelVariables",
    MD,
    &[],
    Content::Elements(unbounded(one(&SCALAR_VARIABLE))),
);

static SCALAR_VARIABLE: Elem = elem(
    "ScalarVariable",
    SV,
    &[&[
        req_attr("name", N),
        req_attr("valueReference", UINT),
        opt_attr("description", S),
        opt_attr(
            "causality",
            Ty::Enum(&[
                "parameter",
                "calculatedParameter",
                "input",
                "output",
                "local",
                "independent",
            ]),
        ),
        opt_attr(
            "variability",
            Ty::Enum(&["constant", "fixed", "tunable", "discrete", "continuous"]),
        ),
        opt_attr("initial", Ty::Enum(&["exact", "approx", "calculated"])),
        opt_attr("canHandleMultipleSetPerTimeInstant", B),
    ]],
    Content::Elements(seq(&[
        choice(&[
            one(&VAR_REAL),
            one(&VAR_INTEGER),
            one(&VAR_BOOLEAN),
            one(&VAR_STRING),
            one(&VAR_ENUMERATION),
        ]),
        opt(one(&SV_ANNOTATIONS)),
    ])),
);

const DECLARED_TYPE: &[Attr] = &[opt_attr("declaredType", N)];

static VAR_REAL: Elem = elem(
    "Real",
    SV,
    &[
        DECLARED_TYPE,
        REAL_ATTRS,
        &[
            opt_attr("start", D),
            opt_attr("derivative", UINT),
            opt_attr("reinit", B),
        ],
    ],
    Content::Empty,
);

static VAR_INTEGER: Elem = elem(
    "Integer",
    SV,
    &[DECLARED_TYPE, INTEGER_ATTRS, &[opt_attr("start", INT)]],
    Content::Empty,
);

static VAR_BOOLEAN: Elem = elem(
    "Boolean",
    SV,
    &[DECLARED_TYPE, &[opt_attr("start", B)]],
    Content::Empty,
);

static VAR_STRING: Elem = elem(
    "String",
    SV,
    &[DECLARED_TYPE, &[opt_attr("start", S)]],
    Content::Empty,
);

static VAR_ENUMERATION: Elem = elem(
    "Enumeration",
    SV,
    &[&[
        req_attr("declaredType", N),
        opt_attr("quantity", N),
        opt_attr("min", INT),
        opt_attr("max", INT),
        opt_attr("start", INT),
    ]],
    Content::Empty,
);

static SV_ANNOTATIONS: Elem = elem(
    "Annotations",
    ANN,
    &[],
    Content::Elements(unbounded(one(&TOOL))),
);

// --- ModelStructure (section 2.2.8) ----------------------------------------------------------

static MODEL_STRUCTURE: Elem = elem(
    "ModelStructure",
    MD,
    &[],
    Content::Elements(seq(&[
        opt(one(&OUTPUTS)),
        opt(one(&DERIVATIVES)),
        opt(one(&INITIAL_UNKNOWNS)),
    ])),
);

/// `dependenciesKind` values (section 2.2.8).
const KIND: Ty = Ty::Enum(&["dependent", "constant", "fixed", "tunable", "discrete"]);

const UNKNOWN_ATTRS: &[Attr] = &[
    req_attr("index", UINT),
    opt_attr("dependencies", Ty::List(&UINT)),
    opt_attr("dependenciesKind", Ty::List(&KIND)),
];

static OUTPUTS: Elem = elem(
    "Outputs",
    MD,
    &[],
    Content::Elements(unbounded(one(&UNKNOWN))),
);

static DERIVATIVES: Elem = elem(
    "Derivatives",
    MD,
    &[],
    Content::Elements(unbounded(one(&UNKNOWN))),
);

static UNKNOWN: Elem = elem("Unknown", DEP, &[UNKNOWN_ATTRS], Content::Empty);

static INITIAL_UNKNOWNS: Elem = elem(
    "InitialUnknowns",
    MD,
    &[],
    Content::Elements(unbounded(one(&INITIAL_UNKNOWN))),
);

static INITIAL_UNKNOWN: Elem = elem("Unknown", MD, &[UNKNOWN_ATTRS], Content::Empty);
