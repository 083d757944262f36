//! Octahedral grids of the outgoing hemisphere (`spec/EVALUATION.md`, "Baked views"): one
//! function of ωo per record, sampled at the vertices of a side × side grid and read back by
//! bilinear interpolation. The octahedral map takes a unit ωo to (a, b) = (x, y)/(|x| + |y| +
//! |z|): the upper hemisphere fills the diamond |a| + |b| ≤ 1 of the square [−1, 1]², whose
//! edge is the horizon. Each vertex (a, b) holds the function at the direction
//! normalize(a, b, 1 − |a| − |b|): outside the diamond that is below the horizon, the same
//! smooth formula continued, so the cells the horizon crosses interpolate a smooth function.
//! The map bends only along a = 0 and b = 0, which are grid lines (the side is odd): within
//! each cell the function is smooth and the error falls as the square of the spacing. No
//! trigonometry: one division per query.

use crate::model::angles::normalize;

/// Where a query falls in a grid: the index of its cell's first vertex and its fractions
/// along v (the next vertex) and u (the next row).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cell {
    at: usize,
    tu: f64,
    tv: f64,
}

/// One grid per record, row-major in u, each `side`² binary32 values.
#[derive(Debug, Clone)]
pub(crate) struct OctahedralGrids {
    side: usize,
    /// (side − 1)/2: grid units per unit of u or v.
    half: f64,
    values: Vec<f32>,
}

/// The unit direction of grid coordinates (a, b) in [−1, 1]² (the octahedral map's inverse on
/// the diamond, its smooth continuation below the horizon outside it).
pub(crate) fn direction(a: f64, b: f64) -> [f64; 3] {
    let z = 1.0 - a.abs() - b.abs();
    // Never the zero vector: |a| + |b| + z = 1 unless both |a|, |b| are large, and then z < 0.
    normalize([a, b, z]).unwrap_or([0.0, 0.0, 1.0])
}

impl OctahedralGrids {
    /// Grids of `count` functions with `side` vertices a side (made odd, at least 3), vertex
    /// values `f(r, ωo)`.
    pub(crate) fn bake(side: usize, count: usize, f: impl Fn(usize, [f64; 3]) -> f64) -> Self {
        let side = side.max(3) | 1;
        let half = 0.5 * (side - 1) as f64;
        let mut values = Vec::with_capacity(count * side * side);
        for r in 0..count {
            for iu in 0..side {
                for iv in 0..side {
                    let d = direction(iu as f64 / half - 1.0, iv as f64 / half - 1.0);
                    values.push(f(r, d) as f32);
                }
            }
        }
        OctahedralGrids { side, half, values }
    }

    /// No grids (side 0): what a view whose SH parts are all constants holds.
    pub(crate) fn none() -> Self {
        OctahedralGrids {
            side: 0,
            half: 0.0,
            values: Vec::new(),
        }
    }

    /// Vertices a side (0 for [`OctahedralGrids::none`]).
    pub(crate) fn side(&self) -> usize {
        self.side
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.values.capacity() * std::mem::size_of::<f32>()
    }

    /// The cell of unit `wo` (z ≥ 0).
    #[inline(always)]
    pub(crate) fn cell(&self, wo: [f64; 3]) -> Cell {
        let inv = 1.0 / (wo[0].abs() + wo[1].abs() + wo[2]);
        let fu = (wo[0] * inv + 1.0) * self.half;
        let fv = (wo[1] * inv + 1.0) * self.half;
        // Negative (rounding at the horizon) converts to 0; the last cell takes the far edge.
        let last = self.side.saturating_sub(2);
        // Through u32, which converts in fewer instructions than usize.
        let iu = (fu as u32 as usize).min(last);
        let iv = (fv as u32 as usize).min(last);
        Cell {
            at: iu * self.side + iv,
            tu: fu - iu as f64,
            tv: fv - iv as f64,
        }
    }

    /// Record r's function at `cell`, interpolated bilinearly (0 past the grids).
    #[inline(always)]
    pub(crate) fn at(&self, r: usize, cell: Cell) -> f64 {
        let n = self.side;
        let at = r * n * n + cell.at;
        let Some(g) = self.values.get(at..at + n + 2) else {
            return 0.0;
        };
        let (v00, v01, v10, v11) = (g[0] as f64, g[1] as f64, g[n] as f64, g[n + 1] as f64);
        let near = v00 + cell.tv * (v01 - v00);
        let far = v10 + cell.tv * (v11 - v10);
        near + cell.tu * (far - near)
    }

    /// The largest |interpolated − f| of record r's grid at its cells' centres and its edges'
    /// midpoints above the horizon, where bilinear interpolation of a smooth function strays
    /// furthest.
    pub(crate) fn worst_error(&self, r: usize, f: impl Fn([f64; 3]) -> f64) -> f64 {
        let mut worst = 0.0f64;
        let steps = 2 * self.side.saturating_sub(1);
        for su in 0..=steps {
            for sv in 0..=steps {
                if su % 2 == 0 && sv % 2 == 0 {
                    continue; // a vertex: exact up to binary32
                }
                let (u, v) = (su as f64 / steps as f64, sv as f64 / steps as f64);
                let d = direction(2.0 * u - 1.0, 2.0 * v - 1.0);
                if d[2] < 0.0 {
                    continue;
                }
                let e = (self.at(r, self.cell(d)) - f(d)).abs();
                worst = if e.is_nan() {
                    f64::INFINITY
                } else {
                    worst.max(e)
                };
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_and_its_inverse_agree_and_the_edge_is_the_horizon() {
        let g = OctahedralGrids::bake(9, 1, |_, d| d[0] + 2.0 * d[1] + 3.0 * d[2]);
        for (u, v) in [
            (-1.0, 0.0),
            (0.0, 1.0),
            (0.25, -0.5),
            (0.0, 0.0),
            (0.5, -0.5),
        ] {
            let d = direction(u, v);
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((n - 1.0).abs() < 1e-12);
            let c = g.cell(d);
            let (fu, fv) = ((u + 1.0) * 4.0, (v + 1.0) * 4.0);
            let (iu, iv) = (c.at / 9, c.at % 9);
            assert!((iu as f64 + c.tu - fu).abs() < 1e-9, "{u} {v}: {c:?}");
            assert!((iv as f64 + c.tv - fv).abs() < 1e-9, "{u} {v}: {c:?}");
        }
        // The diamond's edge is the horizon, its centre the normal, its outside below.
        assert!(direction(0.7, 0.3)[2].abs() < 1e-12);
        assert!(direction(-0.2, -0.8)[2].abs() < 1e-12);
        assert!(direction(0.9, 0.9)[2] < 0.0);
        assert_eq!(direction(0.0, 0.0), [0.0, 0.0, 1.0]);
    }

    #[test]
    fn vertices_are_exact_and_a_finer_grid_strays_less() {
        let f = |d: [f64; 3]| (3.0 * d[0]).sin() + d[2] * d[2];
        let coarse = OctahedralGrids::bake(9, 1, |_, d| f(d));
        let fine = OctahedralGrids::bake(33, 1, |_, d| f(d));
        let d = direction(0.5, -0.25); // a vertex of both, above the horizon
        assert!((coarse.at(0, coarse.cell(d)) - f(d)).abs() < 1e-6);
        let (ec, ef) = (coarse.worst_error(0, f), fine.worst_error(0, f));
        assert!(ef < ec / 8.0, "coarse {ec}, fine {ef}");
        assert!(ef > 0.0);
        // Past the grids: 0, not a panic.
        assert_eq!(fine.at(1, fine.cell(d)), 0.0);
    }
}
