//! Whether an attribute's text is a value of its XML Schema type (XML Schema Part 2: Datatypes,
//! the lexical spaces of the built-in types the FMI schemas use, with the white-space facet of
//! each: `collapse` for numbers, booleans, dates and lists, `replace` for normalized strings).
//!
//! One leniency follows libxml2 (the validator behind lxml and FMPy) rather than the letter of
//! Part 2: a number may end in an exponent mark without digits (`1e`, `2E+`), which libxml2
//! accepts; a finding the reference validators do not give would be a false finding.

use super::model::Ty;

/// XML white space (XML 1.0 production S): space, tab, line feed, carriage return.
pub(crate) fn is_xml_space(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\r')
}

/// The white-space facet `replace`: tab, line feed and carriage return become spaces.
fn replaced(s: &str) -> String {
    s.chars()
        .map(|c| if is_xml_space(c) { ' ' } else { c })
        .collect()
}

/// The white-space facet `collapse`: `replace`, runs of spaces as one, none at either end.
fn collapsed(s: &str) -> String {
    s.split(is_xml_space)
        .filter(|w| !w.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

/// What is wrong with `value` as a value of `ty`, as the end of a sentence that starts with the
/// attribute (`is not an xs:double`), or `None` when it is valid.
pub(crate) fn problem(ty: &Ty, value: &str) -> Option<String> {
    match ty {
        Ty::String | Ty::Normalized => None,
        Ty::Enum(values) => {
            let v = replaced(value);
            (!values.contains(&v.as_str())).then(|| format!("is not one of {}", values.join(", ")))
        }
        Ty::Fixed(fixed) => {
            (replaced(value) != *fixed).then(|| format!("differs from the fixed value \"{fixed}\""))
        }
        Ty::Pattern(matches, pattern) => {
            (!matches(&replaced(value))).then(|| format!("does not match the pattern {pattern}"))
        }
        Ty::List(item) => collapsed(value)
            .split(' ')
            .filter(|w| !w.is_empty())
            .find_map(|w| {
                problem(item, w).map(|p| format!("has the item \"{}\", which {p}", shown(w)))
            }),
        atomic => atomic_problem(atomic, &collapsed(value)),
    }
}

/// The problem of a collapsed value of a number, boolean, date or binary type.
fn atomic_problem(ty: &Ty, v: &str) -> Option<String> {
    let (valid, name) = match ty {
        Ty::Double => (is_double(v), "xs:double"),
        Ty::Float => (is_double(v), "xs:float"),
        Ty::Boolean => (matches!(v, "true" | "false" | "1" | "0"), "xs:boolean"),
        Ty::DateTime => (is_date_time(v), "xs:dateTime"),
        Ty::HexBinary => (
            v.len() % 2 == 0 && v.bytes().all(|b| b.is_ascii_hexdigit()),
            "xs:hexBinary",
        ),
        Ty::NonNegativeInteger => match integer(v) {
            Some((negative, digits)) => (!negative || digits.is_empty(), "xs:nonNegativeInteger"),
            None => (false, "xs:nonNegativeInteger"),
        },
        Ty::Int { min, max, name } => {
            return match integer(v) {
                None => Some(format!("is not an {name}")),
                Some(n) => (!in_range(n, *min, *max))
                    .then(|| format!("is outside the range of {name} ({min} to {max})")),
            }
        }
        _ => (true, ""),
    };
    (!valid).then(|| format!("is not an {name}"))
}

/// An integer literal `[+-]?[0-9]+` as (negative, its digits without leading zeros).
fn integer(v: &str) -> Option<(bool, &str)> {
    let (negative, digits) = match v.as_bytes().first() {
        Some(b'-') => (true, &v[1..]),
        Some(b'+') => (false, &v[1..]),
        _ => (false, v),
    };
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((negative, digits.trim_start_matches('0')))
}

/// Whether the integer (negative, digits) lies in `min..=max`.
fn in_range((negative, digits): (bool, &str), min: i128, max: i128) -> bool {
    // 39 digits hold every bound of an integer type up to 128 bits
    if digits.len() > 38 {
        return false;
    }
    let magnitude: i128 = if digits.is_empty() {
        0
    } else {
        digits.parse().unwrap_or(i128::MAX)
    };
    let n = if negative { -magnitude } else { magnitude };
    (min..=max).contains(&n)
}

/// The lexical space of `xs:double` and `xs:float`: `INF`, `-INF`, `NaN`, or an optional sign,
/// digits with an optional fraction (at least one digit), and an optional exponent.
fn is_double(v: &str) -> bool {
    if matches!(v, "INF" | "-INF" | "NaN") {
        return true;
    }
    let unsigned = v.strip_prefix(['+', '-']).unwrap_or(v);
    let (mantissa, exponent) = match unsigned.find(['e', 'E']) {
        Some(i) => (&unsigned[..i], Some(&unsigned[i + 1..])),
        None => (unsigned, None),
    };
    let (whole, fraction) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    let mantissa_ok =
        digits(whole) && digits(fraction) && !(whole.is_empty() && fraction.is_empty());
    let exponent_ok = exponent.is_none_or(|e| digits(e.strip_prefix(['+', '-']).unwrap_or(e)));
    mantissa_ok && exponent_ok
}

/// The lexical space of `xs:dateTime`: `-?YYYY-MM-DDThh:mm:ss(.s+)?(Z|(+|-)hh:mm)?`, a year of
/// at least four digits (no leading zero beyond four, not 0000), a day that exists in its month,
/// 24:00:00 as the end of a day, and a time zone within ±14:00.
fn is_date_time(v: &str) -> bool {
    let v = v.strip_prefix('-').unwrap_or(v);
    let Some((date, time)) = v.split_once('T') else {
        return false;
    };
    let mut parts = date.rsplitn(3, '-');
    let (Some(day), Some(month), Some(year)) = (parts.next(), parts.next(), parts.next()) else {
        return false;
    };
    let year_ok = year.len() >= 4
        && year.bytes().all(|b| b.is_ascii_digit())
        && !(year.len() > 4 && year.starts_with('0'))
        && year.bytes().any(|b| b != b'0');
    let (Some(month), Some(day)) = (two_digits(month), two_digits(day)) else {
        return false;
    };
    let leap = leap_year(year);
    year_ok && (1..=12).contains(&month) && (1..=days_in(month, leap)).contains(&day) && {
        let (clock, zone) = split_zone(time);
        is_clock(clock) && zone.is_none_or(is_zone)
    }
}

fn two_digits(s: &str) -> Option<u32> {
    (s.len() == 2 && s.bytes().all(|b| b.is_ascii_digit()))
        .then(|| s.parse().ok())
        .flatten()
}

fn leap_year(year: &str) -> bool {
    // the last four digits decide divisibility by 4, 100 and 400
    let tail: u32 = year[year.len().saturating_sub(4)..].parse().unwrap_or(1);
    tail % 4 == 0 && (tail % 100 != 0 || tail % 400 == 0)
}

fn days_in(month: u32, leap: bool) -> u32 {
    match month {
        2 if leap => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// `hh:mm:ss(.s+)?` and the time zone after it, if any.
fn split_zone(time: &str) -> (&str, Option<&str>) {
    match time.find(['Z', '+', '-']) {
        Some(i) => (&time[..i], Some(&time[i..])),
        None => (time, None),
    }
}

fn is_clock(clock: &str) -> bool {
    let (hms, fraction) = clock.split_once('.').unwrap_or((clock, ""));
    if clock.contains('.') && (fraction.is_empty() || !fraction.bytes().all(|b| b.is_ascii_digit()))
    {
        return false;
    }
    let mut it = hms.split(':').map(two_digits);
    let (Some(Some(h)), Some(Some(m)), Some(Some(s)), None) =
        (it.next(), it.next(), it.next(), it.next())
    else {
        return false;
    };
    (h < 24 && m < 60 && s < 60)
        || (h == 24 && m == 0 && s == 0 && fraction.bytes().all(|b| b == b'0'))
}

fn is_zone(zone: &str) -> bool {
    if zone == "Z" {
        return true;
    }
    let Some((h, m)) = zone[1..].split_once(':') else {
        return false;
    };
    match (two_digits(h), two_digits(m)) {
        (Some(h), Some(m)) => (h < 14 && m < 60) || (h == 14 && m == 0),
        _ => false,
    }
}

/// A value as a finding quotes it (at most 40 characters, escaped).
pub(crate) fn shown(v: &str) -> String {
    host::shown(v, 40)
}
