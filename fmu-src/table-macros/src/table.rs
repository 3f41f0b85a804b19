//! The table as written: `ID = value_reference => Variable::constructor("name", ...)...`, one
//! entry per variable, after the path of the crate that defines `Variable`.

use proc_macro2::{TokenStream, TokenTree};
use syn::parse::{Parse, ParseStream};
use syn::punctuated::Punctuated;
use syn::{Expr, ExprCall, ExprLit, Ident, Lit, LitInt, LitStr, Token};

/// What a variable is, from the constructor its declaration starts with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `Variable::parameter` or `Variable::integer_parameter`: an `f64` field of the parameters.
    Number,
    /// `Variable::flag`: a `bool` field, or an effect's switch when named `<effect>.enabled`.
    Flag,
    /// `Variable::input`, `output`, `local`: not a parameter.
    Other,
}

/// One line of the table.
pub struct Entry {
    pub id: Ident,
    pub value_reference: LitInt,
    pub spec: Expr,
    pub kind: Kind,
    /// The variable's name (the constructor's first argument).
    pub name: LitStr,
    /// The description (the constructor's last argument) when it is a string literal.
    pub description: Option<LitStr>,
}

/// The macro's whole input: the defining crate's path (`$crate` of `declare_variables!`), `;`,
/// then the entries.
pub struct Table {
    pub krate: TokenStream,
    pub entries: Vec<Entry>,
}

impl Parse for Table {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let mut krate = TokenStream::new();
        while !input.peek(Token![;]) {
            krate.extend([input.parse::<TokenTree>()?]);
        }
        input.parse::<Token![;]>()?;
        let entries = Punctuated::<Entry, Token![,]>::parse_terminated(input)?;
        Ok(Table {
            krate,
            entries: entries.into_iter().collect(),
        })
    }
}

impl Parse for Entry {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let id: Ident = input.parse()?;
        input.parse::<Token![=]>()?;
        let value_reference: LitInt = input.parse()?;
        input.parse::<Token![=>]>()?;
        let spec: Expr = input.parse()?;
        let (call, kind) = constructor(&spec)?;
        let name = match call.args.first() {
            Some(Expr::Lit(ExprLit {
                lit: Lit::Str(s), ..
            })) => s.clone(),
            _ => {
                return Err(syn::Error::new_spanned(
                    call,
                    "declare_variables!: the variable's name must be a string literal",
                ))
            }
        };
        let description = match call.args.last() {
            Some(Expr::Lit(ExprLit {
                lit: Lit::Str(s), ..
            })) if call.args.len() > 1 => Some(s.clone()),
            _ => None,
        };
        Ok(Entry {
            id,
            value_reference,
            spec,
            kind,
            name,
            description,
        })
    }
}

/// The `Variable` constructor a declaration starts with and the kind it gives, under the chain
/// of builder methods (`Variable::parameter(..)` in `Variable::parameter(..).range(..)`) and
/// through a one-argument wrapper function (`discrete(Variable::output(..))`). Any other
/// function is refused, so that no parameter can be left out of the parameter struct unnoticed.
fn constructor(spec: &Expr) -> syn::Result<(&ExprCall, Kind)> {
    let refuse = || {
        syn::Error::new_spanned(
            spec,
            "declare_variables!: start the declaration with Variable::parameter, \
             integer_parameter, flag, input, output or local",
        )
    };
    let call = match spec {
        Expr::MethodCall(m) => return constructor(&m.receiver),
        Expr::Paren(p) => return constructor(&p.expr),
        Expr::Call(c) => c,
        _ => return Err(refuse()),
    };
    let name = match &*call.func {
        Expr::Path(p) => p.path.segments.last().map(|s| s.ident.to_string()),
        _ => None,
    };
    match name.as_deref() {
        Some("parameter" | "integer_parameter") => Ok((call, Kind::Number)),
        Some("flag") => Ok((call, Kind::Flag)),
        Some("input" | "output" | "local") => Ok((call, Kind::Other)),
        _ if call.args.len() == 1 => constructor(&call.args[0]).map_err(|_| refuse()),
        _ => Err(refuse()),
    }
}
