//! What `sbrdf info --json` prints about a file, as a JSON value: shared by the command line and
//! the Python binding (`Material.info`).

use crate::model::material::{HeldOutProtocol, Material};

/// The description of `m`, read from `file` (a name for the record) of `bytes` bytes.
pub fn to_json(m: &Material, file: &str, bytes: u64) -> serde_json::Value {
    let meta: serde_json::Value = m
        .metadata
        .as_deref()
        .map(|t| serde_json::from_str(t).unwrap_or_else(|_| serde_json::Value::from(t)))
        .unwrap_or(serde_json::Value::Null);
    let held = |i: usize| {
        m.held_out.as_ref().map_or(
            serde_json::Value::Null,
            |h| serde_json::json!({"rel": h.rel[i], "log": h.log[i]}),
        )
    };
    let records: Vec<_> = m
        .records
        .iter()
        .enumerate()
        .map(|(i, r)| {
            serde_json::json!({
                "terms": r.terms, "sh_level": r.sh_level, "precision": r.precision.name(),
                "theta_i": r.theta_i, "phi_i": r.phi_i,
                "theta_p": r.theta_p, "phi_p": r.phi_p,
                "critical_angle": r.critical_angle,
                "lobes": r.lobes.iter().map(|l| l.kind.name()).collect::<Vec<_>>(),
                "rel_error": r.rel_error,
                "held_out_error": held(i),
            })
        })
        .collect();
    serde_json::json!({
        "file": file,
        "bytes": bytes,
        "format_version": format!("{}.{}", crate::format::VERSION_MAJOR, m.version_minor),
        "spectral_basis": m.spectral.basis.name(),
        "basis_storage": m.spectral.table.as_ref().map(|t| t.storage.name()),
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
        "held_out_protocol": m.held_out.as_ref().map(|h| match h.protocol {
            HeldOutProtocol::Folds(k) => format!("{k}-fold"),
            HeldOutProtocol::LeaveOneOut => "leave-one-out".to_string(),
        }),
        "factor_model": m.factor.as_ref().map(|f| serde_json::json!({
            "components": f.components.iter().map(|c| serde_json::json!({
                "rank": c.rank(),
                "features": c.features.iter().map(|k| k.name()).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "parameters": f.parameter_count(),
            "precision": f.precision.name(),
            // Where the measurement ends: each feature's range, [min, max].
            "ranges": {
                "theta_h": f.ranges[0], "theta_d": f.ranges[1], "theta_i": f.ranges[2],
                "theta_o": f.ranges[3], "x": f.ranges[4],
            },
        })),
        "warped": m.warped.as_ref().map(|w| serde_json::json!({
            "transform": match w.transform {
                crate::model::warped::TableTransform::Dct => "dct",
                crate::model::warped::TableTransform::Wavelet53 => "wavelet",
            },
            "grid": w.grid,
            "steps": w.steps,
            "nonzero": w.levels.iter().filter(|&&z| z != 0).count(),
            "predicted": w.predicted,
        })),
        "metadata": meta,
    })
}
