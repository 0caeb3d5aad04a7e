//! The Python package (`python/`, built by `scripts/python-package.sh`) against the
//! command line: the same artifacts, plans and errors, arrays that hold what the files
//! hold, DAgger rounds from in-memory tables, a policy that acts as its ONNX export.

mod common;

use common::*;

#[test]
fn the_python_package_does_what_the_command_line_does() {
    if !repo().join("target/python-package/imitate").is_dir() {
        assert!(
            std::env::var_os("CI").is_none(),
            "the Python package is not built in CI (scripts/test.sh builds it)"
        );
        eprintln!("skipped: the Python package is not built (run scripts/python-package.sh)");
        return;
    }
    let ws = quickstart_workspace();
    let out = imitate(ws.path(), &["run", "pipelines/quickstart.yaml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let binary = std::path::PathBuf::from(env!("CARGO_BIN_EXE_imitate"));
    let Some(checks) = python_script("package_api.py", &[ws.path(), &binary]) else {
        return;
    };
    let names: Vec<&str> = checks.iter().filter_map(|c| c["check"].as_str()).collect();
    assert_eq!(
        names,
        [
            "run_stage",
            "run_pipeline",
            "read_costmap",
            "plan",
            "features",
            "errors",
            "append_round",
            "policy"
        ]
    );
}
