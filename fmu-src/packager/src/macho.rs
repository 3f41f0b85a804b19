//! A universal ("fat") Mach-O file from single-architecture slices, so that `binaries/darwin64/`
//! holds one dylib that loads on Intel and Apple-silicon Macs (FMI 2.0 names one macOS platform).
//!
//! Written here rather than by `lipo`, which is not available on Linux build machines (and
//! `llvm-lipo` only with an LLVM installation); the format is short: a big-endian header
//! (`FAT_MAGIC`, slice count), one `fat_arch` record per slice (CPU type and subtype, offset,
//! size, alignment as a power of two), and the slices at offsets aligned to 2^14 bytes, the
//! page size of arm64 macOS (`mach-o/fat.h`).

/// `FAT_MAGIC` of `mach-o/fat.h`.
const FAT_MAGIC: u32 = 0xcafe_babe;
/// `MH_MAGIC_64`: a 64-bit little-endian Mach-O slice.
const MH_MAGIC_64: u32 = 0xfeed_facf;
/// Slices start at multiples of 2^ALIGN_LOG2 bytes.
const ALIGN_LOG2: u32 = 14;

/// Why slices cannot be joined into one universal file.
#[derive(Debug, thiserror::Error)]
pub enum UniversalError {
    /// Slice `index` (from 1) does not start with `MH_MAGIC_64`.
    #[error("slice {index} is not a 64-bit Mach-O file")]
    NotMachO64 { index: usize },
    /// Two slices name the same CPU type, which a universal file holds once.
    #[error("two slices for CPU type {cpu:#x}")]
    SameCpu { cpu: u32 },
}

/// The universal file of `slices` (each a complete 64-bit Mach-O), in the order given.
pub fn universal(slices: &[Vec<u8>]) -> Result<Vec<u8>, UniversalError> {
    let align = 1usize << ALIGN_LOG2;
    let mut archs = Vec::new();
    let mut offset = align;
    for (i, s) in slices.iter().enumerate() {
        let word = |at: usize| {
            s.get(at..at + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        if word(0) != Some(MH_MAGIC_64) {
            return Err(UniversalError::NotMachO64 { index: i + 1 });
        }
        let (cpu, sub) = (word(4).unwrap_or(0), word(8).unwrap_or(0));
        if archs.iter().any(|&(c, _, _, _)| c == cpu) {
            return Err(UniversalError::SameCpu { cpu });
        }
        archs.push((cpu, sub, offset, s.len()));
        offset = (offset + s.len()).div_ceil(align) * align;
    }
    let mut out = Vec::with_capacity(offset);
    out.extend_from_slice(&FAT_MAGIC.to_be_bytes());
    out.extend_from_slice(&(slices.len() as u32).to_be_bytes());
    for &(cpu, sub, off, size) in &archs {
        for v in [cpu, sub, off as u32, size as u32, ALIGN_LOG2] {
            out.extend_from_slice(&v.to_be_bytes());
        }
    }
    for (s, &(_, _, off, _)) in slices.iter().zip(&archs) {
        out.resize(off, 0);
        out.extend_from_slice(s);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{universal, FAT_MAGIC, MH_MAGIC_64};

    fn slice(cpu: u32, len: usize) -> Vec<u8> {
        let mut s = vec![0u8; len];
        s[..4].copy_from_slice(&MH_MAGIC_64.to_le_bytes());
        s[4..8].copy_from_slice(&cpu.to_le_bytes());
        s[len - 1] = 0xab;
        s
    }

    #[test]
    fn slices_are_aligned_and_described() {
        let (x86, arm) = (slice(0x0100_0007, 20_000), slice(0x0100_000c, 100));
        let fat = universal(&[x86.clone(), arm.clone()]).unwrap();
        let be = |at: usize| u32::from_be_bytes(fat[at..at + 4].try_into().unwrap());
        assert_eq!((be(0), be(4)), (FAT_MAGIC, 2));
        // records: cputype, cpusubtype, offset, size, align
        assert_eq!(
            (be(8), be(16), be(20), be(24)),
            (0x0100_0007, 16384, 20_000, 14)
        );
        assert_eq!((be(28), be(36), be(40)), (0x0100_000c, 3 * 16384, 100));
        assert_eq!(&fat[16384..16384 + 20_000], &x86[..]);
        assert_eq!(&fat[49152..49152 + 100], &arm[..]);
        assert!(universal(&[x86.clone(), x86]).is_err());
        assert!(universal(&[vec![0u8; 64]]).is_err());
    }
}
