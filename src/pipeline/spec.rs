//! The pipeline YAML:
//!
//! ```yaml
//! schema: 1
//! stages:
//!   ingest:                # a name of your choosing
//!     uses: ingest         # the stage kind
//!     with: { ... }        # its parameters, as for the CLI subcommand
//! ```

use serde::de::{MapAccess, Visitor};
use serde::{Deserialize, Deserializer};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    pub schema: u32,
    pub stages: Stages,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    pub uses: String,
    #[serde(default = "empty_object")]
    pub with: serde_json::Value,
}

fn empty_object() -> serde_json::Value {
    serde_json::Value::Object(Default::default())
}

/// Stages in the order the file lists them (a plain map would sort them by name).
#[derive(Debug, Clone)]
pub struct Stages(pub Vec<(String, StageSpec)>);

impl<'de> Deserialize<'de> for Stages {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct InOrder;
        impl<'de> Visitor<'de> for InOrder {
            type Value = Stages;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a mapping of stage names to stages")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Stages, A::Error> {
                let mut stages: Vec<(String, StageSpec)> = Vec::new();
                while let Some((name, spec)) = map.next_entry::<String, StageSpec>()? {
                    if stages.iter().any(|(n, _)| *n == name) {
                        return Err(serde::de::Error::custom(format!(
                            "stage '{name}' is defined twice"
                        )));
                    }
                    stages.push((name, spec));
                }
                Ok(Stages(stages))
            }
        }
        deserializer.deserialize_map(InOrder)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_keep_their_order_and_typos_point_at_the_line() {
        let yaml = "schema: 1\nstages:\n  zeta:\n    uses: ingest\n  alpha:\n    uses: learch\n    with: {rounds: 3}\n";
        let spec: PipelineSpec = serde_saphyr::from_str(yaml).unwrap();
        let names: Vec<&str> = spec.stages.0.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["zeta", "alpha"]);
        assert_eq!(spec.stages.0[1].1.with["rounds"], 3);
        let err =
            serde_saphyr::from_str::<PipelineSpec>("schema: 1\nstages:\n  a:\n    usez: ingest\n")
                .unwrap_err()
                .to_string();
        assert!(err.contains("usez") && err.contains('4'), "{err}");
    }
}
