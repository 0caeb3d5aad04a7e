//! `imitate bench objectworld` on a small world, as a user runs it (the full protocol's
//! figures are in BENCHMARKS.md).

mod common;

use common::*;

#[test]
fn the_benchmark_reports_every_method_and_exports_parquet() {
    let dir = tempfile::tempdir().unwrap();
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "objectworld",
            "--size",
            "10",
            "--seeds",
            "2",
            "--demonstrations",
            "4,16",
            "--rounds",
            "10",
            "--json",
            "--export",
            "export",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(report["schema"], "imitate.bench.objectworld/1");
    let table = report["table"].as_array().unwrap();
    assert_eq!(table.len(), 4 * 2);
    for cell in table {
        let evd = cell["mean_evd"].as_f64().unwrap();
        assert!(evd.is_finite() && evd >= -1e-9, "{cell}");
    }
    assert!(report["random_policy_evd"].as_f64().unwrap() > 0.0);
    assert_eq!(report["runs"].as_array().unwrap().len(), 2 * 2 * 4);
    for seed in 1..=2 {
        assert!(
            dir.path()
                .join(format!("export/world-{seed}.parquet"))
                .is_file()
        );
        for method in ["learch-linear", "learch-tree", "mmp", "maxent"] {
            let file = dir
                .path()
                .join(format!("export/learned-{seed}-16-{method}.parquet"));
            assert!(file.is_file(), "{}", file.display());
        }
    }

    // The same run twice gives the same numbers (times aside).
    let again = imitate(
        dir.path(),
        &[
            "bench",
            "objectworld",
            "--size",
            "10",
            "--seeds",
            "2",
            "--demonstrations",
            "4,16",
            "--rounds",
            "10",
            "--json",
        ],
    );
    let again: serde_json::Value = serde_json::from_str(&stdout(&again)).unwrap();
    let evds = |r: &serde_json::Value| -> Vec<f64> {
        r["runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x["evd"].as_f64().unwrap())
            .collect()
    };
    assert_eq!(evds(&report), evds(&again));

    let bad = imitate(dir.path(), &["bench", "objectworld", "--size", "2"]);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
}
