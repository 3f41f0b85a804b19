//! Unit tests of the CSV reader and writer.

use super::{
    parse_csv, parse_csv_with_text, parse_table, parse_with, read_csv, write_csv_text_to,
    write_csv_to, CsvError, Rules, Table, TimeAxis, MAX_LINE_BYTES,
};

fn e(text: &str) -> CsvError {
    parse_csv(text, "d.csv").unwrap_err()
}

/// The error for `text`: at (line, column), its message containing `part`.
fn refused(text: &str, at: (usize, usize), part: &str) -> CsvError {
    let x = e(text);
    assert_eq!((x.line, x.column), at, "{x}");
    assert!(x.message.contains(part), "{x}");
    x
}

#[test]
fn a_time_repeated_once_is_a_jump_where_jumps_are_allowed() {
    let text = "time,u\n0,0\n0.5,0.5\n0.5,2.5\n1,3\n";
    refused(text, (4, 1), "time must increase strictly");
    let t = parse_table(text, "d.csv", &[], TimeAxis::JumpsAllowed).unwrap();
    assert_eq!(t.time, [0.0, 0.5, 0.5, 1.0]);
    assert_eq!(t.columns[0], [0.0, 0.5, 2.5, 3.0]);
    let three = "time,u\n0,0\n0.5,0.5\n0.5,2.5\n0.5,9\n";
    let x = parse_table(three, "d.csv", &[], TimeAxis::JumpsAllowed).unwrap_err();
    assert_eq!((x.line, x.column), (5, 1), "{x}");
    assert!(x.message.contains("not three"), "{x}");
    let back = "time,u\n0,0\n0.5,0.5\n0.4,2.5\n";
    let x = parse_table(back, "d.csv", &[], TimeAxis::JumpsAllowed).unwrap_err();
    assert!(x.message.contains("less than 0.5 on line 3"), "{x}");
}

#[test]
fn names_with_commas_and_quotes_round_trip() {
    // FMI 2.0 array elements are named like `x[1,2]`; names may hold quotes and spaces.
    let names: Vec<String> = ["x[1,2]", "say \"hi\"", " padded ", "plain"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let cols = vec![
        vec![1.0, 2.0],
        vec![3.0, 4.0],
        vec![5.0, 6.0],
        vec![7.0, 8.0],
    ];
    let mut buf = Vec::new();
    write_csv_to(&mut buf, &[0.0, 0.5], &names, &cols).unwrap();
    let text = String::from_utf8(buf).unwrap();
    assert!(
        text.starts_with("time,\"x[1,2]\",\"say \"\"hi\"\"\",\" padded \",plain\n"),
        "{text}"
    );
    let t = parse_csv(&text, "rt.csv").unwrap();
    assert_eq!(t.names, names);
    assert_eq!(t.columns, cols);
    let e = e("time,\"open\n0,1\n");
    assert_eq!((e.line, e.column), (1, 2), "{e}");
    assert!(e.message.contains("unterminated quote"), "{e}");
}

#[test]
fn text_columns_keep_their_cells_and_are_written_back_quoted() {
    let text = "time, n ,s\n0,1, padded \n1,2,\"a, \"\"b\"\"\"\n";
    let t = parse_csv_with_text(text, "d.csv", &["s".to_string()]).unwrap();
    assert_eq!(t.names, vec!["n"]);
    assert_eq!(t.column("n").unwrap(), &[1.0, 2.0]);
    let s = t.text_column("s").unwrap();
    assert_eq!(s, &[" padded ".to_string(), "a, \"b\"".to_string()]);
    let mut buf = Vec::new();
    write_csv_text_to(&mut buf, &t.time, &t.names, &t.columns, &t.text).unwrap();
    let back = parse_csv_with_text(std::str::from_utf8(&buf).unwrap(), "b", &["s".into()]);
    assert_eq!(
        back.unwrap(),
        Table {
            file: "b".into(),
            ..t
        }
    );
}

#[test]
fn magnitudes_beyond_1e100_are_refused_with_their_place() {
    let e = e("time,y\n0,1\n1,-1e300\n");
    assert_eq!((e.line, e.column), (3, 2), "{e}");
    assert!(e.message.contains("beyond ±1e100"), "{e}");
    assert!(parse_csv("time,y\n0,1e99\n", "d.csv").is_ok());
}

#[test]
fn spreadsheet_exports_with_semicolons_tabs_and_decimal_commas_are_read() {
    let semicolons = parse_csv(
        "Time;u;\"y;1\"\r\n0;1,5;2\r\n0,5;-2,5e-3;3.25\r\n",
        "de.csv",
    );
    let t = semicolons.unwrap();
    assert_eq!(t.time, vec![0.0, 0.5]);
    assert_eq!(t.names, vec!["u", "y;1"]);
    assert_eq!(t.column("u").unwrap(), &[1.5, -2.5e-3]);
    assert_eq!(t.column("y;1").unwrap(), &[2.0, 3.25]);
    let tabs = parse_csv("time\tu\n0\t0,25\n1\t1e3\n", "t.tsv").unwrap();
    assert_eq!(tabs.column("u").unwrap(), &[0.25, 1000.0]);
    // With the comma as separator a decimal comma is a cell too many.
    let e = e("time,u\n0,1,5\n");
    assert_eq!((e.line, e.column), (2, 3), "{e}");
    assert!(
        e.message.contains("row has 3 cells, the header has 2"),
        "{e}"
    );
}

#[test]
fn a_measured_record_may_miss_samples_but_not_times() {
    let rules = Rules {
        time: TimeAxis::Strict,
        missing_allowed: true,
    };
    let t = parse_with("time,u,y\n0,1,\n0.5,nan,2\n1,NaN,3\n", "m.csv", &[], rules).unwrap();
    assert_eq!(t.time, vec![0.0, 0.5, 1.0]);
    let (u, y) = (t.column("u").unwrap(), t.column("y").unwrap());
    assert!(u[0] == 1.0 && u[1].is_nan() && u[2].is_nan(), "{u:?}");
    assert!(y[0].is_nan() && y[1] == 2.0, "{y:?}");
    let no_time = parse_with("time,y\n0,1\n,2\n", "m.csv", &[], rules).unwrap_err();
    assert_eq!((no_time.line, no_time.column), (3, 1), "{no_time}");
    assert!(
        no_time.message.contains("empty cell in column 'time'"),
        "{no_time}"
    );
    // Any other file refuses a missing sample.
    let e = e("time,y\n0,1\n1,\n");
    assert!(e.message.contains("empty cell in column 'y'"), "{e}");
}

#[test]
fn parses_a_good_file_with_comments_and_quotes() {
    let t = parse_csv(
        "# source: test\n\"time\", u ,y\r\n0,1,2\n0.5,1.5,-2e-3\n\n1.0,2,3\n",
        "d.csv",
    )
    .unwrap();
    assert_eq!(t.time, vec![0.0, 0.5, 1.0]);
    assert_eq!(t.names, vec!["u", "y"]);
    assert_eq!(t.column("y").unwrap(), &[2.0, -2e-3, 3.0]);
    assert_eq!(t.sample_interval(), Some(0.5));
}

#[test]
fn sample_interval_of_uniform_and_non_uniform_grids() {
    // 0.1 * k is not exactly representable: single differences are off by an ulp or so
    let mut text = String::from("time,u\n");
    for k in 0..=1000 {
        text.push_str(&format!("{},0\n", k as f64 * 0.001 + 0.3));
    }
    let t = parse_csv(&text, "d.csv").unwrap();
    assert_ne!(t.time[2] - t.time[1], 0.001);
    assert_eq!(t.sample_interval(), Some(0.001));
    let t = parse_csv("time,u\n0,0\n1,0\n3,0\n4,0\n", "d.csv").unwrap();
    assert_eq!(t.sample_interval(), Some(1.0));
    let t = parse_csv("time,u\n0,0\n", "d.csv").unwrap();
    assert_eq!(t.sample_interval(), None);
}

#[test]
fn empty_file() {
    let x = refused("", (1, 0), "empty file");
    assert_eq!(
        x.to_string(),
        "d.csv:1: empty file: expected a header line starting with 'time'"
    );
    assert_eq!(e("time,u\n").line, 2);
    assert!(e("time,u\n").message.contains("no data rows"));
}

#[test]
fn non_numeric_cells() {
    let x = refused("time,u,y\n0,1,2\n1,abc,2\n", (3, 2), "");
    assert_eq!(
        x.to_string(),
        "d.csv:3:2: non-numeric cell 'abc' in column 'u'"
    );
}

/// Each refused file: the line and column of its error, and a part of the message.
#[test]
fn refused_files_name_line_and_column() {
    let cases = [
        ("t,u\n0,1\n", (1, 1), "no 'time' column"),
        ("u,time\n0,1\n", (1, 2), "must be the first column"),
        (
            "time,u\n0,1\n0.1,1\n0.1,2\n",
            (4, 1),
            "not greater than 0.1 on line 3",
        ),
        ("time,u\n0,1\n-1,1\n", (3, 1), ""),
        ("time,u\n0,1\n1,NaN\n", (3, 2), "NaN in column 'u'"),
        ("time,u\n0,inf\n", (2, 2), "infinite"),
        ("time,u\nnan,1\n", (2, 1), ""),
        ("time,u\n0,\n", (2, 2), "empty cell"),
        (
            "time,u,y\n0,1,2\n1,2\n",
            (3, 3),
            "row has 2 cells, the header has 3",
        ),
        ("time,u\n0,1,2\n", (2, 3), ""),
        ("time,u,u\n0,1,2\n", (1, 3), "appears twice"),
        ("time,,y\n0,1,2\n", (1, 2), ""),
    ];
    for (text, at, part) in cases {
        refused(text, at, part);
    }
}

#[test]
fn unknown_columns_against_a_model_description() {
    let md = crate::md::ModelDescription::parse(crate::md::tests::SAMPLE, "md.xml").unwrap();
    let md = crate::view::ModelView::from(&md);
    let t = parse_csv("time,u,x\n0,1,2\n", "d.csv").unwrap();
    t.check_against(&md).unwrap();
    assert_eq!(t.input_columns(&md), vec!["u"]);
    assert_eq!(t.output_columns(&md), vec!["x"]);
    let t = parse_csv("time,u,k\n0,1,2\n", "d.csv").unwrap();
    let x = t.check_against(&md).unwrap_err();
    assert_eq!((x.line, x.column), (1, 3));
    assert!(
        x.message.contains("'k' is neither an input nor an output"),
        "{x}"
    );
    let t = parse_csv("time,zz\n0,1\n", "d.csv").unwrap();
    let x = t.check_against(&md).unwrap_err();
    assert!(
        x.message
            .contains("'zz' is not a variable of the FMU (inputs: u; outputs: x)"),
        "{x}"
    );
}

#[test]
fn written_numbers_read_back_exactly() {
    let time = vec![0.0, 0.1, 0.30000000000000004];
    let cols = vec![
        vec![1e-300, -2.5, 123456789.123],
        vec![f64::MIN_POSITIVE, 1e20, -0.0],
    ];
    let names = vec!["a".to_string(), "b".to_string()];
    let mut buf = Vec::new();
    write_csv_to(&mut buf, &time, &names, &cols).unwrap();
    let t = parse_csv(std::str::from_utf8(&buf).unwrap(), "w.csv").unwrap();
    assert_eq!(t.time, time);
    assert_eq!(t.columns, cols);
}

#[test]
fn hostile_files_are_refused_with_their_location_and_bounded_messages() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let e = read_csv(&write("u.csv", b"time,x\n0,1\n1,2\xff\n")).unwrap_err();
    assert_eq!((e.line, e.column), (3, 4), "{e}");
    let e = read_csv(&write("z.csv", &vec![0u8; MAX_LINE_BYTES + 10])).unwrap_err();
    assert_eq!(e.line, 1);
    assert!(e.message.contains("line longer"), "{e}");
    let mut big = b"time,x\n0,".to_vec();
    big.extend(std::iter::repeat_n(b'a', 100_000));
    big.extend(b"\0\n");
    let e = read_csv(&write("c.csv", &big)).unwrap_err();
    assert!(e.to_string().len() < 200, "{e}");
    assert!(!e.to_string().contains('\0'));
}
