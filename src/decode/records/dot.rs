//! The decoder's dot products of stored binary32 values with binary64 ones, in a fixed order
//! (`spec/EVALUATION.md`, "Rounding").

/// Σ a\[k\]·b\[k\] in order: a record's few spectral terms at one wavelength.
#[inline(always)]
pub(crate) fn dot_terms(a: &[f32], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(b) {
        s += *x as f64 * y;
    }
    s
}

/// Σ a\[j\]·b\[j\] in four interleaved partial sums: one running sum would make every
/// addition wait for the last (a level-6 record has 49 terms per coefficient).
#[inline(always)]
pub(crate) fn dot_f32(a: &[f32], b: &[f64]) -> f64 {
    let (mut s0, mut s1, mut s2, mut s3) = (0.0, 0.0, 0.0, 0.0);
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ar, br) = (a4.remainder(), b4.remainder());
    for (x, y) in a4.zip(b4) {
        s0 += x[0] as f64 * y[0];
        s1 += x[1] as f64 * y[1];
        s2 += x[2] as f64 * y[2];
        s3 += x[3] as f64 * y[3];
    }
    for (x, y) in ar.iter().zip(br) {
        s0 += *x as f64 * y;
    }
    (s0 + s1) + (s2 + s3)
}
