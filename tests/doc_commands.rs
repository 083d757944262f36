//! Every `sbrdf` command in the shell blocks (```sh) of the README and the guide runs as
//! written, through `sh`, in a fresh folder per page holding the files the pages name
//! (`common::examples::example_folder`); each page's commands run in order, so a page's later
//! commands read what its earlier ones wrote. Lines that are not `sbrdf` commands (`cargo`,
//! `pip`, `cc`) are left to CI's own steps; a command that reads a file the repository does not
//! ship (an RGL spectral `.bsdf`) is skipped, and asserted to be the only kind skipped. The
//! guide's `sbrdf validate` commands ([`common::MEASURED_COMMANDS`], a minute of encodes each)
//! are left to `tests/measured.rs`, which runs them as written (with `--json`) and holds their
//! figures.
#![cfg(unix)] // `sh`, and `sbrdf` on the PATH through a symlink

mod common;
use common::examples::{example_folder, inputs};
use common::MEASURED_COMMANDS;
use std::path::{Path, PathBuf};

/// The commands of a Markdown page's ```sh blocks, each with its `\` continuations.
fn shell_commands(text: &str) -> Vec<String> {
    let (mut out, mut inside, mut continued) = (Vec::<String>::new(), false, false);
    for line in text.lines() {
        if line.starts_with("```") {
            inside = line.trim() == "```sh" && !inside;
            continued = false;
            continue;
        }
        if !inside {
            continue;
        }
        if continued {
            let last = out.last_mut().unwrap();
            last.push('\n');
            last.push_str(line);
        } else if !line.trim().is_empty() && !line.trim_start().starts_with('#') {
            out.push(line.to_string());
        }
        continued = line.trim_end().ends_with('\\');
    }
    out
}

#[test]
fn the_readme_and_guide_commands_run_as_written() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // `sbrdf` on the PATH: the binary this test suite built.
    let bin = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_sbrdf"), bin.path().join("sbrdf")).unwrap();
    let path = format!(
        "{}:{}",
        bin.path().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut pages: Vec<PathBuf> = vec![root.join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    guide.sort();
    pages.extend(guide);
    // The pages in parallel, each in its own folder.
    let results: Vec<Page> = std::thread::scope(|scope| {
        let handles: Vec<_> = pages
            .iter()
            .map(|page| {
                let (root, path) = (&root, &path);
                scope.spawn(move || run_page(root, page, path))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let ran: usize = results.iter().map(|r| r.ran).sum();
    let left: Vec<&str> = results.iter().flat_map(|r| r.left.clone()).collect();
    for c in MEASURED_COMMANDS {
        assert!(
            left.contains(&c),
            "`{c}` is on no page: tests/measured.rs runs it for the guide"
        );
    }
    let skipped: Vec<String> = results.into_iter().flat_map(|r| r.skipped).collect();
    assert!(
        skipped.iter().all(|s| s.contains("_spec.bsdf")),
        "commands skipped for want of a file: {skipped:#?}"
    );
    assert!(ran >= 40, "only {ran} commands ran (skipped: {skipped:#?})");
}

/// What one page's commands came to.
struct Page {
    /// How many ran.
    ran: usize,
    /// The ones skipped for want of a file.
    skipped: Vec<String>,
    /// The ones left to `tests/measured.rs` ([`MEASURED_COMMANDS`]).
    left: Vec<&'static str>,
}

/// Runs a page's `sbrdf` commands in order in a fresh example folder, `sbrdf` found on `path`.
fn run_page(root: &Path, page: &Path, path: &str) -> Page {
    let (mut ran, mut skipped, mut left) = (0, Vec::new(), Vec::new());
    let commands = shell_commands(&std::fs::read_to_string(page).unwrap());
    let commands: Vec<&String> = commands
        .iter()
        .filter(|c| c.trim_start().starts_with("sbrdf "))
        .collect();
    if commands.is_empty() {
        return Page {
            ran: 0,
            skipped,
            left,
        };
    }
    let dir = example_folder(root);
    let d: &Path = dir.path();
    for c in commands {
        // The arguments as a shell splits them, up to a comment, globs left unexpanded.
        let words: Vec<String> = c
            .replace("\\\n", " ")
            .split(" #")
            .next()
            .unwrap_or("")
            .split_whitespace()
            .map(|w| w.trim_matches('"').to_string())
            .collect();
        if let Some(m) = MEASURED_COMMANDS
            .iter()
            .find(|m| m.split_whitespace().eq(words.iter().map(String::as_str)))
        {
            left.push(*m);
            continue;
        }
        let globbed = |f: &String| f.contains('*');
        if let Some(missing) = inputs(&words)
            .into_iter()
            .find(|f| !globbed(f) && !d.join(f).exists())
        {
            skipped.push(format!("{}: {c}  (needs {missing})", page.display()));
            continue;
        }
        let started = std::time::Instant::now();
        let o = std::process::Command::new("sh")
            .arg("-c")
            .arg(c)
            .env("PATH", path)
            .current_dir(d)
            .output()
            .unwrap();
        eprintln!("{:6.1} s  {c}", started.elapsed().as_secs_f64());
        assert!(
            o.status.success(),
            "{}: `{c}` failed:\n{}",
            page.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        ran += 1;
    }
    Page { ran, skipped, left }
}
