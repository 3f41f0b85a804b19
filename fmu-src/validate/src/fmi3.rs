//! Checks of an FMI 3.0 FMU's `modelDescription.xml` (FMI 3.0.2 section 2.4) and of its platform
//! binaries (section 2.5: `binaries/<platformTuple>/<modelIdentifier>.<so|dll|dylib>`, each
//! exporting the functions of the interfaces the description declares).

use super::binary::{library_extension, missing_exports};
use super::layout::Survey;
use super::rules::{
    apply, approx_or_calculated, defined_again, identifier_problem, name_problems, names_one_file,
    root_problems, start_problem, Rule,
};
use super::Finding;
use fmi_types::schema::{combination_allowed, initial_allowed, Causality};
use host::fmi3::md::{Causality3, Interface3, ModelDescription3, Unknown3, Variable3};
use host::fmi3::value::Type3;
use host::md::{Initial, Variability};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

/// The FMI 3.0.2 clause of each FMI 3.0 check (section numbers of the FMI 3.0.2 document); its
/// severity is the one [`super::classify`] gives the check.
pub fn classify3(check: &str) -> &'static str {
    match check {
        "fmi-version"
        | "model-name"
        | "instantiation-token"
        | "model-identifier"
        | "interfaces"
        | "model-description-xml" => "FMI 3.0.2 §2.4.1: fmiModelDescription",
        "independent" => "FMI 3.0.2 §2.4.7: exactly one independent variable",
        "dimension" => {
            "FMI 3.0.2 §2.4.7: <Dimension> refers to a UInt64 structural parameter or constant"
        }
        "derivative" => "FMI 3.0.2 §2.4.7: derivative refers to a continuous Float state",
        "model-structure" | "outputs-listed" | "initial-unknowns" => {
            "FMI 3.0.2 §2.4.8: ModelStructure"
        }
        "unit-declared" | "unique-units" => "FMI 3.0.2 §2.4.3: UnitDefinitions",
        "clocks" => "FMI 3.0.2 §2.4.7.4: Clocks and clocked variables",
        "probe-not-run" => {
            "FMI 3.0.2 §2.2.8 (clocks), §5 (Scheduled Execution): not run by the probes"
        }
        "display-unit" => {
            "FMI 3.0.2 §2.4.3: <DisplayUnit> names unique per unit, inverse only with offset 0"
        }
        "display-unit-declared" => {
            "FMI 3.0.2 §2.4.4, §2.4.7.5: displayUnit names a <DisplayUnit> of the unit, which \
             must be defined"
        }
        "declared-type" | "unique-types" => "FMI 3.0.2 §2.4.4: TypeDefinitions",
        "binary" | "binary-format" => {
            "FMI 3.0.2 §2.5: FMU distribution: binaries/<platformTuple>/<modelIdentifier>"
        }
        "symbols" => "FMI 3.0.2 §2.5: every function of fmi3Functions.h implemented",
        "zip-path" => {
            "FMI 3.0.2 §2.5: the ZIP format of APPNOTE.TXT, whose section 4.4.17 allows only '/' \
             as path separator"
        }
        "binary-not-probed" => {
            "FMI 3.0.2 §2.5: at least one implementation, sources or a binary for one platform; \
             this host has none it can load, so the binary is not probed here"
        }
        "platform-folder" => {
            "FMI 3.0.2 §2.5.1.4: binaries/ is named by platform tuples; further names can be \
             introduced by vendors"
        }
        // schema-level variable attributes: names, value references, causality, variability,
        // initial, start
        _ => "FMI 3.0.2 §2.4.7: ModelVariables",
    }
}

fn finding(check: &str, loc: impl Into<String>, message: impl Into<String>) -> Finding {
    let mut f = Finding::new(check, loc, message);
    f.clause = classify3(check).to_string();
    f
}

fn var_loc(v: &Variable3) -> String {
    format!("modelDescription.xml:{} (variable '{}')", v.line, v.name)
}

/// The interfaces an FMU declares, by element name.
fn interfaces(md: &ModelDescription3) -> Vec<(&'static str, &Interface3)> {
    [
        ("ModelExchange", &md.model_exchange),
        ("CoSimulation", &md.co_simulation),
        ("ScheduledExecution", &md.scheduled_execution),
    ]
    .into_iter()
    .filter_map(|(name, i)| i.as_ref().map(|i| (name, i)))
    .collect()
}

/// The rules of an FMI 3.0 description, in the order of their findings.
const RULES: &[Rule<ModelDescription3>] = &[
    check_root,
    check_units_and_types,
    check_display_units,
    check_variables,
    check_clocks,
    check_model_structure,
    check_initial_unknowns,
];

/// Checks of an FMI 3.0 `modelDescription.xml`, one finding per departure from the standard.
pub fn check_model_description3(md: &ModelDescription3) -> Vec<Finding> {
    apply(md, RULES)
}

/// The attributes of `<fmiModelDescription>` and the interface elements (FMI 3.0.2 section
/// 2.4.1): at least one interface, each with a C identifier.
fn check_root(md: &ModelDescription3, f: &mut Vec<Finding>) {
    let root = "modelDescription.xml:<fmiModelDescription>";
    let version = (
        md.fmi_version.as_str(),
        md.fmi_version.starts_with("3."),
        "3.x",
    );
    let required = [
        ("model-name", "modelName", md.model_name.as_str()),
        (
            "instantiation-token",
            "instantiationToken",
            md.instantiation_token.as_str(),
        ),
    ];
    for (check, m) in root_problems(version, required) {
        f.push(finding(check, root, m));
    }
    let declared = interfaces(md);
    if declared.is_empty() {
        let m = "no <ModelExchange>, <CoSimulation> or <ScheduledExecution> element";
        f.push(finding("interfaces", root, m));
    }
    for (name, i) in &declared {
        if let Some(m) = identifier_problem(&i.model_identifier) {
            let loc = format!("modelDescription.xml:{} (<{name}>)", i.line);
            f.push(finding("model-identifier", loc, m));
        }
    }
}

/// Units and type definitions: unique names; a `unit` names a `<Unit>` (FMI 3.0.2 section
/// 2.4.3), a `declaredType` a type definition of the variable's type (section 2.4.4).
fn check_units_and_types(md: &ModelDescription3, f: &mut Vec<Finding>) {
    let mut units = HashMap::new();
    for u in &md.units {
        if let Some(m) = defined_again(&mut units, ("unit", "defined"), &u.name, u.line) {
            let loc = format!("modelDescription.xml:{} (unit '{}')", u.line, u.name);
            f.push(finding("unique-units", loc, m));
        }
    }
    let (mut types, mut type_lines) = (HashMap::new(), HashMap::new());
    for t in &md.type_definitions {
        let loc = format!("modelDescription.xml:{} (type '{}')", t.line, t.name);
        types.insert(t.name.as_str(), t);
        if let Some(m) = defined_again(&mut type_lines, ("type", "defined"), &t.name, t.line) {
            f.push(finding("unique-types", &loc, m));
        }
        if let Some(u) = t.unit.as_deref().filter(|u| !units.contains_key(u)) {
            let m = format!("unit '{u}' is not defined in <UnitDefinitions>");
            f.push(finding("unit-declared", &loc, m));
        }
    }
    for v in &md.variables {
        if let Some(u) = v.unit.as_deref().filter(|u| !units.contains_key(u)) {
            let m = format!("unit '{u}' is not defined in <UnitDefinitions>");
            f.push(finding("unit-declared", var_loc(v), m));
        }
        if let Some(name) = &v.declared_type {
            let m = match types.get(name.as_str()) {
                None => format!("declaredType '{name}' is not defined in <TypeDefinitions>"),
                Some(t) if t.ty != v.ty => format!(
                    "declaredType '{name}' is a {} type, the variable is {}",
                    t.ty.as_str(),
                    v.ty.as_str()
                ),
                Some(_) => continue,
            };
            f.push(finding("declared-type", var_loc(v), m));
        }
    }
}

/// Display units (FMI 3.0.2 section 2.4.3): names unique within their `<Unit>`, `inverse = true`
/// only with `offset = 0`; a `displayUnit` of a type definition or a variable names a
/// `<DisplayUnit>` of its unit (the variable's, else its declared type's), which must be given.
fn check_display_units(md: &ModelDescription3, f: &mut Vec<Finding>) {
    for u in &md.units {
        let mut names = HashMap::new();
        for d in &u.display_units {
            let loc = format!(
                "modelDescription.xml:{} (display unit '{}')",
                d.line, d.name
            );
            if let Some(first) = names.insert(d.name.as_str(), d.line) {
                let m = format!(
                    "display unit '{}' of unit '{}' is already defined on line {first}",
                    d.name, u.name
                );
                f.push(finding("display-unit", &loc, m));
            }
            if d.inverse && d.offset != 0.0 {
                let m = format!(
                    "display unit '{}' has inverse=\"true\" and offset {}: inverse is only \
                     allowed with offset 0",
                    d.name, d.offset
                );
                f.push(finding("display-unit", &loc, m));
            }
        }
    }
    let types: HashMap<&str, &host::fmi3::md::TypeDefinition3> = md
        .type_definitions
        .iter()
        .map(|t| (t.name.as_str(), t))
        .collect();
    for t in &md.type_definitions {
        let loc = format!("modelDescription.xml:{} (type '{}')", t.line, t.name);
        check_display_unit_ref(md, t.unit.as_deref(), t.display_unit.as_deref(), &loc, f);
    }
    for v in &md.variables {
        let unit = v.unit.as_deref().or_else(|| {
            let t = types.get(v.declared_type.as_deref()?)?;
            t.unit.as_deref()
        });
        check_display_unit_ref(md, unit, v.display_unit.as_deref(), &var_loc(v), f);
    }
}

/// `display` given: `unit` is given and has a `<DisplayUnit>` of that name (an undefined unit
/// is the `unit-declared` finding).
fn check_display_unit_ref(
    md: &ModelDescription3,
    unit: Option<&str>,
    display: Option<&str>,
    loc: &str,
    f: &mut Vec<Finding>,
) {
    let Some(display) = display else { return };
    let Some(unit) = unit else {
        let m = format!("displayUnit '{display}' is given without a unit");
        f.push(finding("display-unit-declared", loc, m));
        return;
    };
    let Some(u) = md.units.iter().find(|u| u.name == unit) else {
        return;
    };
    if !u.display_units.iter().any(|d| d.name == display) {
        let m = format!("displayUnit '{display}' is not a <DisplayUnit> of unit '{unit}'");
        f.push(finding("display-unit-declared", loc, m));
    }
}

/// Clocks (FMI 3.0.2 section 2.4.7.4): a Clock has causality input, output or local and
/// variability discrete; the `clocks` of a clocked variable are value references of Clocks,
/// and only a discrete or tunable variable is clocked.
fn check_clocks(md: &ModelDescription3, f: &mut Vec<Finding>) {
    for v in &md.variables {
        let loc = var_loc(v);
        if v.ty == Type3::Clock {
            if !matches!(
                v.causality,
                Causality3::Input | Causality3::Output | Causality3::Local
            ) {
                let m = format!(
                    "a Clock has causality input, output or local, not {}",
                    v.causality
                );
                f.push(finding("clocks", &loc, m));
            }
            if v.variability != Variability::Discrete {
                let m = format!(
                    "a Clock has variability discrete, not {}",
                    variability_name(v.variability)
                );
                f.push(finding("clocks", &loc, m));
            }
        }
        if v.clocks.is_empty() {
            continue;
        }
        if !matches!(v.variability, Variability::Discrete | Variability::Tunable) {
            let m = format!(
                "a clocked variable has variability discrete or tunable, not {}",
                variability_name(v.variability)
            );
            f.push(finding("clocks", &loc, m));
        }
        for vr in &v.clocks {
            match md.by_vr(*vr) {
                Some(c) if c.ty == Type3::Clock => {}
                Some(c) => {
                    let m = format!(
                        "clocks lists valueReference {vr}, '{}', a {} and not a Clock",
                        c.name,
                        c.ty.as_str()
                    );
                    f.push(finding("clocks", &loc, m));
                }
                None => {
                    let m = format!("clocks lists valueReference {vr}, which is not a variable");
                    f.push(finding("clocks", &loc, m));
                }
            }
        }
    }
}

/// The note that the probes did not run the FMU, with the reason (clocks or Scheduled Execution
/// only): its description and binaries were checked, its behaviour was not.
pub fn probe_not_run(reason: &str) -> Finding {
    let mut f = finding(
        "probe-not-run",
        "probe",
        format!("the runtime probe did not run the FMU: {reason}"),
    );
    f.severity = super::Severity::Note;
    f
}

/// The FMI 2.0 causality an FMI 3.0 one is judged as: FMI 3.0.2 section 2.4.7.4 gives a
/// structural parameter the combinations and `initial` values of a parameter, and otherwise
/// keeps the FMI 2.0 tables.
fn as_fmi2(c: Causality3) -> Causality {
    match c {
        Causality3::StructuralParameter | Causality3::Parameter => Causality::Parameter,
        Causality3::CalculatedParameter => Causality::CalculatedParameter,
        Causality3::Input => Causality::Input,
        Causality3::Output => Causality::Output,
        Causality3::Local => Causality::Local,
        Causality3::Independent => Causality::Independent,
    }
}

fn variability_name(v: Variability) -> String {
    format!("{v:?}").to_lowercase()
}

fn check_variables(md: &ModelDescription3, f: &mut Vec<Finding>) {
    let mut names: HashMap<&str, usize> = HashMap::new();
    let mut vrs: BTreeMap<u32, Vec<&Variable3>> = BTreeMap::new();
    for v in &md.variables {
        let loc = var_loc(v);
        for (check, m) in name_problems(&mut names, &v.name, v.line) {
            f.push(finding(check, &loc, m));
        }
        vrs.entry(v.value_reference).or_default().push(v);
        check_combination(v, &loc, f);
        if v.ty != Type3::Clock {
            check_start(v, &loc, f);
        }
        for d in &v.dimensions {
            check_dimension(md, v, d, f);
        }
        if let Some(state_vr) = v.derivative {
            check_derivative(md, v, state_vr, &loc, f);
        }
    }
    let independents: Vec<&Variable3> = md.with_causality(Causality3::Independent).collect();
    if independents.len() != 1 {
        f.push(finding(
            "independent",
            "modelDescription.xml:<ModelVariables>",
            format!(
                "{} variables with causality=\"independent\", exactly one is required",
                independents.len()
            ),
        ));
    }
    for v in independents {
        if v.ty != Type3::Float64 || v.is_array() {
            let m = "the independent variable must be a scalar Float64";
            f.push(finding("independent", var_loc(v), m));
        }
    }
    for (vr, set) in vrs.iter().filter(|(_, set)| set.len() > 1) {
        let names: Vec<&str> = set.iter().map(|v| v.name.as_str()).collect();
        f.push(finding(
            "unique-value-references",
            var_loc(set[1]),
            format!(
                "valueReference {vr} is shared by {} (FMI 3.0 value references are unique; \
                 aliases are <Alias> elements)",
                names.join(", ")
            ),
        ));
    }
}

/// The `initial` values FMI 3.0.2 allows (section 2.4.7.5, the table "Definition of initial"):
/// FMI 2.0.4's, except that an input (discrete or continuous) takes `exact`, its default and only
/// value, where FMI 2.0.4 gives an input no `initial` attribute.
fn initial_allowed3(c: Causality, v: Variability) -> &'static [Option<Initial>] {
    match c {
        Causality::Input => &[None, Some(Initial::Exact)],
        _ => initial_allowed(c, v),
    }
}

/// Causality against variability, and `initial` for an allowed combination (FMI 3.0.2 section
/// 2.4.7.4, the two tables); only Float variables may be continuous.
fn check_combination(v: &Variable3, loc: &str, f: &mut Vec<Finding>) {
    let c = as_fmi2(v.causality);
    if !combination_allowed(c, v.variability) {
        let m = format!(
            "causality {} with variability {} is not allowed by FMI 3.0",
            v.causality,
            variability_name(v.variability)
        );
        f.push(finding("causality-variability", loc, m));
    } else if !initial_allowed3(c, v.variability).contains(&v.initial) {
        let m = format!(
            "initial=\"{}\" is not allowed for causality {} and variability {}",
            format!("{:?}", v.initial.unwrap_or(Initial::Exact)).to_lowercase(),
            v.causality,
            variability_name(v.variability)
        );
        f.push(finding("initial", loc, m));
    }
    if v.variability == Variability::Continuous && !v.ty.is_float() {
        let m = format!("a {} variable cannot be continuous", v.ty.as_str());
        f.push(finding("variability-type", loc, m));
    }
}

/// start is required for inputs, constants and `initial` exact or approx, and not allowed for
/// the independent variable and `initial` calculated (FMI 3.0.2 section 2.4.7.5).
fn check_start(v: &Variable3, loc: &str, f: &mut Vec<Finding>) {
    let initial = v.effective_initial();
    let (input, independent) = (
        v.causality == Causality3::Input,
        v.causality == Causality3::Independent,
    );
    let has_start = v.start.is_some();
    let Some(problem) = start_problem((input, independent), v.variability, initial, has_start)
    else {
        return;
    };
    let initial_name = initial.map_or("none".to_string(), |i| format!("{i:?}").to_lowercase());
    let m = format!(
        "{problem} (causality {}, initial {initial_name})",
        v.causality
    );
    f.push(finding("start", loc, m));
}

/// A `<Dimension>` has exactly one of start and valueReference; a valueReference names a UInt64
/// structural parameter or constant (FMI 3.0.2 section 2.4.7, arrays).
fn check_dimension(
    md: &ModelDescription3,
    v: &Variable3,
    d: &host::fmi3::md::Dimension,
    f: &mut Vec<Finding>,
) {
    let loc = format!(
        "modelDescription.xml:{} (<Dimension> of '{}')",
        d.line, v.name
    );
    let vr = match (d.start, d.value_reference) {
        (Some(_), None) => return,
        (None, Some(vr)) => vr,
        _ => {
            let m = "a <Dimension> needs exactly one of start and valueReference";
            f.push(finding("dimension", loc, m));
            return;
        }
    };
    let problem = match md.by_vr(vr) {
        None => Some(format!("valueReference {vr} is not a variable")),
        Some(p) if p.ty != Type3::UInt64 || p.is_array() => Some(format!(
            "valueReference {vr} is '{}', a {}, not a scalar UInt64",
            p.name,
            p.ty.as_str()
        )),
        Some(p)
            if p.causality != Causality3::StructuralParameter
                && p.variability != Variability::Constant =>
        {
            Some(format!(
                "valueReference {vr} is '{}' with causality {}, not a structural parameter or \
                 constant",
                p.name, p.causality
            ))
        }
        Some(_) => None,
    };
    if let Some(m) = problem {
        f.push(finding("dimension", loc, m));
    }
}

/// `derivative` names the value reference of a continuous Float state; the derivative itself
/// is a continuous Float.
fn check_derivative(
    md: &ModelDescription3,
    v: &Variable3,
    state_vr: u32,
    loc: &str,
    f: &mut Vec<Finding>,
) {
    if !v.ty.is_float() || v.variability != Variability::Continuous {
        let m = "a variable with a derivative attribute must be a continuous Float";
        f.push(finding("derivative", loc, m));
    }
    match md.by_vr(state_vr) {
        None => {
            let m = format!("derivative=\"{state_vr}\" is not a variable");
            f.push(finding("derivative", loc, m));
        }
        Some(s) if !s.ty.is_float() || s.variability != Variability::Continuous => {
            let m = format!(
                "derivative=\"{state_vr}\" is '{}', not a continuous Float",
                s.name
            );
            f.push(finding("derivative", loc, m));
        }
        Some(_) => {}
    }
}

/// `<Output>` lists exactly the outputs, `<ContinuousStateDerivative>` only variables with a
/// derivative attribute, every element names an existing variable (FMI 3.0.2 section 2.4.8).
fn check_model_structure(md: &ModelDescription3, f: &mut Vec<Finding>) {
    let ms = &md.model_structure;
    let lists: [(&str, &Vec<Unknown3>); 5] = [
        ("Output", &ms.outputs),
        (
            "ContinuousStateDerivative",
            &ms.continuous_state_derivatives,
        ),
        ("ClockedState", &ms.clocked_states),
        ("InitialUnknown", &ms.initial_unknowns),
        ("EventIndicator", &ms.event_indicators),
    ];
    for (element, unknowns) in lists {
        let mut seen = BTreeSet::new();
        for u in unknowns {
            let loc = format!(
                "modelDescription.xml:{} (<{element} valueReference=\"{}\">)",
                u.line, u.value_reference
            );
            if !seen.insert(u.value_reference) {
                let m = format!("valueReference {} is listed twice", u.value_reference);
                f.push(finding("model-structure", &loc, m));
            }
            let Some(v) = md.by_vr(u.value_reference) else {
                let m = format!("valueReference {} is not a variable", u.value_reference);
                f.push(finding("model-structure", &loc, m));
                continue;
            };
            if let Some(m) = wrong_kind(element, v) {
                f.push(finding(
                    if element == "Output" {
                        "outputs-listed"
                    } else {
                        "model-structure"
                    },
                    &loc,
                    m,
                ));
            }
            for d in u.dependencies.iter().flatten() {
                if md.by_vr(*d).is_none() {
                    let m = format!("dependency {d} is not a variable");
                    f.push(finding("model-structure", &loc, m));
                }
            }
            let n_deps = u.dependencies.as_ref().map(Vec::len);
            if let Some(kinds) = &u.dependencies_kind {
                if n_deps != Some(kinds.len()) {
                    let m = "dependenciesKind and dependencies differ in length";
                    f.push(finding("model-structure", &loc, m));
                }
            }
        }
    }
    let listed: BTreeSet<u32> = ms.outputs.iter().map(|u| u.value_reference).collect();
    for v in md.with_causality(Causality3::Output) {
        if !listed.contains(&v.value_reference) {
            let m = format!(
                "output '{}' (valueReference {}) is missing from <ModelStructure> <Output>",
                v.name, v.value_reference
            );
            f.push(finding("outputs-listed", var_loc(v), m));
        }
    }
}

/// Every variable `<InitialUnknown>` must list (FMI 3.0.2 section 2.4.8: "This list consists
/// of all variables which: are not clocked variables and have causality = output (with initial =
/// approx or calculated), or have causality = calculatedParameter, or are continuous-time states
/// or state derivatives (defined with elements ContinuousStateDerivative) with initial = approx
/// or calculated"). Listing a clocked variable is optional (section 2.2.8: "Declaring a clocked
/// variable as an InitialUnknown is optional"), so clocked variables and Clocks are not demanded;
/// a Co-Simulation FMU without `providesDirectionalDerivatives` has its
/// `<ContinuousStateDerivative>` elements ignored (section 2.4.8), so its states are not either.
/// An `<Alias>` shares its variable's value reference, which is what is listed.
fn check_initial_unknowns(md: &ModelDescription3, f: &mut Vec<Finding>) {
    let ms = &md.model_structure;
    let states_count = md.model_exchange.is_some()
        || [&md.co_simulation, &md.scheduled_execution]
            .into_iter()
            .flatten()
            .any(|i| i.flag("providesDirectionalDerivatives"));
    let derivatives: BTreeSet<u32> = ms
        .continuous_state_derivatives
        .iter()
        .map(|u| u.value_reference)
        .collect();
    let states: BTreeSet<u32> = derivatives
        .iter()
        .filter_map(|vr| md.by_vr(*vr)?.derivative)
        .collect();
    let listed: BTreeSet<u32> = ms
        .initial_unknowns
        .iter()
        .map(|u| u.value_reference)
        .collect();
    let approx_or_calc = |v: &Variable3| approx_or_calculated(v.effective_initial());
    let mut seen = BTreeSet::new();
    for v in &md.variables {
        let vr = v.value_reference;
        let clocked = !v.clocks.is_empty() || v.ty == Type3::Clock;
        let why = if v.causality == Causality3::Output && !clocked && approx_or_calc(v) {
            "an output with initial approx or calculated"
        } else if v.causality == Causality3::CalculatedParameter {
            "a calculated parameter"
        } else if states_count && states.contains(&vr) && approx_or_calc(v) {
            "a continuous-time state with initial approx or calculated"
        } else if states_count && derivatives.contains(&vr) && approx_or_calc(v) {
            "a state derivative with initial approx or calculated"
        } else {
            continue;
        };
        if !listed.contains(&vr) && seen.insert(vr) {
            let m = format!(
                "'{}' (valueReference {vr}) must be listed in <InitialUnknown>: {why}",
                v.name
            );
            f.push(finding("initial-unknowns", var_loc(v), m));
        }
    }
}

/// Why `v` may not be listed in `<element>`, if it may not.
fn wrong_kind(element: &str, v: &Variable3) -> Option<String> {
    match element {
        "Output" if v.causality != Causality3::Output => Some(format!(
            "'{}' is listed in <Output> but its causality is {}",
            v.name, v.causality
        )),
        "ContinuousStateDerivative" if v.derivative.is_none() => Some(format!(
            "'{}' is listed in <ContinuousStateDerivative> but has no derivative attribute",
            v.name
        )),
        "InitialUnknown"
            if matches!(
                v.causality,
                Causality3::Input
                    | Causality3::Independent
                    | Causality3::Parameter
                    | Causality3::StructuralParameter
            ) || v.variability == Variability::Constant =>
        {
            Some(format!(
                "'{}' (causality {}, variability {}) cannot be an <InitialUnknown>",
                v.name,
                v.causality,
                variability_name(v.variability)
            ))
        }
        _ => None,
    }
}

/// The binary format and architectures of an FMI 3.0 platform tuple (FMI 3.0.2 section 2.5.1:
/// `<arch>-<sys>`), None for a tuple the validator does not know.
pub fn expected_format3(tuple: &str) -> Option<(&'static str, &'static str)> {
    let mut parts = tuple.splitn(3, '-');
    let (arch, sys) = (parts.next()?, parts.next()?);
    let format = match sys {
        "linux" => "ELF",
        "windows" => "PE",
        "darwin" => "Mach-O",
        _ => return None,
    };
    let arch = match arch {
        "x86_64" => "x86_64",
        "aarch64" => "aarch64",
        "x86" => "x86",
        _ => return None,
    };
    Some((format, arch))
}

/// FMI 2.0 platform directory names, which are not FMI 3.0 platform tuples.
const FMI2_PLATFORMS: [&str; 6] = [
    "linux64", "linux32", "win64", "win32", "darwin64", "darwin32",
];

/// Functions the Model Exchange interface adds (FMI 3.0.2 section 3.2).
pub const FMI3_ME_FUNCTIONS: [&str; 12] = [
    "fmi3InstantiateModelExchange",
    "fmi3EnterContinuousTimeMode",
    "fmi3CompletedIntegratorStep",
    "fmi3SetTime",
    "fmi3SetContinuousStates",
    "fmi3GetContinuousStateDerivatives",
    "fmi3GetEventIndicators",
    "fmi3GetContinuousStates",
    "fmi3GetNominalsOfContinuousStates",
    "fmi3GetNumberOfEventIndicators",
    "fmi3GetNumberOfContinuousStates",
    "fmi3UpdateDiscreteStates",
];

/// Functions the Co-Simulation interface adds (FMI 3.0.2 section 4.2).
pub const FMI3_CS_FUNCTIONS: [&str; 4] = [
    "fmi3InstantiateCoSimulation",
    "fmi3EnterStepMode",
    "fmi3GetOutputDerivatives",
    "fmi3DoStep",
];

/// Functions the Scheduled Execution interface adds (FMI 3.0.2 section 5.2).
pub const FMI3_SE_FUNCTIONS: [&str; 2] = [
    "fmi3InstantiateScheduledExecution",
    "fmi3ActivateModelPartition",
];

/// Functions of optional capabilities (partial derivatives, Configuration Mode, clocks, the
/// evaluation of discrete states: FMI 3.0.2 sections 2.2.8 and 2.2.12, 2.3.6 and 3.2).
pub const FMI3_CAPABILITY_FUNCTIONS: [&str; 13] = [
    "fmi3GetDirectionalDerivative",
    "fmi3GetAdjointDerivative",
    "fmi3EnterConfigurationMode",
    "fmi3ExitConfigurationMode",
    "fmi3GetIntervalDecimal",
    "fmi3GetIntervalFraction",
    "fmi3GetShiftDecimal",
    "fmi3GetShiftFraction",
    "fmi3SetIntervalDecimal",
    "fmi3SetIntervalFraction",
    "fmi3SetShiftDecimal",
    "fmi3SetShiftFraction",
    "fmi3EvaluateDiscreteStates",
];

/// The functions every FMI 3.0 binary must export: all of `fmi3Functions.h`, "even if they are
/// only needed for interface types or optional capabilities that the FMU does not support"
/// (FMI 3.0.2 section 2.5).
fn required_functions() -> Vec<&'static str> {
    let mut need: Vec<&'static str> = host::fmi3::ffi::FMI3_COMMON_FUNCTIONS.to_vec();
    need.extend_from_slice(&FMI3_ME_FUNCTIONS);
    need.extend_from_slice(&FMI3_CS_FUNCTIONS);
    need.extend_from_slice(&FMI3_SE_FUNCTIONS);
    need.extend_from_slice(&FMI3_CAPABILITY_FUNCTIONS);
    need.sort_unstable();
    need.dedup();
    need
}

/// Every binary under `binaries/<platformTuple>/` of the FMU extracted at `dir`, read without
/// loading it, with the findings it raises: a missing library where its tuple's folder holds
/// other files, a format or architecture that is not the tuple's, a function of a declared
/// interface not exported; an FMU with no implementation (FMI 3.0.2 section 2.5: "at least one
/// implementation, in other words, either sources or one of the binaries for a particular
/// machine"). A folder with an FMI 2.0 platform name is a vendor's folder (section 2.5.1.4:
/// "Further names can be introduced by vendors"): a note. No library for this host while
/// another implementation exists: a note that it is not probed here.
pub fn check_platform_binaries3(
    dir: &Path,
    md: &ModelDescription3,
) -> (Vec<Finding>, Vec<super::PlatformBinary>) {
    let (mut findings, mut binaries) = (Vec::new(), Vec::new());
    let mut ids: Vec<&str> = interfaces(md)
        .iter()
        .map(|(_, i)| i.model_identifier.as_str())
        .filter(|id| names_one_file(id))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let survey = Survey::of(dir);
    findings.extend(survey.backslash_finding().map(with_clause3));
    let tuple_folder = |name: &str| !FMI2_PLATFORMS.contains(&name);
    for id in &ids {
        if survey.implementation(id, "", tuple_folder).is_none() {
            let m = format!(
                "no binaries/<platformTuple>/{id} library and no sources/: nothing to run \
                 (folders under binaries/: {})",
                survey.folder_list()
            );
            findings.push(finding("binary", "binaries/", m));
        }
    }
    for folder in &survey.folders {
        let tuple = folder.name.as_str();
        if !tuple_folder(tuple) {
            let m = format!(
                "'{tuple}' is an FMI 2.0 platform name, not an FMI 3.0 platform tuple \
                 (x86_64-linux, x86_64-windows, x86_64-darwin, aarch64-darwin, aarch64-linux): \
                 a vendor's folder, which importers do not look in"
            );
            findings.push(finding("platform-folder", format!("binaries/{tuple}/"), m));
            continue;
        }
        let Some((format, arch)) = expected_format3(tuple) else {
            continue;
        };
        let ext = library_extension(format);
        for id in &ids {
            let entry = format!("binaries/{tuple}/{id}.{ext}");
            let Ok(bytes) = std::fs::read(dir.join(&entry)) else {
                // An empty folder claims nothing; other files in it are a misnamed library.
                if !folder.files.is_empty() {
                    let m = format!("no {id}.{ext} in binaries/{tuple}/");
                    findings.push(finding("binary", &entry, m));
                }
                continue;
            };
            let (found, info) = check_library3(&bytes, &entry, (tuple, format, arch));
            findings.extend(found);
            if let Some(info) = info {
                binaries.push(super::PlatformBinary { entry, info });
            }
        }
    }
    findings.extend(not_probed_here(&survey, &ids));
    (findings, binaries)
}

/// A note for each model identifier without a library for this host's platform tuple while the
/// FMU ships another implementation: it is not probed here.
fn not_probed_here(survey: &Survey, ids: &[&str]) -> Vec<Finding> {
    let host = host::fmi3::PLATFORM_TUPLE;
    let lib = |id: &str| format!("{id}.{}", host::LIB_SUFFIX);
    let has = |id: &str| {
        survey
            .folder(host)
            .is_some_and(|f| f.files.iter().any(|n| *n == lib(id)))
    };
    let misnamed = survey.folder(host).is_some_and(|f| !f.files.is_empty());
    ids.iter()
        .filter(|id| !has(id) && !misnamed)
        .filter_map(|id| {
            let other = survey.implementation(id, host, |n| !FMI2_PLATFORMS.contains(&n))?;
            let m = format!(
                "no binaries/{host}/{}: not probed here (the FMU's implementation: {other})",
                lib(id)
            );
            Some(finding("binary-not-probed", format!("binaries/{host}/"), m))
        })
        .collect()
}

/// `f` with its FMI 3.0.2 clause.
fn with_clause3(mut f: Finding) -> Finding {
    f.clause = classify3(&f.check).to_string();
    f
}

/// The findings on the library `entry` of the platform tuple `tuple` (which needs `format` with
/// an `arch` slice), read from `bytes`, and what it is (None when it is not a readable binary):
/// its format and architectures, and the functions of `fmi3Functions.h` each slice exports.
fn check_library3(
    bytes: &[u8],
    entry: &str,
    (tuple, format, arch): (&str, &str, &str),
) -> (Vec<Finding>, Option<host::binary::BinaryInfo>) {
    let info = match host::binary::inspect(bytes) {
        Ok(info) => info,
        Err(e) => return (vec![finding("binary-format", entry, e.to_string())], None),
    };
    let mut findings = Vec::new();
    if info.format != format {
        let m = format!("is {}, but {tuple} needs {format}", info.format);
        findings.push(finding("binary-format", entry, m));
    }
    // A macOS universal binary may hold other slices beside the tuple's.
    if !info.slices.iter().any(|s| s.architecture == arch) {
        let held: Vec<&str> = info
            .slices
            .iter()
            .map(|s| s.architecture.as_str())
            .collect();
        let m = format!("holds {held:?}, {tuple} needs an {arch} slice");
        findings.push(finding("binary-format", entry, m));
    }
    let need = required_functions();
    for slice in &info.slices {
        let missing = missing_exports(&need, slice);
        if !missing.is_empty() {
            let m = format!(
                "the {} slice does not export {} of the functions of fmi3Functions.h, which an \
                 FMU implements whatever interfaces it declares: {}",
                slice.architecture,
                missing.len(),
                missing.join(", ")
            );
            findings.push(finding("symbols", entry, m));
        }
    }
    (findings, Some(info))
}

#[cfg(test)]
mod tests {
    use super::required_functions;

    #[test]
    fn every_function_of_the_header_is_required_once() {
        // fmi3Functions.h of FMI 3.0.2 declares 75 functions
        let need = required_functions();
        assert_eq!(need.len(), 75);
        assert!(need.iter().all(|f| f.starts_with("fmi3")));
    }
}
