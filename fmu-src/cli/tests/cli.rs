//! End-to-end tests of the `actuator-fmu` binary on the host's test FMU (compiled from
//! fmu-src/host/tests/fixtures, including deliberately broken variants).
// Test references use the platform libm: an implementation independent of the `libm` crate
// the FMU code uses (workspace clippy.toml).
#![allow(clippy::disallowed_methods)]

#[path = "../../host/tests/common/mod.rs"]
mod common;

use std::path::Path;
use std::process::{Command, Output};

fn cli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_actuator-fmu"))
        .args(args)
        .output()
        .unwrap()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn validate_passes_a_conforming_fmu_with_exit_0() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(dir.path(), "Good", &[], &common::fixture_md());
    let o = cli(&["validate", s(&fmu)]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    assert_eq!(out.trim(), format!("{}: OK (no findings)", fmu.display()));
}

#[test]
fn validate_catches_a_missing_output_in_model_structure() {
    let dir = tempfile::tempdir().unwrap();
    let md = common::fixture_md().replace(
        "      <Unknown index=\"8\"/>\n    </Outputs>",
        "    </Outputs>",
    );
    assert_ne!(md, common::fixture_md());
    let fmu = common::build_fmu(dir.path(), "NoOutput", &[], &md);
    let o = cli(&["validate", s(&fmu)]);
    let (out, _) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(
        out.contains("[outputs-listed]")
            && out.contains("output 'steps' (index 8) is missing from <ModelStructure><Outputs>"),
        "{out}"
    );
    assert!(out.contains("1 finding(s)"), "{out}");
}

#[test]
fn validate_survives_a_binary_that_crashes_on_a_wrong_call_order() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(
        dir.path(),
        "Crash",
        &["-DCRASH_ON_WRONG_ORDER"],
        &common::fixture_md(),
    );
    let o = cli(&["validate", "--json", s(&fmu)]);
    let (out, err) = text(&o);
    // fmi2DoStep before initialization or after fmi2Terminate is a call the importer must not
    // make (FMI 2.0.4 section 4.2.4): the outcome is undefined, so a crash there is a note.
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v[0]["findings"].as_array().unwrap().len(), 0, "{out}");
    let notes = v[0]["notes"].as_array().unwrap();
    // The probe is re-run past each crashing case, so both wrong-order calls are reported
    // and the other cases still ran (they found nothing).
    assert_eq!(notes.len(), 2, "{out}");
    for (f, step) in notes
        .iter()
        .zip(["do-step-before-init", "do-step-after-terminate"])
    {
        assert_eq!(f["check"], "probe-wrong-call");
        assert_eq!(f["severity"], "note");
        assert_eq!(f["location"], format!("probe {step}"));
        assert!(f["message"].as_str().unwrap().contains("SIGSEGV"), "{out}");
    }
}

#[test]
fn validate_reports_a_binary_that_hangs_as_a_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(
        dir.path(),
        "Hang",
        &["-DHANG_ON_WRONG_ORDER"],
        &common::fixture_md(),
    );
    let o = cli(&["validate", "--timeout", "2", s(&fmu)]);
    let (out, err) = text(&o);
    // a hang on a call the importer must not make is a note, as a crash there is
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 3, "{out}");
    assert!(
        lines[0].contains(
            "note [probe-wrong-call] probe do-step-before-init: the FMU did not return within 2 s"
        ),
        "{out}"
    );
    assert!(
        lines[1].contains("note [probe-wrong-call] probe do-step-after-terminate"),
        "{out}"
    );
}

#[test]
fn validate_lists_every_finding_and_note_of_a_lax_fmu_and_usage_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(
        dir.path(),
        "Lax",
        &["-DLAX", "-DMISSING_SYMBOL"],
        &common::fixture_md(),
    );
    let o = cli(&["validate", s(&fmu)]);
    let (out, _) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    // The wrong calls it accepts are permitted by the standard: notes, each with its clause.
    let notes: Vec<&str> = out
        .lines()
        .filter(|l| l.contains(": note [probe-"))
        .collect();
    assert_eq!(notes.len(), 8, "{out}");
    assert!(notes.iter().all(|l| l.contains("(FMI 2.0.4 §")), "{out}");
    // The missing function is required: the finding that makes the exit status 1.
    assert!(out.contains("does not export fmi2GetStringStatus"), "{out}");
    assert!(out.contains("2 finding(s), 8 note(s)"), "{out}");
    let o = cli(&["validate", "/nonexistent/x.fmu"]);
    assert_eq!(o.status.code(), Some(2));
    let o = cli(&["validate"]);
    assert_eq!(o.status.code(), Some(2));
    let junk = dir.path().join("junk.fmu");
    std::fs::write(&junk, "no zip").unwrap();
    let o = cli(&["validate", s(&junk)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).0.contains("[archive]"));
}

#[test]
fn simulate_writes_every_output_and_applies_sets_and_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(dir.path(), "Good", &[], &common::fixture_md());
    let data = dir.path().join("in.csv");
    // constant force 2 N, sampled every 0.01 s; x is a (ignored) measured output column
    let mut csv = String::from("time,u,x\n");
    for k in 0..=100 {
        csv.push_str(&format!("{},2,0\n", k as f64 * 0.01));
    }
    std::fs::write(&data, csv).unwrap();
    let out = dir.path().join("out.csv");
    let o = cli(&[
        "simulate",
        s(&fmu),
        "--data",
        s(&data),
        "--set",
        "k=9",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{:?}", text(&o));
    let t = host::csv::read_csv(&out).unwrap();
    assert_eq!(t.names, vec!["x", "v", "steps"]);
    assert_eq!(t.time.len(), 101);
    assert_eq!(*t.time.last().unwrap(), 1.0);
    // x = u/k + (x0 - u/k) cos(3 t) for k = 9, u = 2, x0 = 1
    for (tk, xk) in t.time.iter().zip(t.column("x").unwrap()) {
        let exact = 2.0 / 9.0 + (1.0 - 2.0 / 9.0) * (3.0 * tk).cos();
        assert!((xk - exact).abs() < 1e-9, "t={tk}: {xk} vs {exact}");
    }
    // --stop and --step override the CSV
    let o = cli(&[
        "simulate",
        s(&fmu),
        "--data",
        s(&data),
        "--stop",
        "0.5",
        "--step",
        "0.1",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(0));
    let t = host::csv::read_csv(&out).unwrap();
    assert_eq!(t.time.len(), 6);
}

#[test]
fn simulate_reports_bad_data_and_bad_arguments_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::build_fmu(dir.path(), "Good", &[], &common::fixture_md());
    let out = dir.path().join("out.csv");
    let cases: &[(&str, &str)] = &[
        ("tim,u\n0,1\n", ":1:1: no 'time' column"),
        ("time,u\n0,1\n-1,2\n", ":3:1: time -1 is less than 0"),
        ("time,u\n0,1\n0,2\n0,3\n", ":4:1: time 0 is on line 3"),
        (
            "time,u,foo\n0,1,2\n",
            ":1:3: column 'foo' is not a variable of the FMU",
        ),
        (
            "time,u,k\n0,1,2\n",
            ":1:3: column 'k' is neither an input nor an output",
        ),
        ("time,u\n0,1\n1,nan\n", ":3:2: NaN in column 'u'"),
        ("", ":1: empty file"),
        ("time,u\n0,1\n1,x1\n", ":3:2: non-numeric cell 'x1'"),
        ("time,u\n0,1\n1\n", ":3:2: row has 1 cells"),
    ];
    for (i, (content, expected)) in cases.iter().enumerate() {
        let data = dir.path().join(format!("bad{i}.csv"));
        std::fs::write(&data, content).unwrap();
        let o = cli(&["simulate", s(&fmu), "--data", s(&data), "--out", s(&out)]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{content:?}: {err}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(
            err.contains(&format!("bad{i}.csv{expected}")),
            "{content:?}: {err}"
        );
    }
    let data = dir.path().join("ok.csv");
    std::fs::write(&data, "time,u\n0,1\n1,1\n").unwrap();
    for (set, expected) in [
        ("nope=1", "the FMU has no variable 'nope'"),
        ("k", "expected NAME=VALUE"),
        ("damping.enabled=2", "expected true or false"),
        ("k=abc", "'abc' is not a number"),
        ("k=1000", "'k' = 1000 is outside its range [0, 100]"),
    ] {
        let o = cli(&[
            "simulate",
            s(&fmu),
            "--data",
            s(&data),
            "--set",
            set,
            "--out",
            s(&out),
        ]);
        assert_eq!(o.status.code(), Some(2));
        assert!(text(&o).1.contains(expected), "{set}: {:?}", text(&o));
    }
    let o = cli(&[
        "simulate",
        "/nonexistent.fmu",
        "--data",
        s(&data),
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2));
    // the FMU refusing a value at initialization is bad input (exit 2) carrying its message
    let o = cli(&[
        "simulate",
        s(&fmu),
        "--data",
        s(&data),
        "--set",
        "k=0",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("k must be > 0"));
}
