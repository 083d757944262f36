//! What the format fixes (`spec/FORMAT.md`): the signature, the versions and what each minor
//! version added, the `HEAD` flags, the chunk types, the fixed sizes, and the reader's resource
//! limits.

/// The first ten bytes of every file. 0x89 catches 7-bit transports, "\r\n" and "\n" catch
/// line-ending translation, 0x1A stops `type` on old systems (PNG's design).
pub const SIGNATURE: [u8; 10] = [0x89, b'S', b'B', b'R', b'D', b'F', 0x0D, 0x0A, 0x1A, 0x0A];
/// The major version this crate reads and writes; a file with another major version is refused
/// as unsupported.
pub const VERSION_MAJOR: u16 = 1;
/// The newest minor version this crate reads and writes. A file is written as 1.7 when its
/// warped tables carry prediction flags (`WARP` arrangement 2), as 1.6 when its
/// warped tables' payload is range-coded, as 1.5 when its
/// warped tables are coded in the wavelet transform, as 1.4 when it holds warped tables
/// (`WARP`) in the DCT, as 1.3 when its
/// records are compact (one `RECS` chunk), as 1.2 when it holds an anisotropic microfacet lobe
/// (kind 5), as 1.1 when it uses a 1.1 feature (a wavelength range, [`FLAG_WAVELENGTH_RANGE`],
/// or a factor model, `FACT`); otherwise it is 1.0, byte for byte.
pub const VERSION_MINOR: u16 = 7;

/// `HEAD` flag bit 0: only φi = 0 is stored; other azimuths are answered by rotation.
pub const FLAG_ISOTROPIC: u32 = 1;
/// `HEAD` flag bit 1 (version 1.1): the wavelengths are evenly spaced and `HEAD` stores the
/// first and the last only ([`range_wavelengths`]).
pub const FLAG_WAVELENGTH_RANGE: u32 = 2;
/// `HEAD` flag bit 2 (version 1.7, isotropic files only): the incidences are stored as their
/// θi alone (every φi is +0 in an isotropic file), 4 bytes each instead of 8.
pub const FLAG_THETA_ONLY: u32 = 4;

/// The W wavelengths of a range from its first and last (`spec/FORMAT.md` §3.1): λ_i = λ_0 +
/// (i·(λ_{W−1} − λ_0))/(W − 1) in binary64, in that order, rounded to the nearest f32.
pub fn range_wavelengths(first: f32, last: f32, w: usize) -> impl Iterator<Item = f32> {
    let (a, span) = (first as f64, last as f64 - first as f64);
    let n = w.saturating_sub(1).max(1) as f64;
    (0..w).map(move |i| (a + (i as f64 * span) / n) as f32)
}

/// Whether a wavelength list can be stored as a range: at least three, each exactly what
/// [`range_wavelengths`] gives from the first and the last.
pub fn is_wavelength_range(w: &[f32]) -> bool {
    w.len() >= 3
        && range_wavelengths(w[0], w[w.len() - 1], w.len())
            .zip(w)
            .all(|(a, b)| a.to_bits() == b.to_bits())
}
/// The only angle convention so far (see `spec/EVALUATION.md`).
pub const ANGLE_CONVENTION: u8 = 1;

/// The header: version, bases, maximum sizes, wavelengths, incident directions (first chunk).
pub const CHUNK_HEAD: [u8; 4] = *b"HEAD";
/// One incident record (`spec/FORMAT.md` §3.3).
pub const CHUNK_RECD: [u8; 4] = *b"RECD";
/// Version 1.3: all N records in one chunk, without what `HEAD` and their order already say.
pub const CHUNK_RECS: [u8; 4] = *b"RECS";
/// End of file: empty, last.
pub const CHUNK_ENDF: [u8; 4] = *b"ENDF";
/// The tabulated spectral basis functions (basis 3 only).
pub const CHUNK_SBAS: [u8; 4] = *b"SBAS";
/// Ancillary: UTF-8 metadata (JSON).
pub const CHUNK_META: [u8; 4] = *b"meta";
/// Ancillary: the outgoing directions the encoder saw (§3.5).
pub const CHUNK_SAMP: [u8; 4] = *b"samp";
/// Version 1.1: the factor model shared by every incidence (§3.7).
pub const CHUNK_FACT: [u8; 4] = *b"FACT";
/// Ancillary, version 1.1: the encoder's held-out error per record (§3.8).
pub const CHUNK_XVAL: [u8; 4] = *b"xval";
/// Warped tables (format 1.4, §3.10).
pub const CHUNK_WARP: [u8; 4] = *b"WARP";
/// The minor version of files that use a 1.1 feature (a factor model); others are written as 1.0.
pub const VERSION_MINOR_FACTOR: u16 = 1;
/// The minor version of files that hold an anisotropic microfacet lobe (kind 5).
pub const VERSION_MINOR_ANISO: u16 = 2;
/// The minor version of files whose records are compact (`RECS`); the writer uses them whenever
/// the material allows 1.3.
pub const VERSION_MINOR_COMPACT: u16 = 3;
/// The minor version of files with warped tables (`WARP`); their records are compact.
pub const VERSION_MINOR_WARP: u16 = 4;
/// The minor version of files whose warped tables are coded in the CDF 5/3 wavelet (`WARP`
/// transform code 1).
pub const VERSION_MINOR_WAVELET: u16 = 5;
/// The minor version of files whose warped tables' integers are range-coded (`WARP` layout
/// bit 3) instead of deflated.
pub const VERSION_MINOR_RANGE: u16 = 6;
/// The minor version of files whose warped tables may be predicted from the previous
/// incidence's (`WARP` arrangement 2, range-coded only).
pub const VERSION_MINOR_PREDICTED: u16 = 7;
/// `SBAS` precision code of a quantised, range-coded basis (version 1.6, §3.2).
pub const SBAS_QUANTISED: u8 = 3;

pub(crate) const HEAD_FIXED: usize = 40;
pub(crate) const RECD_FIXED: usize = 40;
/// A compact record's fixed part (`RECS`), before its scale (f16 records only) and values.
pub(crate) const RECS_FIXED: usize = 21;
pub(crate) const LOBE_FIXED: usize = 4;

/// The largest chunk the format allows (as PNG: 2³¹ − 1).
pub(crate) const MAX_CHUNK: usize = 0x7FFF_FFFF;

/// Resource limits for reading untrusted files.
#[derive(Debug, Clone)]
pub struct Limits {
    /// Files larger than this are refused before parsing. Every allocation the reader makes is
    /// bounded by the bytes actually present, so memory use stays within about twice this.
    pub max_file_bytes: usize,
    /// Warped tables (`WARP`) are compressed, and opening one costs work no byte count bounds:
    /// (M + N)·G² operations to rebuild σ and the VNDF warps, and 2·N·K·R³ for the inverse DCT
    /// (`spec/FORMAT.md` §8). Files above this are refused as a limit exceeded before anything
    /// is inflated. The default, 2²⁷ (about 0.2 s here), is 60× what an RGL file needs.
    pub max_warp_work: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_file_bytes: 256 << 20,
            max_warp_work: 1 << 27,
        }
    }
}
