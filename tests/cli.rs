//! The command-line program: validation messages, exit codes, no partial or clobbered outputs,
//! and the decode round trip.

mod common;
use common::{sbrdf, stderr};
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A small valid long-layout file: one incidence, a 3×4 outgoing grid, two wavelengths.
fn valid_long() -> String {
    let mut s = String::from("# a comment\ntheta_i,phi_i,theta_o,phi_o,wavelength_nm,value\n");
    for t in [10, 40, 70] {
        for p in [0, 90, 180, 270] {
            for (l, v) in [(500, 0.3), (600, 0.5)] {
                s += &format!("20,0,{t},{p},{l},{:.3}\n", v + 0.001 * t as f64);
            }
        }
    }
    s
}

/// Asserts that encoding `csv` fails, the message names the file and `line`, mentions
/// `needle`, and no output appears.
fn assert_rejected(csv: &str, line: Option<usize>, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "in.csv", csv);
    let o = sbrdf(
        &["encode", "in.csv", "-o", "out.sbrdf", "--terms", "1"],
        dir.path(),
    );
    let err = stderr(&o);
    assert!(!o.status.success(), "accepted:\n{csv}");
    assert_eq!(o.status.code(), Some(1));
    let place = match line {
        Some(l) => format!("in.csv:{l}"),
        None => "in.csv".to_string(),
    };
    assert!(err.contains(&place), "message lacks '{place}': {err}");
    assert!(err.contains(needle), "message lacks '{needle}': {err}");
    assert!(!err.contains("panicked"), "{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 1, "files left behind: {left:?}");
}

#[test]
fn malformed_csv_is_rejected_with_file_and_line() {
    let good = valid_long();
    // Sanity: the unmodified file encodes.
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "in.csv", &good);
    let o = sbrdf(
        &[
            "encode",
            "in.csv",
            "-o",
            "out.sbrdf",
            "--terms",
            "2",
            "--sh-level",
            "1",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));

    let header = "theta_i,phi_i,theta_o,phi_o,wavelength_nm,value\n";
    // Line numbers count the comment line: data starts at line 3.
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,40,90,500,abc"),
        Some(13),
        "'abc' is not a number",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,40,90,500,NaN"),
        Some(13),
        "not a finite number",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,40,90,500,inf"),
        Some(13),
        "not a finite number",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,95,90,500,0.340"),
        Some(13),
        "theta_o = 95 is outside [0, 90]",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "-5,0,40,90,500,0.340"),
        Some(13),
        "theta_i = -5 is outside",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,40,90,5x0,0.340"),
        Some(13),
        "wavelength_nm",
    );
    assert_rejected(
        &good.replace("20,0,40,90,500,0.340", "20,0,40,90,500"),
        Some(13),
        "expected 6 fields",
    );
    assert_rejected(
        &good.replace("phi_o,", "phi_out,"),
        Some(2),
        "column 'phi_out'",
    );
    assert_rejected(
        &good.replace(",value", ""),
        Some(2),
        "missing column 'value'",
    );
    assert_rejected(
        &good.replace("theta_i,", ""),
        Some(2),
        "missing column(s) theta_i",
    );
    // Duplicates: the same sample twice, and φ = 360 is φ = 0 (taken modulo 360).
    assert_rejected(
        &format!("{good}20,0,40,90,500,0.5\n"),
        Some(27),
        "given twice; first at in.csv:13",
    );
    assert_rejected(
        &format!("{good}20,360,40,90,500,0.5\n"),
        Some(27),
        "given twice",
    );
    assert_rejected(
        &format!("{good}20,0,40,-270,500,0.5\n"),
        Some(27),
        "given twice",
    );
    // A direction whose wavelengths differ from the others'.
    assert_rejected(
        &good.replace("20,0,70,270,600,0.570", "20,0,70,270,610,0.570"),
        Some(25),
        "missing here: 600 nm",
    );
    assert_rejected(
        &format!("{good}20,0,70,270,700,0.5\n"),
        Some(25),
        "only here: 700 nm",
    );
    // Empty files.
    assert_rejected("", None, "empty file");
    assert_rejected("# only a comment\n", None, "empty file");
    assert_rejected(header, None, "no data rows");
    // Wide layout: a duplicate direction, and a column that is no wavelength.
    let wide = "theta_i,phi_i,theta_o,phi_o,400nm,412.5\n0,0,10,0,1,2\n0,0,10,0,1,2\n";
    assert_rejected(wide, Some(3), "given twice; first at in.csv:2");
    assert_rejected(
        "theta_i,phi_i,theta_o,phi_o,red\n0,0,10,0,1\n",
        Some(1),
        "column 'red'",
    );
}

#[test]
fn wide_names_negative_values_and_several_inputs() {
    let dir = tempfile::tempdir().unwrap();
    // Two files, one incidence each, wavelength columns spelled three ways.
    let mut a = String::from("theta_i,phi_i,theta_o,phi_o,400nm,412.5,425 nm\n");
    let mut b = String::from("theta_i,phi_i,theta_o,phi_o,400,412.5,425\n");
    for t in [5, 35, 65] {
        for p in (0..360).step_by(60) {
            a += &format!("0,0,{t},{p},0.1,0.2,-0.01\n");
            b += &format!("30,0,{t},{p},0.1,0.2,0.3\n");
        }
    }
    write(dir.path(), "a.csv", &a);
    write(dir.path(), "b.csv", &b);
    let o = sbrdf(
        &[
            "encode",
            "a.csv",
            "b.csv",
            "-o",
            "m.sbrdf",
            "--terms",
            "3",
            "--sh-level",
            "1",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: 18 of 108 samples are negative"),
        "{}",
        stderr(&o)
    );
    let info = sbrdf(&["info", "m.sbrdf", "--json"], dir.path());
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["incident_count"], 2);
    assert_eq!(v["wavelengths"], serde_json::json!([400.0, 412.5, 425.0]));
    assert_eq!(
        v["metadata"]["inputs"],
        serde_json::json!(["a.csv", "b.csv"])
    );
}

#[test]
fn bad_paths_and_failed_runs_leave_outputs_alone() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "in.csv", &valid_long());
    // Missing input.
    let o = sbrdf(&["encode", "nope.csv", "-o", "x.sbrdf"], dir.path());
    assert!(
        !o.status.success() && stderr(&o).contains("nope.csv"),
        "{}",
        stderr(&o)
    );
    // Output folder that does not exist.
    let o = sbrdf(
        &[
            "encode",
            "in.csv",
            "-o",
            "no/such/dir/x.sbrdf",
            "--terms",
            "2",
        ],
        dir.path(),
    );
    assert!(
        !o.status.success() && stderr(&o).contains("does not exist"),
        "{}",
        stderr(&o)
    );
    // An existing output survives a failed run byte for byte.
    write(dir.path(), "keep.sbrdf", "precious");
    write(
        dir.path(),
        "bad.csv",
        "theta_i,phi_i,theta_o,phi_o,500\n0,0,10,0,x\n",
    );
    let o = sbrdf(&["encode", "bad.csv", "-o", "keep.sbrdf"], dir.path());
    assert!(!o.status.success());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("keep.sbrdf")).unwrap(),
        "precious"
    );
    // Options the data cannot satisfy: a clear error, nothing written.
    let o = sbrdf(
        &["encode", "in.csv", "-o", "k.sbrdf", "--terms", "13"],
        dir.path(),
    );
    assert!(
        !o.status.success() && stderr(&o).contains("--terms 13 exceeds the 2 wavelength"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("k.sbrdf").exists());
    // Decoding something that is not an sbrdf file.
    let o = sbrdf(&["decode", "in.csv", "-o", "y.csv"], dir.path());
    assert!(
        !o.status.success() && stderr(&o).contains("not an sbrdf file"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("y.csv").exists());
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".sbrdf-partial"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

/// Reads a CSV into (header, rows of fields), skipping comments.
fn read_table(p: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(p)
        .unwrap();
    let h = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|x| x.unwrap().iter().map(String::from).collect())
        .collect();
    (h, rows)
}

/// Relative L2 error between the value columns of two tables with identical other columns.
fn table_error(reference: &Path, decoded: &Path, value_cols: &[usize]) -> f64 {
    let (h1, r1) = read_table(reference);
    let (h2, r2) = read_table(decoded);
    assert_eq!(h1, h2, "decode --like must keep the header");
    assert_eq!(r1.len(), r2.len(), "decode --like must keep every row");
    let (mut e, mut n) = (0.0, 0.0);
    for (a, b) in r1.iter().zip(&r2) {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            if value_cols.contains(&i) {
                let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
                e += (x - y) * (x - y);
                n += x * x;
            } else {
                assert_eq!(x, y, "decode --like changed a position column");
            }
        }
    }
    (e / n).sqrt()
}

#[test]
fn decode_like_round_trips_long_and_wide_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for layout in ["wide", "long"] {
        let src = format!("{layout}.csv");
        let o = sbrdf(
            &[
                "synth",
                "phong",
                "--diffuse",
                "green",
                "--specular",
                "white",
                "--kd",
                "1",
                "--ks",
                "5",
                "--n",
                "30",
                "--incident",
                "10,0",
                "--incident",
                "40,0",
                "--theta-step",
                "10",
                "--phi-step",
                "15",
                "--layout",
                layout,
                "-o",
                &src,
            ],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let o = sbrdf(&["encode", &src, "-o", "m.sbrdf"], d);
        assert!(o.status.success(), "{}", stderr(&o));
        let info = sbrdf(&["info", "m.sbrdf", "--json"], d);
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        let stored = v["metadata"]["rel_error"].as_f64().unwrap();
        let o = sbrdf(&["decode", "m.sbrdf", "-o", "back.csv", "--like", &src], d);
        assert!(o.status.success(), "{}", stderr(&o));
        let cols: Vec<usize> = if layout == "wide" {
            (4..35).collect()
        } else {
            vec![5]
        };
        let e = table_error(&d.join(&src), &d.join("back.csv"), &cols);
        assert!(
            e > 0.0 && (e - stored).abs() <= 1e-6,
            "{layout}: decoded error {e} vs stored {stored}"
        );
        // Without --like: the encoder's own positions, in the wide layout; re-encodable.
        let o = sbrdf(&["decode", "m.sbrdf", "-o", "positions.csv"], d);
        assert!(o.status.success(), "{}", stderr(&o));
        let (h, rows) = read_table(&d.join("positions.csv"));
        assert_eq!(h.len(), 4 + 31);
        assert_eq!(rows.len(), 2 * 9 * 24);
        let o = sbrdf(&["encode", "positions.csv", "-o", "again.sbrdf"], d);
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

#[test]
fn eval_info_verify_and_help() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let golden = common::samples_dir().join("golden/phong_3inc_paper.sbrdf");
    let g = golden.to_str().unwrap();
    let o = sbrdf(
        &[
            "eval",
            g,
            "--incident",
            "30,0",
            "--outgoing",
            "30,180",
            "--wavelengths",
            "450,550",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "wavelength_nm,value");
    assert_eq!(lines.len(), 3);
    let v: f64 = lines[1].split(',').nth(1).unwrap().parse().unwrap();
    // Green diffuse + 5 × white specular at the peak: about 5.
    assert!((3.0..8.0).contains(&v), "{v}");
    // Below the horizon: zero. Outside the spectral range: an error.
    let o = sbrdf(
        &[
            "eval",
            g,
            "--incident",
            "30,0",
            "--outgoing",
            "100,0",
            "--wavelengths",
            "500",
        ],
        d,
    );
    assert!(o.status.success());
    assert_eq!(
        String::from_utf8(o.stdout).unwrap(),
        "wavelength_nm,value\n500,0\n"
    );
    let o = sbrdf(
        &[
            "eval",
            g,
            "--incident",
            "30,0",
            "--outgoing",
            "10,0",
            "--wavelengths",
            "800",
        ],
        d,
    );
    assert!(!o.status.success() && stderr(&o).contains("outside the file's range"));
    let o = sbrdf(&["eval", g, "--incident", "30", "--outgoing", "10,0"], d);
    assert!(!o.status.success() && stderr(&o).contains("expected θ,φ"));
    let o = sbrdf(&["verify", g], d);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).starts_with("ok:"));
    let o = sbrdf(&["info", g], d);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("fourier, 13 terms"));
    // A damaged copy: verify fails with the CRC named.
    let mut bytes = std::fs::read(&golden).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    write(d, "bad.sbrdf", "");
    std::fs::write(d.join("bad.sbrdf"), &bytes).unwrap();
    let o = sbrdf(&["verify", "bad.sbrdf"], d);
    assert!(
        !o.status.success() && stderr(&o).contains("CRC mismatch"),
        "{}",
        stderr(&o)
    );
    let o = sbrdf(&["encode", "--help"], d);
    let help = String::from_utf8_lossy(&o.stdout);
    assert!(help.contains("Examples:") && help.contains("--critical-angle"));
}

#[test]
fn shipped_sample_encodes_as_the_readme_says() {
    let dir = tempfile::tempdir().unwrap();
    let sample = common::samples_dir().join("phong_green_white_ti15.csv");
    let o = sbrdf(
        &["encode", sample.to_str().unwrap(), "-o", "m.sbrdf"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sbrdf(&["verify", "m.sbrdf"], dir.path());
    assert!(o.status.success());
}
