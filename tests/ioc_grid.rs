//! MMP and MaxEnt on grid costmaps through `imitate learch --method`, and forecasting
//! with `imitate forecast`, as a user runs them.

mod common;

use common::*;
use imitate::io::tables::{Table, read_numeric_table};

fn read_json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Trains `method` briefly on a few of the quickstart's demonstrations (most are held
/// out, which keeps the test short) into folder `out`.
fn learn(ws: &tempfile::TempDir, method: &str, out: &str) {
    let run = imitate(
        ws.path(),
        &[
            "learch",
            "--method",
            method,
            "--dataset",
            "ds",
            "--features",
            "fs",
            "--rounds",
            "6",
            "--holdout",
            "0.85",
            "--out",
            out,
        ],
    );
    assert!(run.status.success(), "{}", stderr(&run));
}

/// `imitate forecast` on the `maxent` artifact's map terrain-000, in cells, into `fc`.
fn forecast(ws: &tempfile::TempDir, observed: &str, destinations: &[&str]) -> std::process::Output {
    let mut args = vec![
        "forecast",
        "maxent",
        "--map",
        "terrain-000",
        "--cells",
        "--observed",
        observed,
        "--out",
        "fc",
    ];
    args.extend_from_slice(destinations);
    imitate(ws.path(), &args)
}

#[test]
fn mmp_and_maxent_write_costmap_artifacts_that_plan_and_forecast() {
    let ws = prepared_workspace();
    learn(&ws, "mmp", "mmp");
    learn(&ws, "maxent", "maxent");
    let mmp = read_json(&ws.path().join("mmp/model.json"));
    assert_eq!(mmp["kind"], "mmp");
    assert_eq!(mmp["cost"]["link"], "linear");
    let maxent = read_json(&ws.path().join("maxent/model.json"));
    assert_eq!(maxent["kind"], "maxent");
    // The exp link is the default and is left out, as in LEARCH's artifacts.
    assert!(maxent["cost"].get("link").is_none());
    for artifact in ["mmp", "maxent"] {
        let metrics = read_json(&ws.path().join(artifact).join("metrics.json"));
        assert_eq!(metrics["rounds"].as_array().unwrap().len(), 6);
        let held_out = &metrics["holdout"]["summary"];
        assert!(
            held_out["within_radius"].as_f64().unwrap() > 0.5,
            "{artifact}: {held_out}"
        );
    }

    // A path planned on the learned costmap, a third of it walked: its own end must
    // be the likeliest of the candidate destinations.
    let plan = imitate(
        ws.path(),
        &[
            "plan",
            "maxent",
            "--map",
            "terrain-000",
            "--cells",
            "--start",
            "5,5",
            "--goal",
            "55,50",
        ],
    );
    assert!(plan.status.success(), "{}", stderr(&plan));
    let plan: serde_json::Value = serde_json::from_str(&stdout(&plan)).unwrap();
    let cells = plan["cells"].as_array().unwrap();
    let observed: Vec<String> = cells[..cells.len() / 3]
        .iter()
        .map(|c| format!("{},{}", c[0], c[1]))
        .collect();
    let observed = observed.join(" ");
    let forecast = forecast(
        &ws,
        &observed,
        &[
            "--destination",
            "55,50",
            "--destination",
            "55,5",
            "--destination",
            "5,60",
        ],
    );
    assert!(forecast.status.success(), "{}", stderr(&forecast));
    let summary = read_json(&ws.path().join("fc/forecast.json"));
    let p: Vec<f64> = summary["destinations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["probability"].as_f64().unwrap())
        .collect();
    assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{p:?}");
    assert!(p[0] > p[1] && p[0] > p[2], "{p:?}");
    let destinations = read_numeric_table(
        &ws.path().join("fc/destinations.parquet"),
        Table::FORECAST_DESTINATIONS,
        &["row", "col", "probability"],
    )
    .unwrap();
    assert_eq!(destinations[2], p);
    let visitation = read_numeric_table(
        &ws.path().join("fc/visitation.parquet"),
        Table::FORECAST_VISITATION,
        &["row", "col", "visits"],
    )
    .unwrap();
    // Every forecast path starts where the walk ended (and may come back to it), and
    // the true goal is reached at least as often as it is the destination.
    let visits_at = |row: f64, col: f64| {
        (0..visitation[0].len())
            .find(|&i| visitation[0][i] == row && visitation[1][i] == col)
            .map(|i| visitation[2][i])
            .unwrap()
    };
    let last = &cells[cells.len() / 3 - 1];
    let (r, c) = (last[0].as_f64().unwrap(), last[1].as_f64().unwrap());
    assert!(visits_at(r, c) >= 1.0 - 1e-6);
    assert!(visits_at(55.0, 50.0) >= p[0] - 1e-6);
    assert!(ws.path().join("fc/forecast.png").is_file());
}

#[test]
fn forecast_refuses_what_it_cannot_use() {
    let ws = prepared_workspace();
    learn(&ws, "maxent", "maxent");
    let forecast = |observed: &str, destination: &str| {
        forecast(&ws, observed, &["--destination", destination])
    };
    // Cells that are not neighbours: the path has a gap.
    let gap = forecast("5,5 5,7", "40,40");
    assert_eq!(gap.status.code(), Some(2), "{}", stderr(&gap));
    assert!(
        stderr(&gap).contains("not neighbouring"),
        "{}",
        stderr(&gap)
    );
    // A destination off the map names the map and its size.
    let off = forecast("5,5 5,6", "400,40");
    assert_eq!(off.status.code(), Some(2), "{}", stderr(&off));
    assert!(
        stderr(&off).contains("outside map 'terrain-000'"),
        "{}",
        stderr(&off)
    );
    assert!(!ws.path().join("fc").exists());
    // MMP learns a linear cost: trees are refused, naming the setting.
    let tree = imitate(
        ws.path(),
        &[
            "learch",
            "--method",
            "mmp",
            "--weak-learner",
            "tree",
            "--dataset",
            "ds",
            "--features",
            "fs",
            "--out",
            "t",
        ],
    );
    assert_eq!(tree.status.code(), Some(2), "{}", stderr(&tree));
    assert!(stderr(&tree).contains("weak_learner"), "{}", stderr(&tree));
    assert!(!ws.path().join("t").exists());
}

/// A costmap as ROS writes them (cells of 1 to 250) with a horizon that binds: the
/// cheap ring round the border is far longer in steps than the 7 the forecast allows,
/// so every path it may take is some 1700 dearer than the cheapest of any length.
/// The forecast must still find the destination and send every path through it.
#[test]
fn forecast_on_a_dear_map_with_a_binding_horizon_reaches_the_destination() {
    use imitate::grid::{GeoRef, Grid};
    let ws = tempfile::tempdir().unwrap();
    let (width, height) = (9u32, 11u32);
    let costs: Vec<f32> = (0..width * height)
        .map(|i| {
            let (row, col) = (i / width, i % width);
            let ring = row == 0 || row == height - 1 || col == 0 || col == width - 1;
            if ring { 1.0 } else { 250.0 }
        })
        .collect();
    let grid = Grid::from_vec(GeoRef::unit(width, height), costs);
    let costmap = ws.path().join("ros.parquet");
    imitate::io::tables::write_costmap(&costmap, "ros", &grid).unwrap();
    let run = imitate(
        ws.path(),
        &[
            "forecast",
            "ros.parquet",
            "--cells",
            "--observed",
            "5,0 5,1",
            "--destination",
            "5,8",
            "--horizon-factor",
            "1",
            "--out",
            "fc",
        ],
    );
    assert!(run.status.success(), "{}", stderr(&run));
    let visitation = read_numeric_table(
        &ws.path().join("fc/visitation.parquet"),
        Table::FORECAST_VISITATION,
        &["row", "col", "visits"],
    )
    .unwrap();
    // Seven steps for seven columns: every path crosses each column once.
    for col in 2..width {
        let crossings: f64 = (0..visitation[0].len())
            .filter(|&i| visitation[1][i] == f64::from(col))
            .map(|i| visitation[2][i])
            .sum();
        assert!((crossings - 1.0).abs() < 1e-5, "column {col}: {crossings}");
    }
}
