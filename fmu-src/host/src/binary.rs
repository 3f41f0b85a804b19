//! What each platform binary of an FMU is, read from its bytes without loading it (goblin):
//! the file format and architectures, the functions it exports, and for Linux the newest GLIBC
//! symbol version it needs. The validator judges every `binaries/<platform>/` entry with it, so
//! the Windows and macOS binaries are checked on a Linux machine too.

use goblin::mach::{Mach, SingleArch};
use goblin::Object;

/// One architecture slice of a binary.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Slice {
    /// `x86_64`, `aarch64`, `x86` or the raw machine number.
    pub architecture: String,
    /// Exported function names, sorted (Mach-O's leading underscore removed).
    pub exports: Vec<String>,
}

/// A platform binary as read from its bytes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BinaryInfo {
    /// `ELF`, `PE` or `Mach-O`.
    pub format: &'static str,
    /// One slice, or several for a universal Mach-O.
    pub slices: Vec<Slice>,
    /// ELF only: the newest `GLIBC_x.y` version any symbol needs (None: no glibc symbol).
    pub max_glibc: Option<String>,
}

/// The format and architectures an FMI 2.0 platform's binary must have (standard section 2.4:
/// `linux64`, `win64`, `darwin64`; macOS universal binaries may hold several architectures).
pub fn expected_format(platform: &str) -> Option<(&'static str, &'static [&'static str])> {
    match platform {
        "linux64" => Some(("ELF", &["x86_64"])),
        "win64" => Some(("PE", &["x86_64"])),
        "darwin64" => Some(("Mach-O", &["x86_64", "aarch64"])),
        "linux32" => Some(("ELF", &["x86"])),
        "win32" => Some(("PE", &["x86"])),
        _ => None,
    }
}

/// Why a file could not be read as a shared library (goblin's cause kept as its text).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BinaryError {
    /// goblin could not parse the file.
    #[error("not a readable binary: {0}")]
    Unreadable(String),
    /// A slice of a macOS universal binary could not be read.
    #[error("universal binary: {0}")]
    UniversalSlice(String),
    /// A macOS universal binary holding a static archive.
    #[error("universal binary holds an archive")]
    UniversalArchive,
    /// The exports of a Mach-O file could not be read.
    #[error("Mach-O exports: {0}")]
    MachOExports(String),
    /// Another object format.
    #[error("not an ELF, PE or Mach-O shared library")]
    NotSharedLibrary,
}

/// Reads a shared library's format, architectures, exports and (ELF) glibc needs.
pub fn inspect(bytes: &[u8]) -> Result<BinaryInfo, BinaryError> {
    match Object::parse(bytes).map_err(|e| BinaryError::Unreadable(e.to_string()))? {
        Object::Elf(elf) => Ok(elf_info(&elf)),
        Object::PE(pe) => Ok(BinaryInfo {
            format: "PE",
            slices: vec![Slice {
                architecture: pe_arch(pe.header.coff_header.machine),
                exports: sorted(pe.exports.iter().filter_map(|e| e.name.map(str::to_string))),
            }],
            max_glibc: None,
        }),
        Object::Mach(Mach::Binary(m)) => Ok(BinaryInfo {
            format: "Mach-O",
            slices: vec![macho_slice(&m)?],
            max_glibc: None,
        }),
        Object::Mach(Mach::Fat(fat)) => {
            let mut slices = Vec::new();
            for arch in fat.into_iter() {
                match arch.map_err(|e| BinaryError::UniversalSlice(e.to_string()))? {
                    SingleArch::MachO(m) => slices.push(macho_slice(&m)?),
                    SingleArch::Archive(_) => return Err(BinaryError::UniversalArchive),
                }
            }
            Ok(BinaryInfo {
                format: "Mach-O",
                slices,
                max_glibc: None,
            })
        }
        _ => Err(BinaryError::NotSharedLibrary),
    }
}

fn sorted(names: impl Iterator<Item = String>) -> Vec<String> {
    let mut v: Vec<String> = names.collect();
    v.sort();
    v.dedup();
    v
}

fn elf_info(elf: &goblin::elf::Elf) -> BinaryInfo {
    use goblin::elf::sym::{STB_GLOBAL, STB_WEAK, STT_FUNC};
    let exports = elf
        .dynsyms
        .iter()
        .filter(|s| s.st_shndx != 0 && s.st_type() == STT_FUNC)
        .filter(|s| matches!(s.st_bind(), STB_GLOBAL | STB_WEAK))
        .filter_map(|s| elf.dynstrtab.get_at(s.st_name).map(str::to_string));
    let mut glibc: Option<(Vec<u32>, String)> = None;
    if let Some(verneed) = &elf.verneed {
        for need in verneed.iter() {
            for aux in need.iter() {
                let Some(name) = elf.dynstrtab.get_at(aux.vna_name) else {
                    continue;
                };
                let Some(v) = name.strip_prefix("GLIBC_") else {
                    continue;
                };
                let key: Vec<u32> = v.split('.').filter_map(|p| p.parse().ok()).collect();
                if glibc.as_ref().is_none_or(|(k, _)| key > *k) {
                    glibc = Some((key, name.to_string()));
                }
            }
        }
    }
    let architecture = match elf.header.e_machine {
        goblin::elf::header::EM_X86_64 => "x86_64".to_string(),
        goblin::elf::header::EM_AARCH64 => "aarch64".to_string(),
        goblin::elf::header::EM_386 => "x86".to_string(),
        m => format!("machine {m}"),
    };
    BinaryInfo {
        format: "ELF",
        slices: vec![Slice {
            architecture,
            exports: sorted(exports),
        }],
        max_glibc: glibc.map(|(_, n)| n),
    }
}

fn pe_arch(machine: u16) -> String {
    match machine {
        goblin::pe::header::COFF_MACHINE_X86_64 => "x86_64".into(),
        goblin::pe::header::COFF_MACHINE_X86 => "x86".into(),
        goblin::pe::header::COFF_MACHINE_ARM64 => "aarch64".into(),
        m => format!("machine {m:#x}"),
    }
}

fn macho_slice(m: &goblin::mach::MachO) -> Result<Slice, BinaryError> {
    use goblin::mach::cputype::{CPU_TYPE_ARM64, CPU_TYPE_X86_64};
    let architecture = match m.header.cputype {
        CPU_TYPE_X86_64 => "x86_64".to_string(),
        CPU_TYPE_ARM64 => "aarch64".to_string(),
        c => format!("cputype {c:#x}"),
    };
    let exports = m
        .exports()
        .map_err(|e| BinaryError::MachOExports(e.to_string()))?;
    let names = exports
        .into_iter()
        .map(|e| e.name)
        .chain(macho_symtab_exports(m))
        .map(|name| name.strip_prefix('_').unwrap_or(&name).to_string());
    Ok(Slice {
        architecture,
        exports: sorted(names),
    })
}

/// The external symbols a Mach-O image defines in a section, from its symbol table
/// (`LC_SYMTAB`): an image linked without export information (no `LC_DYLD_INFO` export trie, the
/// pre-10.6 linkers' style) has its exports there, and dyld resolves `dlsym` from them.
fn macho_symtab_exports(m: &goblin::mach::MachO) -> Vec<String> {
    use goblin::mach::symbols::{N_PEXT, N_SECT};
    m.symbols()
        .filter_map(Result::ok)
        .filter(|(_, nl)| {
            !nl.is_stab() && nl.is_global() && nl.get_type() == N_SECT && nl.n_type & N_PEXT == 0
        })
        .map(|(name, _)| name.to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::inspect;

    /// A minimal x86_64 Mach-O dylib with a symbol table (`LC_SYMTAB`) and no export trie:
    /// `symbols` as (name, n_type), each defined in section 1.
    fn macho_with_symtab(symbols: &[(&str, u8)]) -> Vec<u8> {
        let mut strtab = vec![b' ', 0];
        let mut nlists = Vec::new();
        for (name, n_type) in symbols {
            let strx = strtab.len() as u32;
            strtab.extend_from_slice(name.as_bytes());
            strtab.push(0);
            nlists.extend_from_slice(&strx.to_le_bytes());
            nlists.extend_from_slice(&[*n_type, 1, 0, 0]); // n_type, n_sect, n_desc
            nlists.extend_from_slice(&0x1000u64.to_le_bytes()); // n_value
        }
        let (header, symtab_cmd) = (32u32, 24u32);
        let symoff = header + symtab_cmd;
        let stroff = symoff + nlists.len() as u32;
        let mut b = Vec::new();
        // mach_header_64: magic, cputype x86_64, cpusubtype, filetype MH_DYLIB, ncmds,
        // sizeofcmds, flags, reserved
        for w in [0xfeed_facf_u32, 0x0100_0007, 3, 6, 1, symtab_cmd, 0, 0] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        // symtab_command: LC_SYMTAB, cmdsize, symoff, nsyms, stroff, strsize
        for w in [
            2,
            symtab_cmd,
            symoff,
            symbols.len() as u32,
            stroff,
            strtab.len() as u32,
        ] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        b.extend_from_slice(&nlists);
        b.extend_from_slice(&strtab);
        b
    }

    #[test]
    fn a_macho_without_export_trie_exports_its_external_defined_symbols() {
        // <mach-o/nlist.h>: N_EXT 0x01, N_SECT 0x0e, N_PEXT 0x10 (private extern)
        let bytes = macho_with_symtab(&[
            ("_fmi2DoStep", 0x0f),
            ("_fmi2Reset", 0x0f),
            ("_helper", 0x0e),
            ("_hidden", 0x1f),
            ("_malloc", 0x01),
        ]);
        let info = inspect(&bytes).unwrap();
        assert_eq!(info.format, "Mach-O");
        assert_eq!(info.slices[0].architecture, "x86_64");
        assert_eq!(info.slices[0].exports, vec!["fmi2DoStep", "fmi2Reset"]);
    }

    #[test]
    fn this_test_binary_is_read_as_the_platform_it_runs_on() {
        let exe = std::fs::read(std::env::current_exe().unwrap()).unwrap();
        let info = inspect(&exe).unwrap();
        assert_eq!(info.format, "ELF");
        assert_eq!(info.slices[0].architecture, std::env::consts::ARCH);
        assert!(info.max_glibc.is_some());
        assert!(inspect(b"not a binary at all").is_err());
    }
}
