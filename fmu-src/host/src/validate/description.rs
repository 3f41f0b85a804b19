//! Checks of `modelDescription.xml` (FMI 2.0.4 chapter 2.2) and of the candidate-effect
//! convention of the gap workflow.

use super::{var_loc, Finding};
use crate::md::{
    Causality, Initial, ModelDescription, ScalarVariable, StartValue, VarKind, Variability,
};
use std::collections::{BTreeSet, HashMap};

fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

pub use fmi_types::schema::{combination_allowed, initial_allowed};

/// Checks of `modelDescription.xml` for a Co-Simulation FMU.
pub fn check_model_description(md: &ModelDescription) -> Vec<Finding> {
    let mut f = Vec::new();
    let root = "modelDescription.xml:<fmiModelDescription>";
    if md.fmi_version != "2.0" {
        f.push(Finding::new(
            "fmi-version",
            root,
            format!("fmiVersion is \"{}\", expected \"2.0\"", md.fmi_version),
        ));
    }
    if md.model_name.trim().is_empty() {
        f.push(Finding::new(
            "model-name",
            root,
            "modelName is missing or empty",
        ));
    }
    if md.guid.trim().is_empty() {
        f.push(Finding::new("guid", root, "guid is missing or empty"));
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
    if let Some(id) = md
        .model_exchange
        .as_deref()
        .filter(|id| !is_c_identifier(id))
    {
        let mut finding = Finding::new(
            "model-identifier",
            "modelDescription.xml:<ModelExchange>",
            format!("modelIdentifier \"{id}\" is not a valid C identifier"),
        );
        finding.clause = "FMI 2.0.4 §3.3.1: ModelExchange element".into();
        f.push(finding);
    }
    match &md.co_simulation {
        None if md.model_exchange.is_some() => {}
        None => f.push(Finding::new(
            "co-simulation",
            root,
            "no <CoSimulation> or <ModelExchange> element: neither a Co-Simulation nor a Model \
             Exchange FMU",
        )),
        Some(cs) => {
            if !is_c_identifier(&cs.model_identifier) {
                f.push(Finding::new(
                    "model-identifier",
                    "modelDescription.xml:<CoSimulation>",
                    format!(
                        "modelIdentifier \"{}\" is not a valid C identifier",
                        cs.model_identifier
                    ),
                ));
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
    check_units(md, &mut f);
    check_variables(md, &mut f);
    check_model_structure(md, &mut f);
    f
}

fn check_units(md: &ModelDescription, f: &mut Vec<Finding>) {
    let mut seen = HashMap::new();
    for u in &md.unit_definitions {
        let loc = format!("modelDescription.xml:{} (unit '{}')", u.line, u.name);
        if let Some(first) = seen.insert(u.name.as_str(), u.line) {
            f.push(Finding::new(
                "unique-units",
                &loc,
                format!("unit '{}' is already defined on line {first}", u.name),
            ));
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
        if let Some(first) = types.insert(t.name.as_str(), t.line) {
            f.push(Finding::new(
                "unique-types",
                format!("modelDescription.xml:{} (type '{}')", t.line, t.name),
                format!("type '{}' is already defined on line {first}", t.name),
            ));
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
        if v.name.trim().is_empty() {
            f.push(Finding::new("variable-name", &loc, "empty variable name"));
        }
        if let Some(first) = names.insert(v.name.as_str(), v.line) {
            f.push(Finding::new(
                "unique-names",
                &loc,
                format!("name '{}' is already used on line {first}", v.name),
            ));
        }
        let base = match v.kind {
            VarKind::Real => 0,
            VarKind::Integer | VarKind::Enumeration => 1,
            VarKind::Boolean => 2,
            VarKind::String => 3,
        };
        vrs.entry((base, v.value_reference)).or_default().push(v);

        if !combination_allowed(v.causality, v.variability) {
            f.push(Finding::new(
                "causality-variability",
                &loc,
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
                &loc,
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
                &loc,
                format!(
                    "a {:?} variable cannot be continuous{}",
                    v.kind,
                    if v.variability_given { "" } else { " (variability defaults to continuous: declare it discrete, fixed, tunable or constant)" }
                ),
            ));
        }
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
        // start required / forbidden (FMI 2.0.4 section 2.2.7, attribute start)
        let initial = v.effective_initial();
        let required = v.causality == Causality::Input
            || v.variability == Variability::Constant
            || matches!(initial, Some(Initial::Exact | Initial::Approx));
        let forbidden =
            v.causality == Causality::Independent || initial == Some(Initial::Calculated);
        if required && v.start.is_none() {
            f.push(Finding::new(
                "start",
                &loc,
                format!(
                    "start is required (causality {:?}, initial {:?})",
                    v.causality, initial
                )
                .to_lowercase(),
            ));
        }
        if forbidden && v.start.is_some() {
            f.push(Finding::new(
                "start",
                &loc,
                format!(
                    "start is not allowed (causality {:?}, initial {:?})",
                    v.causality, initial
                )
                .to_lowercase(),
            ));
        }
        // ranges
        let (min, max) = effective_range(md, v);
        if let (Some(a), Some(b)) = (min, max) {
            if a > b {
                f.push(Finding::new("min-max", &loc, format!("min {a} > max {b}")));
            }
        }
        if let Some(s) = v.start.as_ref().and_then(StartValue::as_f64) {
            if v.kind != VarKind::Boolean {
                if matches!(min, Some(a) if s < a) || matches!(max, Some(b) if s > b) {
                    f.push(Finding::new(
                        "start-range",
                        &loc,
                        format!("start {s} is outside [{}, {}]", fmt_opt(min), fmt_opt(max)),
                    ));
                }
                if !s.is_finite() {
                    f.push(Finding::new(
                        "start-range",
                        &loc,
                        format!("start {s} is not finite"),
                    ));
                }
            }
        }
        if matches!(v.nominal, Some(n) if !(n > 0.0 && n.is_finite())) {
            f.push(Finding::new(
                "nominal",
                &loc,
                format!("nominal {} must be > 0", v.nominal.unwrap()),
            ));
        }
        if let Some(t) = &v.declared_type {
            match md.simple_type(t) {
                None => f.push(Finding::new(
                    "declared-type",
                    &loc,
                    format!("declaredType '{t}' is not defined in <TypeDefinitions>"),
                )),
                Some(st) => {
                    if let Some(kind) = st.kind.filter(|k| *k != v.kind) {
                        f.push(Finding::new(
                            "declared-type",
                            &loc,
                            format!(
                                "declaredType '{t}' is {kind:?}, the variable is {:?}",
                                v.kind
                            ),
                        ));
                    }
                }
            }
        }
        if v.kind == VarKind::Real {
            if let Some(u) = &v.unit {
                check_unit_ref(md, u, v.display_unit.as_deref(), &loc, f);
            } else if let Some(d) = &v.display_unit {
                match md.effective_unit(v) {
                    Some(u) => check_unit_ref(md, u, Some(d), &loc, f),
                    None => f.push(Finding::new(
                        "display-unit-declared",
                        &loc,
                        format!("displayUnit '{d}' given without a unit"),
                    )),
                }
            }
        }
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
    // Value references: variables of one base type that share a reference form an alias set;
    // at most one non-constant member may have a start value, and inputs/parameters may not be aliased.
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
        let settable = set
            .iter()
            .filter(|v| matches!(v.causality, Causality::Input | Causality::Parameter))
            .count();
        if with_start > 1 || settable > 0 {
            f.push(Finding::new(
                "unique-value-references",
                var_loc(set[1]),
                format!(
                    "valueReference {} is shared by {} ({})",
                    key.1,
                    names.join(", "),
                    if settable > 0 {
                        "an input or parameter cannot be an alias"
                    } else {
                        "more than one alias has a start value"
                    }
                ),
            ));
        }
    }
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
    let n = md.model_variables.len();
    if !ms.present {
        f.push(Finding::new(
            "model-structure",
            "modelDescription.xml",
            "no <ModelStructure> element",
        ));
        return;
    }
    let var = |i: usize| {
        if i >= 1 && i <= n {
            Some(&md.model_variables[i - 1])
        } else {
            None
        }
    };
    let lists = [
        ("Outputs", &ms.outputs),
        ("Derivatives", &ms.derivatives),
        ("InitialUnknowns", &ms.initial_unknowns),
    ];
    for (list, unknowns) in lists {
        let mut prev = 0;
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
            if u.index <= prev {
                f.push(Finding::new(
                    "model-structure",
                    &loc,
                    format!(
                        "<{list}> must be ordered by index without repeats ({} after {prev})",
                        u.index
                    ),
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
    // Outputs: exactly the variables with causality output.
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
        if let Some(v) = var(u.index) {
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
    for u in &ms.derivatives {
        if let Some(v) = var(u.index) {
            check_listed_derivative(md, v, u, f);
        }
    }
    // InitialUnknowns (FMI 2.0.4 section 2.2.8): outputs with initial approx/calculated,
    // calculated parameters, and derivatives/states with initial approx/calculated; no others.
    let derivs: BTreeSet<usize> = ms.derivatives.iter().map(|u| u.index).collect();
    let states: BTreeSet<usize> = md
        .model_variables
        .iter()
        .filter_map(|v| v.derivative)
        .collect();
    let approx_or_calc = |v: &ScalarVariable| {
        matches!(
            v.effective_initial(),
            Some(Initial::Approx | Initial::Calculated)
        )
    };
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
    for u in &ms.initial_unknowns {
        if var(u.index).is_some() && !required.contains(&u.index) {
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
    u: &crate::md::Unknown,
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
pub fn check_effect_convention(md: &ModelDescription) -> Vec<Finding> {
    let vars: Vec<&ScalarVariable> = md
        .model_variables
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
        .collect();
    let params: Vec<effects::Param> = vars
        .iter()
        .map(|v| {
            let (min, max) = effective_range(md, v);
            effects::Param {
                name: &v.name,
                kind: v.kind,
                variability: v.variability,
                start: v.start.as_ref().and_then(StartValue::as_f64),
                min,
                max,
                has_unit: md.effective_unit(v).is_some(),
                description: v.description.as_deref().unwrap_or(""),
            }
        })
        .collect();
    effects::scan(&params)
        .problems
        .into_iter()
        .map(|(i, problem)| {
            let loc = match i {
                Some(i) => var_loc(vars[i]),
                None => "modelDescription.xml:<ModelVariables>".to_string(),
            };
            Finding::new("effect-convention", &loc, problem.to_string())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{check_effect_convention, check_model_description, combination_allowed};
    use crate::md::{Causality, ModelDescription, Variability};
    use crate::validate::Finding;

    fn md_with_vars(vars: &str, structure: &str) -> ModelDescription {
        let xml = format!(
            r#"<fmiModelDescription fmiVersion="2.0" modelName="T" guid="{{g}}">
<CoSimulation modelIdentifier="T"/>
<UnitDefinitions><Unit name="m"><DisplayUnit name="mm" factor="1000"/></Unit></UnitDefinitions>
<ModelVariables>
{vars}
</ModelVariables>
<ModelStructure>{structure}</ModelStructure>
</fmiModelDescription>"#
        );
        ModelDescription::parse(&xml, "md.xml").unwrap()
    }

    const GOOD_VARS: &str = r#"<ScalarVariable name="y" valueReference="0" causality="output"><Real unit="m" displayUnit="mm"/></ScalarVariable>
<ScalarVariable name="p" valueReference="1" causality="parameter" variability="fixed"><Real start="1" min="0" max="2"/></ScalarVariable>
<ScalarVariable name="u" valueReference="2" causality="input"><Real start="0"/></ScalarVariable>"#;
    const GOOD_STRUCT: &str = r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#;

    fn checks(md: &ModelDescription) -> Vec<String> {
        check_model_description(md)
            .iter()
            .map(|f| f.check.clone())
            .collect()
    }

    fn only(md: &ModelDescription, check: &str) -> Finding {
        let all = check_model_description(md);
        assert_eq!(all.len(), 1, "expected exactly one finding, got {all:#?}");
        assert_eq!(all[0].check, check, "{all:#?}");
        all[0].clone()
    }

    #[test]
    fn a_correct_description_has_no_findings() {
        assert_eq!(
            checks(&md_with_vars(GOOD_VARS, GOOD_STRUCT)),
            Vec::<String>::new()
        );
    }

    #[test]
    fn the_fixture_description_has_no_findings() {
        let xml = include_str!("../../tests/fixtures/modelDescription.xml");
        let md = ModelDescription::parse(xml, "md.xml").unwrap();
        assert_eq!(check_model_description(&md), vec![]);
    }

    #[test]
    fn root_attributes() {
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.guid.clear();
        assert_eq!(only(&md, "guid").message, "guid is missing or empty");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.fmi_version = "3.0".into();
        only(&md, "fmi-version");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.model_name = " ".into();
        only(&md, "model-name");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.co_simulation = None;
        only(&md, "co-simulation");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.co_simulation.as_mut().unwrap().model_identifier = "9 bad".into();
        assert!(only(&md, "model-identifier").clause.contains("§4.3.1"));
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.model_exchange = Some("9 bad".into());
        assert!(only(&md, "model-identifier").clause.contains("§3.3.1"));
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.co_simulation.as_mut().unwrap().can_serialize_fmu_state = true;
        only(&md, "capability-flags");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.variable_naming_convention = Some("dotted".into());
        only(&md, "naming-convention");
        let mut md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        md.default_experiment = Some(crate::md::DefaultExperiment {
            start_time: Some(1.0),
            stop_time: Some(0.0),
            ..Default::default()
        });
        only(&md, "default-experiment");
    }

    #[test]
    fn duplicate_names_and_value_references() {
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"p\" valueReference=\"9\" causality=\"local\"><Real/></ScalarVariable>");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "unique-names");
        assert!(f.message.contains("already used on line"), "{f}");
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"q\" valueReference=\"1\" causality=\"parameter\" variability=\"fixed\"><Real start=\"3\"/></ScalarVariable>");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "unique-value-references");
        assert!(
            f.message.contains("valueReference 1 is shared by p, q"),
            "{f}"
        );
        // A Real and a Boolean may share a number (value references are per base type),
        // and a local may alias an output.
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"b\" valueReference=\"1\" causality=\"local\" variability=\"discrete\"><Boolean/></ScalarVariable>\n<ScalarVariable name=\"y_alias\" valueReference=\"0\"><Real/></ScalarVariable>");
        assert_eq!(
            checks(&md_with_vars(&vars, GOOD_STRUCT)),
            Vec::<String>::new()
        );
    }

    #[test]
    fn causality_variability_combinations() {
        for (c, v) in [
            ("parameter", "continuous"),
            ("input", "fixed"),
            ("output", "tunable"),
            ("independent", "discrete"),
            ("calculatedParameter", "constant"),
        ] {
            let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"{c}\" variability=\"{v}\"><Real start=\"0\"/></ScalarVariable>");
            let all = check_model_description(&md_with_vars(&vars, GOOD_STRUCT));
            assert!(
                all.iter().any(|f| f.check == "causality-variability"),
                "{c}/{v}: {all:#?}"
            );
        }
        assert!(combination_allowed(
            Causality::Output,
            Variability::Constant
        ));
        assert!(!combination_allowed(
            Causality::Input,
            Variability::Constant
        ));
    }

    #[test]
    fn initial_not_allowed() {
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"parameter\" variability=\"fixed\" initial=\"calculated\"><Real/></ScalarVariable>");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "initial");
        assert!(f.message.contains("initial=\"calculated\""), "{f}");
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"z\" valueReference=\"9\" causality=\"input\" initial=\"exact\"><Real start=\"1\"/></ScalarVariable>");
        only(&md_with_vars(&vars, GOOD_STRUCT), "initial");
    }

    #[test]
    fn start_required_and_forbidden() {
        let vars = GOOD_VARS.replace("<Real start=\"0\"/>", "<Real/>");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "start");
        assert!(f.message.contains("required"), "{f}");
        assert!(f.location.contains("variable 'u'"), "{f}");
        let vars = GOOD_VARS.replace(
            "<Real unit=\"m\" displayUnit=\"mm\"/>",
            "<Real unit=\"m\" start=\"2\"/>",
        );
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "start");
        assert!(f.message.contains("not allowed"), "{f}");
    }

    #[test]
    fn continuous_non_real_and_independent() {
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"b\" valueReference=\"9\" causality=\"local\"><Boolean/></ScalarVariable>");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "variability-type");
        assert!(
            f.message.contains("variability defaults to continuous"),
            "{f}"
        );
        let vars = format!("{GOOD_VARS}\n<ScalarVariable name=\"t\" valueReference=\"9\" causality=\"independent\"><Real/></ScalarVariable>\n<ScalarVariable name=\"t2\" valueReference=\"10\" causality=\"independent\"><Real/></ScalarVariable>");
        only(&md_with_vars(&vars, GOOD_STRUCT), "independent");
    }

    #[test]
    fn ranges() {
        let vars = GOOD_VARS.replace(
            "start=\"1\" min=\"0\" max=\"2\"",
            "start=\"3\" min=\"0\" max=\"2\"",
        );
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "start-range");
        assert_eq!(f.message, "start 3 is outside [0, 2]");
        let vars = GOOD_VARS.replace(
            "start=\"1\" min=\"0\" max=\"2\"",
            "start=\"1\" min=\"2\" max=\"0\"",
        );
        assert!(checks(&md_with_vars(&vars, GOOD_STRUCT)).contains(&"min-max".to_string()));
        let vars = GOOD_VARS.replace(
            "start=\"1\" min=\"0\" max=\"2\"",
            "start=\"1\" nominal=\"0\"",
        );
        only(&md_with_vars(&vars, GOOD_STRUCT), "nominal");
    }

    #[test]
    fn units_and_display_units_must_be_declared() {
        let vars = GOOD_VARS.replace("unit=\"m\" displayUnit=\"mm\"", "unit=\"rad\"");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "unit-declared");
        assert!(f.message.contains("unit 'rad' is not defined"), "{f}");
        let vars = GOOD_VARS.replace("displayUnit=\"mm\"", "displayUnit=\"km\"");
        let f = only(&md_with_vars(&vars, GOOD_STRUCT), "display-unit-declared");
        assert!(
            f.message
                .contains("'km' is not a <DisplayUnit> of unit 'm'"),
            "{f}"
        );
        let vars = GOOD_VARS.replace(
            "<Real start=\"0\"/>",
            "<Real start=\"0\" declaredType=\"Angle\"/>",
        );
        only(&md_with_vars(&vars, GOOD_STRUCT), "declared-type");
    }

    #[test]
    fn outputs_must_match_model_structure() {
        let f = only(
            &md_with_vars(
                GOOD_VARS,
                r#"<Outputs></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
            ),
            "outputs-listed",
        );
        assert!(f.message.contains("output 'y' (index 1) is missing"), "{f}");
        let all = check_model_description(&md_with_vars(
            GOOD_VARS,
            r#"<Outputs><Unknown index="1"/><Unknown index="2"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
        ));
        assert!(
            all.iter()
                .any(|f| f.check == "outputs-listed"
                    && f.message.contains("'p' is listed in <Outputs>")),
            "{all:#?}"
        );
        let f = only(
            &md_with_vars(
                GOOD_VARS,
                r#"<Outputs><Unknown index="1" dependencies="7"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
            ),
            "model-structure",
        );
        assert!(f.message.contains("dependency 7"), "{f}");
        let all = check_model_description(&md_with_vars(
            GOOD_VARS,
            r#"<Outputs><Unknown index="1"/><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/></InitialUnknowns>"#,
        ));
        assert!(
            all.iter().any(|f| f.message.contains("ordered")),
            "{all:#?}"
        );
        let md = md_with_vars(GOOD_VARS, GOOD_STRUCT);
        let mut md2 = md.clone();
        md2.model_structure.present = false;
        only(&md2, "model-structure");
    }

    #[test]
    fn effect_convention() {
        let md = ModelDescription::parse(
            include_str!("../../tests/fixtures/modelDescription.xml"),
            "md.xml",
        )
        .unwrap();
        assert_eq!(check_effect_convention(&md), vec![]);
        let bad = |from: &str, to: &str| {
            let xml = include_str!("../../tests/fixtures/modelDescription.xml").replace(from, to);
            assert_ne!(
                xml,
                include_str!("../../tests/fixtures/modelDescription.xml")
            );
            check_effect_convention(&ModelDescription::parse(&xml, "md.xml").unwrap())
        };
        let f = bad(
            r#"<Real start="0.5" min="0.01" max="5" unit="N.s/m"/>"#,
            r#"<Real start="0.5" min="0.01" unit="N.s/m"/>"#,
        );
        assert_eq!(f.len(), 1);
        assert!(f[0].message.contains("finite min < max"), "{f:?}");
        let f = bad(
            r#"<Real start="0.5" min="0.01" max="5" unit="N.s/m"/>"#,
            r#"<Real start="0.5" min="0.01" max="5"/>"#,
        );
        assert_eq!(f[0].message, "an effect parameter needs a unit");
        let f = bad(r#"<Boolean start="false"/>"#, r#"<Boolean start="true"/>"#);
        assert_eq!(
            f[0].message,
            "an effect switch must start false (effect off)"
        );
        let f = bad("[calibrate] spring stiffness", "spring stiffness");
        assert!(f[0].message.contains("[calibrate]"));
        let f = bad(r#"name="damping.d""#, r#"name="dampingd""#);
        assert!(
            f[0].message.contains("no parameter 'damping.<name>'"),
            "{f:?}"
        );
    }

    #[test]
    fn initial_unknowns_required_and_allowed() {
        let f = only(
            &md_with_vars(GOOD_VARS, r#"<Outputs><Unknown index="1"/></Outputs>"#),
            "initial-unknowns",
        );
        assert!(f.message.contains("'y' (index 1) must be listed"), "{f}");
        let f = only(
            &md_with_vars(
                GOOD_VARS,
                r#"<Outputs><Unknown index="1"/></Outputs><InitialUnknowns><Unknown index="1"/><Unknown index="3"/></InitialUnknowns>"#,
            ),
            "initial-unknowns",
        );
        assert!(f.message.contains("'u' may not be listed"), "{f}");
    }
}
