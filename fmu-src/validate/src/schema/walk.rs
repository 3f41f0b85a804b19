//! The walk over a description's elements that checks each against its declaration: the
//! attributes it has, their values, the attributes it lacks, its children in the order and
//! number its content model allows, and text only where the content is mixed. It also gathers
//! what the naming rules need (the naming convention and every variable's name and line).

use super::content::{Automaton, Matched, States};
use super::model::{Content, Elem, Schema};
use super::types::{is_xml_space, problem, shown};
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::collections::HashMap;
use std::rc::Rc;

/// The namespace of `xsi:` attributes, which every element may carry.
const XSI: &str = "http://www.w3.org/2001/XMLSchema-instance";

/// One departure from the schema.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Problem {
    pub(crate) line: usize,
    /// The element the problem is at (`<Annotation>`).
    pub(crate) element: String,
    /// The schema file whose declaration is violated.
    pub(crate) xsd: &'static str,
    pub(crate) message: String,
}

/// What the walk found and gathered.
#[derive(Debug, Default)]
pub(crate) struct Walked {
    pub(crate) problems: Vec<Problem>,
    /// `variableNamingConvention` of the root, if given.
    pub(crate) convention: Option<String>,
    /// The `name` of each variable (and FMI 3.0 `<Alias>`) with its line.
    pub(crate) names: Vec<(String, usize)>,
}

/// How an open element is checked.
enum Check {
    /// Against its declaration: `states` is where its content model is after the children so
    /// far; `broken` once a child was out of place (the order is not checked further).
    Declared {
        elem: &'static Elem,
        automaton: Option<Rc<Automaton>>,
        states: States,
        broken: bool,
    },
    /// Content a wildcard or `xs:anyType` allows: free, except elements the schema declares
    /// globally.
    Lax,
    /// An element the schema does not allow where it is: reported once, its content not checked.
    Skipped,
}

struct Frame {
    name: String,
    check: Check,
    /// Namespace bindings this element declares (popped with it).
    bindings: usize,
    /// The line of its start tag.
    line: usize,
    text_reported: bool,
}

/// The walk's state.
struct Walker<'x> {
    schema: &'static Schema,
    xml: &'x str,
    newlines: Vec<usize>,
    automata: HashMap<usize, Rc<Automaton>>,
    frames: Vec<Frame>,
    /// (prefix, namespace) in scope, innermost last; the prefix "" is the default namespace.
    bindings: Vec<(String, String)>,
    out: Walked,
}

/// Checks `xml` against `schema`. A syntax error ends the walk (the description parser reports
/// it); what was found before it is kept.
pub(crate) fn walk(schema: &'static Schema, xml: &str) -> Walked {
    let mut w = Walker {
        schema,
        xml,
        newlines: xml.match_indices('\n').map(|(i, _)| i).collect(),
        automata: HashMap::new(),
        frames: Vec::new(),
        bindings: Vec::new(),
        out: Walked::default(),
    };
    let mut reader = Reader::from_str(xml);
    loop {
        let pos = reader.buffer_position() as usize;
        let Ok(event) = reader.read_event() else {
            break;
        };
        let ok = match event {
            Event::Start(e) => w.open(&e, pos),
            Event::Empty(e) => w.open(&e, pos) && w.close(),
            Event::End(_) => w.close(),
            Event::Text(t) => {
                let text = t.unescape().map(|c| c.into_owned());
                w.text(
                    &text.unwrap_or_else(|_| String::from_utf8_lossy(&t).into_owned()),
                    pos,
                )
            }
            Event::CData(c) => w.text(&String::from_utf8_lossy(&c), pos),
            Event::Eof => break,
            _ => true,
        };
        if !ok {
            break;
        }
    }
    w.out
}

impl Walker<'_> {
    fn line(&self, pos: usize) -> usize {
        self.newlines
            .partition_point(|&p| p < pos.min(self.xml.len()))
            + 1
    }

    fn report(&mut self, line: usize, element: &str, xsd: &'static str, message: String) {
        self.out.problems.push(Problem {
            line,
            element: format!("<{}>", shown(element)),
            xsd,
            message,
        });
    }

    fn automaton(&mut self, elem: &'static Elem) -> Option<Rc<Automaton>> {
        let particle = elem.particle()?;
        let key = elem as *const Elem as usize;
        Some(
            self.automata
                .entry(key)
                .or_insert_with(|| Rc::new(Automaton::new(particle)))
                .clone(),
        )
    }

    fn declared(&mut self, elem: &'static Elem) -> Check {
        let automaton = self.automaton(elem);
        let states = automaton.as_ref().map(|a| a.start()).unwrap_or_default();
        Check::Declared {
            elem,
            automaton,
            states,
            broken: false,
        }
    }

    /// A global declaration for an element a wildcard took, else free content.
    fn lax(&mut self, name: Option<&str>) -> Check {
        match self.schema.globals.iter().find(|g| Some(g.name) == name) {
            Some(g) => self.declared(g),
            None => Check::Lax,
        }
    }

    /// An element opens: returns false to end the walk (a syntax error).
    fn open(&mut self, e: &BytesStart<'_>, pos: usize) -> bool {
        let line = self.line(pos);
        let qname = String::from_utf8_lossy(e.name().as_ref()).into_owned();
        let Some(attrs) = attributes(e) else {
            return false;
        };
        let before = self.bindings.len();
        for (key, value) in &attrs {
            if key == "xmlns" {
                self.bindings.push((String::new(), value.clone()));
            } else if let Some(prefix) = key.strip_prefix("xmlns:") {
                self.bindings.push((prefix.to_string(), value.clone()));
            }
        }
        let name = self.local_name(&qname);
        let check = self.child_check(&qname, name.as_deref(), line);
        if let Check::Declared { elem, .. } = check {
            self.check_attributes(elem, &attrs, line);
            self.gather(elem, &attrs, line);
        }
        self.frames.push(Frame {
            name: qname,
            check,
            bindings: self.bindings.len() - before,
            line,
            text_reported: false,
        });
        true
    }

    /// The name of an element in no namespace; `None` for one in a namespace (which no FMI
    /// declaration names).
    fn local_name(&self, qname: &str) -> Option<String> {
        if qname.contains(':') {
            return None;
        }
        let default = self.bindings.iter().rev().find(|(p, _)| p.is_empty());
        match default {
            Some((_, ns)) if !ns.is_empty() => None,
            _ => Some(qname.to_string()),
        }
    }

    /// How a child named `qname` (`name` without namespace) of the innermost element is checked,
    /// reporting it when it is out of place.
    fn child_check(&mut self, qname: &str, name: Option<&str>, line: usize) -> Check {
        let root = self.schema.root;
        let Some(parent) = self.frames.last_mut() else {
            if name == Some(root.name) {
                return self.declared(root);
            }
            let m = format!("the root element must be <{}>", root.name);
            self.report(line, qname, root.xsd, m);
            return Check::Skipped;
        };
        let (elem, automaton, states, broken) = match &mut parent.check {
            Check::Lax => return self.lax(name),
            Check::Skipped => return Check::Skipped,
            Check::Declared {
                elem,
                automaton,
                states,
                broken,
            } => (*elem, automaton.clone(), states, broken),
        };
        if matches!(elem.content, Content::AnyType) {
            return self.lax(name);
        }
        let step = automaton
            .as_ref()
            .and_then(|a| (!*broken).then(|| a.step(states, name)).flatten());
        match step {
            Some((next, Matched::Elem(e))) => {
                *states = next;
                self.declared(e)
            }
            Some((next, Matched::Any)) => {
                *states = next;
                self.lax(name)
            }
            None => {
                let was_broken = std::mem::replace(broken, true);
                let out_of_place = automaton.as_ref().and_then(|a| a.declared(name?));
                let expected = automaton
                    .as_ref()
                    .map(|a| a.expected(states))
                    .unwrap_or_default();
                if !was_broken {
                    let m = misplaced(elem, qname, out_of_place.is_some(), &expected);
                    self.report(line, qname, elem.xsd, m);
                }
                match out_of_place {
                    Some(e) => self.declared(e),
                    None => Check::Skipped,
                }
            }
        }
    }

    fn check_attributes(&mut self, elem: &'static Elem, attrs: &[(String, String)], line: usize) {
        let mut messages = Vec::new();
        for (key, value) in attrs {
            if key == "xmlns" || key.starts_with("xmlns:") {
                continue;
            }
            if let Some((prefix, _)) = key.split_once(':') {
                let ns = self.bindings.iter().rev().find(|(p, _)| p == prefix);
                if ns.is_some_and(|(_, ns)| ns == XSI) || elem.any_attribute {
                    continue;
                }
                let key = shown(key);
                messages.push(format!("element <{}> has no attribute '{key}'", elem.name));
                continue;
            }
            match elem.attr(key) {
                Some(a) => {
                    if let Some(p) = problem(&a.ty, value) {
                        let v = shown(value);
                        messages.push(format!("<{}> attribute {key}=\"{v}\" {p}", elem.name));
                    }
                }
                None if elem.any_attribute => {}
                None => {
                    let key = shown(key);
                    messages.push(format!("element <{}> has no attribute '{key}'", elem.name))
                }
            }
        }
        for a in elem.required() {
            if !attrs.iter().any(|(k, _)| k == a.name) {
                let m = format!(
                    "element <{}> lacks the required attribute '{}'",
                    elem.name, a.name
                );
                messages.push(m);
            }
        }
        for m in messages {
            self.report(line, elem.name, elem.xsd, m);
        }
    }

    /// Records the naming convention of the root and the names of variables and aliases.
    fn gather(&mut self, elem: &'static Elem, attrs: &[(String, String)], line: usize) {
        let get = |k: &str| attrs.iter().find(|(a, _)| a == k).map(|(_, v)| v.clone());
        let path: Vec<&str> = self.frames.iter().map(|f| f.name.as_str()).collect();
        match path.as_slice() {
            [] if std::ptr::eq(elem, self.schema.root) => {
                self.out.convention = get("variableNamingConvention");
            }
            [_, "ModelVariables"] => self.out.names.extend(get("name").map(|n| (n, line))),
            [_, "ModelVariables", _] if elem.name == "Alias" => {
                self.out.names.extend(get("name").map(|n| (n, line)))
            }
            _ => {}
        }
    }

    /// The innermost element closes: reports children it still lacks.
    fn close(&mut self) -> bool {
        let Some(frame) = self.frames.pop() else {
            return false;
        };
        self.bindings.truncate(self.bindings.len() - frame.bindings);
        if let Check::Declared {
            elem,
            automaton: Some(a),
            states,
            broken: false,
        } = &frame.check
        {
            if !a.accepts(states) {
                let expected = a.expected(states).join(" or ");
                let m = format!(
                    "element <{}> lacks a child element: expected {expected}",
                    elem.name
                );
                self.report(frame.line, elem.name, elem.xsd, m);
            }
        }
        true
    }

    /// Text in the innermost element: only mixed and free content may have more than white
    /// space.
    fn text(&mut self, text: &str, pos: usize) -> bool {
        if text.chars().all(is_xml_space) {
            return true;
        }
        let line = self.line(pos);
        let Some(frame) = self.frames.last_mut() else {
            return true;
        };
        let Check::Declared { elem, .. } = frame.check else {
            return true;
        };
        if matches!(elem.content, Content::Empty | Content::Elements(_)) && !frame.text_reported {
            frame.text_reported = true;
            let m = format!(
                "element <{}> may not contain text (\"{}\")",
                elem.name,
                shown(text.trim_matches(is_xml_space))
            );
            self.report(line, elem.name, elem.xsd, m);
        }
        true
    }
}

/// What a child out of place is told: an element its parent never has, or one out of the
/// schema's order or beyond its number.
fn misplaced(parent: &Elem, child: &str, known: bool, expected: &[String]) -> String {
    let child = shown(child);
    let next = match expected {
        [] => format!("no further child element is allowed in <{}>", parent.name),
        names => format!("expected here: {}", names.join(" or ")),
    };
    if known {
        format!(
            "element <{child}> is out of the schema's order or occurs too often in <{}>; {next}",
            parent.name
        )
    } else {
        format!(
            "element <{}> has no child element <{child}>; {next}",
            parent.name
        )
    }
}

/// The attributes of `e` as (name, value): the value normalized as XML 1.0 section 3.3.3 reads
/// it (a literal tab or line break is a space; a character reference keeps its character),
/// then unescaped. `None` on a malformed attribute.
fn attributes(e: &BytesStart<'_>) -> Option<Vec<(String, String)>> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.ok()?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let raw = String::from_utf8_lossy(&a.value)
            .replace("\r\n", "\n")
            .replace(['\t', '\n', '\r'], " ");
        let value = quick_xml::escape::unescape(&raw).ok()?.into_owned();
        out.push((key, value));
    }
    Some(out)
}
