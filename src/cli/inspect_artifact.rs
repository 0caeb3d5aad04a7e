//! `imitate inspect DIR`: what an artifact or a DAgger dataset holds, from its
//! manifest: kind, digest, files, how it was made, its metrics; for a policy, what kind
//! of policy; for a DAgger dataset, its rounds.

use std::path::Path;

use serde_json::{Value, json};

use crate::artifact::MANIFEST;
use crate::dagger::dataset::Dataset;
use crate::dagger::{Policy, load_policy_artifact};
use crate::error::{Error, Result};

/// A policy in a few words: its kind and size.
fn describe_policy(policy: &Policy) -> Value {
    match policy {
        Policy::Linear(p) => json!({"kind": "linear", "inputs": p.weights.len()}),
        Policy::Tree { tree, .. } => json!({"kind": "tree", "leaves": tree.leaves()}),
        Policy::Logistic(p) => {
            json!({"kind": "logistic", "classes": p.weights.len(), "inputs": p.mean.len()})
        }
        Policy::ClassTrees { trees } => json!({
            "kind": "class-trees",
            "classes": trees.len(),
            "leaves": trees.iter().map(|t| t.leaves()).sum::<usize>(),
        }),
        Policy::Sequence { steps } => json!({"kind": "sequence", "steps": steps.len()}),
        Policy::Mixture { members } => json!({
            "kind": "mixture",
            "members": members.iter().map(describe_policy).collect::<Vec<_>>(),
        }),
        Policy::Mlp(p) => json!({
            "kind": "mlp",
            "layers": p.network.layers.iter().map(|l| l.outputs).collect::<Vec<_>>(),
            "inputs": p.mean.len(),
        }),
        Policy::Outputs { members } => json!({
            "kind": "outputs",
            "outputs": members.iter().map(describe_policy).collect::<Vec<_>>(),
        }),
    }
}

/// The inspection of the folder `dir` as JSON.
pub fn inspect_folder(dir: &Path) -> Result<Value> {
    let path = dir.join(MANIFEST);
    let bytes = std::fs::read(&path)
        .map_err(|_| Error::input(dir, "is a folder without a manifest.json: not an artifact"))?;
    let manifest: Value = serde_json::from_slice(&bytes)
        .map_err(|e| Error::input(&path, format!("is not a manifest: {e}")))?;
    let verification = crate::artifact::verify_folder(dir)?;
    if let Some(first) = verification.problems.first() {
        return Err(Error::input(
            dir.join(&first.path),
            format!(
                "{} ({} damaged file(s) in {}; `imitate verify` lists them)",
                first.problem,
                verification.problems.len(),
                dir.display()
            ),
        ));
    }
    let files = manifest["files"].as_array().cloned().unwrap_or_default();
    let bytes_total: u64 = files.iter().filter_map(|f| f["size"].as_u64()).sum();
    let mut report = json!({
        "schema": "imitate.inspect-artifact/1",
        "folder": dir.display().to_string(),
        "kind": manifest["kind"],
        "digest": manifest["digest"],
        "files": files.len(),
        "bytes": bytes_total,
        "stage": manifest["lineage"]["stage"],
        "params": manifest["lineage"]["params"],
        "inputs": manifest["lineage"]["inputs"],
        "metrics": manifest["metrics"],
    });
    match manifest["kind"].as_str() {
        Some("dagger-dataset") => {
            let dataset = Dataset::open(dir)?;
            report["observation_names"] = json!(dataset.info.observation_names);
            report["environment"] = json!(dataset.info.environment);
            report["rounds"] = serde_json::to_value(&dataset.rounds).expect("rounds serialise");
        }
        Some("policy") => {
            let (policy, _) = load_policy_artifact(dir)?;
            report["policy"] = describe_policy(&policy);
        }
        _ => {}
    }
    Ok(report)
}

/// The inspection for people.
pub fn render(report: &Value) -> String {
    let text = |v: &Value| match v {
        Value::String(s) => s.clone(),
        Value::Null => "-".into(),
        other => other.to_string(),
    };
    let mut out = format!(
        "folder:  {}\nkind:    {}\ndigest:  {}\nfiles:   {} ({} bytes)\nstage:   {}\nmetrics: {}\n",
        text(&report["folder"]),
        text(&report["kind"]),
        text(&report["digest"]),
        report["files"],
        report["bytes"],
        text(&report["stage"]),
        text(&report["metrics"]),
    );
    if let Some(inputs) = report["inputs"].as_array() {
        for input in inputs {
            out += &format!(
                "input:   {} {}\n",
                text(&input["path"]),
                text(&input["digest"])
            );
        }
    }
    if !report["policy"].is_null() {
        out += &format!("policy:  {}\n", report["policy"]);
    }
    if let Some(rounds) = report["rounds"].as_array() {
        out += &format!(
            "observations: {}\nround  steps  learner  falls  beta  source\n",
            text(&report["observation_names"])
        );
        for r in rounds {
            out += &format!(
                "{:>5}  {:>5}  {:>7}  {:>5}  {:>4}  {}\n",
                r["round"],
                r["steps"],
                r["learner_steps"],
                r["failures"],
                r["beta"],
                text(&r["source"])
            );
        }
    }
    out
}
