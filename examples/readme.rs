//! The README's Rust example, kept compiling: `tests/readme.rs` checks that the README shows
//! exactly this code (from its `main` on). Run it after `sbrdf synth`/`encode` have made
//! `ggx.sbrdf` (the README's command-line session): `cargo run --example readme`.

fn main() -> sbrdf::Result<()> {
    let dec = sbrdf::Decoder::open("ggx.sbrdf")?;
    let (wi, wo) = ([0.2588, 0.0, 0.9659], [-0.2588, 0.0, 0.9659]); // unit vectors, z = normal
    let mut rho = [0.0f32; 3];
    dec.eval(wi, wo, &[450.0, 550.0, 650.0], &mut rho); // 1/sr; no allocation
    let s = dec.sample(wi, [0.3, 0.7]); // importance sampling: wo, pdf
    println!(
        "{rho:?} {:?} {} bytes resident",
        s.map(|s| s.pdf),
        dec.resident_bytes()
    );
    Ok(())
}
