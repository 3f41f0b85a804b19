//! The FMI 3.0 model-description schema as a table: every element of `fmiModelDescription`
//! with its attributes (types, enumerations, required ones) and its children in order with
//! their multiplicity. FMI 3.0.2 section 2.4: `modelDescription.xml` is "in XML format as
//! specified by the XML schema file `fmi3ModelDescription.xsd`" (and the files it includes);
//! each declaration names the file that holds it. Written from the standard's tables of
//! section 2.4 and checked against the schema files (tests/test_schema_validate.py compares
//! verdicts). `terminalsAndIcons.xml` and `buildDescription.xml` are other files, not checked
//! here.

use super::model::{
    any, choice, many, one, opt, opt_attr, req_attr, seq, unbounded, Attr, Content, Elem, Particle,
    Schema, Ty, BYTE, INT, LONG, SHORT, UBYTE, UINT, ULONG, USHORT,
};

const MD: &str = "fmi3ModelDescription.xsd";
const ANN: &str = "fmi3Annotation.xsd";
const IFACE: &str = "fmi3InterfaceType.xsd";
const UNIT_XSD: &str = "fmi3Unit.xsd";
const TYPE: &str = "fmi3Type.xsd";
const VAR: &str = "fmi3Variable.xsd";
const DEP: &str = "fmi3VariableDependency.xsd";

/// The FMI 3.0 schema.
pub(crate) static SCHEMA: Schema = Schema {
    cite: "FMI 3.0.2 §2.4",
    root: &ROOT,
    globals: &[&ROOT, &ANNOTATIONS],
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

/// Content of at most one `<Annotations>`, the child most FMI 3.0 elements may have.
const ANNOTATED: Content = Content::Elements(opt(one(&ANNOTATIONS)));

const B: Ty = Ty::Boolean;
const D: Ty = Ty::Double;
const F: Ty = Ty::Float;
const N: Ty = Ty::Normalized;
const S: Ty = Ty::String;

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

static ROOT: Elem = elem(
    "fmiModelDescription",
    MD,
    &[&[
        req_attr(
            "fmiVersion",
            Ty::Pattern(
                is_fmi3_version,
                "3[.](0|[1-9][0-9]*)([.](0|[1-9][0-9]*))?(-.+)?",
            ),
        ),
        req_attr("modelName", S),
        req_attr("instantiationToken", N),
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
    ]],
    Content::Elements(seq(&[
        opt(one(&MODEL_EXCHANGE)),
        opt(one(&CO_SIMULATION)),
        opt(one(&SCHEDULED_EXECUTION)),
        opt(one(&UNIT_DEFINITIONS)),
        opt(one(&TYPE_DEFINITIONS)),
        opt(one(&LOG_CATEGORIES)),
        opt(one(&DEFAULT_EXPERIMENT)),
        one(&MODEL_VARIABLES),
        one(&MODEL_STRUCTURE),
        opt(one(&ANNOTATIONS)),
    ])),
);

// --- Annotations (section 2.4.1): the content of an <Annotation> is free ---------------------

static ANNOTATIONS: Elem = elem(
    "Annotations",
    ANN,
    &[],
    Content::Elements(unbounded(one(&ANNOTATION))),
);

static ANNOTATION: Elem = elem(
    "Annotation",
    ANN,
    &[&[req_attr("type", N)]],
    Content::Mixed(unbounded(opt(any()))),
);

// --- ModelExchange, CoSimulation, ScheduledExecution (sections 2.4.2, 3.4, 4.4, 5.4) ---------

const INTERFACE: &[Attr] = &[
    req_attr("modelIdentifier", N),
    opt_attr("needsExecutionTool", B),
    opt_attr("canBeInstantiatedOnlyOncePerProcess", B),
    opt_attr("canGetAndSetFMUState", B),
    opt_attr("canSerializeFMUState", B),
    opt_attr("providesDirectionalDerivatives", B),
    opt_attr("providesAdjointDerivatives", B),
    opt_attr("providesPerElementDependencies", B),
];

/// An interface element: the common attributes, further ones allowed (`xs:anyAttribute`).
const fn interface(name: &'static str, own: &'static [&'static [Attr]]) -> Elem {
    Elem {
        name,
        xsd: IFACE,
        attrs: own,
        any_attribute: true,
        content: ANNOTATED,
    }
}

static MODEL_EXCHANGE: Elem = interface(
    "ModelExchange",
    &[
        INTERFACE,
        &[
            opt_attr("needsCompletedIntegratorStep", B),
            opt_attr("providesEvaluateDiscreteStates", B),
        ],
    ],
);

static CO_SIMULATION: Elem = interface(
    "CoSimulation",
    &[
        INTERFACE,
        &[
            opt_attr("canHandleVariableCommunicationStepSize", B),
            opt_attr("fixedInternalStepSize", D),
            opt_attr("maxOutputDerivativeOrder", UINT),
            opt_attr("recommendedIntermediateInputSmoothness", INT),
            opt_attr("providesIntermediateUpdate", B),
            opt_attr("mightReturnEarlyFromDoStep", B),
            opt_attr("canReturnEarlyAfterIntermediateUpdate", B),
            opt_attr("hasEventMode", B),
            opt_attr("providesEvaluateDiscreteStates", B),
        ],
    ],
);

static SCHEDULED_EXECUTION: Elem = interface("ScheduledExecution", &[INTERFACE]);

// --- UnitDefinitions (section 2.4.3) ---------------------------------------------------------

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
    Content::Elements(seq(&[
        opt(one(&BASE_UNIT)),
        many(&DISPLAY_UNIT),
        opt(one(&ANNOTATIONS)),
    ])),
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
        opt_attr("inverse", B),
    ]],
    ANNOTATED,
);

// --- attribute groups shared by types and variables (fmi3AttributeGroups.xsd) ----------------

const REAL_BASE: &[Attr] = &[
    opt_attr("quantity", N),
    opt_attr("unit", N),
    opt_attr("displayUnit", N),
    opt_attr("relativeQuantity", B),
    opt_attr("unbounded", B),
];
const FLOAT64: &[Attr] = &[
    opt_attr("min", D),
    opt_attr("max", D),
    opt_attr("nominal", D),
];
const FLOAT32: &[Attr] = &[
    opt_attr("min", F),
    opt_attr("max", F),
    opt_attr("nominal", F),
];
const INT_BASE: &[Attr] = &[opt_attr("quantity", N)];
const INT8: &[Attr] = &[opt_attr("min", BYTE), opt_attr("max", BYTE)];
const UINT8: &[Attr] = &[opt_attr("min", UBYTE), opt_attr("max", UBYTE)];
const INT16: &[Attr] = &[opt_attr("min", SHORT), opt_attr("max", SHORT)];
const UINT16: &[Attr] = &[opt_attr("min", USHORT), opt_attr("max", USHORT)];
const INT32: &[Attr] = &[opt_attr("min", INT), opt_attr("max", INT)];
const UINT32: &[Attr] = &[opt_attr("min", UINT), opt_attr("max", UINT)];
const INT64: &[Attr] = &[opt_attr("min", LONG), opt_attr("max", LONG)];
const UINT64: &[Attr] = &[opt_attr("min", ULONG), opt_attr("max", ULONG)];
const REAL_VARIABLE: &[Attr] = &[opt_attr("derivative", UINT), opt_attr("reinit", B)];
const ENUMERATION: &[Attr] = &[opt_attr("min", LONG), opt_attr("max", LONG)];
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

static TYPE_DEFINITIONS: Elem = elem(
    "TypeDefinitions",
    MD,
    &[],
    Content::Elements(unbounded(choice(&[
        one(&FLOAT32_TYPE),
        one(&FLOAT64_TYPE),
        one(&INT8_TYPE),
        one(&UINT8_TYPE),
        one(&INT16_TYPE),
        one(&UINT16_TYPE),
        one(&INT32_TYPE),
        one(&UINT32_TYPE),
        one(&INT64_TYPE),
        one(&UINT64_TYPE),
        one(&BOOLEAN_TYPE),
        one(&STRING_TYPE),
        one(&BINARY_TYPE),
        one(&ENUMERATION_TYPE),
        one(&CLOCK_TYPE),
    ]))),
);

const TYPE_BASE: &[Attr] = &[req_attr("name", N), opt_attr("description", S)];

const fn type_def(name: &'static str, attrs: &'static [&'static [Attr]]) -> Elem {
    elem(name, TYPE, attrs, ANNOTATED)
}

static FLOAT32_TYPE: Elem = type_def("Float32Type", &[TYPE_BASE, REAL_BASE, FLOAT32]);
static FLOAT64_TYPE: Elem = type_def("Float64Type", &[TYPE_BASE, REAL_BASE, FLOAT64]);
static INT8_TYPE: Elem = type_def("Int8Type", &[TYPE_BASE, INT_BASE, INT8]);
static UINT8_TYPE: Elem = type_def("UInt8Type", &[TYPE_BASE, INT_BASE, UINT8]);
static INT16_TYPE: Elem = type_def("Int16Type", &[TYPE_BASE, INT_BASE, INT16]);
static UINT16_TYPE: Elem = type_def("UInt16Type", &[TYPE_BASE, INT_BASE, UINT16]);
static INT32_TYPE: Elem = type_def("Int32Type", &[TYPE_BASE, INT_BASE, INT32]);
static UINT32_TYPE: Elem = type_def("UInt32Type", &[TYPE_BASE, INT_BASE, UINT32]);
static INT64_TYPE: Elem = type_def("Int64Type", &[TYPE_BASE, INT_BASE, INT64]);
static UINT64_TYPE: Elem = type_def("UInt64Type", &[TYPE_BASE, INT_BASE, UINT64]);
static BOOLEAN_TYPE: Elem = type_def("BooleanType", &[TYPE_BASE]);
static STRING_TYPE: Elem = type_def("StringType", &[TYPE_BASE]);
static CLOCK_TYPE: Elem = type_def("ClockType", &[TYPE_BASE, CLOCK]);

const BINARY: &[Attr] = &[
    opt_attr("mimeType", N),
    opt_attr("maxSize", Ty::NonNegativeInteger),
];

static BINARY_TYPE: Elem = type_def("BinaryType", &[TYPE_BASE, BINARY]);

static ENUMERATION_TYPE: Elem = elem(
    "EnumerationType",
    TYPE,
    &[TYPE_BASE, INT_BASE, ENUMERATION],
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
    ANNOTATED,
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
    ANNOTATED,
);

// --- ModelVariables (section 2.4.7) ----------------------------------------------------------

static MODEL_VARIABLES: Elem = elem(
    "ModelVariables",
    MD,
    &[],
    Content::Elements(unbounded(choice(&[
        one(&FLOAT32_VAR),
        one(&FLOAT64_VAR),
        one(&INT8_VAR),
        one(&UINT8_VAR),
        one(&INT16_VAR),
        one(&UINT16_VAR),
        one(&INT32_VAR),
        one(&UINT32_VAR),
        one(&INT64_VAR),
        one(&UINT64_VAR),
        one(&BOOLEAN_VAR),
        one(&STRING_VAR),
        one(&BINARY_VAR),
        one(&ENUMERATION_VAR),
        one(&CLOCK_VAR),
    ]))),
);

/// The attributes of every variable (fmi3AbstractVariable).
const VARIABLE: &[Attr] = &[
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
            "structuralParameter",
        ]),
    ),
    opt_attr(
        "variability",
        Ty::Enum(&["constant", "fixed", "tunable", "discrete", "continuous"]),
    ),
    opt_attr("canHandleMultipleSetPerTimeInstant", B),
    opt_attr("clocks", Ty::List(&UINT)),
];
/// The attributes of a variable that can be an array (fmi3ArrayableVariable).
const ARRAYABLE: &[Attr] = &[
    opt_attr("intermediateUpdate", B),
    opt_attr("previous", UINT),
];
const DECLARED_TYPE: &[Attr] = &[opt_attr("declaredType", N)];
const INITIAL: &[Attr] = &[opt_attr(
    "initial",
    Ty::Enum(&["exact", "approx", "calculated"]),
)];

/// The children of an array-capable variable: annotations, dimensions, aliases.
static ARRAY_CHILDREN: [Particle; 3] = [opt(one(&ANNOTATIONS)), many(&DIMENSION), many(&ALIAS)];

/// The children of a Float32 or Float64 variable: its aliases may have a display unit.
static FLOAT_CHILDREN: [Particle; 3] =
    [opt(one(&ANNOTATIONS)), many(&DIMENSION), many(&FLOAT_ALIAS)];

const fn variable(name: &'static str, attrs: &'static [&'static [Attr]]) -> Elem {
    elem(name, VAR, attrs, Content::Elements(seq(&ARRAY_CHILDREN)))
}

const fn float_variable(name: &'static str, attrs: &'static [&'static [Attr]]) -> Elem {
    elem(name, VAR, attrs, Content::Elements(seq(&FLOAT_CHILDREN)))
}

static FLOAT32_VAR: Elem = float_variable(
    "Float32",
    &[
        VARIABLE,
        ARRAYABLE,
        DECLARED_TYPE,
        INITIAL,
        REAL_BASE,
        FLOAT32,
        &[opt_attr("start", Ty::List(&F))],
        REAL_VARIABLE,
    ],
);
static FLOAT64_VAR: Elem = float_variable(
    "Float64",
    &[
        VARIABLE,
        ARRAYABLE,
        DECLARED_TYPE,
        INITIAL,
        REAL_BASE,
        FLOAT64,
        &[opt_attr("start", Ty::List(&D))],
        REAL_VARIABLE,
    ],
);

/// An integer variable whose range attributes are `$range` and whose `start` (one value per
/// array element) has items of type `$item`.
macro_rules! integer_variable {
    ($name:literal, $range:expr, $item:expr) => {
        variable(
            $name,
            &[
                VARIABLE,
                ARRAYABLE,
                DECLARED_TYPE,
                INITIAL,
                INT_BASE,
                $range,
                &[opt_attr("start", Ty::List(&$item))],
            ],
        )
    };
}

static INT8_VAR: Elem = integer_variable!("Int8", INT8, BYTE);
static UINT8_VAR: Elem = integer_variable!("UInt8", UINT8, UBYTE);
static INT16_VAR: Elem = integer_variable!("Int16", INT16, SHORT);
static UINT16_VAR: Elem = integer_variable!("UInt16", UINT16, USHORT);
static INT32_VAR: Elem = integer_variable!("Int32", INT32, INT);
static UINT32_VAR: Elem = integer_variable!("UInt32", UINT32, UINT);
static INT64_VAR: Elem = integer_variable!("Int64", INT64, LONG);
static UINT64_VAR: Elem = integer_variable!("UInt64", UINT64, ULONG);

static BOOLEAN_VAR: Elem = variable(
    "Boolean",
    &[
        VARIABLE,
        ARRAYABLE,
        DECLARED_TYPE,
        INITIAL,
        &[opt_attr("start", Ty::List(&B))],
    ],
);

/// A String or Binary variable: its start values are `<Start>` elements before the aliases.
static STRING_VAR: Elem = elem(
    "String",
    VAR,
    &[VARIABLE, ARRAYABLE, DECLARED_TYPE, INITIAL],
    Content::Elements(seq(&STRING_CHILDREN)),
);
static STRING_CHILDREN: [Particle; 4] = [
    opt(one(&ANNOTATIONS)),
    many(&DIMENSION),
    many(&STRING_START),
    many(&ALIAS),
];
static STRING_START: Elem = elem("Start", VAR, &[&[opt_attr("value", S)]], Content::Empty);

static BINARY_VAR: Elem = elem(
    "Binary",
    VAR,
    &[VARIABLE, ARRAYABLE, DECLARED_TYPE, INITIAL, BINARY],
    Content::Elements(seq(&BINARY_CHILDREN)),
);
static BINARY_CHILDREN: [Particle; 4] = [
    opt(one(&ANNOTATIONS)),
    many(&DIMENSION),
    many(&BINARY_START),
    many(&ALIAS),
];
static BINARY_START: Elem = elem(
    "Start",
    VAR,
    &[&[opt_attr("value", Ty::HexBinary)]],
    Content::Empty,
);

/// An enumeration variable must name its type (fmi3MandatorilyTypedArrayableVariable).
static ENUMERATION_VAR: Elem = variable(
    "Enumeration",
    &[
        VARIABLE,
        ARRAYABLE,
        &[req_attr("declaredType", N)],
        INITIAL,
        INT_BASE,
        ENUMERATION,
        &[opt_attr("start", Ty::List(&LONG))],
    ],
);

/// A clock: typed, not an array, no `initial` (fmi3TypedVariable).
static CLOCK_VAR: Elem = elem(
    "Clock",
    VAR,
    &[VARIABLE, DECLARED_TYPE, CLOCK],
    Content::Elements(seq(&[opt(one(&ANNOTATIONS)), many(&ALIAS)])),
);

static DIMENSION: Elem = elem(
    "Dimension",
    VAR,
    &[&[opt_attr("start", ULONG), opt_attr("valueReference", UINT)]],
    Content::Empty,
);

const ALIAS_ATTRS: &[Attr] = &[req_attr("name", N), opt_attr("description", S)];

static ALIAS: Elem = elem("Alias", VAR, &[ALIAS_ATTRS], Content::Empty);
static FLOAT_ALIAS: Elem = elem(
    "Alias",
    VAR,
    &[ALIAS_ATTRS, &[opt_attr("displayUnit", N)]],
    Content::Empty,
);

// --- ModelStructure (section 2.4.8) ----------------------------------------------------------

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

/// `dependenciesKind` values (section 2.4.8).
const KIND: Ty = Ty::Enum(&["dependent", "constant", "fixed", "tunable", "discrete"]);

const UNKNOWN: &[Attr] = &[
    req_attr("valueReference", UINT),
    opt_attr("dependencies", Ty::List(&UINT)),
    opt_attr("dependenciesKind", Ty::List(&KIND)),
];

const fn unknown(name: &'static str) -> Elem {
    Elem {
        name,
        xsd: DEP,
        attrs: &[UNKNOWN],
        any_attribute: false,
        content: ANNOTATED,
    }
}

static OUTPUT: Elem = unknown("Output");
static CONTINUOUS_STATE_DERIVATIVE: Elem = unknown("ContinuousStateDerivative");
static CLOCKED_STATE: Elem = unknown("ClockedState");
static INITIAL_UNKNOWN: Elem = unknown("InitialUnknown");
static EVENT_INDICATOR: Elem = unknown("EventIndicator");
