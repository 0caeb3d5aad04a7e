//! `imitate bench track` and `bench gridnav` as a user runs them: the JSON reports'
//! shapes and the teacher's own record.

mod common;

use common::*;

#[test]
fn bench_track_reports_both_learners_per_iteration() {
    let dir = tempfile::tempdir().unwrap();
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "track",
            "--iterations",
            "3",
            "--seeds",
            "1",
            "--eval-laps",
            "1",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(report["schema"], "imitate.bench-track/1");
    assert_eq!(report["teacher_falls_per_lap"], 0.0);
    let curves = report["curves"].as_array().unwrap();
    let names: Vec<&str> = curves
        .iter()
        .map(|c| c["learning"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["behaviour-cloning", "dagger"]);
    for curve in curves {
        let falls = curve["falls_per_lap"].as_array().unwrap();
        assert_eq!(falls.len(), 3);
        assert!(falls.iter().all(|f| f.as_f64().unwrap() >= 0.0));
        // One lap of labels per iteration: about length / (speed × period) steps.
        let labels = curve["labels_per_iteration"].as_f64().unwrap();
        assert!((100.0..200.0).contains(&labels), "{labels}");
    }
    // The first iteration is the teacher's lap for both, so both policies are equal.
    assert_eq!(curves[0]["falls_per_lap"][0], curves[1]["falls_per_lap"][0]);

    let bad = imitate(dir.path(), &["bench", "track", "--iterations", "0"]);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
}

#[test]
fn bench_gridnav_reports_success_and_cost_ratio_per_iteration() {
    let dir = tempfile::tempdir().unwrap();
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "gridnav",
            "--iterations",
            "2",
            "--labels",
            "60",
            "--seeds",
            "1",
            "--evaluation-pairs",
            "4",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(report["schema"], "imitate.bench-gridnav/1");
    for curve in report["curves"].as_array().unwrap() {
        let points = curve["per_iteration"].as_array().unwrap();
        assert_eq!(points.len(), 2);
        for p in points {
            let rate = p["success_rate"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&rate));
            // A path that reaches the goal costs at least the teacher's.
            if let Some(ratio) = p["cost_ratio"].as_f64() {
                assert!(ratio >= 1.0 - 1e-9, "{ratio}");
            }
        }
    }
}
