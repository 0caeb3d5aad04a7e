//! Tables as users' tools write them: a demonstrations table from pyarrow (every codec),
//! pandas and polars (zstd, its default, and its other codecs; and as their CSV), and a
//! map table with the codecs GDAL-era pipelines choose, each ingested to the same
//! dataset as the original. The files come from `tests/python/parquet_writers.py`.

mod common;

use std::path::Path;

use common::*;

/// Ingests the quickstart world with `demonstrations` and with `replace_map` (a file
/// standing for terrain-000) and returns the dataset's digest, which covers the maps,
/// demonstrations and paths imitate writes from what it read.
fn ingest_digest(ws: &Path, demonstrations: &str, replace_map: Option<&str>, out: &str) -> String {
    let mut args = vec!["ingest", "--demonstrations", demonstrations];
    let maps: Vec<String> = (0..4)
        .map(|i| match (i, replace_map) {
            (0, Some(file)) => file.to_string(),
            _ => format!("testdata/world/maps/terrain-00{i}.parquet"),
        })
        .collect();
    for map in &maps {
        args.extend(["--map", map.as_str()]);
    }
    args.extend(["--out", out]);
    let result = imitate(ws, &args);
    assert!(
        result.status.success(),
        "{demonstrations} {replace_map:?}: {}",
        stderr(&result)
    );
    stdout(&result)
        .trim()
        .split('\t')
        .nth(2)
        .unwrap()
        .to_string()
}

#[test]
fn tables_from_pyarrow_pandas_and_polars_read_as_the_original() {
    let ws = quickstart_workspace();
    let written = ws.path().join("written");
    let Some(files) = python_script(
        "parquet_writers.py",
        &[
            &ws.path().join("testdata/world/demonstrations.parquet"),
            &ws.path().join("testdata/world/maps/terrain-000.parquet"),
            &written,
        ],
    ) else {
        return;
    };
    let reference = ingest_digest(
        ws.path(),
        "testdata/world/demonstrations.parquet",
        None,
        "reference",
    );
    assert!(files.len() >= 18, "{files:?}");
    for (i, file) in files.iter().enumerate() {
        let path = file["file"].as_str().unwrap();
        let out = format!("ds{i}");
        let digest = match file["table"].as_str().unwrap() {
            "demonstrations" => ingest_digest(ws.path(), path, None, &out),
            _ => ingest_digest(
                ws.path(),
                "testdata/world/demonstrations.parquet",
                Some(path),
                &out,
            ),
        };
        assert_eq!(digest, reference, "{}: another dataset", file["writer"]);
    }
}

#[test]
fn maps_follow_one_flag_as_a_shell_glob_gives_them() {
    let ws = quickstart_workspace();
    let mut args = vec![
        "ingest",
        "--demonstrations",
        "testdata/world/demonstrations.parquet",
        "--map",
    ];
    let maps: Vec<String> = (0..4)
        .map(|i| format!("testdata/world/maps/terrain-00{i}.parquet"))
        .collect();
    args.extend(maps.iter().map(String::as_str));
    args.extend(["--out", "globbed"]);
    let globbed = imitate(ws.path(), &args);
    assert!(globbed.status.success(), "{}", stderr(&globbed));
    let repeated = ingest_digest(
        ws.path(),
        "testdata/world/demonstrations.parquet",
        None,
        "repeated",
    );
    assert_eq!(
        stdout(&globbed).trim().split('\t').nth(2).unwrap(),
        repeated
    );
}

/// A track exported to CSV as ROS bag exporters write it (bagpy: one file a topic, a
/// `Time` column and the message's fields by their dotted names, no episode or map
/// column) is one episode on the default map; malformed CSV is an input error naming
/// the file and the line.
#[test]
fn a_track_exported_to_csv_is_one_episode() {
    let ws = quickstart_workspace();
    let mut text =
        String::from("Time,header.seq,header.frame_id,pose.pose.position.x,pose.pose.position.y\n");
    for i in 0..20 {
        let x = 5.0 + f64::from(i);
        text += &format!("{}.25,{i},odom,{x},{}\n", 100 + i, 3.0 + 0.5 * f64::from(i));
    }
    std::fs::write(ws.path().join("odom.csv"), text).unwrap();
    let out = imitate(
        ws.path(),
        &[
            "ingest",
            "--demonstrations",
            "odom.csv",
            "--column",
            "t=Time",
            "--column",
            "x=pose.pose.position.x",
            "--column",
            "y=pose.pose.position.y",
            "--map",
            "testdata/world/maps/terrain-000.parquet",
            "--out",
            "track",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let demos = imitate::io::demo_tables::read_demonstrations(
        &ws.path().join("track/demonstrations.parquet"),
    )
    .unwrap();
    assert_eq!(demos.len(), 1);
    assert_eq!(
        (demos[0].episode.as_str(), demos[0].map.as_str()),
        ("odom", "terrain-000")
    );
    assert_eq!(demos[0].poses.len(), 20);
    assert_eq!((demos[0].poses[3].t, demos[0].poses[3].x), (103.25, 8.0));

    // Semicolons behind Excel's UTF-8 byte-order mark, and tabs: the same episode.
    let rows: Vec<String> = demos[0]
        .poses
        .iter()
        .map(|p| format!("{};{};{}", p.t, p.x, p.y))
        .collect();
    let semicolons = format!("\u{feff}Time;X;Y\n{}\n", rows.join("\n"));
    std::fs::write(ws.path().join("odom.csv"), &semicolons).unwrap();
    std::fs::write(ws.path().join("tabs.csv"), semicolons.replace(';', "\t")).unwrap();
    for (file, out) in [("odom.csv", "semicolons"), ("tabs.csv", "tabs")] {
        let result = imitate(
            ws.path(),
            &[
                "ingest",
                "--demonstrations",
                file,
                "--column",
                "t=Time",
                "--column",
                "x=X",
                "--column",
                "y=Y",
                "--map",
                "testdata/world/maps/terrain-000.parquet",
                "--out",
                out,
            ],
        );
        assert!(result.status.success(), "{file}: {}", stderr(&result));
        let again = imitate::io::demo_tables::read_demonstrations(
            &ws.path().join(out).join("demonstrations.parquet"),
        )
        .unwrap();
        assert_eq!(again[0].poses, demos[0].poses, "{file}");
    }

    std::fs::write(
        ws.path().join("ragged.csv"),
        "episode,t,x,y\na,0,1,1\na,1,2\n",
    )
    .unwrap();
    std::fs::write(
        ws.path().join("words.csv"),
        "episode,t,x,y\na,0,1,1\na,soon,2,2\n",
    )
    .unwrap();
    for (file, needles) in [
        (
            "ragged.csv",
            &["ragged.csv", "not a readable CSV", "line 3"][..],
        ),
        (
            "words.csv",
            &["words.csv", "column 't'", "expected numbers"],
        ),
    ] {
        let out = imitate(
            ws.path(),
            &[
                "ingest",
                "--demonstrations",
                file,
                "--map",
                "testdata/world/maps/terrain-000.parquet",
                "--out",
                "bad",
            ],
        );
        assert_input_error(&out, needles);
        assert!(
            !ws.path().join("bad").exists(),
            "{file}: nothing is written"
        );
    }
}
