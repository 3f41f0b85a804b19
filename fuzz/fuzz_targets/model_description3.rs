//! The host's FMI 3.0 `modelDescription.xml` reader (`host::fmi3::ModelDescription3::parse`),
//! what the host derives from it (array shapes and element names, start values, the one view
//! of both versions `host::ModelView`, the features it refuses) and validate's FMI 3.0
//! description checks (`validate::check_model_description3`, the effect convention): any text
//! gives a description or an error, never a panic, a hang or an allocation beyond the bounds.
//!
//! Two kinds of input:
//! - text starting with `<` (the corpus' descriptions and whatever libFuzzer makes of them):
//!   parsed as it is;
//! - anything else: the first byte picks an embedded seed (our models' FMI 3.0 descriptions
//!   and hand-written ones with aliases, arrays, clocks, Binary and Enumeration variables), the
//!   rest is decoded into structural edits of it (`md3_tree.rs`), and the edited tree is parsed.
#![no_main]

#[path = "md3_tree.rs"]
mod md3_tree;

use libfuzzer_sys::arbitrary::{Arbitrary, Unstructured};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

const SEEDS: [&str; 5] = [
    include_str!("../seeds/model_description3/aliases-arrays-clocks.xml"),
    include_str!("../seeds/model_description3/event-indicators-me.xml"),
    include_str!("../../modelDescription/fmi3/HydraulicJoint.xml"),
    include_str!("../../modelDescription/fmi3/TwistedString.xml"),
    include_str!("../../modelDescription/fmi3/EMPS.xml"),
];

/// The seeds as trees with their palettes, read once.
fn seeds() -> &'static [(md3_tree::Node, md3_tree::Palette)] {
    static TREES: OnceLock<Vec<(md3_tree::Node, md3_tree::Palette)>> = OnceLock::new();
    TREES.get_or_init(|| {
        let trees = SEEDS.iter().map(|s| md3_tree::read(s));
        trees
            .map(|t| {
                let p = md3_tree::Palette::of(&t);
                (t, p)
            })
            .collect()
    })
}

fuzz_target!(|data: &[u8]| {
    match data.first() {
        None => {}
        Some(b'<') => {
            if let Ok(text) = std::str::from_utf8(data) {
                check(text);
            }
        }
        Some(&which) => {
            let (seed, palette) = &seeds()[which as usize % SEEDS.len()];
            let mut root = seed.clone();
            let mut u = Unstructured::new(&data[1..]);
            let edits = Vec::<md3_tree::Edit>::arbitrary(&mut u).unwrap_or_default();
            md3_tree::apply(&mut root, &edits, palette);
            check(&md3_tree::write(&root));
        }
    }
});

/// Everything the host and validate do with a description before loading a binary.
fn check(text: &str) {
    let Ok(md) = host::fmi3::ModelDescription3::parse(text, "fuzz.xml") else {
        return;
    };
    for f in validate::check_model_description3(&md) {
        let _ = format!("{f:?}");
    }
    for v in &md.variables {
        let _ = v.effective_initial();
        if let Some(start) = &v.start {
            let _ = start.joined(0..start.len().min(8));
            let _ = start.number(0);
        }
        if let Ok(shape) = md.shape(v) {
            let size: usize = shape.iter().product();
            let last = format!(
                "{}[{}]",
                v.name,
                shape
                    .iter()
                    .map(|n| n.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            );
            let index = host::fmi3::element_index(&last, &v.name, &shape);
            if !shape.is_empty() && shape.iter().all(|&n| n > 0) {
                assert_eq!(
                    index,
                    Some(size - 1),
                    "last element of {} {shape:?}",
                    v.name
                );
            }
        }
    }
    let view = host::ModelView::from(&md);
    let _ = view.output_names();
    let _ = view.input_names();
    for v in view.scalars() {
        let _ = v.start_number();
    }
    let _ = validate::check_effect_convention(&view);
    let _ = host::fmi3::unsupported(&md);
}
