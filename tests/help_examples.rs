//! Every `sbrdf SUBCOMMAND --help` ends with examples, and each example runs as written in a
//! folder holding the files it names (made by the earlier examples or copied from the shipped
//! samples and test data); an example whose input this test cannot make (an RGL spectral file,
//! which the repository does not ship) is skipped and listed.

mod common;
use common::examples::{copy, example_folder, inputs};
use common::sbrdf;
use std::path::{Path, PathBuf};

/// The subcommands `--help` lists under "Commands:" (without `help`), as argument paths.
fn commands(prefix: &[&str]) -> Vec<Vec<String>> {
    let mut args: Vec<&str> = prefix.to_vec();
    args.push("--help");
    let o = sbrdf(&args, Path::new("."));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut out = Vec::new();
    let mut listing = false;
    for line in text.lines() {
        if line.starts_with("Commands:") {
            listing = true;
            continue;
        }
        if listing {
            let Some(name) = line
                .strip_prefix("  ")
                .and_then(|l| l.split_whitespace().next())
            else {
                break;
            };
            if name != "help" {
                let mut path: Vec<String> = prefix.iter().map(|s| s.to_string()).collect();
                path.push(name.to_string());
                out.push(path);
            }
        }
    }
    out
}

/// The examples that end a help text: the lines after its last "Example…:" heading, each
/// `sbrdf …` line joined with its `\` continuations. Panics if anything but examples follows
/// the heading.
fn examples(what: &str, help: &str) -> Vec<String> {
    let lines: Vec<&str> = help.trim_end().lines().collect();
    let Some(at) = lines.iter().rposition(|l| l.starts_with("Example")) else {
        panic!("`{what} --help` has no examples:\n{help}");
    };
    let mut out: Vec<String> = Vec::new();
    let mut continued = false;
    for line in &lines[at + 1..] {
        let line = line.trim_end();
        if continued {
            let last = out.last_mut().unwrap();
            *last = format!("{} {}", last.trim_end_matches('\\').trim_end(), line.trim());
        } else if let Some(cmd) = line.strip_prefix("  sbrdf ") {
            out.push(format!("sbrdf {cmd}"));
        } else {
            panic!("`{what} --help` does not end with its examples: {line:?}\n{help}");
        }
        continued = line.ends_with('\\');
    }
    assert!(!out.is_empty(), "`{what} --help`: an empty example list");
    out
}

/// An example's arguments (after `sbrdf`), its comment in parentheses dropped.
fn arguments(example: &str) -> Vec<String> {
    let text = match example.find("  (") {
        Some(i) => &example[..i],
        None => example,
    };
    text.split_whitespace().skip(1).map(String::from).collect()
}

#[test]
fn every_help_ends_with_examples_that_run() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut all: Vec<(String, Vec<String>)> = Vec::new();
    let top = String::from_utf8_lossy(&sbrdf(&["--help"], &root).stdout).into_owned();
    all.extend(
        examples("sbrdf", &top)
            .into_iter()
            .map(|e| ("sbrdf".into(), vec![e])),
    );
    let mut paths = commands(&[]);
    for p in paths.clone() {
        paths.extend(commands(&[p[0].as_str()]));
    }
    assert!(paths.len() >= 14, "{} subcommands: {paths:?}", paths.len());
    for p in &paths {
        let mut args: Vec<&str> = p.iter().map(String::as_str).collect();
        args.push("--help");
        let o = sbrdf(&args, &root);
        assert!(o.status.success(), "{args:?}");
        let what = format!("sbrdf {}", p.join(" "));
        all.push((
            what.clone(),
            examples(&what, &String::from_utf8_lossy(&o.stdout)),
        ));
    }
    // The folder the examples run in: the files they name that no example makes.
    let dir = example_folder(&root);
    let d = dir.path();
    // `plot --reference slices`: the EXR slices `ggx.sbrdf` was encoded from.
    copy(&root.join("samples/ggx_slices"), &d.join("slices"));
    // Examples that make files first (synth, encode), then the rest, each once.
    let mut list: Vec<String> = Vec::new();
    for (_, ex) in &all {
        for e in ex {
            if !list.contains(e) {
                list.push(e.clone());
            }
        }
    }
    let rank = |e: &String| match arguments(e).first().map(String::as_str) {
        Some("synth") => 0,
        Some("encode") => 1,
        _ => 2,
    };
    list.sort_by_key(rank);
    let (mut ran, mut skipped) = (0, Vec::new());
    for e in &list {
        let args = arguments(e);
        // A shell glob, as a shell would expand it in that folder.
        let mut expanded: Vec<String> = Vec::new();
        for a in &args {
            match a.strip_suffix("*.csv") {
                Some(stem) => {
                    let mut m: Vec<String> = std::fs::read_dir(d)
                        .unwrap()
                        .map(|f| f.unwrap().file_name().to_string_lossy().into_owned())
                        .filter(|f| f.starts_with(stem) && f.ends_with(".csv"))
                        .collect();
                    m.sort();
                    expanded.extend(m);
                }
                None => expanded.push(a.clone()),
            }
        }
        if let Some(missing) = inputs(&expanded).into_iter().find(|f| !d.join(f).exists()) {
            skipped.push(format!("{e}  (needs {missing})"));
            continue;
        }
        let refs: Vec<&str> = expanded.iter().map(String::as_str).collect();
        let started = std::time::Instant::now();
        let o = sbrdf(&refs, d);
        eprintln!("{:6.1} s  {e}", started.elapsed().as_secs_f64());
        assert!(
            o.status.success(),
            "the example `{e}` failed:\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        ran += 1;
    }
    // Only the RGL spectral file is out of reach (the repository ships RGB ones).
    assert!(
        skipped.iter().all(|s| s.contains("_spec.bsdf")),
        "examples skipped for want of a file: {skipped:#?}"
    );
    assert!(ran >= 25, "only {ran} examples ran (skipped: {skipped:#?})");
}
