//! The dependency graph of a pipeline's stages: stage B depends on stage A when B reads
//! something under A's output folder. Stages run in a topological order that keeps the
//! file's order wherever dependencies allow.

use std::collections::BTreeSet;
use std::path::{Component, PathBuf};

#[derive(Debug)]
pub struct Graph {
    /// `upstream[i]`: the stages whose outputs stage `i` reads.
    pub upstream: Vec<Vec<usize>>,
    /// `downstream[i]`: the stages that read stage `i`'s output.
    pub downstream: Vec<Vec<usize>>,
    /// Every stage once, each after all it depends on; ties by file order.
    pub order: Vec<usize>,
}

/// Builds the graph, refusing what cannot work: an output outside the workspace, two
/// stages writing one place, a stage reading its own output, and cycles.
pub fn build(names: &[String], deps: &[Vec<PathBuf>], outs: &[PathBuf]) -> Result<Graph, String> {
    let n = names.len();
    for (i, out) in outs.iter().enumerate() {
        let escapes = out
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
        if escapes || out.as_os_str().is_empty() {
            return Err(format!(
                "stage '{}' writes {}, outside the workspace: outputs are relative paths without '..'",
                names[i],
                out.display()
            ));
        }
        for j in i + 1..n {
            if out.starts_with(&outs[j]) || outs[j].starts_with(out) {
                return Err(format!(
                    "stages '{}' and '{}' both write {}",
                    names[i],
                    names[j],
                    out.clone().min(outs[j].clone()).display()
                ));
            }
        }
    }
    let mut upstream = vec![Vec::new(); n];
    let mut downstream = vec![Vec::new(); n];
    for i in 0..n {
        for dep in &deps[i] {
            for j in 0..n {
                if !dep.starts_with(&outs[j]) {
                    continue;
                }
                if i == j {
                    return Err(format!(
                        "stage '{}' reads {}, which it writes itself",
                        names[i],
                        dep.display()
                    ));
                }
                if !upstream[i].contains(&j) {
                    upstream[i].push(j);
                    downstream[j].push(i);
                }
            }
        }
    }
    // Kahn's algorithm, always taking the earliest-listed ready stage.
    let mut waiting: Vec<usize> = upstream.iter().map(Vec::len).collect();
    let mut ready: BTreeSet<usize> = (0..n).filter(|&i| waiting[i] == 0).collect();
    let mut order = Vec::with_capacity(n);
    while let Some(i) = ready.pop_first() {
        order.push(i);
        for &k in &downstream[i] {
            waiting[k] -= 1;
            if waiting[k] == 0 {
                ready.insert(k);
            }
        }
    }
    if order.len() < n {
        let stuck: Vec<&str> = (0..n)
            .filter(|&i| waiting[i] > 0)
            .map(|i| names[i].as_str())
            .collect();
        return Err(format!(
            "stages {} read each other's outputs in a cycle",
            stuck.join(", ")
        ));
    }
    Ok(Graph {
        upstream,
        downstream,
        order,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(spec: &[(&str, &[&str], &str)]) -> Result<Graph, String> {
        let names: Vec<String> = spec.iter().map(|s| s.0.to_string()).collect();
        let deps: Vec<Vec<PathBuf>> = spec
            .iter()
            .map(|s| s.1.iter().map(PathBuf::from).collect())
            .collect();
        let outs: Vec<PathBuf> = spec.iter().map(|s| PathBuf::from(s.2)).collect();
        build(&names, &deps, &outs)
    }

    #[test]
    fn orders_by_dependency_then_listing() {
        let g = graph(&[
            ("c", &["out/b"], "out/c"),
            ("a", &["in"], "out/a"),
            ("b", &["out/a/x"], "out/b"),
        ])
        .unwrap();
        assert_eq!(g.order, [1, 2, 0]);
        assert_eq!(g.upstream[0], [2]);
        assert_eq!(g.downstream[1], [2]);
    }

    #[test]
    fn refuses_cycles_and_self_reads() {
        let err = graph(&[("a", &["out/b"], "out/a"), ("b", &["out/a"], "out/b")]).unwrap_err();
        assert!(
            err.contains("stages a, b read each other's outputs in a cycle"),
            "{err}"
        );
        let err = graph(&[("a", &["out/a/f"], "out/a")]).unwrap_err();
        assert!(err.contains("which it writes itself"), "{err}");
    }
}
