//! A query's incident side over the records: its incident direction in the records' frame,
//! the records to blend with their weights, the incidence they are evaluated at (θ clamped to
//! the stored range), and what the blended records share ([`BlendInfo`], precomputed for each
//! record alone and each pair of neighbours on a θ line). `spec/EVALUATION.md`, "Between stored
//! incidences".

use super::blend::{BlendInfo, Incident};
use super::lattice::{clamp_incidence, Blend, Lattice, QueryFrame};
use super::resident::Resident;
use crate::model::angles::{azimuth_rotation, deg_from_dir, dir_from_deg, polar_deg};
use crate::model::material::Material;

/// A file's records with what places a query among them: what the sampler reads.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Records<'a> {
    pub res: &'a Resident,
    pub places: &'a Incidences,
}

/// How a file's stored incidences place a query, settled when it is opened.
#[derive(Debug, Clone)]
pub(crate) struct Incidences {
    pub(crate) lattice: Lattice,
    /// Whether the records are isotropic (stored at φi = 0, queries rotated into that frame).
    isotropic: bool,
    /// The stored θ range's ends with their sine and cosine: a query clamped to an end keeps
    /// its azimuth without trigonometry.
    pub(crate) theta_ends: [(f64, f64, f64); 2],
    /// [`BlendInfo`] of each record alone and, on a θ line, of each pair of neighbours
    /// (record i with i + 1).
    alone: Vec<BlendInfo>,
    pairs: Vec<BlendInfo>,
}

impl Incidences {
    /// The incidences of `material`, whose resident form is `res`.
    pub(crate) fn new(material: &Material, res: &Resident) -> Self {
        let lattice = Lattice::of(material);
        let end = |t: f64| {
            let (s, c) = t.to_radians().sin_cos();
            (t, s, c)
        };
        let first = material.records.first().map_or(0.0, |r| r.theta_i as f64);
        let last = material.records.last().map_or(0.0, |r| r.theta_i as f64);
        let n = res.recs.len();
        let alone = (0..n).map(|r| BlendInfo::of(res, &[r])).collect();
        let pairs = match lattice {
            Lattice::Theta(_) => (1..n).map(|r| BlendInfo::of(res, &[r - 1, r])).collect(),
            _ => Vec::new(),
        };
        Incidences {
            lattice,
            isotropic: res.isotropic,
            theta_ends: [end(first), end(last)],
            alone,
            pairs,
        }
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        let info =
            std::mem::size_of::<BlendInfo>() * (self.alone.capacity() + self.pairs.capacity());
        self.lattice.heap_bytes() + info
    }

    /// The query's incident direction in the records' frame (`wi` a unit vector with z ≥ 0).
    #[inline(always)]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        let (r, c, s) = azimuth_rotation(wi);
        // θ only places the query between stored incidences: an error below what the f32
        // input vector can say about its own angle (≈1e-7 rad) is allowed ("Rounding"), and
        // an inlined polynomial costs a fraction of a library atan2.
        let theta = polar_deg(r, wi[2]);
        if self.isotropic {
            // Rotate into the stored frame (φi = 0) with the azimuth's cosine and sine, no trig.
            QueryFrame {
                theta,
                phi: 0.0,
                wi: [r, 0.0, wi[2]],
                rotation: Some((c, s)),
            }
        } else {
            let (_, phi) = deg_from_dir(wi);
            QueryFrame {
                theta,
                phi,
                wi,
                rotation: None,
            }
        }
    }

    /// The records to blend for a query incidence (θ, φ in degrees, in the records' frame), the
    /// incident vector they are evaluated with (`wi`, when given, is the unit vector of (θ, φ))
    /// and its angles: outside the stored θ range the nearest stored θ is used, incident vector
    /// included.
    #[inline(always)]
    pub(crate) fn resolve(
        &self,
        res: &Resident,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
    ) -> (Blend, [f64; 3], f64, f64) {
        let (blend, at_theta, at_phi) = self.lattice.blend(&res.recs, theta, phi);
        let wi = match wi {
            Some(v) if at_theta == theta && at_phi == phi => v,
            Some(v) if at_phi == phi => self.clamped(v, at_theta),
            _ => dir_from_deg(at_theta, at_phi),
        };
        (blend, wi, at_theta, at_phi)
    }

    /// The unit vector at polar angle `theta` (degrees; one of the stored range's ends) with the
    /// azimuth of the unit vector `v` ([`clamp_incidence`]); φ = 0 when `v` is the normal.
    #[inline(always)]
    fn clamped(&self, v: [f64; 3], theta: f64) -> [f64; 3] {
        let below = self.theta_ends[0].0 == theta;
        let above = self.theta_ends[1].0 == theta;
        if !below && !above {
            return dir_from_deg(theta, deg_from_dir(v).1);
        }
        let r = (v[0] * v[0] + v[1] * v[1]).sqrt();
        let (s, c) = clamp_incidence(below, above, r, v[2], &self.theta_ends);
        if r > 0.0 {
            [s * v[0] / r, s * v[1] / r, c]
        } else {
            [s, 0.0, c]
        }
    }

    /// The incident side of a query at incidence (θ, φ) in degrees, in the records' frame (`wi`
    /// its unit vector when known).
    #[inline(always)]
    pub(crate) fn incident(
        &self,
        res: &Resident,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
    ) -> Incident {
        let (blend, wi, theta, phi) = self.resolve(res, theta, phi, wi);
        let info = self.blend_info(res, &blend);
        Incident {
            blend,
            wi,
            theta,
            phi,
            terms: info.terms as usize,
            level: info.level as usize,
            nlobes: info.nlobes as usize,
            shared: info.shared,
        }
    }

    /// [`BlendInfo`] of the records `blend` holds: precomputed for one record and for
    /// neighbours on a θ line.
    #[inline(always)]
    fn blend_info(&self, res: &Resident, blend: &Blend) -> BlendInfo {
        let recs = &blend.rec[..blend.n];
        match (recs, &self.lattice) {
            (&[r], _) => self.alone[r],
            (&[r, r1], Lattice::Theta(_)) if r1 == r + 1 => self.pairs[r],
            _ => BlendInfo::of(res, recs),
        }
    }
}
