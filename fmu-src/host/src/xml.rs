//! Pieces shared by the model-description parsers: an element's attributes with the line of its
//! tag, typed attribute reads whose errors name file, line, element and attribute, and the walk
//! over a document's elements with their parents.

use crate::error::HostError;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::str::FromStr;

/// Attributes of one element with the line of its tag.
pub(crate) struct Attrs {
    pub(crate) pairs: Vec<(String, String)>,
    pub(crate) line: usize,
    pub(crate) element: String,
}

impl Attrs {
    pub(crate) fn get(&self, key: &str) -> Option<&str> {
        self.pairs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The text of an optional attribute.
    pub(crate) fn text(&self, key: &str) -> Option<String> {
        self.get(key).map(str::to_string)
    }
}

/// Where an element is in the document: the names of its ancestors, the root first.
pub(crate) type Ancestors<'a> = &'a [String];

/// What a parser does with the document's elements.
pub(crate) trait Visitor {
    /// An element opens (`<x ...>` or `<x .../>`) under `path`.
    fn element(&mut self, doc: &Doc<'_>, path: Ancestors<'_>, a: Attrs) -> Result<(), HostError>;
    /// The element `name` under `path` closes.
    fn end(&mut self, path: Ancestors<'_>, name: &str);
}

/// A document being read: its text, the name used in messages, the offsets of its lines.
pub(crate) struct Doc<'a> {
    xml: &'a str,
    pub(crate) file: String,
    newlines: Vec<usize>,
}

impl<'a> Doc<'a> {
    pub(crate) fn new(xml: &'a str, file: &str) -> Self {
        Doc {
            xml,
            file: file.to_string(),
            newlines: xml
                .bytes()
                .enumerate()
                .filter(|(_, b)| *b == b'\n')
                .map(|(i, _)| i)
                .collect(),
        }
    }

    pub(crate) fn err(&self, line: usize, message: impl Into<String>) -> HostError {
        HostError::ModelDescription {
            file: self.file.clone(),
            line,
            column: 0,
            message: message.into(),
        }
    }

    /// Line of the first non-blank character at or after byte `pos` (the tag's `<`).
    fn line_at(&self, pos: usize) -> usize {
        let mut pos = pos.min(self.xml.len());
        let bytes = self.xml.as_bytes();
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        self.line_col(pos).0
    }

    /// 1-based (line, column) of byte `pos` (binary search in the newline offsets).
    fn line_col(&self, pos: usize) -> (usize, usize) {
        let pos = pos.min(self.xml.len());
        let k = self.newlines.partition_point(|&p| p < pos);
        let line_start = if k == 0 { 0 } else { self.newlines[k - 1] + 1 };
        (k + 1, pos - line_start + 1)
    }

    fn attrs(&self, e: &BytesStart<'_>, line: usize) -> Result<Attrs, HostError> {
        let element = String::from_utf8_lossy(e.name().as_ref()).into_owned();
        let quoted = |text: &str| crate::error::shown(text, 40);
        let mut pairs = Vec::new();
        for a in e.attributes() {
            let a = a.map_err(|err| {
                let m = format!(
                    "<{}>: bad attribute: {}",
                    quoted(&element),
                    quoted(&err.to_string())
                );
                self.err(line, m)
            })?;
            let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
            let value = a
                .unescape_value()
                .map_err(|err| {
                    let (element, key, err) = (quoted(&element), quoted(&key), err.to_string());
                    self.err(line, format!("<{element}> {key}: {}", quoted(&err)))
                })?
                .into_owned();
            pairs.push((key, value));
        }
        Ok(Attrs {
            pairs,
            line,
            element,
        })
    }

    /// Walks every element in document order; the first syntax error ends the walk with its
    /// line and column, as does a root element other than `<fmiModelDescription>` (the root of
    /// both versions' schemas) or a document without one.
    pub(crate) fn walk(&self, v: &mut impl Visitor) -> Result<(), HostError> {
        let mut reader = Reader::from_str(self.xml);
        reader.config_mut().trim_text(true);
        let mut path: Vec<String> = Vec::new();
        let mut seen_root = false;
        loop {
            let pos = reader.buffer_position() as usize;
            let event = reader.read_event().map_err(|e| {
                let (line, column) = self.line_col(reader.error_position() as usize);
                HostError::ModelDescription {
                    file: self.file.clone(),
                    line,
                    column,
                    message: format!(
                        "malformed XML: {}",
                        crate::error::shown(&e.to_string(), 200)
                    ),
                }
            })?;
            match event {
                Event::Start(e) => {
                    let a = self.attrs(&e, self.line_at(pos))?;
                    seen_root |= self.root(&path, &a)?;
                    let name = a.element.clone();
                    v.element(self, &path, a)?;
                    path.push(name);
                }
                Event::Empty(e) => {
                    let a = self.attrs(&e, self.line_at(pos))?;
                    seen_root |= self.root(&path, &a)?;
                    let name = a.element.clone();
                    v.element(self, &path, a)?;
                    v.end(&path, &name);
                }
                Event::End(e) => {
                    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
                    path.pop();
                    v.end(&path, &name);
                }
                Event::Eof if !seen_root => {
                    return Err(self.err(1, "no <fmiModelDescription> root element"))
                }
                Event::Eof => return Ok(()),
                _ => {}
            }
        }
    }

    /// True when `a` is the root element (no ancestors); Err when that root is not
    /// `<fmiModelDescription>`.
    fn root(&self, path: Ancestors<'_>, a: &Attrs) -> Result<bool, HostError> {
        if !path.is_empty() {
            return Ok(false);
        }
        if a.element != "fmiModelDescription" {
            let other = crate::error::shown(&a.element, 40);
            let m = format!("root element is <{other}>, expected <fmiModelDescription>");
            return Err(self.err(a.line, m));
        }
        Ok(true)
    }

    /// `key` parsed as `T` (`what` names the type in the message), None when absent.
    pub(crate) fn parse<T: FromStr>(
        &self,
        a: &Attrs,
        key: &str,
        what: &str,
    ) -> Result<Option<T>, HostError> {
        self.parse_with(a, key, what, |s| s.trim().parse::<T>().ok())
    }

    /// An xs:double attribute.
    pub(crate) fn real(&self, a: &Attrs, key: &str) -> Result<Option<f64>, HostError> {
        self.parse_with(a, key, "a real number", parse_real)
    }

    /// An xs:boolean attribute.
    pub(crate) fn boolean(&self, a: &Attrs, key: &str) -> Result<Option<bool>, HostError> {
        self.parse_with(a, key, "a boolean", parse_bool)
    }

    /// `key` read by `read` (None: not a `what`), None when absent; the error names the element,
    /// the attribute and its text cut short.
    fn parse_with<T>(
        &self,
        a: &Attrs,
        key: &str,
        what: &str,
        read: impl FnOnce(&str) -> Option<T>,
    ) -> Result<Option<T>, HostError> {
        self.read_with(a, key, read, |s| {
            let shown = crate::error::shown(s, 60);
            format!("<{}> attribute {key}=\"{shown}\" is not {what}", a.element)
        })
    }

    /// `key` read by `read`, None when absent; `bad` gives the message for a text `read`
    /// refuses.
    pub(crate) fn read_with<T>(
        &self,
        a: &Attrs,
        key: &str,
        read: impl FnOnce(&str) -> Option<T>,
        bad: impl FnOnce(&str) -> String,
    ) -> Result<Option<T>, HostError> {
        let Some(s) = a.get(key) else { return Ok(None) };
        read(s).map(Some).ok_or_else(|| self.err(a.line, bad(s)))
    }

    /// A required attribute's text.
    pub(crate) fn required(&self, a: &Attrs, key: &str) -> Result<String, HostError> {
        a.text(key).ok_or_else(|| self.missing(a, key))
    }

    /// A required attribute parsed as `T` (`what` names the type in the message).
    pub(crate) fn parsed<T: FromStr>(
        &self,
        a: &Attrs,
        key: &str,
        what: &str,
    ) -> Result<T, HostError> {
        self.parse(a, key, what)?
            .ok_or_else(|| self.missing(a, key))
    }

    /// The error for an element `a` that `parent` may not contain.
    pub(crate) fn unknown_child(&self, parent: &str, a: &Attrs) -> HostError {
        let child = crate::error::shown(&a.element, 40);
        self.err(a.line, format!("<{parent}> has unknown element <{child}>"))
    }

    fn missing(&self, a: &Attrs, key: &str) -> HostError {
        let m = format!("<{}> lacks the required attribute {key}", a.element);
        self.err(a.line, m)
    }
}

/// Walks the document `xml` (named `file` in errors) with the parser `p` and returns it.
pub(crate) fn read<P: Visitor>(xml: &str, file: &str, mut p: P) -> Result<P, HostError> {
    Doc::new(xml, file).walk(&mut p)?;
    Ok(p)
}

/// Parses an xs:double (accepts INF, -INF, NaN as XML Schema writes them).
pub(crate) fn parse_real(s: &str) -> Option<f64> {
    match s.trim() {
        "INF" => Some(f64::INFINITY),
        "-INF" => Some(f64::NEG_INFINITY),
        "NaN" => Some(f64::NAN),
        t => t.parse::<f64>().ok(),
    }
}

/// Parses an xs:boolean (`true`, `false`, `1`, `0`).
pub(crate) fn parse_bool(s: &str) -> Option<bool> {
    match s.trim() {
        "true" | "1" => Some(true),
        "false" | "0" => Some(false),
        _ => None,
    }
}
