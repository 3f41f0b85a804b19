//! Measured / input CSV files: `time` first, numeric cells, SI units.
//!
//! Every error names the file, the 1-based line and the 1-based column (field index), and the
//! column's header name where there is one.
//!
//! Why our own instead of the `csv` crate: the reader must bound each line's length and the
//! file's size before buffering them (hostile inputs such as `/dev/zero`), report the 1-based
//! line and column with the header name, refuse non-finite numbers with that location, and parse
//! straight into columns of f64; the format accepted is the plain RFC 4180 subset FMPy and
//! spreadsheets write, so quoting is all the `csv` crate would add.

use crate::view::{Causality, ModelView, VarKind};
use std::fmt;
use std::io::Write;
use std::path::Path;

/// A CSV problem located in the file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct CsvError {
    /// File as given.
    pub file: String,
    /// 1-based line (0 when the file could not be read at all).
    pub line: usize,
    /// 1-based column (field index; 0 when not about one column).
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for CsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (0, _) => write!(f, "{}: {}", self.file, self.message),
            (l, 0) => write!(f, "{}:{l}: {}", self.file, self.message),
            (l, c) => write!(f, "{}:{l}:{c}: {}", self.file, self.message),
        }
    }
}

/// A parsed CSV: the `time` column and the other columns by header name.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// File name used in messages.
    pub file: String,
    /// The `time` column (increasing; strictly unless read with [`TimeAxis::JumpsAllowed`]).
    pub time: Vec<f64>,
    /// Header names of the other columns, in file order.
    pub names: Vec<String>,
    /// `columns[j][k]`: column `names[j]` at `time[k]`.
    pub columns: Vec<Vec<f64>>,
    /// Columns read as text (String variables), (name, cells), in file order.
    pub text: Vec<(String, Vec<String>)>,
}

impl Table {
    /// Cells of the text column `name`.
    pub fn text_column(&self, name: &str) -> Option<&[String]> {
        self.text
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, c)| c.as_slice())
    }

    /// Every column name but `time`: numeric columns, then text columns.
    pub fn all_names(&self) -> impl Iterator<Item = &String> {
        self.names.iter().chain(self.text.iter().map(|(n, _)| n))
    }

    /// Samples of column `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|j| self.columns[j].as_slice())
    }

    /// The sample interval of the `time` column: see [`sample_interval`].
    pub fn sample_interval(&self) -> Option<f64> {
        sample_interval(&self.time)
    }

    /// Checks every column against the FMU: each must be an input or an output of it.
    /// Returns the error for the first unknown column (line 1, its column number).
    pub fn check_against(&self, md: &ModelView) -> Result<(), CsvError> {
        for (j, name) in self.all_names().enumerate() {
            let ok = md.input_of(name).is_some()
                || md
                    .scalar(name)
                    .map(|v| v.causality == Causality::Output)
                    .unwrap_or(false);
            if !ok {
                let what = if md.scalar(name).is_some() {
                    "is neither an input nor an output of the FMU"
                } else {
                    "is not a variable of the FMU"
                };
                let inputs = md.input_names().join(", ");
                let outputs = md.output_names().join(", ");
                return Err(CsvError {
                    file: self.file.clone(),
                    line: 1,
                    column: j + 2,
                    message: format!(
                        "column '{name}' {what} (inputs: {}; outputs: {})",
                        if inputs.is_empty() { "none" } else { &inputs },
                        if outputs.is_empty() { "none" } else { &outputs }
                    ),
                });
            }
        }
        Ok(())
    }

    /// Names of the columns that are inputs of the FMU or aliases of one.
    pub fn input_columns(&self, md: &ModelView) -> Vec<String> {
        self.all_names()
            .filter(|n| md.input_of(n).is_some())
            .cloned()
            .collect()
    }

    /// Names of the columns that are outputs of the FMU.
    pub fn output_columns(&self, md: &ModelView) -> Vec<String> {
        self.all_names()
            .filter(|n| {
                md.scalar(n)
                    .map(|v| v.causality == Causality::Output)
                    .unwrap_or(false)
            })
            .cloned()
            .collect()
    }
}

/// The sample interval of a time grid. For a uniform grid (every interval within 1e-6 of the
/// mean) it is `(t_last - t_first) / (n - 1)`, snapped to 12 significant digits when that changes it by
/// less than 1e-9 relative (so a grid written as `k * 0.001` gives exactly `0.001`, not the
/// rounding noise of one difference); otherwise the median interval. None with fewer than
/// 2 rows.
pub fn sample_interval(time: &[f64]) -> Option<f64> {
    // A time repeated for a jump of the inputs is one sample instant.
    let mut time = time.to_vec();
    time.dedup();
    let n = time.len();
    if n < 2 {
        return None;
    }
    let mean = (time[n - 1] - time[0]) / (n - 1) as f64;
    let uniform = time
        .windows(2)
        .all(|w| ((w[1] - w[0]) - mean).abs() <= 1e-6 * mean);
    if uniform {
        let snapped: f64 = format!("{mean:.11e}").parse().unwrap_or(mean);
        return Some(if ((snapped - mean) / mean).abs() < 1e-9 {
            snapped
        } else {
            mean
        });
    }
    let mut d: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

/// Largest CSV file read: far above any measured trace (10 s at 1 kHz with 12 columns is
/// 1.3 MB), bounded so that a hostile input ends in a message rather than exhausted memory.
pub const MAX_CSV_BYTES: u64 = 1 << 30;
/// Longest line read (bytes): a row of a thousand numbers is 25 kB.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// What the `time` column may do from row to row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeAxis {
    /// Time increases strictly: a measured record, a reference result.
    Strict,
    /// Time increases, or repeats once: two rows at one time are the values just before and
    /// just after a jump of the inputs (FMPy's input convention, `Input.findEvents`).
    JumpsAllowed,
}

/// Reads and parses the CSV at `path`, bounded by [`MAX_CSV_BYTES`] and [`MAX_LINE_BYTES`]
/// while reading (`/dev/zero` or a file of one endless line is refused after 1 MiB); time
/// must increase strictly.
pub fn read_csv(path: &Path) -> Result<Table, CsvError> {
    read_csv_with_text(path, &[], TimeAxis::Strict)
}

/// The input CSV of a run of an FMU: the columns of its String variables are read as text, and
/// a time may repeat once (a jump).
pub fn read_csv_for(path: &Path, md: &ModelView) -> Result<Table, CsvError> {
    let text: Vec<String> = md
        .scalars()
        .filter(|v| v.scalar_kind() == Some(VarKind::String))
        .map(|v| v.name.clone())
        .collect();
    read_csv_with_text(path, &text, TimeAxis::JumpsAllowed)
}

/// [`read_csv`] with the columns named in `text_columns` kept as text and the time axis `time`.
pub fn read_csv_with_text(
    path: &Path,
    text_columns: &[String],
    time: TimeAxis,
) -> Result<Table, CsvError> {
    let (text, file) = read_text(path)?;
    parse_table(&text, &file, text_columns, time)
}

/// A measured record: [`read_csv`], but an empty numeric cell or one reading `NaN` (any case) is
/// a missing sample, read as NaN, where any other file refuses it. Time may not miss.
pub fn read_measured_csv(path: &Path) -> Result<Table, CsvError> {
    let (text, file) = read_text(path)?;
    parse_measured_csv(&text, &file)
}

/// The text of a measured record: [`parse_csv`], with missing samples read as NaN
/// ([`read_measured_csv`]).
pub fn parse_measured_csv(text: &str, file: &str) -> Result<Table, CsvError> {
    let rules = Rules {
        time: TimeAxis::Strict,
        missing_allowed: true,
    };
    parse_with(text, file, &[], rules)
}

/// The UTF-8 text of the file at `path` and its name for messages, read within the bounds.
fn read_text(path: &Path) -> Result<(String, String), CsvError> {
    let file = path.display().to_string();
    let err = |line: usize, column: usize, message: String| CsvError {
        file: file.clone(),
        line,
        column,
        message,
    };
    let bytes = read_bounded(path).map_err(|(line, message)| err(line, 0, message))?;
    match String::from_utf8(bytes) {
        Ok(t) => Ok((t, file)),
        Err(e) => {
            let bytes = e.as_bytes();
            let bad = e.utf8_error().valid_up_to();
            let line_start = bytes[..bad]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1);
            let line = 1 + bytes[..bad].iter().filter(|&&b| b == b'\n').count();
            let column = 1 + String::from_utf8_lossy(&bytes[line_start..bad])
                .chars()
                .count();
            Err(err(
                line,
                column,
                "not UTF-8 text (invalid byte sequence)".into(),
            ))
        }
    }
}

/// The file's bytes, or (line, message) when it cannot be read or exceeds a bound.
fn read_bounded(path: &Path) -> Result<Vec<u8>, (usize, String)> {
    use std::io::Read;
    let f = std::fs::File::open(path).map_err(|e| (0, format!("cannot read: {e}")))?;
    let mut reader = std::io::BufReader::new(f).take(MAX_CSV_BYTES + 1);
    let mut bytes = Vec::new();
    let mut chunk = vec![0u8; 1 << 16];
    let (mut line, mut line_len) = (1usize, 0usize);
    loop {
        let n = reader
            .read(&mut chunk)
            .map_err(|e| (0, format!("cannot read: {e}")))?;
        if n == 0 {
            return Ok(bytes);
        }
        for &b in &chunk[..n] {
            if b == b'\n' {
                line += 1;
                line_len = 0;
            } else {
                line_len += 1;
                if line_len > MAX_LINE_BYTES {
                    return Err((line, format!("line longer than {MAX_LINE_BYTES} bytes")));
                }
            }
        }
        bytes.extend_from_slice(&chunk[..n]);
        if bytes.len() as u64 > MAX_CSV_BYTES {
            return Err((0, format!("file larger than {MAX_CSV_BYTES} bytes")));
        }
    }
}

/// A cell as shown in a message: at most 40 characters, control characters escaped.
fn shown(cell: &str) -> String {
    crate::error::shown(cell, 40)
}

/// How a file separates its fields and writes its decimals.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Dialect {
    /// `,` (RFC 4180, FMPy), else `;` or a tab.
    separator: char,
    /// Whether a number may carry a decimal comma (`0,25`).
    decimal_comma: bool,
}

impl Dialect {
    /// The dialect of a file, read from its header line. A header with no comma outside quotes
    /// but a semicolon or a tab is a spreadsheet's export in a locale whose decimal mark is the
    /// comma (Excel in German or French writes `time;x` and `0,25;1,5`): such a file's numbers
    /// may carry a decimal comma, which cannot be mistaken for a separator there.
    fn of_header(header: &str) -> Dialect {
        let unquoted: String = header.split('"').step_by(2).collect();
        let separator = if unquoted.contains(',') {
            ','
        } else if unquoted.contains(';') {
            ';'
        } else if unquoted.contains('\t') {
            '\t'
        } else {
            ','
        };
        Dialect {
            separator,
            decimal_comma: separator != ',',
        }
    }

    /// The number a trimmed numeric cell holds.
    fn number(self, cell: &str) -> Option<f64> {
        if self.decimal_comma && cell.contains(',') {
            cell.replace(',', ".").parse().ok()
        } else {
            cell.parse().ok()
        }
    }
}

/// Splits one CSV line into its fields (RFC 4180): a field in double quotes may hold commas and
/// doubled quotes (`""` for `"`), so FMI names such as `x[1,2]` survive. Unquoted fields are
/// trimmed when `trim_unquoted` (header names), else kept as written (RFC 4180: spaces are part
/// of a field, which text cells keep; numeric cells are trimmed when parsed).
/// Err(column) for a quote left open.
fn split_fields(line: &str, separator: char, trim_unquoted: bool) -> Result<Vec<String>, usize> {
    let mut fields = Vec::new();
    let mut cur = String::new();
    // Length of the quoted text of the current field once its closing quote is seen.
    let mut quoted_len: Option<usize> = None;
    let mut in_quotes = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        if in_quotes {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    cur.push('"');
                } else {
                    in_quotes = false;
                    quoted_len = Some(cur.len());
                }
            } else {
                cur.push(c);
            }
        } else if c == '"' && quoted_len.is_none() && cur.trim().is_empty() {
            cur.clear();
            in_quotes = true;
        } else if c == separator {
            fields.push(finish_field(&cur, quoted_len, trim_unquoted));
            cur.clear();
            quoted_len = None;
        } else {
            cur.push(c);
        }
    }
    if in_quotes {
        return Err(fields.len() + 1);
    }
    fields.push(finish_field(&cur, quoted_len, trim_unquoted));
    Ok(fields)
}

/// A field's text: a quoted one as written inside its quotes (blank text after the closing quote
/// is ignored, other text kept), an unquoted one as is or trimmed.
fn finish_field(raw: &str, quoted_len: Option<usize>, trim_unquoted: bool) -> String {
    match quoted_len {
        Some(n) if raw[n..].trim().is_empty() => raw[..n].to_string(),
        None if !trim_unquoted => raw.to_string(),
        _ => raw.trim().to_string(),
    }
}

/// One field for a CSV line (RFC 4180): in double quotes, with `"` doubled, when it holds a
/// comma, a quote, a line break or leading/trailing spaces; as is otherwise.
pub fn quote_field(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains([',', '"', '\n', '\r']) || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\"")).into()
    } else {
        s.into()
    }
}

/// Parses CSV text; `file` names it in errors. Blank lines and lines starting with `#` are
/// skipped (comments, e.g. the data's source).
pub fn parse_csv(text: &str, file: &str) -> Result<Table, CsvError> {
    parse_csv_with_text(text, file, &[])
}

/// Why the time `x` may not follow the time `prev` of line `prev_line`.
fn time_error(axis: TimeAxis, x: f64, prev: f64, prev_line: usize) -> String {
    match axis {
        TimeAxis::Strict => format!(
            "time {x} is not greater than {prev} on line {prev_line}: time must increase strictly"
        ),
        TimeAxis::JumpsAllowed if x == prev => format!(
            "time {x} is on line {prev_line} and the line before already: a jump of the inputs \
             takes two rows at one time (the values before and after it), not three"
        ),
        TimeAxis::JumpsAllowed => format!(
            "time {x} is less than {prev} on line {prev_line}: time must increase (a time \
             repeated once is a jump of the inputs)"
        ),
    }
}

/// Largest magnitude accepted in a numeric cell. Physical data in SI units stay far below it,
/// and beyond it the squares summed by fits and error measures overflow (1e300² is infinite),
/// so such a value is almost surely a unit or format error: refused with its location.
pub const MAX_MAGNITUDE: f64 = 1e100;

/// [`parse_csv`] with the columns named in `text_columns` kept as text (String variables).
pub fn parse_csv_with_text(
    text: &str,
    file: &str,
    text_columns: &[String],
) -> Result<Table, CsvError> {
    parse_table(text, file, text_columns, TimeAxis::Strict)
}

/// [`parse_csv_with_text`] with the time axis `time`.
pub fn parse_table(
    text: &str,
    file: &str,
    text_columns: &[String],
    time: TimeAxis,
) -> Result<Table, CsvError> {
    let rules = Rules {
        time,
        missing_allowed: false,
    };
    parse_with(text, file, text_columns, rules)
}

/// What a file may hold besides complete rows of numbers on a rising time axis.
#[derive(Clone, Copy, Debug)]
struct Rules {
    /// What the time column may do from row to row.
    time: TimeAxis,
    /// Whether an empty or `NaN` numeric cell (not time) is a missing sample, read as NaN.
    missing_allowed: bool,
}

/// The header's column names (`time` first), checked.
fn header_names(
    header: &str,
    line: usize,
    dialect: Dialect,
) -> Result<Vec<String>, (usize, usize, String)> {
    let mut names: Vec<String> = split_fields(header, dialect.separator, true)
        .map_err(|j| (line, j, "unterminated quote in the header".to_string()))?;
    match names.iter().position(|n| n.eq_ignore_ascii_case("time")) {
        // `Time`, `TIME`: the time column whatever its case (spreadsheets and Simulink capitalise it).
        Some(0) => names[0] = "time".to_string(),
        Some(j) => {
            let message = format!(
                "'time' must be the first column, found it in column {}",
                j + 1
            );
            return Err((line, j + 1, message));
        }
        None => {
            let message = format!(
                "no 'time' column: the header must start with 'time' (found '{}')",
                shown(&names[0])
            );
            return Err((line, 1, message));
        }
    }
    for (j, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err((line, j + 1, "empty column name in the header".into()));
        }
        if let Some(k) = names[..j].iter().position(|m| m == n) {
            let message = format!(
                "column '{}' appears twice (also column {})",
                shown(n),
                k + 1
            );
            return Err((line, j + 1, message));
        }
    }
    Ok(names)
}

/// The number of the numeric cell `cell` of column `name`; NaN for a missing sample where
/// `missing_allowed`. Err: why the cell is refused.
fn numeric_cell(
    cell: &str,
    name: &str,
    dialect: Dialect,
    missing_allowed: bool,
) -> Result<f64, String> {
    let c = cell.trim();
    let missing = c.is_empty() || c.eq_ignore_ascii_case("nan");
    if missing && missing_allowed {
        return Ok(f64::NAN);
    }
    let Some(x) = dialect.number(c) else {
        return Err(if c.is_empty() {
            format!("empty cell in column '{}'", shown(name))
        } else {
            format!(
                "non-numeric cell '{}' in column '{}'",
                shown(c),
                shown(name)
            )
        });
    };
    if x.is_nan() {
        return Err(format!("NaN in column '{}'", shown(name)));
    }
    if !x.is_finite() {
        return Err(format!(
            "infinite value '{}' in column '{}'",
            shown(c),
            shown(name)
        ));
    }
    if x.abs() > MAX_MAGNITUDE {
        return Err(format!(
            "value '{}' in column '{}' is beyond ±{MAX_MAGNITUDE:e}: too large to compute with \
             (its square overflows); check the units",
            shown(c),
            shown(name)
        ));
    }
    Ok(x)
}

/// [`parse_table`] under `rules`.
fn parse_with(
    text: &str,
    file: &str,
    text_columns: &[String],
    rules: Rules,
) -> Result<Table, CsvError> {
    let err = |line: usize, column: usize, message: String| CsvError {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((hline, header)) = lines.next() else {
        return Err(err(
            1,
            0,
            "empty file: expected a header line starting with 'time'".into(),
        ));
    };
    let dialect = Dialect::of_header(header);
    let names = header_names(header, hline, dialect).map_err(|(l, c, m)| err(l, c, m))?;
    let ncol = names.len();
    let is_text: Vec<bool> = names
        .iter()
        .enumerate()
        .map(|(j, n)| j > 0 && text_columns.contains(n))
        .collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); ncol];
    let mut texts: Vec<Vec<String>> = vec![Vec::new(); ncol];
    // (time, its line, whether the row before had the same time)
    let mut last_time: Option<(f64, usize, bool)> = None;
    for (lno, line) in lines {
        let cells: Vec<String> = split_fields(line, dialect.separator, false)
            .map_err(|j| err(lno, j, "unterminated quote".into()))?;
        if cells.len() != ncol {
            return Err(err(
                lno,
                cells.len().min(ncol) + 1,
                format!("row has {} cells, the header has {ncol}", cells.len()),
            ));
        }
        for (j, cell) in cells.into_iter().enumerate() {
            if is_text[j] {
                texts[j].push(cell);
                continue;
            }
            let missing_allowed = rules.missing_allowed && j > 0;
            let x = numeric_cell(&cell, &names[j], dialect, missing_allowed)
                .map_err(|m| err(lno, j + 1, m))?;
            if j == 0 {
                let jump = last_time.is_some_and(|(prev, _, repeated)| {
                    rules.time == TimeAxis::JumpsAllowed && x == prev && !repeated
                });
                if let Some((prev, pl, _)) = last_time.filter(|l| x <= l.0 && !jump) {
                    return Err(err(lno, 1, time_error(rules.time, x, prev, pl)));
                }
                last_time = Some((x, lno, jump));
            }
            cols[j].push(x);
        }
    }
    if cols[0].is_empty() {
        return Err(err(hline + 1, 0, "no data rows after the header".into()));
    }
    let time = cols.remove(0);
    let (mut num_names, mut num_cols, mut text) = (Vec::new(), Vec::new(), Vec::new());
    // `names` still starts with `time`; `cols` no longer does.
    for (j, (name, col)) in names.into_iter().skip(1).zip(cols).enumerate() {
        let j = j + 1;
        if is_text[j] {
            text.push((name, std::mem::take(&mut texts[j])));
        } else {
            num_names.push(name);
            num_cols.push(col);
        }
    }
    Ok(Table {
        file: file.to_string(),
        time,
        names: num_names,
        columns: num_cols,
        text,
    })
}

/// Formats a number so that it reads back exactly (shortest round-trip form).
pub fn format_number(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Writes `time` and `columns` (each as long as `time`) as CSV with header `time,names...`.
pub fn write_csv_to<W: Write>(
    w: W,
    time: &[f64],
    names: &[String],
    columns: &[Vec<f64>],
) -> std::io::Result<()> {
    write_csv_text_to(w, time, names, columns, &[])
}

/// [`write_csv_to`] followed by text columns `(name, cells)`, quoted as RFC 4180 requires.
pub fn write_csv_text_to<W: Write>(
    mut w: W,
    time: &[f64],
    names: &[String],
    columns: &[Vec<f64>],
    text: &[(String, Vec<String>)],
) -> std::io::Result<()> {
    let mut line = String::from("time");
    for n in names.iter().chain(text.iter().map(|(n, _)| n)) {
        line.push(',');
        line.push_str(&quote_field(n));
    }
    line.push('\n');
    w.write_all(line.as_bytes())?;
    for (k, &t) in time.iter().enumerate() {
        line.clear();
        line.push_str(&format_number(t));
        for c in columns {
            line.push(',');
            line.push_str(&format_number(c.get(k).copied().unwrap_or(f64::NAN)));
        }
        for (_, c) in text {
            line.push(',');
            line.push_str(&quote_field(c.get(k).map_or("", String::as_str)));
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
    }
    w.flush()
}

/// Writes a CSV file (see [`write_csv_to`]).
pub fn write_csv(
    path: &Path,
    time: &[f64],
    names: &[String],
    columns: &[Vec<f64>],
) -> std::io::Result<()> {
    write_csv_text(path, time, names, columns, &[])
}

/// Writes a CSV file with text columns (see [`write_csv_text_to`]).
pub fn write_csv_text(
    path: &Path,
    time: &[f64],
    names: &[String],
    columns: &[Vec<f64>],
    text: &[(String, Vec<String>)],
) -> std::io::Result<()> {
    write_atomically(path, |f| {
        write_csv_text_to(std::io::BufWriter::new(f), time, names, columns, text)
    })
}

/// Writes `path` through a temporary file in the same directory, renamed over `path` once
/// complete: an interrupted run never leaves half a file in place of a good one.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&std::fs::File) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".actuator-fmu-")
        .suffix(".partial")
        .make_in(dir, |p| {
            // Listed for the supervisor before it exists: a worker killed while writing
            // (Ctrl-C) cannot remove it itself.
            crate::watch::register_output(p)?;
            std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create_new(true)
                .open(p)
        })?;
    write(tmp.as_file())?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
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
}
