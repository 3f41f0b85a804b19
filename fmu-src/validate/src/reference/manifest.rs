//! The FMI-LS-REF manifest `extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml`: its
//! experiments with stimuli and reference results (1.0.0-rc.1: `<Experiment name startTime
//! stopTime stepSize tolerance>` holding `<Stimuli source>` and `<References source>`), and the
//! alpha form of the Modelica Reference-FMUs, a `<Related role="result" source="x.csv">`: the
//! output of the DefaultExperiment without inputs.

use super::ReferenceError;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::path::{Path, PathBuf};

/// The folder of the layered standard inside the FMU (FMI 3.0.2 section 2.5: `extra/<name>`).
pub const LS_DIR: &str = "extra/org.fmi-standard.fmi-ls-ref";
/// The manifest's file name in [`LS_DIR`].
pub const MANIFEST: &str = "fmi-ls-manifest.xml";

/// Why a manifest cannot be read, with the element, attribute or source at fault.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// Not well-formed XML.
    #[error("at byte {position}: {cause}")]
    Xml {
        /// Where the reader stopped.
        position: u64,
        /// The XML error.
        cause: quick_xml::Error,
    },
    /// An attribute that cannot be read (a bad quote, an unknown entity).
    #[error("{0}")]
    Attribute(String),
    /// The root element is not `<fmiReferences>`.
    #[error("root element is <{0}>, not <fmiReferences>")]
    Root(String),
    /// No root element at all.
    #[error("no <fmiReferences> root element")]
    NoRoot,
    /// A manifest of another layered standard.
    #[error("fmi-ls-name is {0:?}, not \"org.fmi-standard.fmi-ls-ref\"")]
    OtherStandard(Option<String>),
    /// A data element outside an `<Experiment>`.
    #[error("<{0}> outside an <Experiment>")]
    OutsideExperiment(String),
    /// An element that needs a `source` has none.
    #[error("<{0}> without source")]
    NoSource(String),
    /// A time or tolerance that is not a finite number.
    #[error("{key}=\"{value}\" is not a finite number")]
    NotANumber {
        /// The attribute.
        key: String,
        /// Its text.
        value: String,
    },
    /// A `source` that would leave the layered standard's folder.
    #[error("source \"{0}\" is not a relative path inside {LS_DIR}")]
    Outside(String),
}

/// One experiment to run and compare.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Experiment {
    /// Its name (alpha form: the result file's name).
    pub name: String,
    /// `startTime`, `stopTime`, `stepSize`, `tolerance` (None: the DefaultExperiment's).
    pub start: Option<f64>,
    /// `stopTime`.
    pub stop: Option<f64>,
    /// `stepSize`.
    pub step: Option<f64>,
    /// `tolerance`.
    pub tolerance: Option<f64>,
    /// The stimuli CSV (None: no inputs).
    pub stimuli: Option<PathBuf>,
    /// The reference CSV (None: the experiment has no references to compare).
    pub references: Option<PathBuf>,
    /// Why the experiment cannot be run as the manifest describes it (a parameter set, a
    /// file type other than CSV).
    pub unsupported: Option<String>,
}

/// The experiments of the manifest at `path`, their files resolved against its folder.
pub fn read(path: &Path) -> Result<Vec<Experiment>, ReferenceError> {
    let xml = std::fs::read_to_string(path).map_err(|source| ReferenceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse(&xml, dir).map_err(|cause| ReferenceError::Manifest {
        path: path.to_path_buf(),
        cause,
    })
}

/// The experiments of the manifest text `xml`, files under `dir`.
pub fn parse(xml: &str, dir: &Path) -> Result<Vec<Experiment>, ManifestError> {
    let mut reader = Reader::from_str(xml);
    let mut out: Vec<Experiment> = Vec::new();
    let mut open: Option<Experiment> = None;
    let mut root_seen = false;
    loop {
        let ev = reader.read_event().map_err(|cause| ManifestError::Xml {
            position: reader.buffer_position(),
            cause,
        })?;
        match ev {
            Event::Start(e) | Event::Empty(e) => {
                let name = local(e.name().as_ref());
                let attrs = attributes(&e)?;
                let get = &attrs;
                match name.as_str() {
                    "fmiReferences" => {
                        root_seen = true;
                        check_root(get.get("fmi-ls-name"))?;
                    }
                    _ if !root_seen => return Err(ManifestError::Root(name)),
                    "Experiment" => {
                        if let Some(done) = open.take() {
                            out.push(done);
                        }
                        open = Some(experiment(get)?);
                    }
                    "Stimuli" | "References" | "Parameters" => {
                        let ex = open
                            .as_mut()
                            .ok_or_else(|| ManifestError::OutsideExperiment(name.clone()))?;
                        data_file(ex, &name, get, dir)?;
                    }
                    "Related" => {
                        if let Some(ex) = related_result(get, dir)? {
                            out.push(ex);
                        }
                    }
                    _ => {}
                }
            }
            Event::End(e) if local(e.name().as_ref()) == "Experiment" => {
                out.extend(open.take());
            }
            Event::Eof => break,
            _ => {}
        }
    }
    out.extend(open.take());
    if !root_seen {
        return Err(ManifestError::NoRoot);
    }
    Ok(out)
}

/// An element's attributes with prefixes dropped (`fmi-ls:fmi-ls-name` as `fmi-ls-name`).
struct Attrs(Vec<(String, String)>);

impl Attrs {
    fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

fn attributes(e: &BytesStart<'_>) -> Result<Attrs, ManifestError> {
    let unreadable = |err: &dyn std::fmt::Display| ManifestError::Attribute(err.to_string());
    e.attributes()
        .map(|a| {
            let a = a.map_err(|err| unreadable(&err))?;
            let value = a.unescape_value().map_err(|err| unreadable(&err))?;
            Ok((local(a.key.as_ref()), value.into_owned()))
        })
        .collect::<Result<_, ManifestError>>()
        .map(Attrs)
}

fn local(name: &[u8]) -> String {
    let s = String::from_utf8_lossy(name);
    s.rsplit(':').next().unwrap_or_default().to_string()
}

fn check_root(ls_name: Option<&str>) -> Result<(), ManifestError> {
    match ls_name {
        Some("org.fmi-standard.fmi-ls-ref") => Ok(()),
        other => Err(ManifestError::OtherStandard(other.map(str::to_string))),
    }
}

fn number(get: &Attrs, key: &str) -> Result<Option<f64>, ManifestError> {
    get.get(key)
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| ManifestError::NotANumber {
                    key: key.to_string(),
                    value: s.to_string(),
                })
        })
        .transpose()
}

fn experiment(get: &Attrs) -> Result<Experiment, ManifestError> {
    Ok(Experiment {
        name: get.get("name").unwrap_or("(unnamed)").to_string(),
        start: number(get, "startTime")?,
        stop: number(get, "stopTime")?,
        step: number(get, "stepSize")?,
        tolerance: number(get, "tolerance")?,
        ..Experiment::default()
    })
}

/// `<Stimuli>`, `<References>` or `<Parameters>` of the experiment `ex`.
fn data_file(
    ex: &mut Experiment,
    element: &str,
    get: &Attrs,
    dir: &Path,
) -> Result<(), ManifestError> {
    if element == "Parameters" {
        ex.unsupported = Some("it sets parameters from a parameter set (SSV)".into());
        return Ok(());
    }
    let source = get
        .get("source")
        .ok_or_else(|| ManifestError::NoSource(element.to_string()))?;
    if let Some(ty) = get.get("type").filter(|t| *t != "text/csv") {
        ex.unsupported = Some(format!("its <{element}> is of type {ty}, not text/csv"));
    }
    let file = Some(resolve(dir, source)?);
    if element == "Stimuli" {
        ex.stimuli = file;
    } else {
        ex.references = file;
    }
    Ok(())
}

/// A `<Related role="result">` CSV: the output of the DefaultExperiment without inputs.
fn related_result(get: &Attrs, dir: &Path) -> Result<Option<Experiment>, ManifestError> {
    let source = get.get("source").unwrap_or_default();
    let csv = get.get("type") == Some("text/csv") || source.to_ascii_lowercase().ends_with(".csv");
    if get.get("role") != Some("result") || !csv {
        return Ok(None);
    }
    Ok(Some(Experiment {
        name: format!("DefaultExperiment ({source})"),
        references: Some(resolve(dir, source)?),
        ..Experiment::default()
    }))
}

/// `source`, a URI relative to the manifest, as a path under `dir`: no scheme, no absolute
/// path, no `..` (a file of the FMU, never one outside it).
fn resolve(dir: &Path, source: &str) -> Result<PathBuf, ManifestError> {
    let rel = Path::new(source);
    let inside = !source.contains(':')
        && !rel.is_absolute()
        && rel.components().all(|c| {
            matches!(
                c,
                std::path::Component::Normal(_) | std::path::Component::CurDir
            )
        });
    if !inside || source.is_empty() {
        return Err(ManifestError::Outside(source.to_string()));
    }
    Ok(dir.join(rel))
}

#[cfg(test)]
mod tests {
    use super::*;

    const RC1: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-rc.1">
  <Experiment name="a" startTime="0" stopTime="2" stepSize="0.01" tolerance="1e-6">
    <Stimuli source="a_in.csv"/>
    <References source="a_ref.csv"/>
  </Experiment>
  <Experiment name="b" stopTime="1">
    <Parameters source="p.ssv"/>
    <References source="sub/b_ref.csv"/>
  </Experiment>
  <Related type="text/x-modelica" source="m.mo" role="model"/>
</fmiReferences>"#;

    #[test]
    fn reads_the_rc1_form() {
        let ex = parse(RC1, Path::new("/x")).expect("parses");
        assert_eq!(ex.len(), 2);
        assert_eq!(ex[0].name, "a");
        assert_eq!(
            (ex[0].start, ex[0].stop, ex[0].step),
            (Some(0.0), Some(2.0), Some(0.01))
        );
        assert_eq!(ex[0].tolerance, Some(1e-6));
        assert_eq!(ex[0].stimuli.as_deref(), Some(Path::new("/x/a_in.csv")));
        assert_eq!(ex[0].references.as_deref(), Some(Path::new("/x/a_ref.csv")));
        assert!(ex[0].unsupported.is_none());
        assert!(
            ex[1].unsupported.is_some(),
            "a parameter set is not applied"
        );
        assert_eq!(
            ex[1].references.as_deref(),
            Some(Path::new("/x/sub/b_ref.csv"))
        );
    }

    #[test]
    fn reads_the_alpha_form_as_the_default_experiment() {
        let xml = r#"<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
            fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-alpha.1">
            <Related type="text/csv" source="M_out.csv" role="result" description="d"/>
        </fmiReferences>"#;
        let ex = parse(xml, Path::new("d")).expect("parses");
        assert_eq!(ex.len(), 1);
        assert_eq!(ex[0].references.as_deref(), Some(Path::new("d/M_out.csv")));
        assert_eq!(
            (ex[0].start, ex[0].stop, ex[0].stimuli.as_ref()),
            (None, None, None)
        );
    }

    #[test]
    fn refuses_sources_outside_the_folder_and_other_layered_standards() {
        for src in ["../x.csv", "/etc/passwd", "file:///x.csv", ""] {
            let xml = format!(
                r#"<fmiReferences fmi-ls-name="org.fmi-standard.fmi-ls-ref"><Experiment name="e"><References source="{src}"/></Experiment></fmiReferences>"#
            );
            assert!(parse(&xml, Path::new("d")).is_err(), "{src}");
        }
        let other = r#"<fmiReferences fmi-ls-name="org.fmi-standard.fmi-ls-xcp"/>"#;
        assert!(parse(other, Path::new("d")).is_err());
    }
}
