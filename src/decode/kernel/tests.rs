//! The batch kernel's lanes against its one-pair computation.

use super::groups::{takes, Stored};
use super::lanes_batch;
use crate::decode::records::incidence::Incidences;
use crate::decode::records::lattice::Lattice;
use crate::decode::records::resident::Resident;
use crate::read_material;
use crate::Limits;

/// Pairs above and below the horizon, at and between stored incidences, and hostile ones.
fn pairs() -> Vec<([f32; 3], [f32; 3])> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    };
    let mut v: Vec<([f32; 3], [f32; 3])> = (0..997)
        .map(|_| ([next(), next(), next()], [next(), next(), next().abs()]))
        .collect();
    let odd = [
        [0.0, 0.0, 0.0],
        [f32::NAN, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
    ];
    for a in odd {
        v.push((a, [0.3, -0.2, 0.9]));
        v.push(([0.3, -0.2, 0.9], a));
    }
    v
}

/// The lanes of the batch, four or eight at a time, are each pair's one-lane computation
/// bit for bit, on every file the kernel takes (so the batch is the same bits on any CPU).
#[test]
fn wide_batches_are_the_one_pair_computation() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
    let mut paths: Vec<_> = std::fs::read_dir(dir.join("golden"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sbrdf"))
        .collect();
    paths.push(dir.join("ggx_slices.sbrdf"));
    let pairs = pairs();
    let (wi, wo) = (|i: usize| pairs[i].0, |i: usize| pairs[i].1);
    let mut taken = 0;
    for path in paths {
        let material = read_material(&std::fs::read(&path).unwrap(), &Limits::default()).unwrap();
        let res = Resident::new(&material);
        let places = Incidences::new(&material, &res);
        let Lattice::Theta(axis) = &places.lattice else {
            continue;
        };
        if !takes(&material) || material.factor.is_some() || material.warped.is_some() {
            continue;
        }
        let kernel = &super::groups::Kernel::new(&res);
        let st = Stored {
            res: &res,
            axis,
            ends: &places.theta_ends,
        };
        taken += 1;
        let (lo, hi) = (material.wavelengths[0] as f64, 550.0);
        for l in [lo, hi, 0.5 * (lo + hi)] {
            let mut b = vec![0.0; res.spectrum.terms()];
            res.spectrum.basis(l, &mut b);
            // The pairs the kernel hands back are its caller's (the general path, held to the
            // same bits by `tests/batch.rs`): here a marker, the same for every route.
            let fallback = |i: usize| -(i as f32) - 1.0;
            let one: Vec<u32> = (0..pairs.len())
                .map(|i| {
                    kernel
                        .one(st, wi(i), wo(i), &b)
                        .unwrap_or_else(|| fallback(i))
                        .to_bits()
                })
                .collect();
            let all = lanes_batch::Pairs {
                wi,
                wo,
                n: pairs.len(),
                fallback,
            };
            let (mut four, mut eight) = (vec![0.0; pairs.len()], vec![0.0; pairs.len()]);
            lanes_batch::batch_lanes::<4, _, _, _>(kernel, st, &all, &b, &mut four);
            lanes_batch::batch_lanes::<8, _, _, _>(kernel, st, &all, &b, &mut eight);
            // Every record collapsed beforehand (`Decoder::at`): the same bits again.
            if let Some(c) = kernel.collapse_all(st.res, &b) {
                let at: Vec<u32> = (0..pairs.len())
                    .map(|i| {
                        kernel
                            .one_collapsed(st, wi(i), wo(i), &c)
                            .unwrap_or_else(|| fallback(i))
                            .to_bits()
                    })
                    .collect();
                assert_eq!(
                    at,
                    one,
                    "{}: collapsed beforehand at {l} nm",
                    path.display()
                );
            }
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&four), one, "{}: four lanes at {l} nm", path.display());
            assert_eq!(
                bits(&eight),
                one,
                "{}: eight lanes at {l} nm",
                path.display()
            );
            assert!(one.iter().any(|&v| f32::from_bits(v) > 0.0));
        }
    }
    assert!(taken >= 5, "the kernel took only {taken} files");
}
