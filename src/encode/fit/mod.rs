//! Fitting one incident direction: the paper's method (Sec. 2.3), its direct-SH baseline, and
//! the joint fit beyond it.
//!
//! Per incident direction, the spectrum at each outgoing direction is projected on the spectral
//! basis; each coefficient, seen as a function of the outgoing direction, is then split into a
//! smooth background (real SH up to level L, least squares by SVD) and a Gaussian peak around the
//! mirror-reflection direction. The objective and the steps are written out in
//! `spec/EVALUATION.md`, section "How the encoder fits (informative)".

mod context;
pub mod joint;
mod options;
mod paper;
mod peak;

pub use context::{lstsq, spectral_projection, FitContext, Fitted};
pub use options::{CriticalAngle, JointOptions, LobeFamily, PeakMode};
pub use peak::find_peak_direction;

use crate::encode::samples::IncidentSamples;

/// Fits one incident direction with the fit `ctx` describes. Values are rounded to f32 (the
/// caller rounds further for f16 and re-measures with [`FitContext::measure`]).
pub fn fit_incidence(ctx: &FitContext, s: &IncidentSamples) -> Result<Fitted, String> {
    if ctx.peak == PeakMode::Joint {
        let (mut f, met) = joint::fit_joint(ctx, s, &ctx.joint)?;
        f.met = met;
        return Ok(f);
    }
    paper::fit_paper(ctx, s)
}
