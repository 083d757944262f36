//! The harness itself, with a stand-in shader (`tests/probe.wgsl`): every covered sample is put
//! in one buffer by `sbrdf::gpu::pack`, and the kernel must read each material's own header
//! words through its base. This is what `device.rs` relies on to address several materials in
//! one buffer.

mod common;
use common::*;

#[test]
fn materials_are_addressed_by_base_offset() {
    let decoders: Vec<sbrdf::Decoder> = sample_files()
        .iter()
        .map(|p| sbrdf::Decoder::open(p).unwrap())
        .filter(|d| d.gpu_layout().is_ok())
        .collect();
    let layouts: Vec<Vec<u32>> = decoders.iter().map(|d| d.gpu_layout().unwrap()).collect();
    assert!(
        layouts.len() >= 2,
        "need several materials to test addressing"
    );
    let buf = sbrdf::gpu::pack(&decoders.iter().collect::<Vec<_>>()).unwrap();
    // Every material but the first sits at a non-zero base: a kernel that ignored `base` would
    // read the first material's header for all of them.
    assert_eq!(buf.bases[0], 0);
    assert!(buf.bases.windows(2).all(|b| b[1] > b[0]));
    let module = full_module(include_str!("probe.wgsl"));
    let gpu = Gpu::new();

    // Queries in reverse material order, so that query i does not simply read material i.
    let queries: Vec<Query> = (0..layouts.len())
        .rev()
        .map(|m| Query {
            wi: [m as f32, 0.0, 1.0],
            lambda_nm: 1000.0 * m as f32,
            wo: [0.0, 2.0 * m as f32, 1.0],
            base: buf.bases[m],
        })
        .collect();
    let spectral = gpu.run(&module, "eval_spectral", &buf.words, &queries, 1);
    let rgb = gpu.run(&module, "eval_rgb", &buf.words, &queries, 3);
    for (i, q) in queries.iter().enumerate() {
        let m = layouts.len() - 1 - i;
        let l = &layouts[m];
        let (lmin, lmax) = (f32::from_bits(l[11]), f32::from_bits(l[12]));
        assert!(
            lmin > 0.0 && lmax > lmin,
            "material {m}: λ range {lmin}..{lmax}"
        );
        // The same f32 additions, in the shader's order: correctly rounded on both sides.
        let want = lmin + q.lambda_nm + q.wi[0] + q.wo[1];
        assert_eq!(
            spectral[i].to_bits(),
            want.to_bits(),
            "material {m} at base {}",
            q.base
        );
        assert_eq!(rgb[3 * i], lmin, "material {m}: λmin");
        assert_eq!(rgb[3 * i + 1], lmax, "material {m}: λmax");
        assert_eq!(rgb[3 * i + 2], l[2] as f32, "material {m}: total_words");
    }
    // eval_four: each group of four consecutive queries is one call of sbrdf_eval4 with the
    // first query's directions and base and the four queries' wavelengths (the probe's
    // sbrdf_eval4 is sbrdf_eval at each).
    let mut fours = Vec::new();
    for q in queries
        .iter()
        .take(queries.len() / 4 * 4)
        .collect::<Vec<_>>()
        .chunks(4)
    {
        for (k, _) in q.iter().enumerate() {
            fours.push(Query {
                lambda_nm: 10.0 * k as f32,
                ..*q[0]
            });
        }
    }
    assert!(!fours.is_empty(), "need four materials for eval_four");
    let four = gpu.run(&module, "eval_four", &buf.words, &fours, 1);
    for (i, q) in fours.iter().enumerate() {
        let m = buf.bases.iter().position(|&b| b == q.base).unwrap();
        let want = f32::from_bits(layouts[m][11]) + q.lambda_nm + q.wi[0] + q.wo[1];
        assert_eq!(four[i].to_bits(), want.to_bits(), "eval_four query {i}");
    }
    println!("{} materials addressed by base offset: OK", layouts.len());
}
