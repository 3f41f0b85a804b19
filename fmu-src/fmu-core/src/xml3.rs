//! The FMI 3.0 `modelDescription.xml` (schema `fmi3ModelDescription.xsd`, FMI 3.0.2 chapter 2)
//! from the same variable table as the FMI 2.0 one: Real variables become `Float64`, Integer
//! `Int32`, Boolean `Boolean`; `time` is added as the independent variable; the
//! `instantiationToken` is the FMI 2.0 description's GUID (the same model, the same FMU states).

use crate::units;
use crate::xml::{default_experiment, fmt_f64, guid, log_categories, unit_definitions};
use crate::{Causality, Initial, MeVTable, Model, VarType, Variable};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use std::collections::BTreeSet;

/// Value reference of `time`, the independent variable FMI 3.0 requires (FMI 3.0.2 section
/// 2.4.7.4: exactly one variable has `causality="independent"`). It lies far above every value
/// reference of the models' tables, which [`crate::variables`] checks.
pub const TIME_VALUE_REFERENCE: u32 = 1_000_000;

/// Value reference of the first event indicator, `eventIndicator[1]` (indicator `k`, from 0, has
/// `EVENT_INDICATOR_VALUE_REFERENCE + k`). FMI 3.0.2 section 2.4.8 lists event indicators as
/// variables (`<EventIndicator valueReference=...>`); the models' tables do not hold them, so
/// the FMI 3.0 description adds them as continuous Float64 locals.
pub const EVENT_INDICATOR_VALUE_REFERENCE: u32 = 1_000_001;

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

/// `"true"` where the model has an analytic Jacobian: directional and adjoint derivatives in
/// Model Exchange and (at the communication point) in Co-Simulation.
fn jacobian<M: Model>() -> &'static str {
    if M::model_exchange().is_some_and(|me| me.provides_jacobian) {
        "true"
    } else {
        "false"
    }
}

/// `<ModelExchange>` (FMI 3.0.2 section 3.3) for a model with Model Exchange.
fn model_exchange<M: Model>(ev: &mut Ev) {
    let jacobian = jacobian::<M>();
    let mut e = BytesStart::new("ModelExchange");
    for (k, v) in [
        ("modelIdentifier", M::NAME),
        ("needsExecutionTool", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canGetAndSetFMUState", "true"),
        ("canSerializeFMUState", "true"),
        ("providesDirectionalDerivatives", jacobian),
        ("providesAdjointDerivatives", jacobian),
        ("providesPerElementDependencies", "false"),
        ("needsCompletedIntegratorStep", "false"),
        ("providesEvaluateDiscreteStates", "false"),
    ] {
        e.push_attribute((k, v));
    }
    ev(Event::Empty(e));
}

fn co_simulation<M: Model>(ev: &mut Ev) {
    let mut cs = BytesStart::new("CoSimulation");
    for (k, v) in [
        ("modelIdentifier", M::NAME),
        ("needsExecutionTool", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canGetAndSetFMUState", "true"),
        ("canSerializeFMUState", "true"),
        ("providesDirectionalDerivatives", jacobian::<M>()),
        ("providesAdjointDerivatives", jacobian::<M>()),
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

/// One variable element: `<Float64 name=... valueReference=... .../>`; `derivative` is the value
/// reference of the state whose derivative the variable is.
fn variable(ev: &mut Ev, v: &Variable, derivative: Option<u32>) {
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
        if let Some(x) = derivative {
            e.push_attribute(("derivative", x.to_string().as_str()));
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
    if let (VarType::Real, Some(n)) = (v.vtype, v.nominal) {
        e.push_attribute(("nominal", fmt_f64(n).as_str()));
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

/// The state and derivative positions in the table (empty without Model Exchange).
fn states<M: Model>(me: &Option<MeVTable<M>>) -> &'static [(usize, usize)] {
    me.as_ref().map_or(&[], |me| me.state_variables)
}

fn model_variables<M: Model>(ev: &mut Ev, vars: &[Variable]) {
    let me = M::model_exchange();
    let states = states(&me);
    ev(Event::Start(BytesStart::new("ModelVariables")));
    let mut time = BytesStart::new("Float64");
    time.push_attribute(("name", "time"));
    time.push_attribute(("valueReference", TIME_VALUE_REFERENCE.to_string().as_str()));
    time.push_attribute(("description", "Simulation time"));
    time.push_attribute(("causality", "independent"));
    time.push_attribute(("variability", "continuous"));
    time.push_attribute(("unit", "s"));
    ev(Event::Empty(time));
    for (i, v) in vars.iter().enumerate() {
        let state = states.iter().find(|&&(_, d)| d == i);
        variable(ev, v, state.map(|&(x, _)| vars[x].value_reference));
    }
    for k in 0..me.map_or(0, |me| me.event_indicators) {
        let mut z = BytesStart::new("Float64");
        let vr = EVENT_INDICATOR_VALUE_REFERENCE + k as u32;
        z.push_attribute(("name", format!("eventIndicator[{}]", k + 1).as_str()));
        z.push_attribute(("valueReference", vr.to_string().as_str()));
        z.push_attribute((
            "description",
            "Event indicator: a sign change is a state event (Model Exchange)",
        ));
        z.push_attribute(("causality", "local"));
        z.push_attribute(("variability", "continuous"));
        ev(Event::Empty(z));
    }
    ev(Event::End(BytesEnd::new("ModelVariables")));
}

/// Value references of table positions, sorted, space-separated.
fn vr_list(vars: &[Variable], positions: impl IntoIterator<Item = usize>) -> String {
    let mut vrs: Vec<u32> = positions
        .into_iter()
        .map(|i| vars[i].value_reference)
        .collect();
    vrs.sort_unstable();
    vrs.dedup();
    let vrs: Vec<String> = vrs.iter().map(u32::to_string).collect();
    vrs.join(" ")
}

/// Table positions of the parameters unknown `u` depends on: the model's declaration (an
/// unknown it does not name depends on none), without one every parameter.
fn parameters_of<M: Model>(me: &Option<MeVTable<M>>, vars: &[Variable], u: usize) -> Vec<usize> {
    match me.as_ref().and_then(|me| me.parameter_dependencies) {
        Some(declared) => declared
            .iter()
            .filter(|(unknown, _)| *unknown == u)
            .flat_map(|(_, parameters)| parameters.iter().copied())
            .collect(),
        None => (0..vars.len())
            .filter(|&i| vars[i].causality == Causality::Parameter)
            .collect(),
    }
}

/// FMI 3.0.2 section 2.4.8. `<Output>` for every output: in Model Exchange an output depends on
/// the continuous states, on the inputs the model names as direct feedthrough (in
/// Co-Simulation an input changes no output before the next step, and the states are values of
/// the last step, so the list is right for both) and on the parameters the model names
/// (parameters are knowns in Event and Continuous-Time Mode and at communication points; a
/// known left out would claim a partial derivative identically zero); without Model Exchange on
/// every parameter. `<ContinuousStateDerivative>` per state, with the model's declared state,
/// input and parameter dependencies (else the default, every known). `<InitialUnknown>` for
/// every calculated output, state and derivative and calculated parameter (dependencies
/// omitted: on every known, inputs, `initial="exact"` variables and time, which is always
/// correct). `<EventIndicator>` per event indicator (dependencies omitted: on every known).
fn model_structure<M: Model>(ev: &mut Ev, vars: &[Variable]) {
    let me = M::model_exchange();
    let states = states(&me);
    ev(Event::Start(BytesStart::new("ModelStructure")));
    let feedthrough = me.as_ref().map_or(&[][..], |me| me.output_feedthrough);
    for (o, v) in vars.iter().enumerate() {
        if v.causality != Causality::Output {
            continue;
        }
        let inputs = feedthrough
            .iter()
            .filter(|(out, _)| *out == o)
            .flat_map(|(_, inputs)| inputs.iter().copied());
        let parameters = parameters_of(&me, vars, o);
        let deps = vr_list(
            vars,
            states
                .iter()
                .map(|&(x, _)| x)
                .chain(inputs)
                .chain(parameters),
        );
        let mut u = BytesStart::new("Output");
        u.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
        u.push_attribute(("dependencies", deps.as_str()));
        ev(Event::Empty(u));
    }
    let declared = me.as_ref().and_then(|me| me.derivative_dependencies);
    for (k, &(_, d)) in states.iter().enumerate() {
        let mut u = BytesStart::new("ContinuousStateDerivative");
        u.push_attribute((
            "valueReference",
            vars[d].value_reference.to_string().as_str(),
        ));
        if let Some(deps) = declared.and_then(|deps| deps.get(k)) {
            let parameters = parameters_of(&me, vars, d);
            let all = deps.iter().copied().chain(parameters);
            u.push_attribute(("dependencies", vr_list(vars, all).as_str()));
        }
        ev(Event::Empty(u));
    }
    let is_state = |i: usize| states.iter().any(|&(x, d)| x == i || d == i);
    for (i, v) in vars.iter().enumerate() {
        let calculated = matches!(v.initial, Some(Initial::Calculated) | Some(Initial::Approx));
        if ((v.causality == Causality::Output || is_state(i)) && calculated)
            || v.causality == Causality::CalculatedParameter
        {
            let mut u = BytesStart::new("InitialUnknown");
            u.push_attribute(("valueReference", v.value_reference.to_string().as_str()));
            ev(Event::Empty(u));
        }
    }
    for k in 0..me.map_or(0, |me| me.event_indicators) {
        let mut u = BytesStart::new("EventIndicator");
        let vr = EVENT_INDICATOR_VALUE_REFERENCE + k as u32;
        u.push_attribute(("valueReference", vr.to_string().as_str()));
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
        if M::model_exchange().is_some() {
            model_exchange::<M>(&mut ev);
        }
        co_simulation::<M>(&mut ev);
        unit_definitions(&mut ev, &used_units(vars));
        log_categories(&mut ev);
        default_experiment::<M>(&mut ev);
        model_variables::<M>(&mut ev, vars);
        model_structure::<M>(&mut ev, vars);
        ev(Event::End(BytesEnd::new("fmiModelDescription")));
    }
    let mut s = String::from_utf8(w.into_inner()).expect("the writer writes UTF-8");
    s.push('\n');
    s
}
