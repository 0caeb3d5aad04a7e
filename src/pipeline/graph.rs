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

/// Why a pipeline's stages cannot form a graph, and the stage the message is about
/// (so that the error can point at its line).
#[derive(Debug)]
pub struct GraphError {
    pub stage: usize,
    pub message: String,
}

/// Builds the graph, refusing what cannot work: an output outside the workspace (or
/// the workspace itself, or its `.imitate` folder), two stages writing one place, a
/// stage reading its own output, and cycles.
pub fn build(
    names: &[String],
    deps: &[Vec<PathBuf>],
    outs: &[PathBuf],
) -> Result<Graph, GraphError> {
    let n = names.len();
    let fail = |stage: usize, message: String| Err(GraphError { stage, message });
    for (i, out) in outs.iter().enumerate() {
        if let Some(problem) = output_problem(out) {
            return fail(i, format!("stage '{}': {problem}", names[i]));
        }
    }
    for (i, out) in outs.iter().enumerate() {
        for j in i + 1..n {
            if out.starts_with(&outs[j]) || outs[j].starts_with(out) {
                return fail(
                    j,
                    format!(
                        "stages '{}' and '{}' both write {}",
                        names[i],
                        names[j],
                        out.clone().min(outs[j].clone()).display()
                    ),
                );
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
                    return fail(
                        i,
                        format!(
                            "stage '{}' reads {}, which it writes itself",
                            names[i],
                            dep.display()
                        ),
                    );
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
        let stuck: Vec<usize> = (0..n).filter(|&i| waiting[i] > 0).collect();
        let listed: Vec<&str> = stuck.iter().map(|&i| names[i].as_str()).collect();
        return fail(
            stuck[0],
            format!(
                "stages {} read each other's outputs in a cycle",
                listed.join(", ")
            ),
        );
    }
    Ok(Graph {
        upstream,
        downstream,
        order,
    })
}

/// What is wrong with a stage's output path, if anything: outputs are relative paths
/// inside the workspace, below it (not the workspace itself) and outside the
/// `.imitate` folder that holds the cache and the locks.
fn output_problem(out: &std::path::Path) -> Option<String> {
    if out.as_os_str().is_empty() {
        return Some("`out` is empty: name the folder the stage writes".into());
    }
    let escapes = out
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
    if escapes {
        return Some(format!(
            "`out` {} is outside the workspace: outputs are relative paths without '..'",
            out.display()
        ));
    }
    let mut parts = out
        .components()
        .filter(|c| matches!(c, Component::Normal(_)));
    match parts.next() {
        None => Some(format!(
            "`out` {} is the workspace itself: outputs are folders inside it",
            out.display()
        )),
        Some(first) if first.as_os_str() == ".imitate" => Some(format!(
            "`out` {} is inside .imitate, where imitate keeps its cache and locks",
            out.display()
        )),
        Some(_) => None,
    }
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
        build(&names, &deps, &outs).map_err(|e| e.message)
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

    #[test]
    fn refuses_outputs_that_are_not_folders_of_the_workspace() {
        for (out, expected) in [
            ("", "`out` is empty"),
            (".", "the workspace itself"),
            ("./", "the workspace itself"),
            ("../x", "outside the workspace"),
            ("/tmp/x", "outside the workspace"),
            (".imitate/cache", "inside .imitate"),
            ("./.imitate", "inside .imitate"),
        ] {
            let err = graph(&[("a", &[], out)]).unwrap_err();
            assert!(err.contains(expected), "{out:?}: {err}");
        }
        graph(&[("a", &[], ".git-not/x")]).unwrap();
    }
}
