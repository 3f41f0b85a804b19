//! Variable names against the naming convention a description declares (FMI 2.0.4 section
//! 2.2.9, FMI 3.0.2 section 2.4.7, the same grammar in both):
//!
//! ```text
//! flat:            name = Unicode-char { Unicode-char }   (no CR, LF nor tab)
//! structured:      name            = identifier | "der(" identifier ["," unsignedInteger ] ")"
//!                  identifier      = B-name [ arrayIndices ] {"." B-name [ arrayIndices ] }
//!                  B-name          = nondigit { digit | nondigit } | Q-name
//!                  nondigit        = "_" | letters "a" to "z" | letters "A" to "Z"
//!                  Q-name          = "'" ( Q-char | escape ) { Q-char | escape } "'"
//!                  Q-char          = nondigit | digit | "!" | "#" | "$" | "%" | "&" | "(" | ")"
//!                                    | "*" | "+" | "," | "-" | "." | "/" | ":" | ";" | "<" | ">"
//!                                    | "=" | "?" | "@" | "[" | "]" | "^" | "{" | "}" | "|" | "~"
//!                                    | " "
//!                  escape          = "\'" | "\"" | "\?" | "\\" | "\a" | "\b" | "\f" | "\n"
//!                                    | "\r" | "\t" | "\v"
//!                  arrayIndices    = "[" unsignedInteger {"," unsignedInteger} "]"
//!                  unsignedInteger = digit { digit }
//! ```

use std::fmt;

/// Where a structured name departs from the grammar: the position (in characters) and what
/// the grammar expects there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NameError {
    /// 0-based position of the first character that does not fit (the name's length at its end).
    pub at: usize,
    /// What the grammar allows there.
    pub expected: &'static str,
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "at character {}, expected {}",
            self.at + 1,
            self.expected
        )
    }
}

/// What is wrong with `name` under the convention `convention` (`flat` or `structured`; any
/// other value is the schema's finding, and the name is not judged).
pub(crate) fn name_problem(convention: &str, name: &str) -> Option<String> {
    match convention {
        "structured" => parse_structured(name).err().map(|e| {
            format!(
                "\"{}\" is not a name of the structured naming convention: {e}",
                host::shown(name, 80)
            )
        }),
        "flat" => name
            .contains(['\r', '\n', '\t'])
            .then(|| "a flat name may not contain a carriage return, line feed or tab".into()),
        _ => None,
    }
}

/// Parses `name` with the grammar of the structured naming convention.
pub fn parse_structured(name: &str) -> Result<(), NameError> {
    let chars: Vec<char> = name.chars().collect();
    let mut p = Parser { chars, at: 0 };
    if p.rest_starts_with("der(") {
        p.at += 4;
        p.identifier()?;
        if p.eat(',') {
            p.unsigned_integer()?;
        }
        p.expect(')', "\",\" or \")\"")?;
    } else {
        p.identifier()?;
    }
    match p.peek() {
        None => Ok(()),
        Some(_) => Err(p.error("\".\", \"[\" or the end of the name")),
    }
}

struct Parser {
    chars: Vec<char>,
    at: usize,
}

impl Parser {
    fn peek(&self) -> Option<char> {
        self.chars.get(self.at).copied()
    }

    fn error(&self, expected: &'static str) -> NameError {
        NameError {
            at: self.at,
            expected,
        }
    }

    fn rest_starts_with(&self, s: &str) -> bool {
        let rest = &self.chars[self.at..];
        s.chars().count() <= rest.len() && s.chars().zip(rest).all(|(a, b)| a == *b)
    }

    fn eat(&mut self, c: char) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.at += 1;
        }
        hit
    }

    fn expect(&mut self, c: char, expected: &'static str) -> Result<(), NameError> {
        if self.eat(c) {
            Ok(())
        } else {
            Err(self.error(expected))
        }
    }

    /// identifier = B-name [ arrayIndices ] {"." B-name [ arrayIndices ] }
    fn identifier(&mut self) -> Result<(), NameError> {
        loop {
            self.b_name()?;
            if self.peek() == Some('[') {
                self.array_indices()?;
            }
            if !self.eat('.') {
                return Ok(());
            }
        }
    }

    /// B-name = nondigit { digit | nondigit } | Q-name
    fn b_name(&mut self) -> Result<(), NameError> {
        match self.peek() {
            Some('\'') => self.q_name(),
            Some(c) if is_nondigit(c) => {
                while self
                    .peek()
                    .is_some_and(|c| is_nondigit(c) || c.is_ascii_digit())
                {
                    self.at += 1;
                }
                Ok(())
            }
            _ => Err(self.error("a letter, \"_\" or a quoted name '...'")),
        }
    }

    /// Q-name = "'" ( Q-char | escape ) { Q-char | escape } "'"
    fn q_name(&mut self) -> Result<(), NameError> {
        self.at += 1;
        let first = self.at;
        loop {
            match self.peek() {
                Some('\'') if self.at > first => {
                    self.at += 1;
                    return Ok(());
                }
                Some('\\') => {
                    self.at += 1;
                    match self.peek() {
                        Some('\'' | '"' | '?' | '\\' | 'a' | 'b' | 'f' | 'n' | 'r' | 't' | 'v') => {
                            self.at += 1
                        }
                        _ => {
                            return Err(self.error(
                                "an escape \\' \\\" \\? \\\\ \\a \\b \\f \\n \\r \\t or \\v",
                            ))
                        }
                    }
                }
                Some(c) if is_q_char(c) => self.at += 1,
                _ if self.at == first => {
                    return Err(self.error("a character of a quoted name (it may not be empty)"))
                }
                _ => return Err(self.error("a character of a quoted name or its closing \"'\"")),
            }
        }
    }

    /// arrayIndices = "[" unsignedInteger {"," unsignedInteger} "]"
    fn array_indices(&mut self) -> Result<(), NameError> {
        self.at += 1;
        loop {
            self.unsigned_integer()?;
            if !self.eat(',') {
                return self.expect(']', "\",\" or \"]\"");
            }
        }
    }

    /// unsignedInteger = digit { digit }
    fn unsigned_integer(&mut self) -> Result<(), NameError> {
        let start = self.at;
        while self.peek().is_some_and(|c| c.is_ascii_digit()) {
            self.at += 1;
        }
        if self.at == start {
            return Err(self.error("a digit"));
        }
        Ok(())
    }
}

/// nondigit = "_" | letters "a" to "z" | letters "A" to "Z"
fn is_nondigit(c: char) -> bool {
    c == '_' || c.is_ascii_alphabetic()
}

/// Q-char: a nondigit, a digit, a space or one of the listed marks (not "'", "\"" nor "\\").
fn is_q_char(c: char) -> bool {
    is_nondigit(c) || c.is_ascii_digit() || "!#$%&()*+,-./:;<>=?@[]^{}|~ ".contains(c)
}

#[cfg(test)]
mod tests {
    use super::{name_problem, parse_structured, NameError};

    #[test]
    fn the_examples_of_the_standard_are_structured_names() {
        // FMI 2.0.4 section 2.2.9 and FMI 3.0.2 section 2.4.7: every name the text gives
        for name in [
            "vehicle.engine.speed",
            "resistor12.u",
            "v_min",
            "robot.axis.'motor #234'",
            "der(pipe[3,4].T[14],2)",
            "vehicle.transmission.ratio",
            "vehicle.engine.inputSpeed",
            "robot.arm1.centerOfMass[1]",
            "transmission.rpms[0]",
            "T[1,1,1]",
            "T[2,3,1]",
        ] {
            assert_eq!(parse_structured(name), Ok(()), "{name}");
        }
    }

    #[test]
    fn derivatives_quoted_names_and_escapes_follow_the_grammar() {
        for name in [
            "der(x)",
            "der(x,12)",
            "der",
            "der.x",
            "_",
            "a.'b.c'.d[1]",
            r"'it\'s'",
            r"'tab\there'",
            "'[]{}()'",
            "'a\"'",
        ] {
            let valid = !name.contains('"');
            assert_eq!(parse_structured(name).is_ok(), valid, "{name}");
        }
    }

    #[test]
    fn names_outside_the_grammar_are_told_where_and_what_was_expected() {
        let cases: [(&str, usize, &str); 14] = [
            ("a..b[1", 2, "a letter"),
            ("1x", 0, "a letter"),
            ("", 0, "a letter"),
            ("x.", 2, "a letter"),
            ("x[]", 2, "a digit"),
            ("x[1,]", 4, "a digit"),
            ("x[1", 3, "\",\" or \"]\""),
            ("der(x,)", 6, "a digit"),
            ("der(x", 5, "\",\" or \")\""),
            ("der (x)", 3, "\".\", \"[\""),
            ("x y", 1, "\".\", \"[\""),
            (
                "''",
                1,
                "a character of a quoted name (it may not be empty)",
            ),
            ("'a'b", 3, "\".\", \"[\""),
            (r"'a\x'", 3, "an escape"),
        ];
        for (name, at, expected) in cases {
            let e: NameError = parse_structured(name).expect_err(name);
            assert_eq!(e.at, at, "{name}: {e}");
            assert!(e.expected.starts_with(expected), "{name}: {e}");
        }
        let e = parse_structured("x.ü").expect_err("non-ASCII letter");
        assert_eq!(e.at, 2);
    }

    #[test]
    fn the_convention_decides_which_names_are_judged() {
        assert!(name_problem("structured", "a..b[1").is_some());
        assert_eq!(name_problem("flat", "a..b[1"), None);
        assert!(name_problem("flat", "a\tb").is_some());
        assert_eq!(name_problem("unknown", "a..b"), None);
        let m = name_problem("structured", "a..b[1").unwrap();
        assert!(m.contains("at character 3, expected a letter"), "{m}");
    }
}
