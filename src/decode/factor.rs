//! The factor model's route (`FACT`, `spec/EVALUATION.md`, "Reconstruction", step 5): its
//! angular terms at a query's own directions and its spectra interpolated at the file's
//! wavelengths, added to the records' value before the clamp.

use super::records::resident::Resident;
use crate::model::factor::{FeatureValues, MAX_COMPONENTS, MAX_RANK};

/// A factor model's angular terms T_cr at one pair of directions.
pub(crate) type FactorTerms = [f64; MAX_COMPONENTS * MAX_RANK];

/// No factor model: every term 0.
pub(crate) const NO_FACTOR: FactorTerms = [0.0; MAX_COMPONENTS * MAX_RANK];

/// The factor model's angular terms at unit vectors `wi`, `wo` (any common frame: its features
/// depend on the pair alone), if the file has one.
#[inline]
pub(crate) fn factor_terms(res: &Resident, wi: [f64; 3], wo: [f64; 3]) -> Option<FactorTerms> {
    res.factor.as_ref().map(|f| {
        let feats = FeatureValues::of(wi, wo).clamped(&f.ranges);
        let mut t = NO_FACTOR;
        f.angular(&feats, &mut t);
        t
    })
}

/// ρ at one wavelength `l` (nm) from the blended coefficients `c` and the factor terms `t`,
/// before the clamp; 0 at a non-finite wavelength. `nodes` are the file's wavelengths when it
/// has a factor model.
#[inline]
pub(crate) fn value_with_factor(
    res: &Resident,
    nodes: Option<&WavelengthNodes>,
    c: &[f64],
    t: &FactorTerms,
    l: f64,
) -> f64 {
    if !l.is_finite() {
        return 0.0;
    }
    let mut v = res.spectrum.dot(c, l);
    if let (Some(f), Some(nodes)) = (&res.factor, nodes) {
        let (j, a) = nodes.bracket(l);
        v += f.value(t, j, a);
    }
    v
}

/// The file's wavelengths as interpolation nodes: a wavelength's bracket (j, a), value =
/// (1 − a)·v_j + a·v_{j+1}, λ clamped to the nodes' range.
#[derive(Debug, Clone)]
pub(crate) struct WavelengthNodes {
    nodes: Vec<f64>,
    /// 1/(mean spacing): evenly spaced nodes (the usual case) are located by one
    /// multiplication, the guess checked; 0 with fewer than two nodes.
    inv_step: f64,
}

impl WavelengthNodes {
    pub(crate) fn new(w: &[f32]) -> Self {
        let nodes: Vec<f64> = w.iter().map(|&v| v as f64).collect();
        let inv_step = match nodes.as_slice() {
            [first, .., last] if last > first => (nodes.len() - 1) as f64 / (last - first),
            _ => 0.0,
        };
        WavelengthNodes { nodes, inv_step }
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        8 * self.nodes.capacity()
    }

    fn bracket(&self, l: f64) -> (usize, f64) {
        let n = &self.nodes;
        if n.len() == 1 || l.is_nan() || l <= n[0] {
            return (0, 0.0);
        }
        let last = n.len() - 1;
        if l >= n[last] {
            return (last, 0.0);
        }
        // n[0] < l < n[last] here, so the guess is below last.
        let g = (((l - n[0]) * self.inv_step) as usize).min(last - 1);
        let j = if n[g] <= l && l < n[g + 1] {
            g
        } else {
            n.partition_point(|&x| x <= l) - 1
        };
        (j, (l - n[j]) / (n[j + 1] - n[j]))
    }
}
