//! The decoder at one wavelength ([`crate::Decoder::at`]): a hero-wavelength renderer's many
//! queries at one λ, with the spectral basis values at λ computed once.

use super::batch;
use super::evaluator::{AtRoute, Evaluator};
use crate::error::Result;

/// [`crate::Decoder`] at one wavelength, made by [`crate::Decoder::at`]. Its values are `Decoder::eval`'s at
/// that wavelength, bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct AtWavelength<'a> {
    evaluator: &'a Evaluator,
    wavelength: f32,
    /// How its queries are answered, chosen here once (`Evaluator::at_route`): from every
    /// record collapsed at the wavelength, from the wavelength's basis values, or through
    /// `eval`.
    route: AtRoute,
}

impl<'a> AtWavelength<'a> {
    pub(crate) fn new(evaluator: &'a Evaluator, wavelength: f32) -> Self {
        AtWavelength {
            evaluator,
            wavelength,
            route: evaluator.at_route(wavelength),
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
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        self.evaluator.eval_at(&self.route, self.wavelength, wi, wo)
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
        let wavelengths = [self.wavelength];
        let s = batch::check(wi, wo, &wavelengths, out)?;
        self.evaluator.eval_batch(
            |i| wi[i * s.wi_step],
            |i| wo[i * s.wo_step],
            s.n,
            &wavelengths,
            out,
        );
        Ok(())
    }
}
