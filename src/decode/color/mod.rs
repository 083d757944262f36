//! Spectrum to colour, for renderers that shade in RGB: CIE 1931 2° XYZ under an illuminant, and
//! linear sRGB (IEC 61966-2-1 primaries, D65 white).

pub(crate) mod cie;

/// The light the reflected spectrum is seen under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Illuminant {
    /// CIE standard illuminant D65 (daylight), the sRGB white.
    #[default]
    D65,
    /// Equal energy at every wavelength (CIE illuminant E).
    Equal,
}

impl Illuminant {
    fn power(self, i: usize) -> f64 {
        match self {
            Illuminant::D65 => cie::D65[i],
            Illuminant::Equal => 1.0,
        }
    }
}

/// The wavelengths of the CIE tables, nm.
pub const CIE_WAVELENGTHS: [f32; cie::COUNT] = {
    let mut a = [0.0f32; cie::COUNT];
    let mut i = 0;
    while i < cie::COUNT {
        a[i] = (cie::FIRST_NM + cie::STEP_NM * i as f64) as f32;
        i += 1;
    }
    a
};

/// XYZ of a spectrum given at [`CIE_WAVELENGTHS`]: Σ s(λ)·E(λ)·(x̄, ȳ, z̄)(λ) / Σ E(λ)·ȳ(λ), so a
/// constant spectrum of 1 has Y = 1 (for a BRDF value in 1/sr, multiply by π for the albedo of a
/// Lambertian surface of that value).
pub fn spectrum_to_xyz(spectrum: &[f32; cie::COUNT], illuminant: Illuminant) -> [f64; 3] {
    let (mut x, mut y, mut z, mut norm) = (0.0, 0.0, 0.0, 0.0);
    for (i, &s) in spectrum.iter().enumerate() {
        let e = illuminant.power(i);
        x += s as f64 * e * cie::X_BAR[i];
        y += s as f64 * e * cie::Y_BAR[i];
        z += s as f64 * e * cie::Z_BAR[i];
        norm += e * cie::Y_BAR[i];
    }
    [x / norm, y / norm, z / norm]
}

/// Linear sRGB from XYZ (the IEC 61966-2-1 matrix; no transfer curve).
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
}
