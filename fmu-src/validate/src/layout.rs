//! What an extracted FMU ships as its implementation and how its archive names files (FMI 2.0.4
//! section 2.3, FMI 3.0.2 section 2.5): "The FMU must be distributed with at least one
//! implementation, in other words, either sources or one of the binaries for a particular
//! machine", and the ZIP format of APPNOTE.TXT, whose section 4.4.17 allows only forward slashes
//! as path separator.

use super::binary::platform_dirs;
use super::Finding;
use std::path::Path;

/// Most files and folders looked at when walking an extracted FMU (far above any real FMU).
const MAX_WALKED: usize = 100_000;

/// One folder under `binaries/` and the files directly in it.
pub(crate) struct Folder {
    /// Its name: an FMI 2.0 platform (`linux64`), an FMI 3.0 platform tuple or a vendor's.
    pub name: String,
    /// The names of the files it holds.
    pub files: Vec<String>,
}

/// The implementation an FMU ships, read from its extracted tree.
pub(crate) struct Survey {
    /// The folders under `binaries/`, sorted by name.
    pub folders: Vec<Folder>,
    /// Whether `sources/` holds a file.
    pub sources: bool,
    /// Paths (relative to the root) whose names hold a backslash: archive entries written with
    /// `\` as separator, which an extractor that follows APPNOTE.TXT keeps as one name.
    pub backslash: Vec<String>,
}

impl Survey {
    /// The survey of the FMU extracted at `dir`.
    pub fn of(dir: &Path) -> Survey {
        let folders = platform_dirs(dir, true)
            .into_iter()
            .map(|name| {
                let mut files: Vec<String> = std::fs::read_dir(dir.join("binaries").join(&name))
                    .map(|rd| {
                        rd.filter_map(|e| e.ok())
                            .filter(|e| e.path().is_file())
                            .map(|e| e.file_name().to_string_lossy().into_owned())
                            .collect()
                    })
                    .unwrap_or_default();
                files.sort();
                Folder { name, files }
            })
            .collect();
        let mut sources = Vec::new();
        walk(&dir.join("sources"), Path::new(""), &mut sources);
        let mut all = Vec::new();
        walk(dir, Path::new(""), &mut all);
        Survey {
            folders,
            sources: sources
                .iter()
                .any(|p| dir.join("sources").join(p).is_file()),
            backslash: all.into_iter().filter(|p| p.contains('\\')).collect(),
        }
    }

    /// The folder `name` under `binaries/`, if there is one.
    pub fn folder(&self, name: &str) -> Option<&Folder> {
        self.folders.iter().find(|f| f.name == name)
    }

    /// An implementation of the model `id` other than in the folder `except`, in words: a
    /// library named `<id>.<extension>` in another folder (of the folders `counts` accepts), a
    /// file under `sources/`, or such a library written with backslashes (reported by
    /// [`Self::backslash_finding`]).
    pub fn implementation(
        &self,
        id: &str,
        except: &str,
        counts: impl Fn(&str) -> bool,
    ) -> Option<String> {
        let named = |file: &str| file.split('.').next() == Some(id) && file.contains('.');
        let binary = self
            .folders
            .iter()
            .filter(|f| f.name != except && counts(&f.name))
            .find_map(|f| {
                let file = f.files.iter().find(|n| named(n))?;
                Some(format!("binaries/{}/{file}", f.name))
            });
        let backslashed = || {
            self.backslash
                .iter()
                .find(|p| p.starts_with("binaries\\") && p.rsplit('\\').next().is_some_and(named))
                .cloned()
        };
        binary
            .or_else(|| self.sources.then(|| "sources/".to_string()))
            .or_else(backslashed)
    }

    /// The folders under `binaries/`, each marked when it holds no file; `none` without any.
    pub fn folder_list(&self) -> String {
        if self.folders.is_empty() {
            return "none".into();
        }
        let names: Vec<String> = self
            .folders
            .iter()
            .map(|f| match f.files.is_empty() {
                true => format!("{} (empty)", f.name),
                false => f.name.clone(),
            })
            .collect();
        names.join(", ")
    }

    /// The finding on entries written with `\` as path separator, if there are any: APPNOTE.TXT
    /// 4.4.17.1, "All slashes MUST be forward slashes '/'"; an importer does not find such a
    /// file where the FMU's layout puts it.
    pub fn backslash_finding(&self) -> Option<Finding> {
        // the deepest entry names a file rather than one of its folders
        let first = self
            .backslash
            .iter()
            .max_by_key(|p| p.matches('\\').count())?;
        let m = format!(
            "{} archive {} '\\' as path separator (e.g. '{}'): only '/' is allowed, so \
             importers do not find these files where the FMU's layout puts them",
            self.backslash.len(),
            if self.backslash.len() == 1 {
                "entry uses"
            } else {
                "entries use"
            },
            first
                .chars()
                .take(80)
                .map(|c| if c.is_control() { '?' } else { c })
                .collect::<String>()
        );
        Some(Finding::new("zip-path", "archive entries", m))
    }
}

/// Appends to `out` the paths (relative to the walk's root, `rel` so far) of the files and folders
/// under `path`, at most [`MAX_WALKED`]; symbolic links are not followed.
fn walk(path: &Path, rel: &Path, out: &mut Vec<String>) {
    let Ok(rd) = std::fs::read_dir(path) else {
        return;
    };
    for e in rd.filter_map(|e| e.ok()) {
        if out.len() >= MAX_WALKED {
            return;
        }
        let rel = rel.join(e.file_name());
        out.push(rel.to_string_lossy().into_owned());
        if e.file_type().is_ok_and(|t| t.is_dir()) {
            walk(&e.path(), &rel, out);
        }
    }
}
