//! The decoder at one wavelength ([`crate::Decoder::at`]): a hero-wavelength renderer's many
//! queries at one λ, with the spectral basis values at λ computed once.

use super::evaluator::{Evaluator, SMALL_TERMS};
use super::kernel::Collapsed;
use crate::error::Result;

/// [`crate::Decoder`] at one wavelength, made by [`crate::Decoder::at`]. Its values are `Decoder::eval`'s at
/// that wavelength, bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct AtWavelength<'a> {
    evaluator: &'a Evaluator,
    wavelength: f32,
    /// B_0..B_{K−1} at the wavelength (NaN first when it is not finite), when the file's
    /// queries can use them ([`Evaluator::hoists_basis`]); otherwise each query goes through
    /// `eval`.
    basis: Option<[f64; SMALL_TERMS]>,
    /// On the θ-line path, every record with its spectral terms applied at the wavelength
    /// (when the file's records fit: 17 at SH level 6, more at lower levels): a query then
    /// only evaluates its directions. Computed here, at about the cost of two queries per
    /// record.
    collapsed: Option<Collapsed>,
}

impl<'a> AtWavelength<'a> {
    pub(crate) fn new(evaluator: &'a Evaluator, wavelength: f32) -> Self {
        let basis = evaluator.hoists_basis().then(|| {
            let mut b = [0.0f64; SMALL_TERMS];
            evaluator.basis_at(wavelength, &mut b);
            b
        });
        let collapsed = match (&basis, evaluator.kernel_input()) {
            (Some(b), Some((kernel, st))) if !b[0].is_nan() => {
                kernel.collapse_all(st.res, &b[..st.res.spectrum.terms()])
            }
            _ => None,
        };
        AtWavelength {
            evaluator,
            wavelength,
            basis,
            collapsed,
        }
    }

    /// The wavelength (nm) this view answers at.
    pub fn wavelength(&self) -> f32 {
        self.wavelength
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), in 1/sr: [`crate::Decoder::eval`] at this wavelength. Never allocates.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// // A hero-wavelength path tracer: one view per sampled wavelength, many queries each.
    /// for lambda in [480.0f32, 560.0, 640.0] {
    ///     let at = decoder.at(lambda);
    ///     let rho = at.eval([0.3, 0.0, 0.954], [-0.3, 0.1, 0.949]);
    ///     assert!(rho >= 0.0);
    ///     assert_eq!(at.eval([0.3, 0.0, 0.954], [0.0, 0.0, -1.0]), 0.0); // below the horizon
    /// }
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    #[inline]
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        if let (Some(c), Some((kernel, st)), Some(b)) =
            (&self.collapsed, self.evaluator.kernel_input(), &self.basis)
        {
            return kernel.one_collapsed(st, wi, wo, c).unwrap_or_else(|| {
                let k = st.res.spectrum.terms();
                self.evaluator.line_fallback(wi, wo, &b[..k])
            });
        }
        match &self.basis {
            Some(b) => {
                let k = self.evaluator.res.spectrum.terms();
                self.evaluator.eval_one(wi, wo, &b[..k])
            }
            None => {
                let mut out = [0.0f32];
                self.evaluator.eval(wi, wo, &[self.wavelength], &mut out);
                out[0]
            }
        }
    }

    /// ρ for many pairs at this wavelength: [`crate::Decoder::eval_batch`] with one wavelength
    /// (the same slices, errors and bits).
    ///
    /// ```
    /// let decoder = sbrdf::Decoder::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf"))?;
    /// let at = decoder.at(550.0);
    /// let wi = [[0.5f32, 0.0, 0.866]; 2];
    /// let wo = [[-0.5f32, 0.0, 0.866], [0.0, 0.5, 0.866]];
    /// let mut out = [0.0f32; 2];
    /// at.eval_batch(&wi, &wo, &mut out)?;
    /// assert_eq!(out[0], at.eval(wi[0], wo[0])); // the same bits as one at a time
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn eval_batch(&self, wi: &[[f32; 3]], wo: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        super::batch::checked(self.evaluator, wi, wo, &[self.wavelength], out)
    }
}
