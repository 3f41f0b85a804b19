//! The host's CSV reader (`host::csv::parse_csv`, what `read_csv` calls after UTF-8 decoding):
//! any text gives a table or a located error, never a panic or a hang. A parsed table must keep
//! the reader's promises (rectangular, finite values, strictly increasing time) and read back
//! bit-identically after `write_csv_to`. Read as `simulate --data` reads it (a time may repeat
//! once, a jump): time increases, no time on three rows, and a table the strict reader takes
//! comes out the same. Read as a measured record (`gap --data`: missing samples as NaN): time
//! increases strictly and a table the strict reader takes comes out the same.
#![no_main]

use host::csv::{parse_table, TimeAxis};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let jumps = parse_table(text, "fuzz.csv", &[], TimeAxis::JumpsAllowed);
    if let Ok(t) = &jumps {
        assert!(t.time.windows(2).all(|w| w[1] >= w[0]), "time decreasing");
        assert!(
            t.time.windows(3).all(|w| w[2] > w[0]),
            "a time on three rows"
        );
        if let Some(dt) = t.sample_interval() {
            assert!(dt > 0.0, "sample interval {dt} with jumps");
        }
    }
    let measured = host::csv::parse_measured_csv(text, "fuzz.csv");
    if let Ok(t) = &measured {
        assert!(
            t.time.windows(2).all(|w| w[1] > w[0]),
            "measured time not increasing"
        );
        assert!(
            t.time.iter().all(|x| x.is_finite()),
            "measured time not finite"
        );
        for col in &t.columns {
            assert!(
                col.iter().all(|x| x.is_finite() || x.is_nan()),
                "infinite sample"
            );
        }
    }
    let Ok(table) = host::csv::parse_csv(text, "fuzz.csv") else {
        return;
    };
    assert_eq!(
        measured.as_ref().ok(),
        Some(&table),
        "a complete table read otherwise as a measured record"
    );
    assert_eq!(
        jumps.as_ref().ok(),
        Some(&table),
        "the strict table read otherwise with jumps"
    );
    assert!(!table.time.is_empty(), "table without rows");
    assert_eq!(table.names.len(), table.columns.len());
    assert!(
        table.time.windows(2).all(|w| w[1] > w[0]),
        "time not increasing"
    );
    for (name, col) in table.names.iter().zip(&table.columns) {
        assert_eq!(
            col.len(),
            table.time.len(),
            "column {name} is not as long as time"
        );
        assert!(
            col.iter().all(|x| x.is_finite()),
            "non-finite value in {name}"
        );
        assert_eq!(table.column(name).map(|c| c.len()), Some(col.len()));
    }
    if let Some(dt) = table.sample_interval() {
        assert!(dt > 0.0, "sample interval {dt}");
    }
    // write and read back: numbers bit-identical (format_number is a shortest round-trip form).
    // The writer does not quote names, so names holding '"' are not expected to survive.
    if table.names.iter().any(|n| n.contains('"')) {
        return;
    }
    let mut out = Vec::new();
    host::csv::write_csv_to(&mut out, &table.time, &table.names, &table.columns).unwrap();
    let again = host::csv::parse_csv(std::str::from_utf8(&out).unwrap(), "again.csv")
        .unwrap_or_else(|e| {
            panic!(
                "written table does not read back: {e}\n{}",
                String::from_utf8_lossy(&out)
            )
        });
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&again.time), bits(&table.time));
    for (a, b) in again.columns.iter().zip(&table.columns) {
        assert_eq!(bits(a), bits(b));
    }
});
