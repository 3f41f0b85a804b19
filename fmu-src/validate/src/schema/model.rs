//! The vocabulary of the schema tables: an element's attributes with their XML Schema types,
//! the attributes it requires, and its children as a content model (sequences and choices of
//! particles with their multiplicity, as `xs:sequence`, `xs:choice`, `minOccurs`/`maxOccurs`
//! and `xs:any` write them). Tables are `static`s built with the `const fn`s below, so that an
//! element can refer to itself or to one declared after it.

/// The type of an attribute (XML Schema Part 2 built-in types and the restrictions the FMI
/// schemas derive from them).
#[derive(Debug)]
pub(crate) enum Ty {
    /// `xs:string`: any text.
    String,
    /// `xs:normalizedString`: any text (tabs and line breaks read as spaces).
    Normalized,
    /// `xs:double`.
    Double,
    /// `xs:float`.
    Float,
    /// An integer type between `min` and `max` (`xs:byte` … `xs:unsignedLong`).
    Int {
        min: i128,
        max: i128,
        name: &'static str,
    },
    /// `xs:nonNegativeInteger`: digits of any length.
    NonNegativeInteger,
    /// `xs:boolean`: `true`, `false`, `1`, `0`.
    Boolean,
    /// `xs:dateTime`.
    DateTime,
    /// `xs:hexBinary`: pairs of hexadecimal digits.
    HexBinary,
    /// A restriction of `xs:normalizedString` to these values.
    Enum(&'static [&'static str]),
    /// `xs:list` of the item type: items separated by white space (none is a valid list).
    List(&'static Ty),
    /// The single value an attribute declared `fixed` may have.
    Fixed(&'static str),
    /// A restriction of `xs:normalizedString` by a pattern, as a predicate with the pattern's
    /// text for the message.
    Pattern(fn(&str) -> bool, &'static str),
}

/// `xs:byte`.
pub(crate) const BYTE: Ty = int(i8::MIN as i128, i8::MAX as i128, "xs:byte");
/// `xs:unsignedByte`.
pub(crate) const UBYTE: Ty = int(0, u8::MAX as i128, "xs:unsignedByte");
/// `xs:short`.
pub(crate) const SHORT: Ty = int(i16::MIN as i128, i16::MAX as i128, "xs:short");
/// `xs:unsignedShort`.
pub(crate) const USHORT: Ty = int(0, u16::MAX as i128, "xs:unsignedShort");
/// `xs:int`.
pub(crate) const INT: Ty = int(i32::MIN as i128, i32::MAX as i128, "xs:int");
/// `xs:unsignedInt`.
pub(crate) const UINT: Ty = int(0, u32::MAX as i128, "xs:unsignedInt");
/// `xs:long`.
pub(crate) const LONG: Ty = int(i64::MIN as i128, i64::MAX as i128, "xs:long");
/// `xs:unsignedLong`.
pub(crate) const ULONG: Ty = int(0, u64::MAX as i128, "xs:unsignedLong");

const fn int(min: i128, max: i128, name: &'static str) -> Ty {
    Ty::Int { min, max, name }
}

/// One attribute an element may (or must) carry.
#[derive(Debug)]
pub(crate) struct Attr {
    pub(crate) name: &'static str,
    pub(crate) ty: Ty,
    pub(crate) required: bool,
}

/// An optional attribute.
pub(crate) const fn opt_attr(name: &'static str, ty: Ty) -> Attr {
    Attr {
        name,
        ty,
        required: false,
    }
}

/// A required attribute (`use="required"`).
pub(crate) const fn req_attr(name: &'static str, ty: Ty) -> Attr {
    Attr {
        name,
        ty,
        required: true,
    }
}

/// What an element may contain.
#[derive(Debug)]
pub(crate) enum Content {
    /// Nothing but white space, comments and processing instructions.
    Empty,
    /// Child elements following the particle; text other than white space is not allowed.
    Elements(Particle),
    /// Child elements following the particle, with text between them (`mixed="true"`).
    Mixed(Particle),
    /// `xs:anyType`: any attributes, text and elements.
    AnyType,
}

/// An element declaration.
#[derive(Debug)]
pub(crate) struct Elem {
    pub(crate) name: &'static str,
    /// The schema file that declares it, named in findings.
    pub(crate) xsd: &'static str,
    /// Its attributes, in groups (a group shared by several elements is one slice).
    pub(crate) attrs: &'static [&'static [Attr]],
    /// `xs:anyAttribute processContents="lax"`: attributes not declared are allowed.
    pub(crate) any_attribute: bool,
    pub(crate) content: Content,
}

/// An element with these attributes and content (no undeclared attributes).
pub(crate) const fn elem(
    name: &'static str,
    xsd: &'static str,
    attrs: &'static [&'static [Attr]],
    content: Content,
) -> Elem {
    Elem {
        name,
        xsd,
        attrs,
        any_attribute: false,
        content,
    }
}

/// An element with attributes and no content.
pub(crate) const fn empty(
    name: &'static str,
    xsd: &'static str,
    attrs: &'static [&'static [Attr]],
) -> Elem {
    elem(name, xsd, attrs, Content::Empty)
}

/// An element whose children follow the sequence `children`.
pub(crate) const fn parent(
    name: &'static str,
    xsd: &'static str,
    attrs: &'static [&'static [Attr]],
    children: &'static [Particle],
) -> Elem {
    elem(name, xsd, attrs, Content::Elements(seq(children)))
}

/// An element without attributes that lists one or more `item`s: the containers
/// (`<UnitDefinitions>`, `<ModelVariables>`, `<Outputs>`, ...).
pub(crate) const fn list(name: &'static str, xsd: &'static str, item: &'static Elem) -> Elem {
    elem(name, xsd, &[], Content::Elements(unbounded(one(item))))
}

impl Elem {
    /// The declaration of attribute `name`, if the element has one.
    pub(crate) fn attr(&self, name: &str) -> Option<&'static Attr> {
        self.attrs
            .iter()
            .flat_map(|g| g.iter())
            .find(|a| a.name == name)
    }

    /// The attributes the element requires.
    pub(crate) fn required(&self) -> impl Iterator<Item = &'static Attr> {
        self.attrs
            .iter()
            .flat_map(|g| g.iter())
            .filter(|a| a.required)
    }

    /// The particle of its children, if it has element content.
    pub(crate) fn particle(&self) -> Option<&Particle> {
        match &self.content {
            Content::Elements(p) | Content::Mixed(p) => Some(p),
            Content::Empty | Content::AnyType => None,
        }
    }
}

/// A term of a content model.
#[derive(Debug)]
pub(crate) enum Term {
    /// An element (declared locally or a reference to a global one).
    Elem(&'static Elem),
    /// `xs:sequence`: the particles in this order.
    Seq(&'static [Particle]),
    /// `xs:choice`: one of the particles.
    Choice(&'static [Particle]),
    /// `xs:any processContents="lax"`: any element; one the schema declares globally is checked
    /// against its declaration.
    Any,
}

/// A term with its multiplicity (`minOccurs`, `maxOccurs`; `None` is `unbounded`).
#[derive(Debug)]
pub(crate) struct Particle {
    pub(crate) term: Term,
    pub(crate) min: u32,
    pub(crate) max: Option<u32>,
}

/// Exactly one `e`.
pub(crate) const fn one(e: &'static Elem) -> Particle {
    Particle {
        term: Term::Elem(e),
        min: 1,
        max: Some(1),
    }
}

/// The particle `p` made optional (`minOccurs="0"`).
pub(crate) const fn opt(p: Particle) -> Particle {
    Particle { min: 0, ..p }
}

/// The particle `p` repeated without bound (`maxOccurs="unbounded"`), keeping its `minOccurs`.
pub(crate) const fn unbounded(p: Particle) -> Particle {
    Particle { max: None, ..p }
}

/// The particle `p` with `maxOccurs` = `max`.
pub(crate) const fn at_most(p: Particle, max: u32) -> Particle {
    Particle {
        max: Some(max),
        ..p
    }
}

/// Any number of `e` (`minOccurs="0" maxOccurs="unbounded"`).
pub(crate) const fn many(e: &'static Elem) -> Particle {
    unbounded(opt(one(e)))
}

/// `xs:sequence` of `ps`, once.
pub(crate) const fn seq(ps: &'static [Particle]) -> Particle {
    Particle {
        term: Term::Seq(ps),
        min: 1,
        max: Some(1),
    }
}

/// `xs:choice` of `ps`, once.
pub(crate) const fn choice(ps: &'static [Particle]) -> Particle {
    Particle {
        term: Term::Choice(ps),
        min: 1,
        max: Some(1),
    }
}

/// Column `col` of `rows` as particles `one(e)`: a version's types, each with its type
/// definition (column 0) and its variable element (column 1), for the choices among them.
pub(crate) const fn column<const K: usize>(
    rows: &[[&'static Elem; 2]; K],
    col: usize,
) -> [Particle; K] {
    let mut out = [const { any() }; K];
    let mut i = 0;
    while i < K {
        out[i] = one(rows[i][col]);
        i += 1;
    }
    out
}

/// `xs:any`, once.
pub(crate) const fn any() -> Particle {
    Particle {
        term: Term::Any,
        min: 1,
        max: Some(1),
    }
}

/// A schema of one FMI version: the root element, the global elements (which `xs:any` checks
/// laxly), and how findings cite it.
#[derive(Debug)]
pub(crate) struct Schema {
    /// `FMI 2.0.4 §2.2` or `FMI 3.0.2 §2.4`: the standard's chapter on the schema.
    pub(crate) cite: &'static str,
    pub(crate) root: &'static Elem,
    pub(crate) globals: &'static [&'static Elem],
}
