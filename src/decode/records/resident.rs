//! The decoder's resident form of a material: what an opened file keeps in memory. Renderers open
//! thousands of materials, so the records live in a few flat arrays (no allocation per record
//! or lobe) holding exactly the stored values (`f16` values times their scale are `f32` numbers),
//! plus what evaluation would otherwise recompute per query: each record's unit peak vector, the
//! logarithms of the lobe parameters that are blended geometrically, and a signature of its lobe
//! kinds. The [`Material`] it came from can be rebuilt from it exactly
//! ([`Resident::material`]), so the decoder need not keep both.

use crate::model::angles::dir_from_deg;
use crate::model::factor::FactorModel;
use crate::model::material::HeldOutErrors;
use crate::model::material::{DirectionSet, MAX_LOBES};
use crate::model::material::{IncidentRecord, Lobe, LobeKind, Material, SamplePositions};
use crate::model::sh::sh_count;
use crate::model::spectral::{SpectralSpace, SpectrumEvaluator};
use crate::model::warped::WarpedModel;
use crate::model::Precision;

/// `$ty { … }` with the fields a [`Rec`] keeps exactly as its [`IncidentRecord`] has them
/// (incidence, peak angles, error, critical angle, precision) copied from `$from`, plus the
/// fields given: the one list of them, for both directions ([`Resident::new`],
/// [`Resident::material`]).
macro_rules! with_kept_fields {
    ($from:expr => $ty:ident { $($rest:tt)* }) => {{
        let from = $from;
        $ty {
            theta_i: from.theta_i,
            phi_i: from.phi_i,
            theta_p: from.theta_p,
            phi_p: from.phi_p,
            rel_error: from.rel_error,
            critical_angle: from.critical_angle,
            precision: from.precision,
            $($rest)*
        }
    }};
}

/// One record: where its values are, its sizes, and the fields a [`Material`] needs back.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rec {
    /// The unit peak vector d(θp, φp).
    pub peak: [f64; 3],
    pub theta_i: f32,
    pub phi_i: f32,
    pub theta_p: f32,
    pub phi_p: f32,
    pub rel_error: f32,
    pub critical_angle: f32,
    /// Offset of its SH coefficients (terms × (level + 1)², term-major) in `vals`.
    pub sh: u32,
    /// Index of its first lobe in `lobes`.
    pub lobe0: u32,
    pub terms: u16,
    pub level: u8,
    pub nlobes: u8,
    pub precision: Precision,
    /// The lobe kinds' codes, 4 bits each, first lobe lowest: blended records whose signatures
    /// are equal share every lobe position (`spec/EVALUATION.md`, "Lobes by position").
    pub kinds: u32,
}

/// One lobe: its kind and where its amplitudes and parameters are.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LobeRec {
    pub kind: LobeKind,
    /// Offset of its amplitudes (variant-major, `terms` per variant) in `vals`.
    pub amp: u32,
    /// Offset of its parameters in `params` and of their logarithms in `ln_params`.
    pub par: u32,
}

/// A material as the decoder holds it.
#[derive(Debug, Clone)]
pub(crate) struct Resident {
    pub recs: Vec<Rec>,
    pub lobes: Vec<LobeRec>,
    /// SH coefficients and lobe amplitudes of every record, as stored (1/sr).
    pub vals: Vec<f32>,
    /// Lobe shape parameters as stored, and their natural logarithms (widths, exponents and
    /// microfacet b, c are blended geometrically; a's logarithm is unused).
    pub params: Vec<f32>,
    pub ln_params: Vec<f64>,
    pub spectrum: SpectrumEvaluator,
    /// `HEAD`'s basis, K and interval (the table lives in `spectrum`).
    pub spectral: SpectralSpace,
    pub sh_level: usize,
    pub isotropic: bool,
    pub version_minor: u16,
    pub wavelengths: Vec<f32>,
    pub metadata: Option<Box<str>>,
    pub sample_positions: Option<SamplePositions>,
    /// The factor model shared by every incidence (`FACT`) and the held-out errors (`xval`),
    /// as read.
    pub factor: Option<FactorModel>,
    pub held_out: Option<HeldOutErrors>,
    /// Warped tables (`WARP`) as read, their integers deflated (their decoded form lives in
    /// the evaluator).
    pub warped: Option<Box<HeldWarpedModel>>,
}

/// A [`WarpedModel`] as an open decoder keeps it to give the material back: every field but
/// the N·K·R² integers, which are kept as zigzag LEB128 varints, deflated (mostly zeros: 98 KiB
/// of `i32` for an RGL measurement become about 3 KiB, the size of the file's own payload).
#[derive(Debug, Clone)]
pub(crate) struct HeldWarpedModel {
    /// The model with `levels` empty.
    model: WarpedModel,
    levels: Box<[u8]>,
    count: usize,
}

impl HeldWarpedModel {
    fn new(w: &WarpedModel) -> Self {
        let mut bytes = Vec::with_capacity(w.levels.len());
        for &z in &w.levels {
            let mut v = ((z << 1) ^ (z >> 31)) as u32;
            while v >= 0x80 {
                bytes.push((v as u8) | 0x80);
                v >>= 7;
            }
            bytes.push(v as u8);
        }
        let levels = miniz_oxide::deflate::compress_to_vec(&bytes, 1).into_boxed_slice();
        HeldWarpedModel {
            model: WarpedModel {
                levels: Vec::new(),
                ..w.clone()
            },
            levels,
            count: w.levels.len(),
        }
    }

    /// The model, its integers inflated again.
    pub(crate) fn model(&self) -> WarpedModel {
        // Written above from `count` integers of at most five bytes each.
        let bytes =
            miniz_oxide::inflate::decompress_to_vec_with_limit(&self.levels, 5 * self.count)
                .expect("deflated by HeldWarpedModel::new");
        let mut levels = Vec::with_capacity(self.count);
        let (mut v, mut shift) = (0u32, 0);
        for b in bytes {
            v |= ((b & 0x7f) as u32) << shift;
            if b & 0x80 == 0 {
                levels.push((v >> 1) as i32 ^ -((v & 1) as i32));
                (v, shift) = (0, 0);
            } else {
                shift += 7;
            }
        }
        WarpedModel {
            levels,
            ..self.model.clone()
        }
    }

    /// The model's quantisation steps q(i, k).
    pub(crate) fn steps(&self) -> &[f32] {
        &self.model.steps
    }

    /// The box holding this and what it owns (the model's own vectors, the deflated bytes).
    pub(crate) fn heap_bytes(&self) -> usize {
        // `boxed_heap_bytes` counts a boxed model's own struct, which here is inside `Self`.
        std::mem::size_of::<Self>() - std::mem::size_of::<WarpedModel>()
            + self.model.boxed_heap_bytes()
            + self.levels.len()
    }
}

impl Resident {
    /// The mean of each basis function over the file's wavelengths: Σ_k c_k·mean_k is the
    /// spectrum-averaged value of a coefficient vector c (what both samplers draw from).
    pub(crate) fn basis_means(&self) -> Vec<f64> {
        let k = self.spectrum.terms();
        let mut sum = vec![0.0; k];
        let mut b = vec![0.0; k];
        for &l in &self.wavelengths {
            self.spectrum.basis(l as f64, &mut b);
            for (s, v) in sum.iter_mut().zip(&b) {
                *s += v;
            }
        }
        let n = self.wavelengths.len().max(1) as f64;
        sum.iter().map(|s| s / n).collect()
    }

    /// The resident form of a validated material.
    pub fn new(m: &Material) -> Self {
        let n_vals: usize = m
            .records
            .iter()
            .map(|r| r.sh.len() + r.lobes.iter().map(|l| l.amplitude.len()).sum::<usize>())
            .sum();
        let n_lobes: usize = m.records.iter().map(|r| r.lobes.len()).sum();
        let n_params: usize = m
            .records
            .iter()
            .flat_map(|r| r.lobes.iter().map(|l| l.params.len()))
            .sum();
        let mut vals = Vec::with_capacity(n_vals);
        let mut lobes = Vec::with_capacity(n_lobes);
        let mut params = Vec::with_capacity(n_params);
        let mut ln_params = Vec::with_capacity(n_params);
        let mut recs = Vec::with_capacity(m.records.len());
        for r in &m.records {
            let sh = vals.len() as u32;
            vals.extend_from_slice(&r.sh);
            let lobe0 = lobes.len() as u32;
            let mut kinds = 0u32;
            for (li, l) in r.lobes.iter().enumerate().take(MAX_LOBES) {
                kinds |= (l.kind.code() as u32) << (4 * li);
                lobes.push(LobeRec {
                    kind: l.kind,
                    amp: vals.len() as u32,
                    par: params.len() as u32,
                });
                vals.extend_from_slice(&l.amplitude);
                params.extend_from_slice(&l.params);
                ln_params.extend(l.params.iter().map(|&p| (p as f64).ln()));
            }
            recs.push(with_kept_fields!(r => Rec {
                peak: dir_from_deg(r.theta_p as f64, r.phi_p as f64),
                sh,
                lobe0,
                terms: r.terms as u16,
                level: r.sh_level as u8,
                nlobes: r.lobes.len() as u8,
                kinds,
            }));
        }
        Resident {
            recs,
            lobes,
            vals,
            params,
            ln_params,
            spectrum: SpectrumEvaluator::new(&m.spectral),
            spectral: SpectralSpace {
                table: None,
                ..m.spectral.clone()
            },
            sh_level: m.sh_level,
            isotropic: m.isotropic,
            version_minor: m.version_minor,
            wavelengths: m.wavelengths.clone(),
            metadata: m.metadata.as_deref().map(Box::from),
            sample_positions: m.sample_positions.clone(),
            factor: m.factor.clone(),
            held_out: m.held_out.clone(),
            warped: m
                .warped
                .as_deref()
                .map(|w| Box::new(HeldWarpedModel::new(w))),
        }
    }

    /// Record r's SH coefficients of term k (P_r values).
    #[inline]
    pub fn sh_row(&self, r: &Rec, k: usize) -> &[f32] {
        let p = sh_count(r.level as usize);
        let at = r.sh as usize + k * p;
        &self.vals[at..at + p]
    }

    /// Record r's lobe at position `li` (which it has).
    #[inline]
    pub fn lobe(&self, r: &Rec, li: usize) -> &LobeRec {
        &self.lobes[r.lobe0 as usize + li]
    }

    /// A lobe's amplitudes of variant j, one per term of its record.
    #[inline]
    pub fn amplitudes(&self, r: &Rec, l: &LobeRec, j: usize) -> &[f32] {
        let t = r.terms as usize;
        let at = l.amp as usize + j * t;
        &self.vals[at..at + t]
    }

    /// A lobe's parameters as stored.
    #[inline]
    pub fn params(&self, r: &Rec, l: &LobeRec) -> &[f32] {
        let at = l.par as usize;
        &self.params[at..at + l.kind.param_count(r.terms as usize)]
    }

    /// The material this form was made from, exactly.
    pub fn material(&self) -> Material {
        let records = self
            .recs
            .iter()
            .map(|r| {
                let t = r.terms as usize;
                let p = sh_count(r.level as usize);
                let lobes = (0..r.nlobes as usize)
                    .map(|li| {
                        let l = self.lobe(r, li);
                        let na = l.kind.amplitude_count(t);
                        Lobe {
                            kind: l.kind,
                            amplitude: self.vals[l.amp as usize..l.amp as usize + na].to_vec(),
                            params: self.params(r, l).to_vec(),
                        }
                    })
                    .collect();
                with_kept_fields!(r => IncidentRecord {
                    terms: t,
                    sh_level: r.level as usize,
                    sh: self.vals[r.sh as usize..r.sh as usize + t * p].to_vec(),
                    lobes,
                })
            })
            .collect();
        Material {
            version_minor: self.version_minor,
            spectral: SpectralSpace {
                table: self.spectrum.table(),
                ..self.spectral.clone()
            },
            sh_level: self.sh_level,
            isotropic: self.isotropic,
            wavelengths: self.wavelengths.clone(),
            records,
            metadata: self.metadata.as_deref().map(String::from),
            sample_positions: self.sample_positions.clone(),
            factor: self.factor.clone(),
            held_out: self.held_out.clone(),
            warped: self.warped.as_ref().map(|w| Box::new(w.model())),
        }
    }

    /// Bytes this form holds on the heap (capacities, not lengths).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        let samp = self.sample_positions.as_ref().map_or(0, |sp| {
            sp.set_of_incidence.capacity() * 4
                + sp.sets.capacity() * size_of::<DirectionSet>()
                + sp.sets
                    .iter()
                    .map(|s| match s {
                        DirectionSet::List(v) => v.capacity() * 8,
                        DirectionSet::Grid { .. } => 0,
                    })
                    .sum::<usize>()
        });
        self.recs.capacity() * size_of::<Rec>()
            + self.lobes.capacity() * size_of::<LobeRec>()
            + self.vals.capacity() * 4
            + self.params.capacity() * 4
            + self.ln_params.capacity() * 8
            + self.spectrum.heap_bytes()
            + self.wavelengths.capacity() * 4
            + self.metadata.as_ref().map_or(0, |m| m.len())
            + samp
            + self.factor.as_ref().map_or(0, factor_heap_bytes)
            + self
                .held_out
                .as_ref()
                .map_or(0, |h| 4 * (h.rel.capacity() + h.log.capacity()))
            + self.warped.as_ref().map_or(0, |w| w.heap_bytes())
    }
}

/// Heap bytes of a factor model: its components, their spectra and tables, and the vectors
/// that hold them (a `Vec` of `Vec`s allocates the inner vectors' headers too).
fn factor_heap_bytes(f: &FactorModel) -> usize {
    use crate::model::factor::{FactorComponent, Feature};
    use std::mem::size_of;
    f.components.capacity() * size_of::<FactorComponent>()
        + f.components
            .iter()
            .map(|c| {
                c.features.capacity() * size_of::<Feature>()
                    + 4 * c.spectrum.capacity()
                    + c.modulation.capacity() * size_of::<Vec<f32>>()
                    + 4 * c.modulation.iter().map(Vec::capacity).sum::<usize>()
                    + c.tables.capacity() * size_of::<Vec<Vec<f32>>>()
                    + c.tables
                        .iter()
                        .map(|r| {
                            r.capacity() * size_of::<Vec<f32>>()
                                + 4 * r.iter().map(Vec::capacity).sum::<usize>()
                        })
                        .sum::<usize>()
            })
            .sum::<usize>()
}
