//! The normative spec and the code agree: the byte-by-byte walk through in spec/FORMAT.md is
//! the shipped sample file, and the constants the spec names are the code's.

use std::path::Path;

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).unwrap()
}

/// Parses every `<!-- hexdump FILE -->` block: lines `OFFSET  HH HH ...  ; comment`.
fn hexdumps(spec: &str) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut lines = spec.lines().peekable();
    while let Some(line) = lines.next() {
        let Some(file) = line
            .trim()
            .strip_prefix("<!-- hexdump ")
            .and_then(|r| r.strip_suffix("-->"))
        else {
            continue;
        };
        assert!(
            lines.next().unwrap().starts_with("```"),
            "fence after {line}"
        );
        let mut bytes = Vec::new();
        for l in lines.by_ref() {
            if l.starts_with("```") {
                break;
            }
            let data = l.split(';').next().unwrap();
            let mut fields = data.split_whitespace();
            let Some(offset) = fields.next() else {
                continue;
            };
            let offset = usize::from_str_radix(offset, 16).unwrap();
            assert_eq!(offset, bytes.len(), "offset of line '{l}'");
            for h in fields {
                assert_eq!(h.len(), 2, "byte '{h}' in line '{l}'");
                bytes.push(u8::from_str_radix(h, 16).unwrap());
            }
        }
        out.push((file.trim().to_string(), bytes));
    }
    out
}

#[test]
fn format_md_hexdump_is_the_sample_file() {
    let spec = String::from_utf8(read("spec/FORMAT.md")).unwrap();
    let dumps = hexdumps(&spec);
    assert!(!dumps.is_empty(), "spec/FORMAT.md has no hexdump block");
    for (file, bytes) in dumps {
        let actual = read(&file);
        assert_eq!(bytes.len(), actual.len(), "{file}: length");
        assert!(
            bytes == actual,
            "{file}: the spec's hex dump differs from the file"
        );
        // And the file is valid: the walk through describes a real file.
        sbrdf::read_material(&actual, &sbrdf::Limits::default()).unwrap();
    }
}

#[test]
fn format_md_names_the_codes_constants() {
    let spec = String::from_utf8(read("spec/FORMAT.md")).unwrap();
    let sig: Vec<String> = sbrdf::format::SIGNATURE
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect();
    assert!(
        spec.to_uppercase().contains(&sig.join(" ")),
        "signature bytes {} not in spec",
        sig.join(" ")
    );
    for chunk in ["HEAD", "RECD", "ENDF", "meta", "samp"] {
        assert!(
            spec.contains(&format!("`{chunk}`")),
            "chunk {chunk} not in spec"
        );
    }
    assert!(spec.contains("0xEDB88320") && spec.contains("0xCBF43926"));
}
