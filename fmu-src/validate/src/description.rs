//! Checks of `modelDescription.xml` (FMI 2.0.4 chapter 2.2) and of the candidate-effect
//! convention of the gap workflow.

use super::rules::{
    apply, approx_or_calculated, defined_again, identifier_problem, name_problems, root_problems,
    start_problem, Rule,
};
use super::{var_loc, Finding};

use host::md::{
    Causality, Initial, ModelDescription, ScalarVariable, StartValue, VarKind, Variability,
};
use std::collections::{BTreeSet, HashMap};

pub use fmi_types::schema::{combination_allowed, initial_allowed};

/// The rules of an FMI 2.0 description, in the order of their findings.
const RULES: &[Rule<ModelDescription>] = &[
    check_root,
    check_interfaces,
    check_default_experiment,
    check_units,
    check_variables,
    check_model_structure,
];

/// Checks of `modelDescription.xml` for a Co-Simulation FMU.
pub fn check_model_description(md: &ModelDescription) -> Vec<Finding> {
    apply(md, RULES)
}

/// The attributes of `<fmiModelDescription>` (FMI 2.0.4 section 2.2.1).
fn check_root(md: &ModelDescription, f: &mut Vec<Finding>) {
    let root = "modelDescription.xml:<fmiModelDescription>";
    let version = (md.fmi_version.as_str(), md.fmi_version == "2.0", "2.0");
    let required = [
        ("model-name", "modelName", md.model_name.as_str()),
        ("guid", "guid", md.guid.as_str()),
    ];
    for (check, m) in root_problems(version, required) {
        f.push(Finding::new(check, root, m));
    }
    if let Some(c) = &md.variable_naming_convention {
        if c != "flat" && c != "structured" {
            f.push(Finding::new(
                "naming-convention",
                root,
                format!("variableNamingConvention \"{c}\" is neither flat nor structured"),
            ));
        }
    }
}

/// A `<CoSimulation>` or `<ModelExchange>` element, each with a C identifier (FMI 2.0.4
/// sections 3.3.1 and 4.3.1), and the Co-Simulation capability flags consistent.
fn check_interfaces(md: &ModelDescription, f: &mut Vec<Finding>) {
    let root = "modelDescription.xml:<fmiModelDescription>";
    let me = md.model_exchange.as_ref();
    if let Some(m) = me.and_then(|m| identifier_problem(&m.model_identifier)) {
        let mut finding = Finding::new(
            "model-identifier",
            "modelDescription.xml:<ModelExchange>",
            m,
        );
        finding.clause = "FMI 2.0.4 §3.3.1: ModelExchange element".into();
        f.push(finding);
    }
    match &md.co_simulation {
        None if me.is_some() => {}
        None => f.push(Finding::new(
            "co-simulation",
            root,
            "no <CoSimulation> or <ModelExchange> element: neither a Co-Simulation nor a Model \
             Exchange FMU",
        )),
        Some(cs) => {
            if let Some(m) = identifier_problem(&cs.model_identifier) {
                let loc = "modelDescription.xml:<CoSimulation>";
                f.push(Finding::new("model-identifier", loc, m));
            }
            if cs.can_serialize_fmu_state && !cs.can_get_and_set_fmu_state {
                f.push(Finding::new(
                    "capability-flags",
                    "modelDescription.xml:<CoSimulation>",
                    "canSerializeFMUstate is true but canGetAndSetFMUstate is false",
                ));
            }
        }
    }
}

/// `<DefaultExperiment>` (FMI 2.0.4 section 2.2.5): stop after start, positive step and
/// tolerance.
fn check_default_experiment(md: &ModelDescription, f: &mut Vec<Finding>) {
    if let Some(de) = &md.default_experiment {
        let loc = "modelDescription.xml:<DefaultExperiment>";
        if let (Some(a), Some(b)) = (de.start_time, de.stop_time) {
            if b < a {
                f.push(Finding::new(
                    "default-experiment",
                    loc,
                    format!("stopTime {b} is before startTime {a}"),
                ));
            }
        }
        if matches!(de.step_size, Some(h) if h.is_nan() || h <= 0.0) {
            f.push(Finding::new(
                "default-experiment",
                loc,
                "stepSize must be > 0",
            ));
        }
        if matches!(de.tolerance, Some(t) if t.is_nan() || t <= 0.0) {
            f.push(Finding::new(
                "default-experiment",
                loc,
                "tolerance must be > 0",
            ));
        }
    }
}

fn check_units(md: &ModelDescription, f: &mut Vec<Finding>) {
    let mut seen = HashMap::new();
    for u in &md.unit_definitions {
        let loc = format!("modelDescription.xml:{} (unit '{}')", u.line, u.name);
        if let Some(m) = defined_again(&mut seen, ("unit", "defined"), &u.name, u.line) {
            f.push(Finding::new("unique-units", &loc, m));
        }
        let mut names = BTreeSet::new();
        for d in &u.display_units {
            if !names.insert(d.name.as_str()) {
                f.push(Finding::new(
                    "unique-units",
                    &loc,
                    format!("display unit '{}' defined twice", d.name),
                ));
            }
            if d.factor == 0.0 || !d.factor.is_finite() {
                f.push(Finding::new(
                    "display-unit",
                    &loc,
                    format!("display unit '{}' has factor {}", d.name, d.factor),
                ));
            }
        }
    }
    let mut types = HashMap::new();
    for t in &md.type_definitions {
        if let Some(m) = defined_again(&mut types, ("type", "defined"), &t.name, t.line) {
            let loc = format!("modelDescription.xml:{} (type '{}')", t.line, t.name);
            f.push(Finding::new("unique-types", loc, m));
        }
        if let Some(u) = &t.unit {
            check_unit_ref(
                md,
                u,
                t.display_unit.as_deref(),
                &format!("modelDescription.xml:{} (type '{}')", t.line, t.name),
                f,
            );
        }
    }
    let mut cats = BTreeSet::new();
    for c in &md.log_categories {
        if !cats.insert(c.name.as_str()) {
            f.push(Finding::new(
                "log-categories",
                "modelDescription.xml:<LogCategories>",
                format!("category '{}' defined twice", c.name),
            ));
        }
    }
}

fn check_unit_ref(
    md: &ModelDescription,
    unit: &str,
    display: Option<&str>,
    loc: &str,
    f: &mut Vec<Finding>,
) {
    match md.unit(unit) {
        None => f.push(Finding::new(
            "unit-declared",
            loc,
            format!("unit '{unit}' is not defined in <UnitDefinitions>"),
        )),
        Some(u) => {
            if let Some(d) = display {
                if !u.display_units.iter().any(|x| x.name == d) {
                    f.push(Finding::new(
                        "display-unit-declared",
                        loc,
                        format!("displayUnit '{d}' is not a <DisplayUnit> of unit '{unit}'"),
                    ));
                }
            }
        }
    }
}

fn check_variables(md: &ModelDescription, f: &mut Vec<Finding>) {
    let mut names: HashMap<&str, usize> = HashMap::new();
    let mut vrs: HashMap<(u8, u32), Vec<&ScalarVariable>> = HashMap::new();
    let mut independents = 0;
    for v in &md.model_variables {
        let loc = var_loc(v);
        for (check, m) in name_problems(&mut names, &v.name, v.line) {
            f.push(Finding::new(check, &loc, m));
        }
        let base = match v.kind {
            VarKind::Real => 0,
            VarKind::Integer | VarKind::Enumeration => 1,
            VarKind::Boolean => 2,
            VarKind::String => 3,
        };
        vrs.entry((base, v.value_reference)).or_default().push(v);
        check_combination(v, &loc, f);
        if v.causality == Causality::Independent {
            independents += 1;
            if v.kind != VarKind::Real {
                f.push(Finding::new(
                    "independent",
                    &loc,
                    "the independent variable must be Real",
                ));
            }
        }
        check_start(v, &loc, f);
        check_range(md, v, &loc, f);
        check_type_and_unit(md, v, &loc, f);
        if let Some(d) = v.derivative {
            if d == 0 || d > md.model_variables.len() {
                f.push(Finding::new(
                    "derivative",
                    &loc,
                    format!("derivative index {d} is out of range"),
                ));
            }
        }
    }
    if independents > 1 {
        f.push(Finding::new(
            "independent",
            "modelDescription.xml:<ModelVariables>",
            format!("{independents} independent variables, at most one is allowed"),
        ));
    }
    check_aliases(&vrs, f);
}

/// Causality against variability, and `initial` for an allowed combination (FMI 2.0.4 section
/// 2.2.7, the two tables); only Real variables may be continuous.
fn check_combination(v: &ScalarVariable, loc: &str, f: &mut Vec<Finding>) {
    if !combination_allowed(v.causality, v.variability) {
        f.push(Finding::new(
            "causality-variability",
            loc,
            format!(
                "causality {:?} with variability {:?} is not allowed by FMI 2.0",
                v.causality, v.variability
            )
            .to_lowercase()
            .replace("fmi 2.0", "FMI 2.0"),
        ));
    } else if !initial_allowed(v.causality, v.variability).contains(&v.initial) {
        f.push(Finding::new(
            "initial",
            loc,
            format!(
                "initial=\"{}\" is not allowed for causality {:?} and variability {:?}",
                format!("{:?}", v.initial.unwrap()).to_lowercase(),
                v.causality,
                v.variability
            ),
        ));
    }
    if v.variability == Variability::Continuous && v.kind != VarKind::Real {
        f.push(Finding::new(
            "variability-type",
            loc,
            format!(
                "a {:?} variable cannot be continuous{}",
                v.kind,
                if v.variability_given { "" } else { " (variability defaults to continuous: declare it discrete, fixed, tunable or constant)" }
            ),
        ));
    }
}

/// start required / forbidden (FMI 2.0.4 section 2.2.7, attribute start).
fn check_start(v: &ScalarVariable, loc: &str, f: &mut Vec<Finding>) {
    let initial = v.effective_initial();
    let io = (
        v.causality == Causality::Input,
        v.causality == Causality::Independent,
    );
    if let Some(problem) = start_problem(io, v.variability, initial, v.start.is_some()) {
        let m = format!(
            "{problem} (causality {:?}, initial {initial:?})",
            v.causality
        );
        f.push(Finding::new("start", loc, m.to_lowercase()));
    }
}

/// min <= max, start within them and finite, nominal > 0: the FMI 2.0 schema's documentation
/// of these attributes says "max >= min required", "max >= start >= min required" and "nominal >
/// 0.0 required" (fmi2AttributeGroups.xsd, fmi2ScalarVariable.xsd); the FMI 3.0 schema states none.
fn check_range(md: &ModelDescription, v: &ScalarVariable, loc: &str, f: &mut Vec<Finding>) {
    let (min, max) = effective_range(md, v);
    if let (Some(a), Some(b)) = (min, max) {
        if a > b {
            f.push(Finding::new(
                "min-max",
                loc,
                format!("min {a} > max {b} (the schema: \"max >= min required\")"),
            ));
        }
    }
    if let Some(s) = v.start.as_ref().and_then(StartValue::as_f64) {
        if v.kind != VarKind::Boolean {
            if matches!(min, Some(a) if s < a) || matches!(max, Some(b) if s > b) {
                f.push(Finding::new(
                    "start-range",
                    loc,
                    format!(
                        "start {s} is outside [{}, {}] (the schema: \"max >= start >= min \
                         required\")",
                        fmt_opt(min),
                        fmt_opt(max)
                    ),
                ));
            }
            if !s.is_finite() {
                f.push(Finding::new(
                    "start-range",
                    loc,
                    format!("start {s} is not finite"),
                ));
            }
        }
    }
    if matches!(v.nominal, Some(n) if !(n > 0.0 && n.is_finite())) {
        f.push(Finding::new(
            "nominal",
            loc,
            format!(
                "nominal {} must be > 0 (the schema: \"nominal > 0.0 required\")",
                v.nominal.unwrap()
            ),
        ));
    }
}

/// The declared type exists and has the variable's type; a Real's unit and display unit are
/// defined.
fn check_type_and_unit(md: &ModelDescription, v: &ScalarVariable, loc: &str, f: &mut Vec<Finding>) {
    if let Some(t) = &v.declared_type {
        let problem = match md.simple_type(t) {
            None => Some(format!(
                "declaredType '{t}' is not defined in <TypeDefinitions>"
            )),
            Some(st) => st.ty.filter(|k| *k != v.kind).map(|kind| {
                format!(
                    "declaredType '{t}' is {kind:?}, the variable is {:?}",
                    v.kind
                )
            }),
        };
        if let Some(m) = problem {
            f.push(Finding::new("declared-type", loc, m));
        }
    }
    if v.kind == VarKind::Real {
        if let Some(u) = &v.unit {
            check_unit_ref(md, u, v.display_unit.as_deref(), loc, f);
        } else if let Some(d) = &v.display_unit {
            match md.effective_unit(v) {
                Some(u) => check_unit_ref(md, u, Some(d), loc, f),
                None => f.push(Finding::new(
                    "display-unit-declared",
                    loc,
                    format!("displayUnit '{d}' given without a unit"),
                )),
            }
        }
    }
}

/// Value references: variables of one base type that share a reference form an alias set
/// (FMI 2.0.4 section 2.2.7, restrictions on alias variables): "Variables `a` and `b` that can
/// both be set with `fmi2SetXXX`, or variable `a` that can be set with `fmiSetXXX` and variable
/// `b` that is defined with `causality = "independent"`, cannot be alias variables", and "at most
/// one variable of the same alias set of variables with `variability != "constant"` can have a
/// start attribute". An input aliased with a variable that cannot be set (a calculated local, a
/// calculated parameter) is allowed.
fn check_aliases(vrs: &HashMap<(u8, u32), Vec<&ScalarVariable>>, f: &mut Vec<Finding>) {
    let mut keys: Vec<_> = vrs.keys().copied().collect();
    keys.sort();
    for key in keys {
        let set = &vrs[&key];
        if set.len() < 2 {
            continue;
        }
        let names: Vec<&str> = set.iter().map(|v| v.name.as_str()).collect();
        let with_start = set
            .iter()
            .filter(|v| v.start.is_some() && v.variability != Variability::Constant)
            .count();
        let settable = set.iter().filter(|v| settable(v)).count();
        let independent = set.iter().any(|v| v.causality == Causality::Independent);
        let why = if settable > 1 {
            "two variables that can be set with fmi2SetXXX cannot be aliases"
        } else if settable > 0 && independent {
            "a variable that can be set cannot be an alias of the independent variable"
        } else if with_start > 1 {
            "more than one alias has a start value"
        } else {
            continue;
        };
        let m = format!(
            "valueReference {} is shared by {} ({why})",
            key.1,
            names.join(", ")
        );
        f.push(Finding::new("unique-value-references", var_loc(set[1]), m));
    }
}

/// Whether `fmi2SetXXX` may be called on `v` in some mode (FMI 2.0.4 section 2.2.7, the rules
/// after the table of `causality`): an input, or a variable with `variability != "constant"` and
/// `initial` exact or approx (its start value can be set before or during initialization;
/// a tunable parameter has initial exact).
fn settable(v: &ScalarVariable) -> bool {
    v.causality == Causality::Input
        || (v.variability != Variability::Constant
            && matches!(
                v.effective_initial(),
                Some(Initial::Exact | Initial::Approx)
            ))
}

fn effective_range(md: &ModelDescription, v: &ScalarVariable) -> (Option<f64>, Option<f64>) {
    let t = v.declared_type.as_deref().and_then(|t| md.simple_type(t));
    (
        v.min.or(t.and_then(|t| t.min)),
        v.max.or(t.and_then(|t| t.max)),
    )
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map(|x| x.to_string())
        .unwrap_or_else(|| "-inf/inf".into())
}

fn check_model_structure(md: &ModelDescription, f: &mut Vec<Finding>) {
    let ms = &md.model_structure;
    if !ms.present {
        f.push(Finding::new(
            "model-structure",
            "modelDescription.xml",
            "no <ModelStructure> element",
        ));
        return;
    }
    let lists = [
        ("Outputs", &ms.outputs),
        ("Derivatives", &ms.derivatives),
        ("InitialUnknowns", &ms.initial_unknowns),
    ];
    for (list, unknowns) in lists {
        check_unknowns(md, list, unknowns, f);
    }
    check_outputs_listed(md, f);
    for u in &ms.derivatives {
        if let Some(v) = variable(md, u.index) {
            check_listed_derivative(md, v, u, f);
        }
    }
    check_initial_unknowns(md, f);
}

/// The variable of the 1-based `index` into `<ModelVariables>`, if there is one.
fn variable(md: &ModelDescription, index: usize) -> Option<&ScalarVariable> {
    md.model_variables.get(index.wrapping_sub(1))
}

/// The `<Unknown>` elements of the list `<list>`: indices of variables, none twice; ordered by
/// index in `<InitialUnknowns>` only (FMI 2.0.4 section 2.2.8: "The `Unknowns` in this list must
/// be ordered according to their `ScalarVariable` index"; for `<Outputs>` and `<Derivatives>`
/// "the ordering of the variables in this list is defined by the exporting tool");
/// dependencies of variables, with as many kinds as dependencies.
fn check_unknowns(
    md: &ModelDescription,
    list: &str,
    unknowns: &[host::md::Unknown],
    f: &mut Vec<Finding>,
) {
    let n = md.model_variables.len();
    let var = |i: usize| variable(md, i);
    let ordered = list == "InitialUnknowns";
    let mut prev = 0;
    let mut seen = BTreeSet::new();
    for u in unknowns {
        let loc = format!(
            "modelDescription.xml:{} (<{list}> <Unknown index=\"{}\">)",
            u.line, u.index
        );
        if var(u.index).is_none() {
            f.push(Finding::new(
                "model-structure",
                &loc,
                format!("index {} is not a variable (1..{n})", u.index),
            ));
        }
        if ordered && u.index <= prev {
            f.push(Finding::new(
                "model-structure",
                &loc,
                format!(
                    "<{list}> must be ordered by index without repeats ({} after {prev})",
                    u.index
                ),
            ));
        } else if !ordered && !seen.insert(u.index) {
            f.push(Finding::new(
                "model-structure",
                &loc,
                format!("<{list}> lists index {} twice", u.index),
            ));
        }
        prev = u.index;
        if let Some(deps) = &u.dependencies {
            for &d in deps {
                if var(d).is_none() {
                    f.push(Finding::new(
                        "model-structure",
                        &loc,
                        format!("dependency {d} is not a variable (1..{n})"),
                    ));
                }
            }
            if let Some(kinds) = &u.dependencies_kind {
                if kinds.len() != deps.len() {
                    f.push(Finding::new(
                        "model-structure",
                        &loc,
                        "dependenciesKind and dependencies differ in length",
                    ));
                }
            }
        } else if u.dependencies_kind.is_some() {
            f.push(Finding::new(
                "model-structure",
                &loc,
                "dependenciesKind without dependencies",
            ));
        }
    }
}

/// `<Outputs>` lists exactly the variables with causality output.
fn check_outputs_listed(md: &ModelDescription, f: &mut Vec<Finding>) {
    let ms = &md.model_structure;
    let listed: BTreeSet<usize> = ms.outputs.iter().map(|u| u.index).collect();
    for (i, v) in md.model_variables.iter().enumerate() {
        if v.causality == Causality::Output && !listed.contains(&(i + 1)) {
            f.push(Finding::new(
                "outputs-listed",
                var_loc(v),
                format!(
                    "output '{}' (index {}) is missing from <ModelStructure><Outputs>",
                    v.name,
                    i + 1
                ),
            ));
        }
    }
    for u in &ms.outputs {
        if let Some(v) = variable(md, u.index) {
            if v.causality != Causality::Output {
                f.push(Finding::new(
                    "outputs-listed",
                    format!(
                        "modelDescription.xml:{} (<Outputs> <Unknown index=\"{}\">)",
                        u.line, u.index
                    ),
                    format!(
                        "'{}' is listed in <Outputs> but its causality is {:?}",
                        v.name, v.causality
                    )
                    .replace("Parameter", "parameter"),
                ));
            }
        }
    }
}

/// `<InitialUnknowns>` (FMI 2.0.4 section 2.2.8): outputs with initial approx/calculated,
/// calculated parameters, and "all continuous-time states and all state derivatives (defined
/// with element `<Derivatives>`)" with initial approx/calculated must be listed. A variable that
/// a `derivative` attribute names while its derivative is not in `<Derivatives>` is no state in
/// that sense (a Co-Simulation FMU may leave `<Derivatives>` out): it is not demanded, and
/// listing it is tolerated.
fn check_initial_unknowns(md: &ModelDescription, f: &mut Vec<Finding>) {
    let ms = &md.model_structure;
    let derivs: BTreeSet<usize> = ms.derivatives.iter().map(|u| u.index).collect();
    let states: BTreeSet<usize> = ms
        .derivatives
        .iter()
        .filter_map(|u| variable(md, u.index))
        .filter_map(|v| v.derivative)
        .collect();
    let approx_or_calc = |v: &ScalarVariable| approx_or_calculated(v.effective_initial());
    let mut required = BTreeSet::new();
    for (i, v) in md.model_variables.iter().enumerate() {
        let idx = i + 1;
        let needed = (v.causality == Causality::Output && approx_or_calc(v))
            || v.causality == Causality::CalculatedParameter
            || ((derivs.contains(&idx) || states.contains(&idx)) && approx_or_calc(v));
        if needed {
            required.insert(idx);
        }
    }
    let listed: BTreeSet<usize> = ms.initial_unknowns.iter().map(|u| u.index).collect();
    for idx in required.difference(&listed) {
        let v = &md.model_variables[idx - 1];
        f.push(Finding::new(
            "initial-unknowns",
            var_loc(v),
            format!(
                "'{}' (index {idx}) must be listed in <InitialUnknowns>",
                v.name
            ),
        ));
    }
    // a variable some `derivative` names, listed though not demanded, is tolerated
    let named_states: BTreeSet<usize> = md
        .model_variables
        .iter()
        .filter_map(|v| v.derivative)
        .collect();
    for u in &ms.initial_unknowns {
        let tolerated =
            named_states.contains(&u.index) && variable(md, u.index).is_some_and(&approx_or_calc);
        if variable(md, u.index).is_some() && !required.contains(&u.index) && !tolerated {
            let v = &md.model_variables[u.index - 1];
            f.push(Finding::new(
                "initial-unknowns",
                format!("modelDescription.xml:{} (<InitialUnknowns> <Unknown index=\"{}\">)", u.line, u.index),
                format!("'{}' may not be listed in <InitialUnknowns> (only outputs, calculated parameters and states/derivatives with initial approx or calculated)", v.name),
            ));
        }
    }
}

/// An element of `<Derivatives>` is a continuous Real whose `derivative` attribute names a
/// continuous Real, the state (FMI 2.0.4 section 2.2.8: the state derivatives, whose states
/// section 3.1 integrates).
fn check_listed_derivative(
    md: &ModelDescription,
    v: &ScalarVariable,
    u: &host::md::Unknown,
    f: &mut Vec<Finding>,
) {
    let loc = format!(
        "modelDescription.xml:{} (<Derivatives> <Unknown index=\"{}\">)",
        u.line, u.index
    );
    let continuous_real =
        |v: &ScalarVariable| v.kind == VarKind::Real && v.variability == Variability::Continuous;
    let Some(state) = v.derivative else {
        let m = format!(
            "'{}' is listed in <Derivatives> but is not a Real with a derivative attribute",
            v.name
        );
        f.push(Finding::new("model-structure", &loc, m));
        return;
    };
    if !continuous_real(v) {
        let m = format!(
            "'{}' is listed in <Derivatives> but is not a continuous Real",
            v.name
        );
        f.push(Finding::new("derivative", &loc, m));
    }
    if let Some(s) = md.model_variables.get(state.wrapping_sub(1)) {
        if !continuous_real(s) {
            let m = format!(
                "'{}' is the derivative of '{}' (index {state}), which is not a continuous Real state",
                v.name, s.name
            );
            f.push(Finding::new("derivative", &loc, m));
        }
    }
}

/// The candidate-effect convention (see [`effects`]) for FMUs meant for the gap
/// workflow, one finding per departure, located at its variable.
pub fn check_effect_convention(view: &host::ModelView) -> Vec<Finding> {
    view.effect_problems()
        .into_iter()
        .map(|(variable, problem)| {
            let loc = match variable {
                Some(v) => format!("modelDescription.xml:{} (variable '{}')", v.line, v.name),
                None => "modelDescription.xml:<ModelVariables>".to_string(),
            };
            Finding::new("effect-convention", &loc, problem.to_string())
        })
        .collect()
}

#[cfg(test)]
mod tests;
