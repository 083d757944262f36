//! An archive's worst days, through the command line: damaged files refused by `verify`,
//! `decode` and `eval`; unreadable inputs; a full disk; Ctrl-C during an encode; and
//! byte-identical output whatever `RAYON_NUM_THREADS` says.

mod common;
use common::{sbrdf, stderr};
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// A refusal: exit status 1 (not a crash: a panic exits 101, a signal has no code), an
/// `sbrdf: error:` message, nothing on stdout.
fn assert_refused(o: &Output, what: &str) {
    assert_eq!(o.status.code(), Some(1), "{what}: {}", stderr(o));
    assert!(
        stderr(o).starts_with("sbrdf: error: "),
        "{what}: {}",
        stderr(o)
    );
    assert!(o.stdout.is_empty(), "{what}: printed {:?}", o.stdout);
}

fn no_partial_files(dir: &Path) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".sbrdf-partial"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn damaged_files_are_refused_by_verify_decode_and_eval() {
    let tmp = tempfile::tempdir().unwrap();
    let good = std::fs::read(common::samples_dir().join("golden/tiny.sbrdf")).unwrap();
    let check = |bytes: &[u8], what: &str| {
        std::fs::write(tmp.path().join("d.sbrdf"), bytes).unwrap();
        for args in [
            &["verify", "d.sbrdf"][..],
            &["decode", "d.sbrdf", "-o", "out.csv"],
            &[
                "eval",
                "d.sbrdf",
                "--incident",
                "15,0",
                "--outgoing",
                "15,180",
            ],
        ] {
            let o = sbrdf(args, tmp.path());
            assert_refused(&o, &format!("{what}, {}", args[0]));
            assert!(!tmp.path().join("out.csv").exists(), "{what}: decode wrote");
        }
    };
    // Every truncation (the library test checks them all in-process; here every 7th length and
    // the last few bytes, through the program).
    for cut in (0..good.len()).step_by(7).chain(good.len() - 4..good.len()) {
        check(&good[..cut], &format!("truncated to {cut}"));
    }
    // A bit flip in every 5th byte, a different bit each time.
    for i in (0..good.len()).step_by(5) {
        let mut bad = good.clone();
        bad[i] ^= 1 << (i % 8);
        check(&bad, &format!("bit {} of byte {i} flipped", i % 8));
    }
    no_partial_files(tmp.path());
}

#[test]
fn unreadable_inputs_and_unwritable_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = common::samples_dir().join("golden/tiny.csv");
    let csv = csv.to_str().unwrap();
    // A folder where a file is expected, and a missing file, for every reading command.
    std::fs::create_dir(tmp.path().join("folder.sbrdf")).unwrap();
    for name in ["folder.sbrdf", "missing.sbrdf"] {
        for args in [
            &["verify", name][..],
            &["info", name],
            &["decode", name, "-o", "o.csv"],
            &["eval", name, "--incident", "0,0", "--outgoing", "0,0"],
        ] {
            let o = sbrdf(args, tmp.path());
            assert_refused(&o, &format!("{} {name}", args[0]));
            assert!(stderr(&o).contains(name), "{}", stderr(&o));
        }
    }
    // Output into a folder that does not exist, or onto a folder.
    for out in ["no/such/dir/x.sbrdf", "folder.sbrdf"] {
        let o = sbrdf(&["encode", csv, "-o", out, "--peak", "paper"], tmp.path());
        assert_refused(&o, out);
        assert!(
            stderr(&o).contains(out.split('/').next().unwrap()),
            "{}",
            stderr(&o)
        );
    }
    no_partial_files(tmp.path());
}

#[cfg(unix)]
#[test]
fn a_full_disk_leaves_no_file_and_keeps_the_old_one() {
    // The file-size limit stands in for a full disk: writes past 1 KiB fail with EFBIG (the
    // signal that would otherwise end the process is ignored, and stays ignored across exec).
    let tmp = tempfile::tempdir().unwrap();
    let csv = common::samples_dir().join("golden/phong_3inc.csv");
    std::fs::write(tmp.path().join("keep.csv"), "precious").unwrap();
    let script = format!(
        "ulimit -f 2; trap '' XFSZ; exec '{}' encode '{}' -o keep.csv.sbrdf --peak paper \
         --precision f32 --basis fourier --terms 13 --sh-level 4",
        env!("CARGO_BIN_EXE_sbrdf"),
        csv.display()
    );
    let o = Command::new("sh")
        .args(["-c", &script])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    assert_refused(&o, "encode onto a full disk");
    assert!(
        stderr(&o).contains("keep.csv.sbrdf") && stderr(&o).to_lowercase().contains("large"),
        "{}",
        stderr(&o)
    );
    assert!(!tmp.path().join("keep.csv.sbrdf").exists());
    // decode --like onto an existing file that cannot be replaced by a bigger one.
    let golden = common::samples_dir().join("golden/phong_3inc_paper.sbrdf");
    let script = format!(
        "ulimit -f 2; trap '' XFSZ; exec '{}' decode '{}' -o keep.csv",
        env!("CARGO_BIN_EXE_sbrdf"),
        golden.display()
    );
    let o = Command::new("sh")
        .args(["-c", &script])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    assert_refused(&o, "decode onto a full disk");
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("keep.csv")).unwrap(),
        "precious"
    );
    no_partial_files(tmp.path());
}

/// An output interrupted while it is being written: the temporary file exists when the signal
/// comes (the test waits for it), and afterwards the destination is what it was and no
/// temporary file is left. `decode --like REF` creates its temporary output and then reads the
/// reference; the reference is a FIFO that nobody writes, so the decode waits there, with its
/// temporary file open, for as long as the test needs.
#[cfg(unix)]
fn interrupt_while_writing(signal: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let golden = common::samples_dir().join("golden/tiny.sbrdf");
    std::fs::write(tmp.path().join("out.csv"), "precious").unwrap();
    let made = Command::new("mkfifo")
        .arg("ref.csv")
        .current_dir(tmp.path())
        .status()
        .unwrap();
    assert!(made.success(), "mkfifo failed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sbrdf"))
        .args(["decode", golden.to_str().unwrap(), "-o", "out.csv"])
        .args(["--like", "ref.csv"])
        .current_dir(tmp.path())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let partial = || {
        std::fs::read_dir(tmp.path()).unwrap().any(|e| {
            e.unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with(".sbrdf-partial")
        })
    };
    let start = std::time::Instant::now();
    while !partial() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "decode ended before it created its temporary output"
        );
        assert!(
            start.elapsed() < std::time::Duration::from_secs(120),
            "no temporary output appeared in 120 s"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > std::time::Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{signal}: the program still runs 60 s after the signal");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert_eq!(
        status.code(),
        Some(130),
        "{signal}: the program should exit with 130 after removing its partial output ({status})"
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("out.csv")).unwrap(),
        "precious",
        "{signal}: the destination changed"
    );
    no_partial_files(tmp.path());
}

#[cfg(unix)]
#[test]
fn ctrl_c_while_an_output_is_written_leaves_the_old_output_and_no_partial_file() {
    interrupt_while_writing("-INT");
}

#[cfg(unix)]
#[test]
fn sigterm_while_an_output_is_written_leaves_the_old_output_and_no_partial_file() {
    interrupt_while_writing("-TERM");
}

#[test]
fn output_is_byte_identical_across_runs_and_thread_counts() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = common::samples_dir().join("golden/phong_3inc.csv");
    let mut outputs = Vec::new();
    for threads in ["1", "2", "3", "1"] {
        let out = format!("t{threads}_{}.sbrdf", outputs.len());
        let o = Command::new(env!("CARGO_BIN_EXE_sbrdf"))
            .args(["encode", csv.to_str().unwrap(), "-o", &out])
            .env("RAYON_NUM_THREADS", threads)
            .current_dir(tmp.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        outputs.push(std::fs::read(tmp.path().join(out)).unwrap());
    }
    for (i, o) in outputs.iter().enumerate().skip(1) {
        assert!(o == &outputs[0], "run {i} differs from run 0");
    }
}
