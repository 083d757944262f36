//! Baked views (`spec/EVALUATION.md`, "Baked views"): the decoder at one wavelength with each
//! record's spherical-harmonic part sampled on an octahedral grid of ωo (`grid.rs`) instead of
//! summed per query, its lobes analytic with their shapes blended ahead (`kernel/baked.rs`). A renderer asks for one with a tolerance τ and
//! trades memory for speed: every value stays within τ·max(ρ, ρ̄) of the exact route's (ρ̄ the
//! mean of ρ over the hemisphere's pairs at that wavelength). [`crate::Decoder::at`] stays
//! exact; this is its faster, approximate sibling.

pub(crate) mod grid;

use super::evaluator::{BakedInput, Evaluator};
use super::kernel::groups::Collapsed;
use crate::error::{Error, Result};
use crate::model::sh::ShBasis;
use grid::OctahedralGrids;

/// The smallest grid side tried, and the largest a baked view holds (1 MiB per record).
const MIN_SIDE: usize = 9;
const MAX_SIDE: usize = 513;
/// The share of τ the grids may take on their own check points: the rest is margin for the
/// points between them (a bilinear grid's error peaks near, not exactly at, a cell's centre),
/// for the shapes blended ahead and for the table of θi.
const GRID_SHARE: f64 = 0.5;
/// The smallest tolerance taken: below it the grids outgrow what a renderer would hold for one
/// wavelength (the NIST PTFE measurement needs 513² vertices a record, 6 MB, at 10⁻⁴).
const MIN_TOLERANCE: f32 = 1e-4;
/// The fewest and most steps the shapes are blended at between two records.
const MIN_STEPS: usize = 16;
const MAX_STEPS: usize = 4096;
/// Pairs over which ρ̄ is averaged (uniform in solid angle on both hemispheres, a fixed
/// sequence: the same view every time).
const MEAN_PAIRS: usize = 4096;

/// [`crate::Decoder`] at one wavelength with its records' SH parts baked on octahedral grids
/// of ωo, made by [`crate::Decoder::baked`]. Its values are within the tolerance it was made
/// with of [`crate::Decoder::eval`]'s at that wavelength: |ρ_baked − ρ| ≤ τ·max(ρ, ρ̄).
#[derive(Debug, Clone)]
pub struct Baked<'a> {
    evaluator: &'a Evaluator,
    wavelength: f32,
    tolerance: f64,
    /// What the exact route gives it at its wavelength: basis values, collapsed records,
    /// shapes blended ahead.
    input: BakedInput,
    grids: OctahedralGrids,
    /// Each record's SH part where every record has only Y_0^0 (a constant: no grid read);
    /// empty otherwise.
    constants: Vec<f64>,
    mean: f64,
    grid_error: f64,
}

impl<'a> Baked<'a> {
    pub(crate) fn new(evaluator: &'a Evaluator, wavelength: f32, tolerance: f32) -> Result<Self> {
        let tol = tolerance as f64;
        if !(MIN_TOLERANCE..1.0).contains(&tolerance) {
            return Err(Error::Parameter(format!(
                "a baked view's tolerance must be in [{MIN_TOLERANCE:e}, 1) (a share of ρ, e.g. \
                 0.001; below {MIN_TOLERANCE:e} use Decoder::at, which is exact); got \
                 {tolerance}"
            )));
        }
        // Shapes blended at K + 1 weights: (Δ/K)²/8 ≤ τ/64 for Δ the widest change of a
        // shape's logarithm between two records.
        let steps = |widest: f64| {
            let k = (widest / (tol / 8.0).sqrt()).ceil();
            if k.is_finite() {
                (k as usize).clamp(MIN_STEPS, MAX_STEPS)
            } else {
                MAX_STEPS
            }
        };
        let input = evaluator
            .baked_input(wavelength, steps)
            .map_err(Error::Parameter)?;
        let (collapsed, counts) = (&input.collapsed, &input.sh_counts);
        let at = evaluator.at_route(wavelength);
        let mean = mean_value(|wi, wo| evaluator.eval_at(&at, wavelength, wi, wo) as f64);
        let floor = if mean > 0.0 { mean } else { f64::MIN_POSITIVE };
        let basis_sh = ShBasis::shared();
        let exact = |r: usize, d: [f64; 3]| {
            let coefficients = collapsed.sh(r, counts[r]);
            let mut y = [0.0f64; 64];
            let y = &mut y[..coefficients.len()];
            let level = (coefficients.len() as f64).sqrt() as usize;
            basis_sh.eval_to_level(level.saturating_sub(1), d, y);
            coefficients
                .iter()
                .zip(y.iter())
                .map(|(a, y)| a * y)
                .sum::<f64>()
        };
        let worst = |g: &OctahedralGrids| {
            (0..counts.len())
                .map(|r| g.worst_error(r, |d| exact(r, d)))
                .fold(0.0f64, f64::max)
                / floor
        };
        let (grids, grid_error, constants) = if counts.iter().all(|&p| p <= 1) {
            // Every record's SH part is its Y_0^0 term, a constant: held as one value a
            // record, exact, with no grid to bake or read.
            let constants = (0..counts.len())
                .map(|r| exact(r, [0.0, 0.0, 1.0]))
                .collect();
            (OctahedralGrids::none(), 0.0, constants)
        } else {
            let target = GRID_SHARE * tol;
            // A bilinear grid's error falls as the square of its spacing: one coarse grid
            // predicts the side, and the side grows until its check points hold.
            let coarse = OctahedralGrids::bake(MIN_SIDE, counts.len(), exact);
            let e0 = worst(&coarse);
            if e0 <= target {
                (coarse, e0, Vec::new())
            } else {
                let ratio = (e0 / target).sqrt();
                let mut side =
                    (((MIN_SIDE - 1) as f64 * ratio * 1.1).ceil() as usize + 1).min(MAX_SIDE);
                loop {
                    let g = OctahedralGrids::bake(side, counts.len(), exact);
                    let e = worst(&g);
                    if e <= target {
                        break (g, e, Vec::new());
                    }
                    if side >= MAX_SIDE {
                        return Err(Error::Parameter(format!(
                            "a baked view at {wavelength} nm cannot hold a tolerance of \
                             {tolerance}: its grids stray {:.2e}·ρ̄ at {MAX_SIDE}² vertices a \
                             record (the most it holds); ask for {:.1e} or more, or use \
                             Decoder::at",
                            e,
                            e / GRID_SHARE
                        )));
                    }
                    side = (side + side / 4 + 1).min(MAX_SIDE);
                }
            }
        };
        Ok(Baked {
            evaluator,
            wavelength,
            tolerance: tol,
            input,
            grids,
            constants,
            mean,
            grid_error,
        })
    }

    /// The wavelength (nm) this view answers at.
    pub fn wavelength(&self) -> f32 {
        self.wavelength
    }

    /// The tolerance τ it was made with.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// ρ̄: the mean of ρ over pairs uniform in solid angle at this wavelength (1/sr), the
    /// floor of the tolerance's scale.
    pub fn mean_value(&self) -> f64 {
        self.mean
    }

    /// Vertices a side of each record's grid; 0 where every record's SH part is a constant
    /// (its Y_0^0 term alone), held as one value a record with no grid.
    pub fn grid_side(&self) -> usize {
        self.grids.side()
    }

    /// The largest difference its grids showed from the exact SH parts on their check points
    /// (cells' centres, edges' midpoints), as a share of ρ̄: at most half the tolerance.
    pub fn grid_error(&self) -> f64 {
        self.grid_error
    }

    /// Bytes this view holds beyond the decoder's own: itself, its grids and its table of
    /// collapsed records.
    pub fn resident_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.grids.heap_bytes()
            + std::mem::size_of::<Collapsed>()
            + self.input.lobes.heap_bytes()
            + self.input.sh_counts.capacity() * std::mem::size_of::<usize>()
            + self.constants.capacity() * std::mem::size_of::<f64>()
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local
    /// frame (z = normal), in 1/sr, within the view's tolerance of
    /// [`crate::Decoder::eval`]'s; 0 below the horizon. Never allocates.
    ///
    /// ```
    /// # let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/golden/ggx_3inc_default.sbrdf");
    /// let decoder = sbrdf::Decoder::open(path)?;
    /// let baked = decoder.baked(550.0, 1e-3)?; // made once per wavelength, at open
    /// let (wi, wo) = ([0.3, 0.0, 0.954], [-0.3, 0.1, 0.949]);
    /// let exact = decoder.at(550.0).eval(wi, wo);
    /// let floor = exact.max(baked.mean_value() as f32);
    /// assert!((baked.eval(wi, wo) - exact).abs() <= 1e-3 * floor);
    /// # Ok::<(), sbrdf::Error>(())
    /// ```
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        let grids = &self.grids;
        self.evaluator.eval_baked(
            &self.input,
            |r0, count, wo| {
                if let Some(c) = self.constants.get(r0..r0 + count) {
                    return [c[0], c.get(1).copied().unwrap_or(0.0)];
                }
                let cell = grids.cell(wo);
                let s0 = grids.at(r0, cell);
                let s1 = if count == 2 {
                    grids.at(r0 + 1, cell)
                } else {
                    0.0
                };
                [s0, s1]
            },
            wi,
            wo,
        )
    }
}

/// The mean of `rho` over [`MEAN_PAIRS`] pairs uniform in solid angle on the upper hemisphere
/// (a fixed low-discrepancy sequence: z = u, φ = 2πv).
fn mean_value(rho: impl Fn([f32; 3], [f32; 3]) -> f64) -> f64 {
    let golden = [0.618_033_988_749_894_9, 0.754_877_666_246_692_7];
    let dir = |u: f64, v: f64| {
        let (z, phi) = (u, std::f64::consts::TAU * v);
        let r = (1.0 - z * z).max(0.0).sqrt();
        [(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32]
    };
    let mut sum = 0.0;
    for i in 0..MEAN_PAIRS {
        let x = (i as f64 + 0.5) / MEAN_PAIRS as f64;
        let a = (0.5 + golden[0] * i as f64).fract();
        let b = (0.5 + golden[1] * i as f64).fract();
        let c = (0.25 + golden[0] * golden[1] * i as f64).fract();
        sum += rho(dir(x, a), dir(b, c));
    }
    sum / MEAN_PAIRS as f64
}
