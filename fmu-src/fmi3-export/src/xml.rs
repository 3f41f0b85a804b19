//! The FMI 3.0 `modelDescription.xml` (schema `fmi3ModelDescription.xsd`, FMI 3.0.2 chapter 2)
//! from the same variable table as the FMI 2.0 one: Real variables become `Float64`, Integer
//! `Int32`, Boolean `Boolean`; `time` is added as the independent variable; the
//! `instantiationToken` is the FMI 2.0 description's GUID (the same model, the same FMU states).

use crate::TIME_VALUE_REFERENCE;
use fmi2_export::instance::LOG_CATEGORIES;
use fmi2_export::units;
use fmi2_export::xml::{fmt_f64, guid};
use fmi2_export::{Causality, Initial, Model, VarType, Variable};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use std::collections::BTreeSet;

/// Units named by the table plus `s` (the unit of `time`), sorted, each with its definition.
fn used_units(vars: &[Variable]) -> Vec<&'static units::UnitDef> {
    let mut names: BTreeSet<&str> = vars.iter().filter_map(|v| v.unit).collect();
    names.insert("s");
    names.into_iter().filter_map(units::lookup).collect()
}

/// The FMI 3.0 element name of a variable's type.
fn element(t: VarType) -> &'static str {
    match t {
        VarType::Integer => "Int32",
        VarType::Boolean => "Boolean",
        _ => "Float64",
    }
}

type Ev<'a> = dyn FnMut(Event) + 'a;

fn co_simulation<M: Model>(ev: &mut Ev) {
    let mut cs = BytesStart::new("CoSimulation");
    for (k, v) in [
        ("modelIdentifier", M::NAME),
        ("needsExecutionTool", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canGetAndSetFMUState", "true"),
        ("canSerializeFMUState", "true"),
        ("providesDirectionalDerivatives", "false"),
        ("providesAdjointDerivatives", "false"),
        ("providesPerElementDependencies", "false"),
        ("canHandleVariableCommunicationStepSize", "true"),
        ("maxOutputDerivativeOrder", "0"),
        ("providesIntermediateUpdate", "false"),
        ("mightReturnEarlyFromDoStep", "false"),
        ("canReturnEarlyAfterIntermediateUpdate", "false"),
        ("hasEventMode", "false"),
    ] {
        cs.push_attribute((k, v));
    }
    ev(Event::Empty(cs));
}

fn unit_definitions(ev: &mut Ev, vars: &[Variable]) {
    ev(Event::Start(BytesStart::new("UnitDefinitions")));
    for u in used_units(vars) {
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

fn log_categories(ev: &mut Ev) {
    ev(Event::Start(BytesStart::new("LogCategories")));
    for (name, description) in LOG_CATEGORIES {
        let mut e = BytesStart::new("Category");
        e.push_attribute(("name", name));
        e.push_attribute(("description", description));
        ev(Event::Empty(e));
    }
    ev(Event::End(BytesEnd::new("LogCategories")));
}

fn default_experiment<M: Model>(ev: &mut Ev) {
    let mut de = BytesStart::new("DefaultExperiment");
    de.push_attribute(("startTime", "0"));
    de.push_attribute(("stopTime", fmt_f64(M::DEFAULT_STOP_TIME).as_str()));
    de.push_attribute(("tolerance", fmt_f64(M::DEFAULT_TOLERANCE).as_str()));
    de.push_attribute(("stepSize", fmt_f64(M::DEFAULT_STEP_SIZE).as_str()));
    ev(Event::Empty(de));
}

/// One variable element: `<Float64 name=... valueReference=... .../>`.
fn variable(ev: &mut Ev, v: &Variable) {
    let mut e = BytesStart::new(element(v.vtype));
    e.push_attribute(("name", v.name));
    e.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
    if !v.description.is_empty() {
        e.push_attribute(("description", v.description));
    }
    e.push_attribute(("causality", v.causality.as_str()));
    e.push_attribute(("variability", v.variability.as_str()));
    if let Some(i) = v.initial {
        e.push_attribute(("initial", i.as_str()));
    }
    if v.vtype == VarType::Real {
        if let Some(u) = v.unit {
            e.push_attribute(("unit", u));
        }
        if let Some(d) = v.display_unit {
            e.push_attribute(("displayUnit", d));
        }
    }
    if v.vtype != VarType::Boolean {
        if let Some(m) = v.min {
            e.push_attribute(("min", fmt_f64(m).as_str()));
        }
        if let Some(m) = v.max {
            e.push_attribute(("max", fmt_f64(m).as_str()));
        }
    }
    if v.has_start() {
        let s = match v.vtype {
            VarType::Boolean => (if v.start != 0.0 { "true" } else { "false" }).to_string(),
            VarType::Integer => (v.start as i64).to_string(),
            _ => fmt_f64(v.start),
        };
        e.push_attribute(("start", s.as_str()));
    }
    ev(Event::Empty(e));
}

fn model_variables(ev: &mut Ev, vars: &[Variable]) {
    ev(Event::Start(BytesStart::new("ModelVariables")));
    let mut time = BytesStart::new("Float64");
    time.push_attribute(("name", "time"));
    time.push_attribute(("valueReference", TIME_VALUE_REFERENCE.to_string().as_str()));
    time.push_attribute(("description", "Simulation time"));
    time.push_attribute(("causality", "independent"));
    time.push_attribute(("variability", "continuous"));
    time.push_attribute(("unit", "s"));
    ev(Event::Empty(time));
    for v in vars {
        variable(ev, v);
    }
    ev(Event::End(BytesEnd::new("ModelVariables")));
}

/// `<Output>` for every output (no direct feedthrough: outputs change in `fmi3DoStep` only, so
/// each depends on no input between steps), `<InitialUnknown>` for every calculated output and
/// calculated parameter (dependencies omitted: on every known, which is always correct).
fn model_structure(ev: &mut Ev, vars: &[Variable]) {
    ev(Event::Start(BytesStart::new("ModelStructure")));
    for v in vars.iter().filter(|v| v.causality == Causality::Output) {
        let mut u = BytesStart::new("Output");
        u.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
        u.push_attribute(("dependencies", ""));
        ev(Event::Empty(u));
    }
    let initial_unknown = |v: &&Variable| {
        (v.causality == Causality::Output
            && matches!(v.initial, Some(Initial::Calculated) | Some(Initial::Approx)))
            || v.causality == Causality::CalculatedParameter
    };
    for v in vars.iter().filter(initial_unknown) {
        let mut u = BytesStart::new("InitialUnknown");
        u.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
        ev(Event::Empty(u));
    }
    ev(Event::End(BytesEnd::new("ModelStructure")));
}

/// The complete FMI 3.0 `modelDescription.xml`.
pub fn model_description<M: Model>() -> String {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    let vars = M::variables();
    let token = guid::<M>();
    {
        let mut ev = |e: Event| w.write_event(e).expect("writing to a Vec cannot fail");
        ev(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));
        let mut root = BytesStart::new("fmiModelDescription");
        root.push_attribute(("fmiVersion", "3.0"));
        root.push_attribute(("modelName", M::NAME));
        root.push_attribute(("instantiationToken", token.as_str()));
        root.push_attribute(("description", M::DESCRIPTION));
        root.push_attribute(("author", M::AUTHOR));
        root.push_attribute(("version", M::VERSION));
        root.push_attribute(("copyright", M::COPYRIGHT));
        root.push_attribute(("license", M::LICENSE));
        root.push_attribute(("generationTool", "actuator-fmu fmi3-export"));
        root.push_attribute(("variableNamingConvention", "structured"));
        ev(Event::Start(root));
        co_simulation::<M>(&mut ev);
        unit_definitions(&mut ev, vars);
        log_categories(&mut ev);
        default_experiment::<M>(&mut ev);
        model_variables(&mut ev, vars);
        model_structure(&mut ev, vars);
        ev(Event::End(BytesEnd::new("fmiModelDescription")));
    }
    let mut s = String::from_utf8(w.into_inner()).expect("the writer writes UTF-8");
    s.push('\n');
    s
}
