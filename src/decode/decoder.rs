//! The decoder: opens a file once, then answers ρ(ωi, ωo, λ) without allocating, and draws
//! outgoing directions in proportion to it.

use super::at_wavelength::AtWavelength;
use super::baked::Baked;
use super::color::{spectrum_to_xyz, xyz_to_linear_srgb, Illuminant, CIE_WAVELENGTHS};
use super::evaluator::Evaluator;
use super::sampling::{self, Sample, SamplingWeights};
use super::warped::Residency;
use crate::error::{Error, Result};
use crate::format::{read_material, Limits};
use crate::model::material::Material;
use std::path::Path;

/// A validated material plus what makes evaluation cheap. `Send + Sync`: one decoder can serve
/// every render thread.
///
/// An incident direction that is not stored is answered by interpolating the *parameters* of the
/// neighbouring records (SH coefficients, lobe amplitudes and shapes, the peak's offset from the
/// mirror direction) and evaluating once, so a specular peak moves with the incident direction
/// instead of cross-fading between two peaks (`spec/EVALUATION.md`, "Between stored incidences").
///
/// Memory: an opened file is held in a compact resident form (flat arrays of the stored values,
/// no allocation per record); [`Decoder::resident_bytes`] says how much. The [`Material`] view
/// ([`Decoder::material`]) is rebuilt from it on first use, for tools; a renderer that only
/// evaluates never pays for it.
#[derive(Debug, Clone)]
pub struct Decoder {
    evaluator: Evaluator,
    /// The material view, built on first use of [`Decoder::material`] (or kept from
    /// [`Decoder::from_material`]).
    material: std::sync::OnceLock<Material>,
    /// Per record, the energy of the background and of each lobe: the mixture weights of
    /// importance sampling ([`super::sampling`]). Computed on first use, once: they cost three
    /// times the rest of opening a file, which a decoder that only evaluates need not pay.
    sampling: std::sync::OnceLock<SamplingWeights>,
    residency: Residency,
}

impl Decoder {
    /// Parses a file held in memory, with the default [`Limits`]. Errors as
    /// [`Decoder::from_bytes_with_limits`].
    ///
    /// ```
    /// let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"),
    ///     "/samples/golden/ggx_3inc_default.sbrdf")).unwrap();
    /// let decoder = sbrdf::Decoder::from_bytes(&bytes)?;
    /// assert_eq!(decoder.material().records.len(), 3);
    /// // Bytes that are not an sbrdf file are refused as malformed.
    /// assert!(matches!(
    ///     sbrdf::Decoder::from_bytes(b"not an sbrdf file"),
    ///     Err(sbrdf::Error::Format { .. })
    /// ));
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        Self::from_bytes_with_limits(bytes, &Limits::default())
    }

    /// Parses a file held in memory under the given resource [`Limits`] (for untrusted input).
    ///
    /// Errors: [`Error::Format`] for a damaged file (or warped tables that cannot be prepared),
    /// [`Error::Unsupported`] for one that needs a newer reader, [`Error::LimitsExceeded`] for
    /// one above `limits`.
    ///
    /// ```
    /// let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf")).unwrap();
    /// // Untrusted input: refuse anything larger than 512 bytes before parsing it (this file is 1013).
    /// let small = sbrdf::Limits { max_file_bytes: 512, ..Default::default() };
    /// assert!(matches!(
    ///     sbrdf::Decoder::from_bytes_with_limits(&bytes, &small),
    ///     Err(sbrdf::Error::LimitsExceeded(_))
    /// ));
    /// let decoder = sbrdf::Decoder::from_bytes_with_limits(&bytes, &sbrdf::Limits::default())?;
    /// assert_eq!(decoder.material().records.len(), 3);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn from_bytes_with_limits(bytes: &[u8], limits: &Limits) -> Result<Self> {
        Self::from_bytes_with(bytes, limits, Residency::Compact)
    }

    /// Parses a file held in memory under `limits`, its warped tables (if any) held as
    /// `residency` says: [`Residency::Compact`] (what [`Decoder::from_bytes`] and
    /// [`Decoder::open`] give) or [`Residency::Exact`] (binary64, the specification's values, for
    /// tools). Errors as [`Decoder::from_bytes_with_limits`].
    ///
    /// ```
    /// let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/rgl_satin_warp_v15.sbrdf")).unwrap();
    /// let exact = sbrdf::Decoder::from_bytes_with(&bytes, &sbrdf::Limits::default(), sbrdf::Residency::Exact)?;
    /// assert_eq!(exact.residency(), sbrdf::Residency::Exact);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn from_bytes_with(bytes: &[u8], limits: &Limits, residency: Residency) -> Result<Self> {
        // The reader validated the material: only its resident form is kept.
        let material = read_material(bytes, limits)?;
        Ok(Decoder {
            evaluator: Evaluator::new(&material, residency).map_err(|message| Error::Format {
                at: crate::error::Location {
                    offset: 0,
                    chunk: Some(crate::format::CHUNK_WARP),
                },
                message,
            })?,
            material: std::sync::OnceLock::new(),
            sampling: std::sync::OnceLock::new(),
            residency,
        })
    }

    /// Reads and parses a file; refuses files above the default size limit before reading them.
    ///
    /// Errors: [`Error::Io`] when the file cannot be read, [`Error::LimitsExceeded`] when it is
    /// larger than [`Limits::default`] allows, otherwise as [`Decoder::from_bytes_with_limits`]
    /// (with the path in the message).
    ///
    /// ```
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// let wavelengths = &decoder.material().wavelengths; // nm, as the input was sampled
    /// assert!(wavelengths.len() > 1 && wavelengths[0] < wavelengths[1]);
    /// assert!(matches!(
    ///     sbrdf::Decoder::open("no/such/file.sbrdf"),
    ///     Err(sbrdf::Error::Io { .. })
    /// ));
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        Self::open_with(path, Residency::Compact)
    }

    /// [`Decoder::open`] with the warped tables (if any) held as `residency` says
    /// ([`Decoder::from_bytes_with`]).
    pub fn open_with(path: impl AsRef<Path>, residency: Residency) -> Result<Self> {
        let path = path.as_ref();
        let limits = Limits::default();
        let len = std::fs::metadata(path)
            .map_err(|e| Error::io(path, e))?
            .len();
        if len > limits.max_file_bytes as u64 {
            return Err(Error::LimitsExceeded(format!(
                "{}: {len} bytes exceeds the limit of {} bytes",
                path.display(),
                limits.max_file_bytes
            )));
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::from_bytes_with(&bytes, &limits, residency).map_err(|e| match e {
            Error::Format { at, message } => Error::Format {
                at,
                message: format!("{}: {message}", path.display()),
            },
            Error::Unsupported { at, message } => Error::Unsupported {
                at,
                message: format!("{}: {message}", path.display()),
            },
            other => other,
        })
    }

    /// Wraps a material built in memory (by the encoder, say), validating it first. Its warped
    /// tables (if any) are held [exactly](Residency::Exact): a decoder built from a material
    /// keeps the material too, and is what tools that measure a file's accuracy evaluate.
    pub fn from_material(material: Material) -> Result<Self> {
        material
            .validate()
            .map_err(|e| Error::Parameter(format!("invalid material: {e}")))?;
        Ok(Decoder {
            evaluator: Evaluator::new(&material, Residency::Exact)
                .map_err(|e| Error::Parameter(format!("invalid material: {e}")))?,
            material: material.into(),
            sampling: std::sync::OnceLock::new(),
            residency: Residency::Exact,
        })
    }

    /// How this decoder holds the file's warped tables ([`Residency`]).
    pub fn residency(&self) -> Residency {
        self.residency
    }

    /// The file's content: records, metadata, sample positions. Rebuilt from the resident form
    /// on first use (exactly what was read) and kept; thread-safe.
    pub fn material(&self) -> &Material {
        self.material.get_or_init(|| self.evaluator.res.material())
    }

    /// Consumes the decoder and returns its [`Material`] (the view of [`Decoder::material`],
    /// built now if it was not yet).
    pub fn into_material(mut self) -> Material {
        self.material
            .take()
            .unwrap_or_else(|| self.evaluator.res.material())
    }

    /// The flat device layout of this material (`spec/GPU_LAYOUT.md`): 32-bit little-endian
    /// words (f32 and u32) with a header of word offsets, for a shader to evaluate, sample and
    /// give the pdf of (the sampling section holds the weights [`Decoder::sample`] uses; the model
    /// section a factor model, `FACT`, or the warped tables, `WARP`, in the compact form a
    /// decoder opened with [`Residency::Compact`] evaluates: the same words whichever residency
    /// this decoder has).
    ///
    /// ```
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// let words = decoder.gpu_layout()?;
    /// assert_eq!(words[0], u32::from_le_bytes(*b"SBGL"));
    /// assert_eq!(words[2] as usize, words.len()); // total words
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn gpu_layout(&self) -> Result<Vec<u32>> {
        let mut words = super::gpu_layout::gpu_layout(&self.evaluator.res)?;
        let res = &self.evaluator.res;
        // Warped tables (spec/GPU_LAYOUT.md, "Warped tables section"): the compact form this
        // decoder evaluates, which answers every query and samples itself (no sampling section).
        if let (Some(w), Some(held)) = (self.evaluator.warped(), &res.warped) {
            let section = w.section_words(held.steps())?;
            super::gpu_layout::warped::append_warped_section(&mut words, &section)?;
            return Ok(words);
        }
        // The records' mixture weights (spec/GPU_LAYOUT.md, "Sampling section"): what
        // `Decoder::sample` draws from, a factor model included (it samples the records' mixture,
        // whose cosine covers F).
        super::gpu_layout::sampling::append_sampling_section(
            &mut words,
            self.sampling_weights(),
            res.recs.len(),
        )?;
        // The factor model (spec/GPU_LAYOUT.md, "Model section").
        if let Some(model) = &res.factor {
            super::gpu_layout::factor::append_factor_section(&mut words, model)?;
        }
        Ok(words)
    }

    /// Bytes this decoder holds in memory: the struct and everything it owns on the heap
    /// (capacities as requested from the allocator, whose own overhead, typically 8–16 bytes
    /// per allocation over about a dozen allocations, is not counted). An opened file starts
    /// at its resident form; the importance-sampling weights ([`Decoder::prepare_sampling`])
    /// and the [`Material`] view ([`Decoder::material`]) add to it once used.
    ///
    /// ```
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// let before = decoder.resident_bytes();
    /// decoder.prepare_sampling(); // the sampling weights add to it
    /// assert!(decoder.resident_bytes() > before);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn resident_bytes(&self) -> usize {
        let mut n = std::mem::size_of::<Self>() + self.evaluator.heap_bytes();
        if let Some(w) = self.sampling.get() {
            n += w.heap_bytes();
        }
        if let Some(m) = self.material.get() {
            n += material_heap_bytes(m);
        }
        n
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), for each wavelength in nm, into `out` (1/sr); never negative (the series is
    /// clamped at 0, `spec/EVALUATION.md`). Directions below the horizon give 0; so do zero or
    /// non-finite vectors. Wavelengths outside the file's spectral interval are clamped to it;
    /// incident directions outside the stored θ range are clamped to it. Writes
    /// `min(wavelengths.len(), out.len())` values; never allocates.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// // Light 30° from the normal in the x–z plane; viewer near its mirror direction.
    /// let (s, c) = 30f32.to_radians().sin_cos();
    /// let wi = [s, 0.0, c];
    /// let wo = [-s, 0.0, c];
    /// let mut rho = [0.0f32; 3];
    /// decoder.eval(wi, wo, &[450.0, 550.0, 650.0], &mut rho);
    /// assert!(rho.iter().all(|&v| v > 0.0));
    /// // Below the horizon the value is 0.
    /// decoder.eval(wi, [0.0, 0.0, -1.0], &[550.0], &mut rho[..1]);
    /// assert_eq!(rho[0], 0.0);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    // Not `#[inline]` (nor `AtWavelength::eval`, `Baked::eval`): with it every crate that calls
    // it compiled the whole evaluator chain below (`#[inline(always)]`) again: `cargo test
    // --release --no-run` took 11 minutes over the 33 test crates against 3 without it. Same-run cost: eval at 31
    // wavelengths 9% slower in the bench's loop; at(λ) and the baked view 5–8% faster.
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3], wavelengths: &[f32], out: &mut [f32]) {
        self.evaluator.eval(wi, wo, wavelengths, out)
    }

    /// [`Decoder::eval_deg`] without the clamp at 0 of `spec/EVALUATION.md`, "Reconstruction",
    /// step 5: the model's own value, which can be negative between the samples. For measuring
    /// how often a fit undershoots; renderers want [`Decoder::eval`].
    pub fn eval_deg_unclamped(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
    ) {
        self.evaluator
            .eval_deg_with(incident, outgoing, wavelengths, out, false)
    }

    /// Convenience form of [`Decoder::eval`] with angles in degrees.
    ///
    /// ```
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// // Light at θ = 30°, φ = 0°; viewer at the mirror direction θ = 30°, φ = 180° (degrees).
    /// let mut rho = [0.0f64; 2];
    /// decoder.eval_deg((30.0, 0.0), (30.0, 180.0), &[450.0, 650.0], &mut rho);
    /// assert!(rho.iter().all(|v| v.is_finite() && *v > 0.0)); // 1/sr
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn eval_deg(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
    ) {
        self.evaluator
            .eval_deg_with(incident, outgoing, wavelengths, out, true)
    }

    /// The decoder at one wavelength λ (nm), for a renderer that asks many queries at one
    /// wavelength (a hero-wavelength path tracer): what depends on λ alone (the spectral basis
    /// values) is computed here, once, instead of on every query. Its answers are
    /// [`Decoder::eval`]'s at `[λ]`, bit for bit. Never allocates; cheap to make and to copy.
    ///
    /// ```
    /// # let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"),
    /// #     "/samples/golden/ggx_3inc_default.sbrdf")).unwrap();
    /// let decoder = sbrdf::Decoder::from_bytes(&bytes)?;
    /// let at = decoder.at(550.0);
    /// let (wi, wo) = ([0.3, 0.0, 0.954], [-0.3, 0.1, 0.949]);
    /// let mut rho = [0.0f32];
    /// decoder.eval(wi, wo, &[550.0], &mut rho);
    /// assert_eq!(at.eval(wi, wo).to_bits(), rho[0].to_bits());
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn at(&self, wavelength: f32) -> AtWavelength<'_> {
        AtWavelength::new(&self.evaluator, wavelength)
    }

    /// The decoder at one wavelength, faster and approximate: each record's spherical-harmonic
    /// part sampled on an octahedral grid of ωo (sized for `tolerance`), the lobes analytic with
    /// their shapes blended ahead (`spec/EVALUATION.md`, "Baked views"). Every value is within `tolerance`·max(ρ, ρ̄) of
    /// [`Decoder::eval`]'s at `[wavelength]`, ρ̄ the mean of ρ over the hemisphere's pairs
    /// there ([`Baked::mean_value`]). Allocates its grids ([`Baked::resident_bytes`]: tens of
    /// KiB at 10⁻², MiB at 10⁻³ and below), so make one per wavelength at open, not per query.
    ///
    /// Taken by files whose records go through the one-wavelength kernel (a θ line, at most two
    /// cosine-power or microfacet lobes a record, SH level ≤ 6, ≤ 16 spectral terms); others,
    /// and a tolerance its largest grid cannot hold, give [`Error::Parameter`] saying why.
    pub fn baked(&self, wavelength: f32, tolerance: f32) -> Result<Baked<'_>> {
        Baked::new(&self.evaluator, wavelength, tolerance)
    }

    /// The same decoder with its batch kernel run `lanes` wide (1, 4 or 8): for tests, which
    /// hold every width to the same bits on one machine. None where this CPU lacks the
    /// instructions (8: AVX-512, 4: AVX2) or the file does not use the kernel.
    #[doc(hidden)]
    pub fn with_kernel_lanes(mut self, lanes: u32) -> Option<Self> {
        self.evaluator = self.evaluator.with_kernel_lanes(lanes)?;
        Some(self)
    }

    /// ρ for many direction pairs at once: pair i is (`wi[i]`, `wo[i]`), and a slice of length 1
    /// is used for every pair (one light, many viewers, say). Row i of `out` (`wavelengths.len()`
    /// values from i·`wavelengths.len()`) receives what [`Decoder::eval`] would write for pair i,
    /// bit for bit, on every CPU and whatever else is in the batch. Work that depends on the
    /// incident direction alone (the records to blend and the blended lobe shapes) is done once
    /// per run of pairs with the same `wi`, and the spectral basis once per wavelength for the
    /// whole batch; at one wavelength, on the files the encoder writes by default, the pairs
    /// are sorted by the records they blend and evaluated four or eight at a time (AVX2,
    /// AVX-512), each record's spectral terms applied once per group.
    /// Never allocates.
    ///
    /// Errors (nothing written): `wi` and `wo` have different lengths, neither being 1, or
    /// `out` holds fewer than N·`wavelengths.len()` values.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// let wi = [[0.5f32, 0.0, 0.866]]; // one light for every pair
    /// let wo = [[-0.5f32, 0.0, 0.866], [0.0, 0.5, 0.866], [0.0, 0.0, 1.0]];
    /// let wavelengths = [450.0f32, 550.0];
    /// let mut out = [0.0f32; 3 * 2]; // row i: pair i's two values
    /// decoder.eval_batch(&wi, &wo, &wavelengths, &mut out)?;
    /// let mut one = [0.0f32; 2];
    /// decoder.eval(wi[0], wo[1], &wavelengths, &mut one);
    /// assert_eq!(&out[2..4], &one[..]); // bit for bit what eval gives
    /// // Too small an output is refused, and nothing is written.
    /// assert!(decoder.eval_batch(&wi, &wo, &wavelengths, &mut out[..5]).is_err());
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn eval_batch(
        &self,
        wi: &[[f32; 3]],
        wo: &[[f32; 3]],
        wavelengths: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        let s = super::batch::check(wi, wo, wavelengths, out)?;
        self.evaluator.eval_batch(
            |i| wi[i * s.wi_step],
            |i| wo[i * s.wo_step],
            s.n,
            wavelengths,
            out,
        );
        Ok(())
    }

    /// [`Decoder::eval_batch`] over vectors read through accessors (the C ABI's strided
    /// arrays): pair i is (`wi(i)`, `wo(i)`) for i < `n`. `out` must hold n·M values.
    pub(crate) fn eval_batch_with(
        &self,
        n: usize,
        wi: impl Fn(usize) -> [f32; 3],
        wo: impl Fn(usize) -> [f32; 3],
        wavelengths: &[f32],
        out: &mut [f32],
    ) {
        self.evaluator.eval_batch(wi, wo, n, wavelengths, out)
    }

    /// Computes the importance-sampling weights now rather than on the first call of
    /// [`Decoder::sample`] or [`Decoder::pdf`] (the only call that allocates): for renderers
    /// that want every later call allocation-free. Thread-safe; later calls do nothing.
    ///
    /// ```
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// decoder.prepare_sampling(); // allocates once, here
    /// // ... so that sampling in the render loop never allocates:
    /// let wi = [0.5f32, 0.0, 0.866];
    /// let s = decoder.sample(wi, [0.25, 0.5]).expect("wi is above the surface");
    /// assert!(s.pdf > 0.0 && s.wo[2] >= 0.0);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn prepare_sampling(&self) {
        self.sampling_weights();
    }

    fn sampling_weights(&self) -> &SamplingWeights {
        self.sampling
            .get_or_init(|| SamplingWeights::new(self.evaluator.records()))
    }

    /// Draws an outgoing direction (toward the viewer) for the incident direction `wi` (toward
    /// the light; local frame, z = normal, need not be unit length) from two uniform numbers
    /// in [0, 1). The density is the same for every wavelength: a mixture of the stored lobes'
    /// shapes and a cosine, weighted by the energy of each in the spectrum-averaged BRDF times
    /// cos θo. The returned `pdf` (1/sr, over solid angle) is exactly [`Decoder::pdf`] at the
    /// returned direction. None when `wi` is below the horizon, zero or not finite, or a `u`
    /// is not finite. Never allocates after the first call (see
    /// [`Decoder::prepare_sampling`]). Details: `spec/EVALUATION.md`, "Importance sampling".
    ///
    /// A path tracer that starts at the camera knows the direction toward the viewer, not the
    /// light: it passes that one as `wi` and uses the drawn direction as the light's, which is
    /// right to the extent that the material is reciprocal (ρ(wi, wo) = ρ(wo, wi)); the stored
    /// BRDF is reciprocal exactly as far as its input and its fit are (`tests/sampling.rs`
    /// reports how far).
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// let wi = [0.5f32, 0.0, 0.866];
    /// let s = decoder.sample(wi, [0.25, 0.75]).expect("wi is above the horizon");
    /// assert!(s.wo[2] > 0.0 && s.pdf > 0.0);
    /// assert_eq!(s.pdf, decoder.pdf(wi, s.wo));
    /// // One-sample estimate of the reflected radiance from this light at 550 nm:
    /// let mut rho = [0.0f32];
    /// decoder.eval(wi, s.wo, &[550.0], &mut rho);
    /// let weight = rho[0] * s.wo[2] / s.pdf;
    /// assert!(weight.is_finite() && weight >= 0.0);
    /// assert!(decoder.sample([0.0, 0.0, -1.0], [0.25, 0.75]).is_none()); // below the horizon
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn sample(&self, wi: [f32; 3], u: [f32; 2]) -> Option<Sample> {
        if let Some(w) = self.evaluator.warped() {
            return super::warped::sample_warped(w, wi, u);
        }
        sampling::sample(self.evaluator.records(), self.sampling_weights(), wi, u)
    }

    /// The density (1/sr, over solid angle) with which [`Decoder::sample`] draws `wo` for `wi`:
    /// 0 when either is below the horizon, zero or not finite; otherwise > 0 wherever
    /// cos θo > 0. Never allocates.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// let wi = [0.5f32, 0.0, 0.866];
    /// assert!(decoder.pdf(wi, [-0.5, 0.0, 0.866]) > 0.0);
    /// assert_eq!(decoder.pdf(wi, [0.0, 0.0, -1.0]), 0.0); // below the horizon
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn pdf(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        if let Some(w) = self.evaluator.warped() {
            return super::warped::pdf_warped(w, wi, wo);
        }
        sampling::pdf(self.evaluator.records(), self.sampling_weights(), wi, wo)
    }

    /// ρ(wi, wo) as CIE XYZ under `illuminant`: the spectrum evaluated at 380–780 nm every 5 nm
    /// (held at the file's end values outside its wavelength range, as [`Decoder::eval`] does)
    /// and integrated against the 1931 2° observer. No allocation.
    pub fn eval_xyz(&self, wi: [f32; 3], wo: [f32; 3], illuminant: Illuminant) -> [f64; 3] {
        let mut s = [0.0f32; CIE_WAVELENGTHS.len()];
        self.eval(wi, wo, &CIE_WAVELENGTHS, &mut s);
        spectrum_to_xyz(&s, illuminant)
    }

    /// ρ(wi, wo) as linear sRGB under `illuminant` (D65 is sRGB's own white).
    ///
    /// ```
    /// use sbrdf::decode::color::Illuminant;
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// let rgb = decoder.eval_linear_srgb([0.5, 0.0, 0.866], [-0.5, 0.0, 0.866], Illuminant::D65);
    /// assert!(rgb.iter().all(|c| c.is_finite()));
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn eval_linear_srgb(&self, wi: [f32; 3], wo: [f32; 3], illuminant: Illuminant) -> [f64; 3] {
        xyz_to_linear_srgb(self.eval_xyz(wi, wo, illuminant))
    }
}

/// Heap bytes of a material held in memory (capacities).
fn material_heap_bytes(m: &Material) -> usize {
    use crate::model::material::{DirectionSet, IncidentRecord, Lobe};
    use std::mem::size_of;
    let table = m
        .spectral
        .table
        .as_ref()
        .map_or(0, |t| 8 * (t.nodes.capacity() + t.values.capacity()));
    let records: usize = m
        .records
        .iter()
        .map(|r| {
            4 * r.sh.capacity()
                + size_of::<Lobe>() * r.lobes.capacity()
                + r.lobes
                    .iter()
                    .map(|l| 4 * (l.amplitude.capacity() + l.params.capacity()))
                    .sum::<usize>()
        })
        .sum();
    let samp = m.sample_positions.as_ref().map_or(0, |sp| {
        4 * sp.set_of_incidence.capacity()
            + size_of::<DirectionSet>() * sp.sets.capacity()
            + sp.sets
                .iter()
                .map(|s| match s {
                    DirectionSet::List(v) => 8 * v.capacity(),
                    DirectionSet::Grid { .. } => 0,
                })
                .sum::<usize>()
    });
    table
        + 4 * m.wavelengths.capacity()
        + size_of::<IncidentRecord>() * m.records.capacity()
        + records
        + m.metadata.as_ref().map_or(0, |s| s.capacity())
        + samp
        + m.warped.as_ref().map_or(0, |w| w.boxed_heap_bytes())
}
