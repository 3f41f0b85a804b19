//! The variable table of a model, declared once: `declare_variables!` (the core crate's
//! `macro_rules!`, which forwards here with its own path `$crate`) generates from it
//!
//! - `enum V`: one identifier per variable, its discriminant the position in the table (the
//!   storage index into the value vector);
//! - `static VARIABLES`: the table, each variable with its declared value reference, and a
//!   compile-time check that no value reference occurs twice;
//! - `struct Params`: one field per parameter named after the variable (`load_mass: f64`,
//!   flags as `bool`), the parameters `<effect>.<name>` of a candidate effect in a struct of
//!   their own (`seal_friction: Option<SealFriction>`, `SealFriction { coulomb, .. }`) present
//!   when the effect's switch `<effect>.enabled` is on, and `Params::read` taking them all
//!   from the variable values.
//!
//! So a new parameter is one line of the table plus its use in the equations.

use proc_macro::TokenStream;
use quote::quote;
use syn::parse_macro_input;

mod params;
mod table;

/// `declare_variables!($crate; ID = vr => Variable::..., ...)`: see the crate documentation.
#[proc_macro]
pub fn declare_variables(input: TokenStream) -> TokenStream {
    let table = parse_macro_input!(input as table::Table);
    match expand(&table) {
        Ok(tokens) => tokens.into(),
        Err(e) => e.to_compile_error().into(),
    }
}

fn expand(table: &table::Table) -> syn::Result<proc_macro2::TokenStream> {
    let krate = &table.krate;
    let ids: Vec<_> = table.entries.iter().map(|e| &e.id).collect();
    let vrs: Vec<_> = table.entries.iter().map(|e| &e.value_reference).collect();
    let specs = table.entries.iter().map(|e| &e.spec);
    let params = params::generate(krate, &table.entries)?;
    Ok(quote! {
        /// The model's variables: each discriminant is the position in [`VARIABLES`] (storage
        /// index); the value reference is [`VARIABLES`]`[i].value_reference`.
        #[allow(non_camel_case_types, clippy::upper_case_acronyms, dead_code)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[repr(usize)]
        pub enum V { #(#ids),* }
        /// The model's variable table, in declaration order.
        pub static VARIABLES: &[#krate::Variable] = &[#(#specs.with_value_reference(#vrs)),*];
        const _: () = assert!(
            #krate::variables::references_unique(&[#(#vrs),*]),
            "declare_variables!: two variables share a value reference"
        );
        impl #krate::variables::VarId for V {
            fn index(self) -> usize {
                self as usize
            }
        }
        #params
    })
}
