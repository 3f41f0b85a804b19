//! `modelDescription.xml` generated from a model's variable table (FMI 2.0 schema,
//! `fmi2ModelDescription.xsd`), and consistency checks of the table itself.
//!
//! The GUID is derived from the content (SHA-256 of the description written with a zero GUID),
//! so the same table always gives the same file and any change gives a new GUID.

use crate::instance::LOG_CATEGORIES;
use crate::units;
use crate::{Causality, Initial, Model, VarType, Variable};
use fmi_types::schema::{combination_allowed, initial_allowed};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use sha2::{Digest, Sha256};
use std::collections::BTreeSet;

const ZERO_GUID: &str = "{00000000-0000-0000-0000-000000000000}";

/// Format a double so it reads back to the same bits, without locale or trailing noise.
pub fn fmt_f64(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Units named by the table, sorted, each with its definition.
fn used_units(vars: &[Variable]) -> Vec<&'static units::UnitDef> {
    let names: BTreeSet<&str> = vars.iter().filter_map(|v| v.unit).collect();
    names.into_iter().filter_map(units::lookup).collect()
}

/// `<UnitDefinitions>` with each unit's `<BaseUnit>` exponents and factor and its display units
/// (the same element in FMI 2.0 and FMI 3.0).
pub fn unit_definitions(ev: &mut dyn FnMut(Event), units: &[&units::UnitDef]) {
    ev(Event::Start(BytesStart::new("UnitDefinitions")));
    for u in units {
        let mut e = BytesStart::new("Unit");
        e.push_attribute(("name", u.name));
        ev(Event::Start(e));
        let mut b = BytesStart::new("BaseUnit");
        let exps = [
            ("kg", u.base.kg),
            ("m", u.base.m),
            ("s", u.base.s),
            ("A", u.base.a),
            ("K", u.base.k),
            ("mol", u.base.mol),
            ("cd", u.base.cd),
            ("rad", u.base.rad),
        ];
        for (k, x) in exps {
            if x != 0 {
                b.push_attribute((k, x.to_string().as_str()));
            }
        }
        if u.base.factor != 1.0 {
            b.push_attribute(("factor", fmt_f64(u.base.factor).as_str()));
        }
        ev(Event::Empty(b));
        for d in u.display {
            let mut e = BytesStart::new("DisplayUnit");
            e.push_attribute(("name", d.name));
            e.push_attribute(("factor", fmt_f64(d.factor).as_str()));
            if d.offset != 0.0 {
                e.push_attribute(("offset", fmt_f64(d.offset).as_str()));
            }
            ev(Event::Empty(e));
        }
        ev(Event::End(BytesEnd::new("Unit")));
    }
    ev(Event::End(BytesEnd::new("UnitDefinitions")));
}

fn write_description<M: Model>(guid: &str) -> String {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    let vars = M::variables();
    let me = M::model_exchange();
    let states: &[(usize, usize)] = me.map_or(&[], |me| me.state_variables);
    let event_indicators = me.map_or(0, |me| me.event_indicators);
    let mut ev = |e: Event| w.write_event(e).expect("writing to a Vec cannot fail");
    ev(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));

    let mut root = BytesStart::new("fmiModelDescription");
    root.push_attribute(("fmiVersion", "2.0"));
    root.push_attribute(("modelName", M::NAME));
    root.push_attribute(("guid", guid));
    root.push_attribute(("description", M::DESCRIPTION));
    root.push_attribute(("author", M::AUTHOR));
    root.push_attribute(("version", M::VERSION));
    root.push_attribute(("copyright", M::COPYRIGHT));
    root.push_attribute(("license", M::LICENSE));
    root.push_attribute(("generationTool", "actuator-fmu fmi2-export"));
    root.push_attribute(("variableNamingConvention", "structured"));
    root.push_attribute((
        "numberOfEventIndicators",
        event_indicators.to_string().as_str(),
    ));
    ev(Event::Start(root));

    // Directional derivatives in both interfaces where the model has an analytic Jacobian:
    // Co-Simulation at the communication point, over the same Model Exchange equations.
    let jacobian = if me.is_some_and(|me| me.provides_jacobian) {
        "true"
    } else {
        "false"
    };
    if me.is_some() {
        let mut e = BytesStart::new("ModelExchange");
        for (k, v) in [
            ("modelIdentifier", M::NAME),
            ("needsExecutionTool", "false"),
            ("completedIntegratorStepNotNeeded", "true"),
            ("canBeInstantiatedOnlyOncePerProcess", "false"),
            ("canNotUseMemoryManagementFunctions", "true"),
            ("canGetAndSetFMUstate", "true"),
            ("canSerializeFMUstate", "true"),
            ("providesDirectionalDerivative", jacobian),
        ] {
            e.push_attribute((k, v));
        }
        ev(Event::Empty(e));
    }

    let mut cs = BytesStart::new("CoSimulation");
    for (k, v) in [
        ("modelIdentifier", M::NAME),
        ("needsExecutionTool", "false"),
        ("canHandleVariableCommunicationStepSize", "true"),
        ("canInterpolateInputs", "false"),
        ("maxOutputDerivativeOrder", "0"),
        ("canRunAsynchronuously", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canNotUseMemoryManagementFunctions", "true"),
        ("canGetAndSetFMUstate", "true"),
        ("canSerializeFMUstate", "true"),
        ("providesDirectionalDerivative", jacobian),
    ] {
        cs.push_attribute((k, v));
    }
    ev(Event::Empty(cs));

    let units = used_units(vars);
    if !units.is_empty() {
        unit_definitions(&mut ev, &units);
    }

    log_categories(&mut ev);
    default_experiment::<M>(&mut ev);

    ev(Event::Start(BytesStart::new("ModelVariables")));
    for (i, v) in vars.iter().enumerate() {
        ev(Event::Comment(quick_xml::events::BytesText::new(&format!(
            " index {} ",
            i + 1
        ))));
        let mut sv = BytesStart::new("ScalarVariable");
        sv.push_attribute(("name", v.name));
        sv.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
        if !v.description.is_empty() {
            sv.push_attribute(("description", v.description));
        }
        sv.push_attribute(("causality", v.causality.as_str()));
        sv.push_attribute(("variability", v.variability.as_str()));
        if let Some(i) = v.initial {
            sv.push_attribute(("initial", i.as_str()));
        }
        ev(Event::Start(sv));
        let mut t = BytesStart::new(v.vtype.as_str());
        if v.vtype == VarType::Real {
            if let Some(u) = v.unit {
                t.push_attribute(("unit", u));
            }
            if let Some(d) = v.display_unit {
                t.push_attribute(("displayUnit", d));
            }
            if let Some(&(x, _)) = states.iter().find(|(_, d)| *d == i) {
                t.push_attribute(("derivative", (x + 1).to_string().as_str()));
            }
        }
        if v.vtype != VarType::Boolean {
            if let Some(m) = v.min {
                t.push_attribute(("min", fmt_f64(m).as_str()));
            }
            if let Some(m) = v.max {
                t.push_attribute(("max", fmt_f64(m).as_str()));
            }
        }
        if let (VarType::Real, Some(n)) = (v.vtype, v.nominal) {
            t.push_attribute(("nominal", fmt_f64(n).as_str()));
        }
        if v.has_start() {
            let s = match v.vtype {
                VarType::Boolean => (if v.start != 0.0 { "true" } else { "false" }).to_string(),
                VarType::Integer => (v.start as i64).to_string(),
                _ => fmt_f64(v.start),
            };
            t.push_attribute(("start", s.as_str()));
        }
        ev(Event::Empty(t));
        ev(Event::End(BytesEnd::new("ScalarVariable")));
    }
    ev(Event::End(BytesEnd::new("ModelVariables")));

    ev(Event::Start(BytesStart::new("ModelStructure")));
    let outputs: Vec<usize> = (0..vars.len())
        .filter(|&i| vars[i].causality == Causality::Output)
        .collect();
    let derivatives: Vec<usize> = states.iter().map(|&(_, d)| d).collect();
    // FMI 2.0.4 section 2.2.8: outputs and continuous-time states and state derivatives with
    // initial approx or calculated, and calculated parameters, ordered by index.
    let is_state = |i: usize| states.iter().any(|&(x, d)| x == i || d == i);
    let initial_unknowns: Vec<usize> = (0..vars.len())
        .filter(|&i| {
            let v = &vars[i];
            let calculated = matches!(v.initial, Some(Initial::Calculated) | Some(Initial::Approx));
            ((v.causality == Causality::Output || is_state(i)) && calculated)
                || v.causality == Causality::CalculatedParameter
        })
        .collect();
    // Outputs depend on the continuous states (Model Exchange) and on the inputs the model
    // names as direct feedthrough (Model Exchange only: in Co-Simulation an input changes no
    // output before the next step); without Model Exchange on nothing.
    let feedthrough = me.map_or(&[][..], |me| me.output_feedthrough);
    let output_dependencies = |output: usize| -> String {
        let mut deps: Vec<usize> = states.iter().map(|&(x, _)| x).collect();
        for (_, inputs) in feedthrough.iter().filter(|(o, _)| *o == output) {
            deps.extend(inputs.iter().copied());
        }
        deps.sort_unstable();
        deps.dedup();
        let deps: Vec<String> = deps.iter().map(|i| (i + 1).to_string()).collect();
        deps.join(" ")
    };
    let declared = me.and_then(|me| me.derivative_dependencies);
    let derivative_dependencies = |d: usize| -> Option<String> {
        let k = states.iter().position(|&(_, der)| der == d)?;
        let mut deps: Vec<usize> = declared?.get(k)?.to_vec();
        deps.sort_unstable();
        deps.dedup();
        let deps: Vec<String> = deps.iter().map(|i| (i + 1).to_string()).collect();
        Some(deps.join(" "))
    };
    for (tag, list) in [
        ("Outputs", &outputs),
        ("Derivatives", &derivatives),
        ("InitialUnknowns", &initial_unknowns),
    ] {
        if list.is_empty() {
            continue;
        }
        ev(Event::Start(BytesStart::new(tag)));
        for &i in list {
            let mut u = BytesStart::new("Unknown");
            u.push_attribute(("index", (i + 1).to_string().as_str()));
            // Derivatives list the model's dependencies when it declares them; initial unknowns
            // keep the default (every known), which is always correct.
            if tag == "Outputs" {
                u.push_attribute(("dependencies", output_dependencies(i).as_str()));
            }
            if tag == "Derivatives" {
                if let Some(deps) = derivative_dependencies(i) {
                    u.push_attribute(("dependencies", deps.as_str()));
                }
            }
            ev(Event::Empty(u));
        }
        ev(Event::End(BytesEnd::new(tag)));
    }
    ev(Event::End(BytesEnd::new("ModelStructure")));
    ev(Event::End(BytesEnd::new("fmiModelDescription")));
    let mut s = String::from_utf8(w.into_inner()).expect("the writer writes UTF-8");
    s.push('\n');
    s
}

/// `<LogCategories>` (the same element in FMI 2.0 and FMI 3.0).
pub(crate) fn log_categories(ev: &mut dyn FnMut(Event)) {
    ev(Event::Start(BytesStart::new("LogCategories")));
    for (name, description) in LOG_CATEGORIES {
        let mut e = BytesStart::new("Category");
        e.push_attribute(("name", name));
        e.push_attribute(("description", description));
        ev(Event::Empty(e));
    }
    ev(Event::End(BytesEnd::new("LogCategories")));
}

/// `<DefaultExperiment>` (the same element in FMI 2.0 and FMI 3.0).
pub(crate) fn default_experiment<M: Model>(ev: &mut dyn FnMut(Event)) {
    let mut de = BytesStart::new("DefaultExperiment");
    de.push_attribute(("startTime", "0"));
    de.push_attribute(("stopTime", fmt_f64(M::DEFAULT_STOP_TIME).as_str()));
    de.push_attribute(("tolerance", fmt_f64(M::DEFAULT_TOLERANCE).as_str()));
    de.push_attribute(("stepSize", fmt_f64(M::DEFAULT_STEP_SIZE).as_str()));
    ev(Event::Empty(de));
}

/// The content-derived GUID: SHA-256 of the description written with a zero GUID, as a UUID.
pub fn guid<M: Model>() -> String {
    let digest = Sha256::digest(write_description::<M>(ZERO_GUID).as_bytes());
    let h: String = digest[..16].iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &h[0..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..32]
    )
}

/// Departures from the candidate-effect convention (see [`effects`]), one sentence
/// each naming the variable.
fn effect_convention(vars: &[Variable]) -> Vec<String> {
    let params: Vec<&Variable> = vars
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
        .collect();
    let scanned: Vec<effects::Param> = params
        .iter()
        .map(|v| effects::Param {
            name: v.name,
            kind: v.vtype,
            variability: v.variability,
            start: v.has_start().then_some(v.start),
            min: v.min,
            max: v.max,
            has_unit: v.unit.is_some(),
            description: v.description,
        })
        .collect();
    let convention = effects::scan(&scanned);
    let has_effects = !convention.effects.is_empty();
    convention
        .problems
        .into_iter()
        .filter_map(|(i, p)| match i {
            Some(i) => Some(format!("'{}': {p}", params[i].name)),
            // A model without candidate effects needs no default calibration set.
            None => has_effects.then(|| format!("model: {p}")),
        })
        .collect()
}

/// The complete `modelDescription.xml`.
pub fn model_description<M: Model>() -> String {
    write_description::<M>(&guid::<M>())
}

/// Problems in a variable table, one sentence each (empty when consistent): names, units,
/// ranges, FMI 2.0 causality/variability/initial combinations, and the effect convention.
pub fn check_table(vars: &[Variable]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut names = BTreeSet::new();
    for v in vars {
        let n = v.name;
        if n.is_empty() || !names.insert(n) {
            problems.push(format!("'{n}': empty or duplicate name"));
        }
        if v.description.is_empty() {
            problems.push(format!("'{n}': no description"));
        }
        if !matches!(v.vtype, VarType::Real | VarType::Integer | VarType::Boolean) {
            problems.push(format!(
                "'{n}': the exporter supports Real, Integer and Boolean only"
            ));
        }
        if v.vtype == VarType::Real {
            match v.unit.map(|u| (u, units::lookup(u))) {
                None if v.unit_not_expressible => {}
                None => problems.push(format!("'{n}': Real variable without a unit")),
                Some((u, None)) => problems.push(format!("'{n}': unit '{u}' not in units::KNOWN")),
                Some((u, Some(def))) => {
                    if let Some(d) = v.display_unit {
                        if !def.display.iter().any(|x| x.name == d) {
                            problems
                                .push(format!("'{n}': display unit '{d}' not defined for '{u}'"));
                        }
                    }
                }
            }
        }
        if let (Some(lo), Some(hi)) = (v.min, v.max) {
            if lo.is_nan() || hi.is_nan() || lo > hi {
                problems.push(format!("'{n}': min {lo} > max {hi}"));
            }
        }
        if v.has_start() {
            if !v.start.is_finite() {
                problems.push(format!("'{n}': start is not finite"));
            }
            if v.min.is_some_and(|m| v.start < m) || v.max.is_some_and(|m| v.start > m) {
                problems.push(format!("'{n}': start {} outside [min, max]", v.start));
            }
        }
        let ok_combination = combination_allowed(v.causality, v.variability)
            && initial_allowed(v.causality, v.variability).contains(&v.initial);
        if !ok_combination {
            problems.push(format!(
                "'{n}': causality {:?} with variability {:?} and initial {:?} is not allowed by FMI 2.0",
                v.causality, v.variability, v.initial
            ));
        }
        if let Some(effect) = v.effect() {
            let flag = format!("{effect}.enabled");
            if !vars.iter().any(|f| f.name == flag) {
                problems.push(format!(
                    "'{n}': dotted names are for effects; '{flag}' is missing"
                ));
            }
        }
    }
    problems.extend(effect_convention(vars));
    problems
}
