//! The folder in which the examples of `--help`, the README and the guide run
//! (`tests/help_examples.rs`, `tests/doc_commands.rs`): the files they name that no example
//! makes, copied from the shipped samples and test data.

use std::path::Path;

/// The files an example reads: arguments naming a file by its extension (or the `slices`
/// folder) that are not the value of an output option.
pub fn inputs(args: &[String]) -> Vec<String> {
    let outputs = ["-o", "--csv", "--plot", "--report"];
    let mut v = Vec::new();
    for (i, a) in args.iter().enumerate() {
        if i > 0 && outputs.contains(&args[i - 1].as_str()) {
            continue;
        }
        let file = [".csv", ".sbrdf", ".astm", ".bsdf", ".exr"]
            .iter()
            .any(|e| a.ends_with(e));
        if file || (a == "slices" && i > 0 && args[i - 1] == "--reference") {
            v.push(a.clone());
        }
    }
    v
}

/// Copies a file, or a folder with everything in it, creating the destination's parents.
pub fn copy(from: &Path, to: &Path) {
    if from.is_dir() {
        std::fs::create_dir_all(to).unwrap();
        for e in std::fs::read_dir(from).unwrap() {
            let e = e.unwrap().path();
            copy(&e, &to.join(e.file_name().unwrap()));
        }
    } else {
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::copy(from, to).unwrap();
    }
}

/// A fresh folder holding what the examples read: `material.csv`, `ti15.csv` and `m.sbrdf` (a
/// Phong material and its file), `ggx.sbrdf` (GGX encoded from the shipped EXR slices), `ptfe.csv`,
/// `satin_rosaline_rgb.bsdf`, `acryl_blue.astm` (every sixth sample of the Cornell file), and
/// `tests/data/` as the repository has it but for that same Cornell cut.
pub fn example_folder(root: &Path) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = root.join("tests/data");
    // The Cornell measurement, every sixth sample: the same file kind and incidences, in a
    // fraction of the time (`validate --leave-incidence-out` encodes it nine times).
    let astm = std::fs::read_to_string(data.join("cornell/acryl_blue.astm")).unwrap();
    let (mut head, mut rows) = (Vec::new(), Vec::new());
    for line in astm.lines() {
        if line.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
            rows.push(line);
        } else {
            head.push(line);
        }
    }
    let kept: Vec<&str> = rows.iter().step_by(6).copied().collect();
    let mut text = String::new();
    for line in head {
        match line.strip_prefix("NUM_POINTS ") {
            Some(_) => text += &format!("NUM_POINTS {}\n", kept.len()),
            None => text += &format!("{line}\n"),
        }
    }
    for row in kept {
        text += &format!("{row}\n");
    }
    std::fs::write(d.join("acryl_blue.astm"), text).unwrap();
    copy(
        &data.join("rgl/satin_rosaline_rgb.bsdf"),
        &d.join("satin_rosaline_rgb.bsdf"),
    );
    copy(&data.join("nist_ptfe_fr11.csv"), &d.join("ptfe.csv"));
    copy(
        &root.join("samples/golden/phong_3inc.csv"),
        &d.join("material.csv"),
    );
    copy(
        &root.join("samples/golden/phong_3inc.csv"),
        &d.join("ti15.csv"),
    );
    copy(
        &root.join("samples/golden/phong_3inc_default.sbrdf"),
        &d.join("m.sbrdf"),
    );
    copy(&root.join("samples/ggx_slices.sbrdf"), &d.join("ggx.sbrdf"));
    for sub in ["cornell", "rgl"] {
        copy(&data.join(sub), &d.join("tests/data").join(sub));
    }
    copy(
        &data.join("nist_ptfe_fr11.csv"),
        &d.join("tests/data/nist_ptfe_fr11.csv"),
    );
    copy(
        &d.join("acryl_blue.astm"),
        &d.join("tests/data/cornell/acryl_blue.astm"),
    );
    copy(&root.join("samples"), &d.join("samples"));
    dir
}
