//! What every table records about its origin, shared by the build pipeline and the physics
//! that produce derived tables (the shipped medulla assets): canonical JSON, the content key,
//! the tool's name, version and git commit, and the creation time.
//!
//! A table's content key is the SHA-256 (hex) of the canonical JSON of
//! `{stage, algorithm_version, parameters}` ([`content_key`]); two tables with the same key hold
//! the same values.

use sha2::{Digest, Sha256};

/// Name of the tool, as recorded in every table's provenance.
pub const TOOL: &str = "scatterbake";
/// Version of the tool, as recorded in every table's provenance.
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Canonical JSON (keys sorted, no whitespace) used for content keys.
pub fn canonical_json(v: &serde_json::Value) -> String {
    // serde_json::Map is a BTreeMap without the `preserve_order` feature: keys are sorted.
    serde_json::to_string(v).expect("JSON values serialise")
}

/// SHA-256 (hex) of the canonical JSON of `v`: the key of anything described by a JSON value.
pub fn json_key(v: &serde_json::Value) -> String {
    hex::encode(Sha256::digest(canonical_json(v).as_bytes()))
}

/// The content key of a table made by stage `stage` at `algorithm_version` from `parameters`.
pub fn content_key(stage: &str, algorithm_version: u32, parameters: &serde_json::Value) -> String {
    json_key(&serde_json::json!({
        "stage": stage,
        "algorithm_version": algorithm_version,
        "parameters": parameters,
    }))
}

/// Git commit of the tool's source tree, when known at build time.
pub fn git_commit() -> Option<String> {
    let c = env!("SCATTERBAKE_GIT_COMMIT");
    (!c.is_empty()).then(|| c.to_string())
}

/// Creation time for provenance: `SOURCE_DATE_EPOCH` when set (reproducible builds), else now.
pub fn creation_time() -> String {
    let t = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .map(|s| std::time::UNIX_EPOCH + std::time::Duration::from_secs(s))
        .unwrap_or_else(std::time::SystemTime::now);
    humantime::format_rfc3339_seconds(t).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// Keys do not depend on the order in which a value's fields were written, and do depend on
    /// every part of the key.
    #[test]
    fn content_key_is_canonical_and_covers_every_part() {
        let a = json!({"b": 1, "a": [1.5, "x"]});
        let b: serde_json::Value = serde_json::from_str(r#"{"a":[1.5,"x"],"b":1}"#).unwrap();
        assert_eq!(canonical_json(&a), r#"{"a":[1.5,"x"],"b":1}"#);
        assert_eq!(content_key("mie", 3, &a), content_key("mie", 3, &b));
        assert_ne!(content_key("mie", 3, &a), content_key("mie", 4, &a));
        assert_ne!(content_key("mie", 3, &a), content_key("debye", 3, &a));
        assert_ne!(
            content_key("mie", 3, &a),
            content_key("mie", 3, &json!({"b": 2}))
        );
        // SHA-256 of `{"algorithm_version":1,"parameters":{},"stage":"s"}`.
        assert_eq!(
            content_key("s", 1, &json!({})),
            hex::encode(Sha256::digest(
                br#"{"algorithm_version":1,"parameters":{},"stage":"s"}"#
            ))
        );
    }
}
