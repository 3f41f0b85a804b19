//! The host against a real FMU: the mass-spring test FMU of tests/fixtures (compiled here),
//! compared with closed-form solutions of its equations (see testfmu.c).
// Host side: runs in the user's process, not inside an FMU; the FMUs' bit-determinism (the
// workspace clippy.toml) does not bind it.
#![allow(clippy::disallowed_methods)]

mod common;

use host::md::Causality;
use host::{simulate, Fmu, HostError, InputSeries, SimulationRequest, Simulator, Status, Value};

fn dummy() -> (tempfile::TempDir, Fmu) {
    let dir = tempfile::tempdir().unwrap();
    let path = common::build_fmu(dir.path(), "Dummy", &[], &common::fixture_md());
    let fmu = Fmu::open(&path).unwrap();
    (dir, fmu)
}

/// Closed form of x'' + d x' + k x = u (u constant), x(0) = x0, x'(0) = 0, underdamped.
fn closed_form(k: f64, d: f64, u: f64, x0: f64, t: f64) -> f64 {
    let xe = u / k;
    let a = x0 - xe;
    let s = d / 2.0;
    let wd = (k - s * s).sqrt();
    xe + a * (-s * t).exp() * ((wd * t).cos() + s / wd * (wd * t).sin())
}

fn max_err(res: &host::SimulationResult, k: f64, d: f64, u: f64, x0: f64) -> f64 {
    let x = res.column("x").unwrap();
    res.time
        .iter()
        .zip(x)
        .map(|(&t, &xi)| (xi - closed_form(k, d, u, x0, t)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn opens_and_describes_the_fmu() {
    let (_d, fmu) = dummy();
    let md = fmu.model_description();
    assert_eq!(md.model_name, "Dummy");
    assert_eq!(md.output_names(), vec!["x", "v", "steps"]);
    assert_eq!(md.input_names(), vec!["u"]);
    assert_eq!(md.with_causality(Causality::Parameter).count(), 4);
    assert!(fmu.missing_functions().is_empty());
}

#[test]
fn free_oscillation_matches_the_closed_form() {
    let (_d, fmu) = dummy();
    let res = simulate(&fmu, &SimulationRequest::new(0.0, 2.0, 0.01)).unwrap();
    assert_eq!(res.time.len(), 201);
    assert_eq!(res.names, vec!["x", "v", "steps"]);
    assert!(
        max_err(&res, 4.0, 0.0, 0.0, 1.0) < 1e-9,
        "{}",
        max_err(&res, 4.0, 0.0, 0.0, 1.0)
    );
    assert_eq!(res.column("steps").unwrap()[200], 200.0);
}

#[test]
fn start_values_real_and_boolean_are_applied_before_initialization() {
    let (_d, fmu) = dummy();
    let mut req = SimulationRequest::new(0.0, 3.0, 0.05);
    req.start_values = vec![
        ("k".into(), Value::Real(9.0)),
        ("x0".into(), Value::Real(0.5)),
        ("damping.enabled".into(), Value::Boolean(true)),
        ("damping.d".into(), Value::Real(0.8)),
    ];
    req.outputs = vec!["x".into()];
    let res = simulate(&fmu, &req).unwrap();
    assert_eq!(res.names, vec!["x"]);
    let e = max_err(&res, 9.0, 0.8, 0.0, 0.5);
    assert!(e < 1e-9, "{e}");
}

#[test]
fn inputs_are_interpolated_and_set_at_each_communication_point() {
    let (_d, fmu) = dummy();
    let mut req = SimulationRequest::new(0.0, 2.0, 0.01);
    // a constant force given as a two-sample series: x = u/k + (x0 - u/k) cos(2t)
    req.inputs = InputSeries {
        time: vec![0.0, 2.0],
        columns: vec![("u".into(), vec![2.0, 2.0])],
        ..Default::default()
    };
    let res = simulate(&fmu, &req).unwrap();
    assert!(max_err(&res, 4.0, 0.0, 2.0, 1.0) < 1e-9);
}

#[test]
fn bad_requests_are_typed_errors() {
    let (_d, fmu) = dummy();
    let mut req = SimulationRequest::new(0.0, 1.0, 0.1);
    req.start_values = vec![("nope".into(), Value::Real(1.0))];
    assert!(matches!(simulate(&fmu, &req), Err(HostError::UnknownVariable(n)) if n == "nope"));
    let mut req = SimulationRequest::new(0.0, 1.0, 0.1);
    req.start_values = vec![("damping.enabled".into(), Value::Real(1.0))];
    assert!(matches!(simulate(&fmu, &req), Err(HostError::Request(_))));
    let mut req = SimulationRequest::new(0.0, 1.0, 0.1);
    req.inputs = InputSeries {
        time: vec![0.0],
        columns: vec![("x".into(), vec![1.0])],
        ..Default::default()
    };
    let e = simulate(&fmu, &req).unwrap_err().to_string();
    assert!(e.contains("'x' is not an input"), "{e}");
    // k = 0 is refused by the FMU at fmi2ExitInitializationMode: the error carries its message
    let mut req = SimulationRequest::new(0.0, 1.0, 0.1);
    req.start_values = vec![("k".into(), Value::Real(0.0))];
    match simulate(&fmu, &req) {
        Err(HostError::Fmi {
            function,
            status,
            messages,
        }) => {
            assert_eq!(function, "fmi2ExitInitializationMode");
            assert_eq!(status, Status::Error);
            assert_eq!(messages.len(), 1);
            assert_eq!(messages[0].message, "k must be > 0");
            assert_eq!(messages[0].instance, "host");
        }
        other => panic!(
            "expected an Fmi error, got {other:?}",
            other = other.map(|_| ())
        ),
    }
}

#[test]
fn instance_calls_in_the_wrong_state_return_fmi_errors_with_the_log() {
    let (_d, fmu) = dummy();
    let mut inst = fmu.instantiate("probe").unwrap();
    let e = inst.do_step(0.0, 0.1, true).unwrap_err();
    assert_eq!(e.status(), Some(Status::Error));
    assert!(
        e.to_string()
            .contains("fmi2DoStep: not allowed in the current state"),
        "{e}"
    );
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let e = inst.set_real(&[2], &[5.0]).unwrap_err();
    assert_eq!(e.status(), Some(Status::Error));
    assert!(e.messages()[0].message.contains("only the input u"));
    let e = inst.set_real(&[3], &[f64::NAN]).unwrap_err();
    assert!(e.to_string().contains("not finite"));
    let e = inst.set_real(&[3, 4], &[1.0]).unwrap_err();
    assert!(matches!(e, HostError::Request(_)));
    let mut out = [0.0];
    inst.get_real(&[0], &mut out).unwrap();
    assert_eq!(out[0], 1.0);
    let mut b = [true];
    inst.get_boolean(&[4], &mut b).unwrap();
    assert!(!b[0]);
    let mut i = [5];
    inst.get_integer(&[7], &mut i).unwrap();
    assert_eq!(i[0], 0);
    inst.set_debug_logging(true, &["logStatusError"]).unwrap();
    inst.set_debug_logging(false, &[]).unwrap();
    assert!(inst.get_string(&[]).unwrap().is_empty());
    let e = inst.set_string(&[0], &["x"]).unwrap_err();
    assert!(e.to_string().contains("no String variables"), "{e}");
}

#[test]
fn wrong_guid_makes_instantiate_fail_with_the_logged_message() {
    let dir = tempfile::tempdir().unwrap();
    let md = common::fixture_md().replace("{8c4e810f-3df3-4a00-8276-176fa3c9f000}", "{other}");
    let path = common::build_fmu(dir.path(), "Dummy", &[], &md);
    let fmu = Fmu::open(&path).unwrap();
    let e = fmu.instantiate("x").err().unwrap();
    assert!(matches!(e, HostError::Instantiate { .. }));
    assert_eq!(
        e.to_string(),
        "fmi2Instantiate returned NULL (FMU log: wrong fmuType or GUID)"
    );
}

#[test]
fn simulator_reuses_one_instance_and_reproduces_results_bit_for_bit() {
    let (_d, fmu) = dummy();
    let mut sim = Simulator::new(&fmu).unwrap();
    let req = SimulationRequest::new(0.0, 1.0, 0.01);
    let a = sim.run(&req).unwrap();
    let mut req2 = req.clone();
    req2.start_values = vec![("k".into(), Value::Real(9.0))];
    let b = sim.run(&req2).unwrap();
    let c = sim.run(&req).unwrap();
    assert_eq!(a, c);
    assert_ne!(a, b);
    assert!(max_err(&b, 9.0, 0.0, 0.0, 1.0) < 1e-9);
    assert_eq!(a, simulate(&fmu, &req).unwrap());
}

#[test]
fn fmu_state_get_set_and_serialize_continue_identically() {
    let (_d, fmu) = dummy();
    let mut inst = fmu.instantiate("s").unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    inst.do_step(0.0, 0.3, true).unwrap();
    let saved = inst.get_fmu_state().unwrap();
    let bytes = inst.serialize_fmu_state(&saved).unwrap();
    inst.do_step(0.3, 0.2, true).unwrap();
    assert_eq!(inst.last_successful_time().unwrap(), 0.3 + 0.2);
    let mut first = [0.0; 2];
    inst.get_real(&[0, 1], &mut first).unwrap();
    inst.set_fmu_state(&saved).unwrap();
    inst.do_step(0.3, 0.2, true).unwrap();
    let mut second = [0.0; 2];
    inst.get_real(&[0, 1], &mut second).unwrap();
    assert_eq!(first, second);
    let restored = inst.deserialize_fmu_state(&bytes).unwrap();
    inst.set_fmu_state(&restored).unwrap();
    inst.do_step(0.3, 0.2, true).unwrap();
    let mut third = [0.0; 2];
    inst.get_real(&[0, 1], &mut third).unwrap();
    assert_eq!(first, third);
    inst.free_fmu_state(saved).unwrap();
}

#[test]
fn one_fmu_serves_several_threads_each_with_its_own_instance() {
    let (_d, fmu) = dummy();
    let reqs: Vec<SimulationRequest> = (1..=6)
        .map(|i| {
            let mut r = SimulationRequest::new(0.0, 2.0, 0.01);
            r.start_values = vec![("k".into(), Value::Real(i as f64))];
            r
        })
        .collect();
    let serial: Vec<_> = reqs.iter().map(|r| simulate(&fmu, r).unwrap()).collect();
    let parallel: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = reqs
            .iter()
            .map(|r| s.spawn(|| simulate(&fmu, r).unwrap()))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(serial, parallel);
}

#[test]
fn opening_bad_files_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = Fmu::open(dir.path().join("missing.fmu"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("missing.fmu"), "{e}");
    let junk = dir.path().join("junk.fmu");
    std::fs::write(&junk, b"not a zip").unwrap();
    let e = Fmu::open(&junk).err().unwrap().to_string();
    assert!(e.contains("not a valid FMU: not a zip archive"), "{e}");
    let md = common::fixture_md().replace("<ModelVariables>", "<ModelVariables><Oops>");
    let p = common::build_fmu(dir.path(), "Bad", &[], &md);
    let e = Fmu::open(&p).err().unwrap().to_string();
    assert!(
        e.contains("Bad.fmu!modelDescription.xml:") && e.contains("malformed XML"),
        "{e}"
    );
}

#[test]
fn only_once_per_process_is_enforced() {
    let dir = tempfile::tempdir().unwrap();
    let md = common::fixture_md().replace(
        "canNotUseMemoryManagementFunctions=\"true\"",
        "canNotUseMemoryManagementFunctions=\"true\" canBeInstantiatedOnlyOncePerProcess=\"true\"",
    );
    let path = common::build_fmu(dir.path(), "Once", &[], &md);
    let fmu = Fmu::open(&path).unwrap();
    let a = fmu.instantiate("a").unwrap();
    let e = fmu.instantiate("b").err().unwrap().to_string();
    assert!(e.contains("canBeInstantiatedOnlyOncePerProcess"), "{e}");
    drop(a);
    fmu.instantiate("c").unwrap();
    // the default FMU allows many
    let (_d, fmu) = dummy();
    let _x = fmu.instantiate("x").unwrap();
    let _y = fmu.instantiate("y").unwrap();
}

#[test]
fn fmu_is_send_and_sync_and_instance_is_send() {
    fn send_sync<T: Send + Sync>() {}
    fn send<T: Send>() {}
    send_sync::<Fmu>();
    send::<host::Instance<'static>>();
}

#[test]
fn an_error_after_many_logged_lines_keeps_its_own_message() {
    // An FMU logging every step fills the host's bounded log long before it fails: the error's
    // message, logged last, is the one that must survive.
    let dir = tempfile::tempdir().unwrap();
    let path = common::build_fmu(dir.path(), "Chatty", &["-DCHATTY"], &common::fixture_md());
    let fmu = Fmu::open(&path).unwrap();
    let mut inst = fmu.instantiate("chatty").unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let steps = host::ffi::MAX_LOG_RECORDS + 5;
    for k in 0..steps {
        inst.do_step(k as f64 * 1e-3, 1e-3, true).unwrap();
    }
    let e = inst.do_step(steps as f64 * 1e-3, -1.0, true).unwrap_err();
    assert!(e.to_string().contains("step size must be > 0"), "{e}");
    assert_eq!(e.messages().len(), host::ffi::MAX_LOG_RECORDS);
}

#[test]
fn simulator_recovers_after_a_failed_run() {
    let (_d, fmu) = dummy();
    let mut sim = Simulator::new(&fmu).unwrap();
    let mut bad = SimulationRequest::new(0.0, 1.0, 0.01);
    bad.start_values = vec![("k".into(), Value::Real(0.0))];
    let e = sim.run(&bad).unwrap_err();
    assert_eq!(e.status(), Some(Status::Error));
    let good = SimulationRequest::new(0.0, 1.0, 0.01);
    assert_eq!(sim.run(&good).unwrap(), simulate(&fmu, &good).unwrap());
}
