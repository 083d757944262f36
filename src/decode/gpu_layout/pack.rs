//! Several materials' device layouts in one buffer (`sbrdf::gpu::pack`, C `sbrdf_gpu_pack`):
//! each layout checked as a renderer checks it once on the host (`spec/GPU_LAYOUT.md`,
//! "Header"), then concatenated, each at its base word.

use super::words::header;
use super::{GPU_LAYOUT_MAGIC, GPU_LAYOUT_VERSION};
use crate::{Decoder, Error, Result};

/// Several materials' flat device layouts in one buffer, as a renderer uploads it: what
/// [`pack`] and [`pack_layouts`] return.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packed {
    /// The layouts, one after another: the contents of the storage buffer the shader reads as
    /// `sbrdf_words` (32-bit words; upload them little-endian).
    pub words: Vec<u32>,
    /// Each material's base, in the order given: the word offset of its layout in `words`, the
    /// `base` argument of the shader's functions.
    pub bases: Vec<u32>,
}

/// Lays out each material ([`Decoder::gpu_layout`]) and packs the layouts into one buffer
/// ([`pack_layouts`]): the words to upload and each material's base.
///
/// The shader needs nothing else from the host: no array in it is sized by a material (it
/// streams the spherical harmonics, the spectral terms and the factor model's terms), so the
/// same text (`sbrdf::gpu::WGSL`) serves every buffer and no pipeline constant is to be set.
///
/// Errors: no material at all; a layout or buffer past 2³² words (every file the decoder opens
/// is laid out, warped tables included since layout version 4).
///
/// ```
/// let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/");
/// let ggx = sbrdf::Decoder::open(format!("{dir}ggx_3inc_default.sbrdf"))?;
/// let krylon = sbrdf::Decoder::open(format!("{dir}krylon_shared_v11.sbrdf"))?;
/// let packed = sbrdf::gpu::pack(&[&ggx, &krylon])?;
/// // Upload packed.words as the storage buffer `sbrdf_words`; a query of the krylon material
/// // calls sbrdf_eval(packed.bases[1], wi, wo, lambda) in the shader.
/// assert_eq!(packed.bases[0], 0);
/// assert_eq!(packed.bases[1] as usize, ggx.gpu_layout()?.len());
/// assert_eq!(packed.words.len(), packed.bases[1] as usize + krylon.gpu_layout()?.len());
/// # Ok::<(), sbrdf::Error>(())
/// ```
pub fn pack(materials: &[&Decoder]) -> Result<Packed> {
    let layouts = materials
        .iter()
        .enumerate()
        .map(|(i, d)| {
            d.gpu_layout().map_err(|e| match e {
                Error::Parameter(m) => Error::Parameter(format!("gpu pack: material {i}: {m}")),
                e => e,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    pack_layouts(&layouts.iter().map(Vec::as_slice).collect::<Vec<_>>())
}

/// Packs layouts already made (by [`Decoder::gpu_layout`], or read back from the files `sbrdf
/// layout` writes) into one buffer, one after another, checking each first: at least the
/// header's words, the magic `SBGL`, a layout version this crate's shader reads (1 to
/// [`GPU_LAYOUT_VERSION`]) and `total_words` equal to its length (`spec/GPU_LAYOUT.md`,
/// "Header"). What a renderer checks once on the host, so that the shader need not.
///
/// ```
/// let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/");
/// let layout = sbrdf::Decoder::open(format!("{dir}ggx_3inc_default.sbrdf"))?.gpu_layout()?;
/// let packed = sbrdf::gpu::pack_layouts(&[&layout, &layout])?;
/// assert_eq!(packed.bases, [0, layout.len() as u32]);
/// // A layout cut short is refused, naming the material.
/// let err = sbrdf::gpu::pack_layouts(&[&layout, &layout[..40]]).unwrap_err();
/// assert!(err.to_string().contains("material 1"));
/// # Ok::<(), sbrdf::Error>(())
/// ```
pub fn pack_layouts(layouts: &[&[u32]]) -> Result<Packed> {
    if layouts.is_empty() {
        return Err(Error::Parameter(
            "gpu pack: no materials (a storage buffer cannot be empty)".into(),
        ));
    }
    let total: usize = layouts.iter().map(|l| l.len()).sum();
    if u32::try_from(total).is_err() {
        return Err(Error::LimitsExceeded(format!(
            "gpu pack: {total} words; a buffer past 2^32 words cannot be addressed"
        )));
    }
    let mut words = Vec::with_capacity(total);
    let mut bases = Vec::with_capacity(layouts.len());
    for (i, l) in layouts.iter().enumerate() {
        let bad = |what: String| Err(Error::Parameter(format!("gpu pack: material {i}: {what}")));
        if l.len() < header::WORDS {
            return bad(format!(
                "{} words, shorter than the layout's {}-word header",
                l.len(),
                header::WORDS
            ));
        }
        if l[header::MAGIC] != GPU_LAYOUT_MAGIC {
            return bad(format!(
                "word 0 is {:#010x}, not the layout's magic {GPU_LAYOUT_MAGIC:#010x} (SBGL)",
                l[header::MAGIC]
            ));
        }
        let version = l[header::VERSION];
        if !(1..=GPU_LAYOUT_VERSION).contains(&version) {
            return bad(format!(
                "layout version {version}; the shader reads versions 1 to {GPU_LAYOUT_VERSION}"
            ));
        }
        if l[header::TOTAL] as usize != l.len() {
            return bad(format!(
                "total_words (header word {}) is {}, the layout has {} words",
                header::TOTAL,
                l[header::TOTAL],
                l.len()
            ));
        }
        bases.push(words.len() as u32); // < total, checked above
        words.extend_from_slice(l);
    }
    Ok(Packed { words, bases })
}
