//! The pipeline YAML:
//!
//! ```yaml
//! schema: 1
//! vars: {rounds: 40}          # optional; `${rounds}` in any string of `with`
//! stages:
//!   ingest:                   # a name of your choosing
//!     uses: ingest            # the stage kind
//!     with: { ... }           # its parameters, as for the CLI subcommand
//!   features:
//!     foreach: [a, b]         # or {glob: "data/*.parquet"}: one stage per item,
//!     uses: features          # named `features@<item>`, with `${item}` and
//!     with: {out: "out/${item}", ...}   # `${item_stem}` (file name, no extension)
//! ```

use std::collections::BTreeMap;

use serde::de::{MapAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::Value;
use serde_saphyr::Spanned;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    pub schema: u32,
    #[serde(default)]
    pub vars: BTreeMap<String, Value>,
    pub stages: Stages,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    pub uses: String,
    #[serde(default)]
    pub with: Option<Spanned<With>>,
    /// Inputs beyond those the parameters name (a config file the stage's tools read,
    /// say): they join the stage's lineage and order it after their writers.
    #[serde(default)]
    pub deps: Vec<String>,
    /// The output, declared: must be the one the parameters name.
    #[serde(default)]
    pub outs: Option<Vec<String>>,
    #[serde(default)]
    pub foreach: Option<Foreach>,
}

/// What a stage fans out over.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Foreach {
    List(Vec<String>),
    Glob {
        /// Matched against the workspace, in sorted order.
        glob: String,
    },
}

/// A stage's parameters, with where each key stands in the file, so that a mistake in
/// one points at its line.
#[derive(Debug, Clone, Default)]
pub struct With(pub Vec<(Spanned<String>, Value)>);

impl<'de> Deserialize<'de> for With {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Entries;
        impl<'de> Visitor<'de> for Entries {
            type Value = With;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a mapping of parameter names to values")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<With, A::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry::<Spanned<String>, Value>()? {
                    entries.push(entry);
                }
                Ok(With(entries))
            }
        }
        deserializer.deserialize_map(Entries)
    }
}

impl With {
    fn to_value(&self) -> Value {
        Value::Object(
            self.0
                .iter()
                .map(|(k, v)| (k.value.clone(), v.clone()))
                .collect(),
        )
    }
}

/// Line and column (1-based) in the pipeline file.
pub type Position = (u64, u64);

/// A stage after `vars` and `foreach` are applied.
#[derive(Debug, Clone)]
pub struct ExpandedStage {
    pub name: String,
    pub uses: String,
    pub with: Value,
    pub deps: Vec<std::path::PathBuf>,
    pub outs: Option<Vec<std::path::PathBuf>>,
    /// Where the stage's `with` block and each of its keys stand.
    pub with_at: Option<Position>,
    pub keys_at: Vec<(String, Position)>,
}

impl ExpandedStage {
    /// Where a message about this stage's parameters should point: at the key it names
    /// in backticks (as serde's "unknown field `x`"), else at the `with` block.
    pub fn position_for(&self, message: &str) -> Option<Position> {
        let named = message.split('`').nth(1);
        named
            .and_then(|key| {
                self.keys_at
                    .iter()
                    .find(|(k, _)| k == key)
                    .map(|(_, at)| *at)
            })
            .or(self.with_at)
    }
}

fn position(location: &serde_saphyr::Location) -> Position {
    (location.line(), location.column())
}

/// Replaces `${name}` in every string of `value`. A string that is exactly one
/// reference takes the variable's value as it is (a number stays a number).
fn substitute(value: &Value, vars: &BTreeMap<String, Value>) -> Result<Value, String> {
    Ok(match value {
        Value::String(text) => {
            let whole = text.strip_prefix("${").and_then(|t| t.strip_suffix('}'));
            if let Some(name) = whole.filter(|n| !n.contains("${") && !n.contains('}')) {
                return vars.get(name).cloned().ok_or_else(|| unknown(name, vars));
            }
            let mut out = String::new();
            let mut rest = text.as_str();
            while let Some(start) = rest.find("${") {
                out.push_str(&rest[..start]);
                let end = rest[start..]
                    .find('}')
                    .ok_or_else(|| format!("'{text}': '${{' without a closing '}}'"))?;
                let name = &rest[start + 2..start + end];
                match vars.get(name).ok_or_else(|| unknown(name, vars))? {
                    Value::String(s) => out.push_str(s),
                    other => out.push_str(&other.to_string()),
                }
                rest = &rest[start + end + 1..];
            }
            out.push_str(rest);
            Value::String(out)
        }
        Value::Array(items) => Value::Array(
            items
                .iter()
                .map(|v| substitute(v, vars))
                .collect::<Result<_, _>>()?,
        ),
        Value::Object(map) => Value::Object(
            map.iter()
                .map(|(k, v)| Ok((k.clone(), substitute(v, vars)?)))
                .collect::<Result<_, String>>()?,
        ),
        other => other.clone(),
    })
}

fn unknown(name: &str, vars: &BTreeMap<String, Value>) -> String {
    let known: Vec<&str> = vars.keys().map(String::as_str).collect();
    format!("unknown variable ${{{name}}} (known: {})", known.join(", "))
}

impl PipelineSpec {
    /// The stages with `vars` substituted and `foreach` fanned out, in file order.
    pub fn expand(&self) -> Result<Vec<ExpandedStage>, String> {
        let mut stages = Vec::new();
        for (name, spec) in &self.stages.0 {
            let items: Vec<String> = match &spec.foreach {
                None => {
                    let with = substitute(&spec.with_value(), &self.vars)
                        .map_err(|e| format!("stage '{name}': {e}"))?;
                    let (with_at, keys_at) = spec.positions();
                    let (deps, outs) = spec
                        .paths(&self.vars)
                        .map_err(|e| format!("stage '{name}': {e}"))?;
                    stages.push(ExpandedStage {
                        name: name.clone(),
                        uses: spec.uses.clone(),
                        with,
                        deps,
                        outs,
                        with_at,
                        keys_at,
                    });
                    continue;
                }
                Some(Foreach::List(items)) => items.clone(),
                Some(Foreach::Glob { glob }) => {
                    let paths = glob::glob(glob)
                        .map_err(|e| format!("stage '{name}': glob '{glob}': {e}"))?;
                    let mut found: Vec<String> = paths
                        .filter_map(|p| p.ok())
                        .map(|p| p.to_string_lossy().replace('\\', "/"))
                        .collect();
                    found.sort();
                    if found.is_empty() {
                        return Err(format!("stage '{name}': glob '{glob}' matches nothing"));
                    }
                    found
                }
            };
            for item in items {
                let mut vars = self.vars.clone();
                let stem = std::path::Path::new(&item)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned());
                vars.insert("item".into(), Value::String(item.clone()));
                vars.insert(
                    "item_stem".into(),
                    Value::String(stem.unwrap_or_else(|| item.clone())),
                );
                let with = substitute(&spec.with_value(), &vars)
                    .map_err(|e| format!("stage '{name}@{item}': {e}"))?;
                let (with_at, keys_at) = spec.positions();
                let (deps, outs) = spec
                    .paths(&vars)
                    .map_err(|e| format!("stage '{name}@{item}': {e}"))?;
                stages.push(ExpandedStage {
                    name: format!("{name}@{item}"),
                    uses: spec.uses.clone(),
                    with,
                    deps,
                    outs,
                    with_at,
                    keys_at,
                });
            }
        }
        Ok(stages)
    }
}

impl StageSpec {
    /// `deps` and `outs` with variables substituted.
    fn paths(
        &self,
        vars: &BTreeMap<String, Value>,
    ) -> Result<(Vec<std::path::PathBuf>, Option<Vec<std::path::PathBuf>>), String> {
        let resolve = |list: &[String]| -> Result<Vec<std::path::PathBuf>, String> {
            list.iter()
                .map(|p| match substitute(&Value::String(p.clone()), vars)? {
                    Value::String(s) => Ok(std::path::PathBuf::from(s)),
                    other => Err(format!("'{p}' is {other}, not a path")),
                })
                .collect()
        };
        Ok((
            resolve(&self.deps)?,
            self.outs.as_deref().map(resolve).transpose()?,
        ))
    }

    fn with_value(&self) -> Value {
        self.with
            .as_ref()
            .map_or_else(|| Value::Object(Default::default()), |w| w.value.to_value())
    }

    fn positions(&self) -> (Option<Position>, Vec<(String, Position)>) {
        let Some(with) = &self.with else {
            return (None, Vec::new());
        };
        let keys = with
            .value
            .0
            .iter()
            .map(|(k, _)| (k.value.clone(), position(&k.referenced)))
            .collect();
        (Some(position(&with.referenced)), keys)
    }
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
    fn vars_and_foreach_expand() {
        let yaml = "schema: 1\nvars: {rounds: 7, root: out}\nstages:\n  f:\n    foreach: [a/x.parquet, b/y.parquet]\n    uses: features\n    with: {dataset: \"${item}\", out: \"${root}/${item_stem}\", n: \"${rounds}\"}\n";
        let spec: PipelineSpec = serde_saphyr::from_str(yaml).unwrap();
        let stages = spec.expand().unwrap();
        let names: Vec<&str> = stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["f@a/x.parquet", "f@b/y.parquet"]);
        assert_eq!(stages[1].with["out"], "out/y");
        assert_eq!(
            stages[1].with["n"], 7,
            "a whole-string reference keeps its type"
        );
        let bad = "schema: 1\nstages:\n  f:\n    uses: features\n    with: {out: \"${nope}\"}\n";
        let err = serde_saphyr::from_str::<PipelineSpec>(bad)
            .unwrap()
            .expand()
            .unwrap_err();
        assert!(
            err.contains("stage 'f'") && err.contains("unknown variable ${nope}"),
            "{err}"
        );
    }

    #[test]
    fn stages_keep_their_order_and_typos_point_at_the_line() {
        let yaml = "schema: 1\nstages:\n  zeta:\n    uses: ingest\n  alpha:\n    uses: learch\n    with: {rounds: 3}\n";
        let spec: PipelineSpec = serde_saphyr::from_str(yaml).unwrap();
        let names: Vec<&str> = spec.stages.0.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["zeta", "alpha"]);
        assert_eq!(spec.stages.0[1].1.with_value()["rounds"], 3);
        let expanded = spec.expand().unwrap();
        assert_eq!(
            expanded[1].position_for("unknown field `rounds`"),
            Some((7, 12))
        );
        let err =
            serde_saphyr::from_str::<PipelineSpec>("schema: 1\nstages:\n  a:\n    usez: ingest\n")
                .unwrap_err()
                .to_string();
        assert!(err.contains("usez") && err.contains('4'), "{err}");
    }
}
