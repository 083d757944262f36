//! ASTM E1392 text through the program: the Cornell measurements encode, their header travels in
//! the metadata and comes back first in `decode --astm`, at the measured positions; the azimuth
//! convention is checked against the data; bad files are refused naming file and line.

mod common;
use common::{sbrdf, stderr};
use sbrdf::io::astm::read_astm;
use std::path::{Path, PathBuf};

fn cornell(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/cornell")
        .join(name)
}

#[test]
fn cornell_file_round_trips_through_encode_and_decode_astm() {
    let dir = tempfile::tempdir().unwrap();
    let src = cornell("krylon_blue.astm");
    let original = read_astm("k", &std::fs::read(&src).unwrap()).unwrap();
    assert_eq!(original.rows.len(), 1439);
    assert_eq!(original.wavelengths.len(), 31);
    assert!(!original.azimuth_turned, "Cornell's peaks are at φs = π");
    // Radians printed to six decimals snap to the degrees they stand for.
    let thetas: Vec<f64> = original.rows.iter().map(|r| r.angles[0]).collect();
    assert!(thetas.contains(&10.0) && thetas.contains(&80.0));

    let o = sbrdf(
        &["encode", src.to_str().unwrap(), "-o", "k.sbrdf"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sbrdf(&["info", "k.sbrdf", "--json"], dir.path());
    let info = String::from_utf8_lossy(&o.stdout);
    assert!(info.contains("LAB_OPERATOR Eric P. F. Lafortune"), "{info}");

    let o = sbrdf(
        &["decode", "k.sbrdf", "--astm", "-o", "back.astm"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read(dir.path().join("back.astm")).unwrap();
    let back = read_astm("back.astm", &text).unwrap();
    assert_eq!(
        back.header, original.header,
        "the header comes back as it was"
    );
    assert_eq!(back.wavelengths, original.wavelengths);
    assert_eq!(back.rows.len(), original.rows.len());
    // Same positions (the rows come back grouped by incidence, in the encoder's order; the
    // stored positions are f32 degrees, so compare to 1e-4°).
    let sorted = |rows: &[sbrdf::io::astm::AstmRow]| {
        let mut v: Vec<([f64; 4], Vec<f64>)> =
            rows.iter().map(|r| (r.angles, r.values.clone())).collect();
        v.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
        v
    };
    let (want, got) = (sorted(&original.rows), sorted(&back.rows));
    let (mut e, mut r) = (0.0, 0.0);
    for (g, w) in got.iter().zip(&want) {
        let off = (0..4).map(|k| (g.0[k] - w.0[k]).abs()).fold(0.0, f64::max);
        assert!(off < 1e-4, "position {:?} came back as {:?}", w.0, g.0);
        // The values are the decoded model's: close to the measurement where it is bright.
        for (x, y) in g.1.iter().zip(&w.1) {
            e += (x - y) * (x - y);
            r += y * y;
        }
    }
    assert!(
        (e / r).sqrt() < 0.05,
        "decoded vs measured {}",
        (e / r).sqrt()
    );
}

#[test]
fn peaks_on_the_source_side_are_turned_and_turned_back() {
    // Cornell's acrylic with φs measured from the other axis: every peak on the source's side.
    let text = std::fs::read_to_string(cornell("acryl_blue.astm")).unwrap();
    let mut lines: Vec<String> = Vec::new();
    let mut data = false;
    for l in text.lines() {
        if data && !l.trim().is_empty() {
            let mut f: Vec<String> = l.split(',').map(String::from).collect();
            let phi: f64 = f[3].parse().unwrap();
            let turned = if phi > 0.0 {
                phi - std::f64::consts::PI
            } else {
                phi + std::f64::consts::PI
            };
            f[3] = format!("{turned:.6}");
            lines.push(f.join(","));
        } else {
            data |= l.starts_with("VARS");
            lines.push(l.to_string());
        }
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.astm"), lines.join("\n")).unwrap();
    let o = sbrdf(
        &[
            "encode",
            "t.astm",
            "-o",
            "t.sbrdf",
            "--max-error",
            "5%",
            "--best-effort",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("turned by 180°"), "{}", stderr(&o));
    let o = sbrdf(
        &["decode", "t.sbrdf", "--astm", "-o", "back.astm"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let back = read_astm("b", &std::fs::read(dir.path().join("back.astm")).unwrap()).unwrap();
    // Written back in the file's own convention: read again, it is turned again.
    assert!(back.azimuth_turned);
    let orig = read_astm("t", &std::fs::read(dir.path().join("t.astm")).unwrap()).unwrap();
    let mut a: Vec<i64> = orig
        .rows
        .iter()
        .map(|r| (r.angles[3] * 1e3).round() as i64)
        .collect();
    let mut b: Vec<i64> = back
        .rows
        .iter()
        .map(|r| (r.angles[3] * 1e3).round() as i64)
        .collect();
    a.sort();
    b.sort();
    assert_eq!(a, b);
}

#[test]
fn bad_astm_files_are_refused_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(cornell("acryl_blue.astm")).unwrap();
    for (edit, needle) in [
        (
            text.replace("NUM_POINTS 1439", "NUM_POINTS 1440"),
            "bad.astm:20: NUM_POINTS says 1440",
        ),
        (
            text.replacen("0.872665,0.000000,0.573513", "0.872665,0.000000,zz", 1),
            "bad.astm:23: theta_s 'zz'",
        ),
        (
            text.replace("theta_s", "polar"),
            "bad.astm:21: VARS lacks theta_s",
        ),
    ] {
        std::fs::write(dir.path().join("bad.astm"), edit).unwrap();
        let o = sbrdf(&["encode", "bad.astm", "-o", "bad.sbrdf"], dir.path());
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains(needle), "{needle}: {}", stderr(&o));
        assert!(!dir.path().join("bad.sbrdf").exists());
    }
}
