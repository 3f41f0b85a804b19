//! A structure-aware mutator of FMI 3.0 `modelDescription.xml` for `model_description3`: the
//! seed is read into an element tree, the input's edits (decoded by `arbitrary`) delete,
//! duplicate, move, swap and insert elements and set or remove attributes, with values from a
//! palette of FMI 3.0 words, edge-case numbers and the seed's own value references and names,
//! and the tree is written back as XML.
//!
//! The reader is only for the seeds this target embeds (elements, double-quoted attributes,
//! whitespace between elements, an XML declaration): it never sees the fuzzer's text.

use libfuzzer_sys::arbitrary::{self, Arbitrary};

/// An element: its name, its attributes as written (already escaped) and its children.
#[derive(Clone, Debug)]
pub struct Node {
    name: String,
    attrs: Vec<(String, String)>,
    children: Vec<Node>,
}

/// Read a seed into its root element.
pub fn read(xml: &str) -> Node {
    let mut stack: Vec<Node> = vec![Node {
        name: String::new(),
        attrs: Vec::new(),
        children: Vec::new(),
    }];
    let mut rest = xml;
    while let Some(i) = rest.find('<') {
        rest = &rest[i + 1..];
        let end = rest.find('>').expect("seed: unclosed tag");
        let tag = &rest[..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let node = stack.pop().expect("seed: unbalanced");
            assert_eq!(node.name, name.trim(), "seed: mismatched end tag");
            stack
                .last_mut()
                .expect("seed: unbalanced")
                .children
                .push(node);
            continue;
        }
        let empty = tag.ends_with('/');
        let node = element(tag.trim_end_matches('/'));
        if empty {
            stack
                .last_mut()
                .expect("seed: unbalanced")
                .children
                .push(node);
        } else {
            stack.push(node);
        }
    }
    let mut doc = stack.pop().expect("seed: unbalanced");
    assert!(
        stack.is_empty() && doc.children.len() == 1,
        "seed: not one root"
    );
    doc.children.remove(0)
}

/// `name key="value" ...`
fn element(tag: &str) -> Node {
    let (name, mut rest) = tag.split_once(char::is_whitespace).unwrap_or((tag, ""));
    let mut attrs = Vec::new();
    while let Some(eq) = rest.find("=\"") {
        let key = rest[..eq].trim().to_string();
        let after = &rest[eq + 2..];
        let close = after.find('"').expect("seed: unclosed attribute");
        attrs.push((key, after[..close].to_string()));
        rest = &after[close + 1..];
    }
    Node {
        name: name.to_string(),
        attrs,
        children: Vec::new(),
    }
}

/// Write the tree as an XML document.
pub fn write(root: &Node) -> String {
    let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    write_node(root, 0, &mut out);
    out
}

fn write_node(n: &Node, depth: usize, out: &mut String) {
    out.push_str(&"  ".repeat(depth.min(16)));
    out.push('<');
    out.push_str(&n.name);
    for (k, v) in &n.attrs {
        out.push_str(&format!(" {k}=\"{v}\""));
    }
    if n.children.is_empty() {
        out.push_str("/>\n");
        return;
    }
    out.push_str(">\n");
    for c in &n.children {
        write_node(c, depth + 1, out);
    }
    out.push_str(&"  ".repeat(depth.min(16)));
    out.push_str(&format!("</{}>\n", n.name));
}

/// Escape text for an attribute value.
fn escaped(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('"', "&quot;")
        .replace('>', "&gt;")
}

/// Element names an edit may insert.
const TAGS: &[&str] = &[
    "Float64",
    "Float32",
    "Int32",
    "Int8",
    "UInt64",
    "Int64",
    "Boolean",
    "String",
    "Binary",
    "Enumeration",
    "Clock",
    "Dimension",
    "Alias",
    "Start",
    "Output",
    "ContinuousStateDerivative",
    "ClockedState",
    "InitialUnknown",
    "EventIndicator",
    "Unit",
    "BaseUnit",
    "DisplayUnit",
    "EnumerationType",
    "Item",
    "Float64Type",
    "ClockType",
    "BinaryType",
    "ModelExchange",
    "CoSimulation",
    "ScheduledExecution",
    "ModelVariables",
    "ModelStructure",
    "TypeDefinitions",
    "UnitDefinitions",
    "DefaultExperiment",
    "Category",
    "Annotations",
    "Real",
    "fmiModelDescription",
];

/// Attribute names an edit may set.
const KEYS: &[&str] = &[
    "name",
    "valueReference",
    "causality",
    "variability",
    "initial",
    "start",
    "min",
    "max",
    "nominal",
    "unit",
    "displayUnit",
    "declaredType",
    "derivative",
    "clocks",
    "intervalVariability",
    "dependencies",
    "dependenciesKind",
    "value",
    "factor",
    "offset",
    "inverse",
    "modelIdentifier",
    "fmiVersion",
    "instantiationToken",
    "intervalDecimal",
    "shiftDecimal",
    "supportsFraction",
    "canBeDeactivated",
    "priority",
    "maxSize",
    "mimeType",
    "reinit",
    "previous",
    "quantity",
    "description",
    "hasEventMode",
    "canGetAndSetFMUState",
    "fixedInternalStepSize",
    "maxOutputDerivativeOrder",
    "startTime",
    "stopTime",
    "stepSize",
    "tolerance",
    "modelName",
    "unbounded",
    "relativeQuantity",
    "intervalCounter",
    "resolution",
];

/// Attribute values from the standard's vocabulary and the edges of the types.
const WORDS: &[&str] = &[
    "input",
    "output",
    "parameter",
    "structuralParameter",
    "calculatedParameter",
    "local",
    "independent",
    "constant",
    "fixed",
    "tunable",
    "discrete",
    "continuous",
    "exact",
    "approx",
    "calculated",
    "true",
    "false",
    "1",
    "0",
    "triggered",
    "countdown",
    "changing",
    "dependent",
    "",
    " ",
    "-1",
    "3.0",
    "2.0",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775809",
    "1e308",
    "1e309",
    "-0",
    "NaN",
    "INF",
    "-INF",
    "0x10",
    "1 2 3",
    "0 0 0 0",
    "100000000",
    "16777217",
    "0aff",
    "0AFF",
    "xyz",
    "0a f",
    "a&amp;b",
    "&lt;tag&gt;",
    "&#0;",
    "\u{feff}",
    "ü",
    "der(x)",
    "x",
    "time",
    "m",
    "mm",
    "Mode",
    "Length",
    "Tick",
    "Blob",
    "1000000",
    "1000001",
    "-128",
    "255",
    "127 -128",
    "true false",
    "1 0 1",
    "3.0-beta",
];

/// A value for an attribute.
#[derive(Arbitrary, Debug)]
pub enum Value {
    Word(u8),
    /// a value reference of the seed (or a list of them)
    Vr(u8),
    Vrs(Vec<u8>),
    /// the name of a variable of the seed
    Name(u8),
    Number(i64),
    Float(f64),
    Text(String),
    /// a word repeated (long lists, long names)
    Repeat(u8, u16),
}

#[derive(Arbitrary, Debug)]
pub enum Edit {
    Set {
        elem: u16,
        key: u8,
        value: Value,
    },
    Rename {
        elem: u16,
        attr: u8,
        key: u8,
    },
    Remove {
        elem: u16,
        attr: u8,
    },
    Delete {
        elem: u16,
    },
    Duplicate {
        elem: u16,
    },
    Move {
        elem: u16,
        to: u16,
    },
    Swap {
        elem: u16,
        with: u16,
    },
    Insert {
        parent: u16,
        tag: u8,
        attrs: Vec<(u8, Value)>,
    },
}

/// What values are drawn from: the seed's value references and variable names.
pub struct Palette {
    vrs: Vec<String>,
    names: Vec<String>,
}

impl Palette {
    pub fn of(root: &Node) -> Palette {
        let mut p = Palette {
            vrs: Vec::new(),
            names: Vec::new(),
        };
        let mut all = Vec::new();
        collect(root, &mut all);
        for n in all {
            for (k, v) in &n.attrs {
                match k.as_str() {
                    "valueReference" => p.vrs.push(v.clone()),
                    "name" => p.names.push(v.clone()),
                    _ => {}
                }
            }
        }
        p.vrs.push("0".into());
        p.names.push("x".into());
        p
    }

    fn value(&self, v: &Value) -> String {
        let pick = |list: &[String], i: u8| list[i as usize % list.len()].clone();
        match v {
            Value::Word(i) => WORDS[*i as usize % WORDS.len()].to_string(),
            Value::Vr(i) => pick(&self.vrs, *i),
            Value::Vrs(is) => is
                .iter()
                .take(64)
                .map(|&i| pick(&self.vrs, i))
                .collect::<Vec<_>>()
                .join(" "),
            Value::Name(i) => escaped(&pick(&self.names, *i)),
            Value::Number(n) => n.to_string(),
            Value::Float(x) => format!("{x:e}"),
            Value::Text(s) => escaped(s),
            Value::Repeat(i, n) => {
                let w = WORDS[*i as usize % WORDS.len()];
                vec![w; (*n as usize) % 4096].join(" ")
            }
        }
    }
}

fn collect<'a>(n: &'a Node, out: &mut Vec<&'a Node>) {
    out.push(n);
    for c in &n.children {
        collect(c, out);
    }
}

fn count(n: &Node) -> usize {
    1 + n.children.iter().map(count).sum::<usize>()
}

/// The element number `i` (pre-order, the root 0), modulo the element count.
fn nth(root: &mut Node, i: u16) -> &mut Node {
    let mut i = i as usize % count(root);
    nth_in(root, &mut i).expect("index within the count")
}

fn nth_in<'a>(n: &'a mut Node, i: &mut usize) -> Option<&'a mut Node> {
    if *i == 0 {
        return Some(n);
    }
    *i -= 1;
    for c in &mut n.children {
        if let Some(found) = nth_in(c, i) {
            return Some(found);
        }
    }
    None
}

/// Run `f` on the children of the parent of element number `i` (not the root) and its
/// position among them.
fn at_parent(root: &mut Node, i: u16, f: &mut dyn FnMut(&mut Vec<Node>, usize)) {
    let mut target = i as usize % count(root);
    if target > 0 {
        at_parent_in(root, &mut target, f);
    }
}

/// `*i`: the number of the element relative to `n` (`n` itself is 0).
fn at_parent_in(n: &mut Node, i: &mut usize, f: &mut dyn FnMut(&mut Vec<Node>, usize)) {
    let mut offset = 1;
    for j in 0..n.children.len() {
        let size = count(&n.children[j]);
        if *i == offset {
            return f(&mut n.children, j);
        }
        if *i < offset + size {
            *i -= offset;
            return at_parent_in(&mut n.children[j], i, f);
        }
        offset += size;
    }
}

/// Remove element number `i` (not the root) from its parent; returns it.
fn take(root: &mut Node, i: u16) -> Option<Node> {
    let mut taken = None;
    at_parent(root, i, &mut |children, j| taken = Some(children.remove(j)));
    taken
}

/// Apply the edits (at most 16; the tree stays below 20 000 elements).
pub fn apply(root: &mut Node, edits: &[Edit], palette: &Palette) {
    for e in edits.iter().take(16) {
        match e {
            Edit::Set { elem, key, value } => {
                let n = nth(root, *elem);
                let k = KEYS[*key as usize % KEYS.len()];
                let v = palette.value(value);
                match n.attrs.iter_mut().find(|(name, _)| name == k) {
                    Some(a) => a.1 = v,
                    None => n.attrs.push((k.to_string(), v)),
                }
            }
            Edit::Rename { elem, attr, key } => {
                let n = nth(root, *elem);
                if !n.attrs.is_empty() {
                    let i = *attr as usize % n.attrs.len();
                    n.attrs[i].0 = KEYS[*key as usize % KEYS.len()].to_string();
                }
            }
            Edit::Remove { elem, attr } => {
                let n = nth(root, *elem);
                if !n.attrs.is_empty() {
                    n.attrs.remove(*attr as usize % n.attrs.len());
                }
            }
            Edit::Delete { elem } => {
                take(root, *elem);
            }
            Edit::Duplicate { elem } => {
                if count(root) < 20_000 {
                    at_parent(root, *elem, &mut |children, j| {
                        let copy = children[j].clone();
                        children.insert(j + 1, copy);
                    });
                }
            }
            Edit::Move { elem, to } => {
                if let Some(n) = take(root, *elem) {
                    nth(root, *to).children.push(n);
                }
            }
            Edit::Swap { elem, with } => {
                let a = nth(root, *elem);
                if a.children.len() >= 2 {
                    let len = a.children.len();
                    a.children.swap(0, *with as usize % len);
                }
            }
            Edit::Insert { parent, tag, attrs } => {
                let name = TAGS[*tag as usize % TAGS.len()].to_string();
                let attrs = attrs
                    .iter()
                    .take(8)
                    .map(|(k, v)| (KEYS[*k as usize % KEYS.len()].to_string(), palette.value(v)))
                    .collect();
                nth(root, *parent).children.push(Node {
                    name,
                    attrs,
                    children: Vec::new(),
                });
            }
        }
    }
}
