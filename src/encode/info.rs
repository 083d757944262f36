//! What `sbrdf info --json` prints about a file, as a JSON value: shared by the command line and
//! the Python binding (`Material.info`).

use crate::model::material::Material;

/// The description of `m`, read from `file` (a name for the record) of `bytes` bytes.
pub fn to_json(m: &Material, file: &str, bytes: u64) -> serde_json::Value {
    let meta: serde_json::Value = m
        .metadata
        .as_deref()
        .map(|t| serde_json::from_str(t).unwrap_or_else(|_| serde_json::Value::from(t)))
        .unwrap_or(serde_json::Value::Null);
    let records: Vec<_> = m
        .records
        .iter()
        .map(|r| {
            serde_json::json!({
                "terms": r.terms, "sh_level": r.sh_level, "precision": r.precision.name(),
                "theta_i": r.theta_i, "phi_i": r.phi_i,
                "theta_p": r.theta_p, "phi_p": r.phi_p,
                "critical_angle": r.critical_angle,
                "lobes": r.lobes.iter().map(|l| l.kind.name()).collect::<Vec<_>>(),
                "rel_error": r.rel_error,
            })
        })
        .collect();
    serde_json::json!({
        "file": file,
        "bytes": bytes,
        "format_version": format!("{}.{}", crate::format::VERSION_MAJOR, m.version_minor),
        "spectral_basis": m.spectral.basis.name(),
        "terms": m.spectral.terms,
        "lambda_min": m.spectral.lambda_min,
        "lambda_max": m.spectral.lambda_max,
        "wavelengths": m.wavelengths,
        "sh_level": m.sh_level,
        "precision": m.precision_name(),
        "isotropic": m.isotropic,
        "incident_count": m.records.len(),
        "sample_positions": m.sample_positions.is_some(),
        "records": records,
        "metadata": meta,
    })
}
