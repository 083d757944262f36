//! What every sampler of the decoder returns and shares (the records' mixture in
//! [`super`], the warped tables' in `crate::decode::warped`): the drawn direction with its
//! density, the cosine's least share, and how the two uniform numbers are taken.

/// A direction drawn by [`Decoder::sample`](crate::Decoder::sample): the unit outgoing vector (toward the viewer, local
/// frame, z = normal) and the density it was drawn with, over solid angle (1/sr).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The drawn outgoing direction: a unit vector toward the viewer, local frame (z = normal).
    pub wo: [f32; 3],
    /// The density `wo` was drawn with, over solid angle (1/sr); equals [`Decoder::pdf`](crate::Decoder::pdf).
    pub pdf: f32,
}

/// The least share of the cosine component in the mixture: it keeps the density positive
/// wherever the BRDF can be (a lobe's proposal covers only part of the hemisphere) and bounds
/// the variance where the lobes' energies underestimate the background.
pub const MIN_COSINE_WEIGHT: f64 = 0.1;

/// The largest f64 below 1.
pub(crate) const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// The two uniform numbers of a draw in [0, 1) (clamped there), or `None` when one is not
/// finite.
#[inline]
pub(crate) fn uniforms(u: [f32; 2]) -> Option<[f64; 2]> {
    if !(u[0].is_finite() && u[1].is_finite()) {
        return None;
    }
    Some([
        (u[0] as f64).clamp(0.0, ONE_BELOW),
        (u[1] as f64).clamp(0.0, ONE_BELOW),
    ])
}
