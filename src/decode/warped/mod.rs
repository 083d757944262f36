//! Evaluation and sampling of warped tables (`spec/EVALUATION.md`, "Warped tables"), in either
//! of two forms a decoder holds ([`Residency`]):
//!
//! * compact (`compact.rs`, the default): the GPU layout's warped-tables section, tables packed
//!   to the resolution the file stores them at, the rest f32 — tens of kilobytes for an RGL
//!   measurement, the same words a shader reads;
//! * exact (`source.rs`): binary64, the values the specification defines (the reference
//!   decoder's), for tools and archival checks.
//!
//! Both are prepared from the NDF without G × G grids (`vndf.rs`) and read by one text of the
//! formulas (`query.rs`).

mod compact;
mod query;
mod source;
mod vndf;

use super::records::lattice::unit_above;
use super::sampling::sample::{uniforms, Sample};
use crate::error::Result;
use crate::model::warped::WarpedModel;
pub(crate) use compact::CompactTables;
use source::ExactTables;
#[cfg(feature = "encode")]
pub(crate) use vndf::vndf_totals;

/// How an opened file's warped tables (`WARP`, the RGL measurements) are held in memory; files
/// without them are held the same way either way.
///
/// ```
/// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/rgl_paper_warp_v14.sbrdf");
/// let bytes = std::fs::read(path).unwrap();
/// let limits = sbrdf::Limits::default();
/// let compact = sbrdf::Decoder::from_bytes_with(&bytes, &limits, sbrdf::Residency::Compact)?;
/// let exact = sbrdf::Decoder::from_bytes_with(&bytes, &limits, sbrdf::Residency::Exact)?;
/// assert!(compact.resident_bytes() < 64 << 10);
/// assert!(exact.resident_bytes() > 4 * compact.resident_bytes());
/// let (wi, wo) = ([0.3f32, 0.0, 0.954], [-0.3f32, 0.1, 0.949]);
/// let (mut a, mut b) = ([0.0f32], [0.0f32]);
/// compact.eval(wi, wo, &[550.0], &mut a);
/// exact.eval(wi, wo, &[550.0], &mut b);
/// assert!((a[0] - b[0]).abs() <= 1e-3 * b[0]);
/// # Ok::<(), sbrdf::Error>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Residency {
    /// Packed to the precision the file stores (each table value within 1/256 of its
    /// quantisation step of the decoded value; the warps' quantities in f32): the form the GPU
    /// layout holds, 20–60 KiB for a 32 × 32 RGL measurement. What a renderer opens.
    #[default]
    Compact,
    /// Decoded in binary64, every value as `spec/EVALUATION.md` defines it: 0.2–0.9 MiB for
    /// the same material. What tools open (`sbrdf eval`, `decode`, the encoder's checks).
    Exact,
}

/// A warped-table material ready for queries.
#[derive(Debug, Clone)]
pub(crate) enum WarpedEval {
    Compact(CompactTables),
    Exact(Box<ExactTables>),
}

/// The entry points, each one `match` on the form and then the one text of `query.rs`.
macro_rules! on_form {
    ($self:expr, $s:ident => $e:expr) => {
        match $self {
            WarpedEval::Compact($s) => $e,
            WarpedEval::Exact(b) => {
                let $s = &**b;
                $e
            }
        }
    };
}

impl WarpedEval {
    /// Prepares a validated model for `thetas_deg` (HEAD's θi) and `k` terms. Fails, saying
    /// why, when a stored incidence's VNDF or a σ node is zero, or a slice's values all are, or
    /// (compact residency) the tables cannot be packed (the reader refuses such files).
    pub(crate) fn new(
        w: &WarpedModel,
        thetas_deg: &[f32],
        k: usize,
        basis_means: &[f64],
        residency: Residency,
    ) -> std::result::Result<Self, String> {
        let exact = ExactTables::new(w, thetas_deg, k, basis_means).ok_or_else(|| {
            "warped tables whose NDF leaves a stored incidence's VNDF or a σ node at zero"
                .to_string()
        })?;
        Ok(match residency {
            Residency::Exact => WarpedEval::Exact(Box::new(exact)),
            Residency::Compact => WarpedEval::Compact(
                CompactTables::new(&exact, &w.steps).map_err(|e| e.to_string())?,
            ),
        })
    }

    /// The GPU layout's warped-tables section: the compact form's words (built from the exact
    /// form when that is what is held: the same words either way).
    pub(crate) fn section_words(&self, steps: &[f32]) -> Result<Vec<u32>> {
        match self {
            WarpedEval::Compact(c) => Ok(c.words().to_vec()),
            WarpedEval::Exact(e) => Ok(CompactTables::new(e, steps)?.words().to_vec()),
        }
    }

    pub(crate) fn heap_bytes(&self) -> usize {
        match self {
            WarpedEval::Compact(c) => c.heap_bytes(),
            WarpedEval::Exact(e) => std::mem::size_of::<ExactTables>() + e.heap_bytes(),
        }
    }

    /// The spectral coefficients of ρ at unit vectors `wi` (toward the light), `wo` (toward
    /// the viewer), z ≥ 0, into `c` (K values): [`query::coefficients`].
    #[inline]
    pub(crate) fn coefficients(&self, wi: [f64; 3], wo: [f64; 3], c: &mut [f64]) -> bool {
        on_form!(self, s => query::coefficients(s, wi, wo, c))
    }

    /// [`WarpedEval::coefficients`] in a stack buffer handed to `put` (all zero where ρ is 0).
    #[inline]
    pub(crate) fn with_coefficients(&self, wi: [f64; 3], wo: [f64; 3], put: impl FnOnce(&[f64])) {
        const SMALL: usize = 16;
        let k = on_form!(self, s => query_terms(s));
        if k <= SMALL {
            let mut c = [0.0f64; SMALL];
            self.coefficients(wi, wo, &mut c);
            put(&c[..k]);
        } else {
            let mut c = [0.0f64; crate::model::material::MAX_TERMS];
            self.coefficients(wi, wo, &mut c);
            put(&c[..k]);
        }
    }

    fn sample(&self, wi: [f64; 3], u: [f64; 2]) -> Option<[f64; 3]> {
        on_form!(self, s => query::sample(s, wi, u))
    }

    fn pdf(&self, wi: [f64; 3], wo: [f64; 3]) -> f64 {
        on_form!(self, s => query::pdf(s, wi, wo))
    }
}

/// K, the number of terms a query fills.
#[inline(always)]
fn query_terms<S: source::WarpSource>(s: &S) -> usize {
    s.dims().k
}

/// [`super::sampling::sample`] for warped tables (`spec/EVALUATION.md`, "Warped tables"): the
/// density is [`pdf_warped`] at the direction as returned.
pub(crate) fn sample_warped(w: &WarpedEval, wi: [f32; 3], u: [f32; 2]) -> Option<Sample> {
    let u = uniforms(u)?;
    let wi = unit_above(wi)?;
    let d = w.sample(wi, u)?;
    let wo = [d[0] as f32, d[1] as f32, d[2] as f32];
    let back = unit_above(wo)?;
    let pdf = w.pdf(wi, back) as f32;
    (pdf > 0.0 && pdf.is_finite()).then_some(Sample { wo, pdf })
}

/// [`super::sampling::pdf`] for warped tables.
pub(crate) fn pdf_warped(w: &WarpedEval, wi: [f32; 3], wo: [f32; 3]) -> f32 {
    let (Some(wi), Some(wo)) = (unit_above(wi), unit_above(wo)) else {
        return 0.0;
    };
    w.pdf(wi, wo) as f32
}
