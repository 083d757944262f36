//! Writes the synthetic fuzz seeds (small EXR slices, a small spectral RGL file).
use sbrdf::io::exr::{write_slice, PixelType};
use sbrdf::io::rgl::{write_tensor, DType, TensorFile};
use std::fs;

fn main() {
    let out = std::env::args().nth(1).expect("output folder");
    let exr = format!("{out}/exr");
    let rgl = format!("{out}/rgl");
    fs::create_dir_all(&exr).unwrap();
    fs::create_dir_all(&rgl).unwrap();
    // EXR: 2 x 4 pixels, 3 wavelengths, float; one NaN pixel (missing).
    let wl = [450.0, 550.0, 650.0];
    let (h, w) = (2usize, 4usize);
    let mut v: Vec<f64> = (0..h * w * wl.len()).map(|i| 0.05 + 0.01 * (i % 7) as f64).collect();
    let a = write_slice(30.0, 0.0, h, w, &wl, &v, PixelType::Float).unwrap();
    fs::write(format!("{exr}/tiny_ti30_pi0.exr"), &a).unwrap();
    v[3] = f64::NAN;
    v[4] = f64::NAN;
    v[5] = f64::NAN;
    let b = write_slice(45.0, 90.0, h, w, &wl, &v, PixelType::Half).unwrap();
    fs::write(format!("{exr}/tiny_half_missing_ti45_pi90.exr"), &b).unwrap();
    // 4 x 8 pixels, 2 wavelengths, angle not representable as f32 (f64 attribute).
    let (h, w) = (4usize, 8usize);
    let wl2 = [500.0, 600.0];
    let v2: Vec<f64> = (0..h * w * 2).map(|i| 0.2 + 0.003 * i as f64).collect();
    let c = write_slice(10.1, 0.0, h, w, &wl2, &v2, PixelType::Float).unwrap();
    fs::write(format!("{exr}/tiny_4x8_ti10.1_pi0.exr"), &c).unwrap();

    // RGL: tests/data/rgl/tiny_rgb.bsdf with `spectra` at 4 wavelengths instead of `rgb`
    // (as src/io/rgl/tests.rs spectral_file_reads builds it).
    let base = fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../tests/data/rgl/tiny_rgb.bsdf")).unwrap();
    let tf = TensorFile::parse(&base).unwrap();
    let mut fields: Vec<(&str, u8, Vec<u64>, Vec<u8>)> = tf
        .fields
        .iter()
        .filter(|f| f.name != "rgb")
        .map(|f| {
            let code = if f.dtype == DType::U8 { 1 } else { 10 };
            (f.name.as_str(), code, f.shape.clone(), tf.data(f).to_vec())
        })
        .collect();
    let r = 5usize;
    let spectra: Vec<u8> = (0..2 * 4 * r * r)
        .flat_map(|i| (0.1f32 + 0.01 * (i % 17) as f32).to_le_bytes())
        .collect();
    let wls: Vec<u8> = [450.0f32, 500.0, 550.0, 600.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    fields.push(("spectra", 10, vec![1, 2, 4, r as u64, r as u64], spectra));
    fields.push(("wavelengths", 10, vec![4], wls));
    fs::write(format!("{rgl}/tiny_spec.bsdf"), write_tensor(&fields)).unwrap();
}
