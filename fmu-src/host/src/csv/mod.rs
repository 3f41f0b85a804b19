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
/// Err: the 1-based column and what is wrong there.
fn header_names(header: &str, dialect: Dialect) -> Result<Vec<String>, (usize, String)> {
    let mut names: Vec<String> = split_fields(header, dialect.separator, true)
        .map_err(|j| (j, "unterminated quote in the header".to_string()))?;
    match names.iter().position(|n| n.eq_ignore_ascii_case("time")) {
        // `Time`, `TIME`: the time column whatever its case (spreadsheets and Simulink capitalise it).
        Some(0) => names[0] = "time".to_string(),
        Some(j) => {
            let message = format!(
                "'time' must be the first column, found it in column {}",
                j + 1
            );
            return Err((j + 1, message));
        }
        None => {
            let message = format!(
                "no 'time' column: the header must start with 'time' (found '{}')",
                shown(&names[0])
            );
            return Err((1, message));
        }
    }
    for (j, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err((j + 1, "empty column name in the header".into()));
        }
        if let Some(k) = names[..j].iter().position(|m| m == n) {
            let message = format!(
                "column '{}' appears twice (also column {})",
                shown(n),
                k + 1
            );
            return Err((j + 1, message));
        }
    }
    Ok(names)
}

/// Why a numeric cell is refused; `column` and `cell` as shown in messages (cut short).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
enum CellError {
    #[error("empty cell in column '{column}'")]
    Empty { column: String },
    #[error("non-numeric cell '{cell}' in column '{column}'")]
    NonNumeric { cell: String, column: String },
    #[error("NaN in column '{column}'")]
    NaN { column: String },
    #[error("infinite value '{cell}' in column '{column}'")]
    Infinite { cell: String, column: String },
    #[error(
        "value '{cell}' in column '{column}' is beyond ±{MAX_MAGNITUDE:e}: too large to compute \
         with (its square overflows); check the units"
    )]
    TooLarge { cell: String, column: String },
}

/// The number of the numeric cell `cell` of column `name`; NaN for a missing sample where
/// `missing_allowed`.
fn numeric_cell(
    cell: &str,
    name: &str,
    dialect: Dialect,
    missing_allowed: bool,
) -> Result<f64, CellError> {
    let c = cell.trim();
    let missing = c.is_empty() || c.eq_ignore_ascii_case("nan");
    if missing && missing_allowed {
        return Ok(f64::NAN);
    }
    let (cell, column) = (shown(c), shown(name));
    match dialect.number(c) {
        None if c.is_empty() => Err(CellError::Empty { column }),
        None => Err(CellError::NonNumeric { cell, column }),
        Some(x) if x.is_nan() => Err(CellError::NaN { column }),
        Some(x) if !x.is_finite() => Err(CellError::Infinite { cell, column }),
        Some(x) if x.abs() > MAX_MAGNITUDE => Err(CellError::TooLarge { cell, column }),
        Some(x) => Ok(x),
    }
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
    let names = header_names(header, dialect).map_err(|(c, m)| err(hline, c, m))?;
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
                .map_err(|e| err(lno, j + 1, e.to_string()))?;
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
mod tests;
