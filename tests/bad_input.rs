//! Bad input ends with exit code 2, a message naming the file and the problem, no
//! panic, and no artifact.

mod common;

use std::path::Path;
use std::sync::Arc;

use common::*;
use imitate::grid::{Demonstration, Pose};
use imitate::io::tables::write_demonstrations;

const MAP: &str = "testdata/world/maps/terrain-000.parquet";

fn ingest(ws: &Path, demonstrations: &str) -> std::process::Output {
    imitate(
        ws,
        &[
            "ingest",
            "--map",
            MAP,
            "--demonstrations",
            demonstrations,
            "--out",
            "out/dataset",
        ],
    )
}

fn demo(episode: &str, poses: &[(f64, f64)]) -> Demonstration {
    Demonstration {
        episode: episode.into(),
        map: "terrain-000".into(),
        poses: poses
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| Pose {
                t: i as f64,
                x,
                y,
                yaw: None,
            })
            .collect(),
    }
}

#[test]
fn a_missing_file_is_named() {
    let ws = quickstart_workspace();
    let out = ingest(ws.path(), "nowhere/demos.parquet");
    assert_input_error(&out, &["nowhere/demos.parquet", "no such file"]);
    assert!(!ws.path().join("out").exists(), "nothing is written");
}

#[test]
fn a_table_of_the_wrong_kind_is_refused() {
    let ws = quickstart_workspace();
    let out = imitate(
        ws.path(),
        &[
            "ingest",
            "--map",
            "testdata/world/truth/terrain-000.parquet",
            "--demonstrations",
            "testdata/world/demonstrations.parquet",
            "--out",
            "out/dataset",
        ],
    );
    assert_input_error(
        &out,
        &[
            "truth/terrain-000.parquet",
            "'costmap/1'",
            "expected a 'map/1' table",
        ],
    );
    assert!(!ws.path().join("out").exists());
}

#[test]
fn an_unknown_schema_version_is_refused() {
    use arrow::array::{ArrayRef, Float64Array, RecordBatch, StringArray};
    let ws = quickstart_workspace();
    let text = |v: &str| Arc::new(StringArray::from(vec![v, v])) as ArrayRef;
    let number = |a: f64, b: f64| Arc::new(Float64Array::from(vec![a, b])) as ArrayRef;
    let batch = RecordBatch::try_from_iter([
        ("episode", text("e")),
        ("map", text("terrain-000")),
        ("t", number(0.0, 1.0)),
        ("x", number(1.5, 9.5)),
        ("y", number(1.5, 9.5)),
    ])
    .unwrap();
    let props = parquet::file::properties::WriterProperties::builder()
        .set_key_value_metadata(Some(vec![parquet::file::metadata::KeyValue::new(
            "imitate.schema".to_string(),
            "demonstrations/9".to_string(),
        )]))
        .build();
    let file = std::fs::File::create(ws.path().join("future.parquet")).unwrap();
    let mut writer =
        parquet::arrow::ArrowWriter::try_new(file, batch.schema(), Some(props)).unwrap();
    writer.write(&batch).unwrap();
    writer.close().unwrap();
    let out = ingest(ws.path(), "future.parquet");
    assert_input_error(
        &out,
        &[
            "future.parquet",
            "demonstrations/9",
            "reads 'demonstrations/1' only",
        ],
    );
    assert!(!ws.path().join("out").exists());
}

#[test]
fn a_pose_off_the_map_is_named() {
    let ws = quickstart_workspace();
    let demos = [
        demo("fine", &[(1.5, 1.5), (9.5, 9.5)]),
        demo("wanders-off", &[(1.5, 1.5), (20.0, 20.0), (70.0, 3.0)]),
    ];
    write_demonstrations(&ws.path().join("demos.parquet"), &demos).unwrap();
    let out = ingest(ws.path(), "demos.parquet");
    assert_input_error(
        &out,
        &[
            "demos.parquet",
            "episode 'wanders-off'",
            "pose 2",
            "outside the map 'terrain-000'",
        ],
    );
    assert!(!ws.path().join("out").exists());
}

/// Poses said to be in another CRS cannot be moved into a map that names none (a
/// Parquet map in its own metres), nor from a CRS that is not one.
#[test]
fn a_demonstrations_crs_needs_a_map_crs_and_a_crs() {
    let ws = quickstart_workspace();
    let demos = [demo("fine", &[(1.5, 1.5), (9.5, 9.5)])];
    write_demonstrations(&ws.path().join("demos.parquet"), &demos).unwrap();
    for (crs, says) in [
        ("EPSG:4326", "its frame 'map' names no EPSG code"),
        ("WGS 84", "'WGS 84' is not a CRS"),
    ] {
        let out = imitate(
            ws.path(),
            &[
                "ingest",
                "--map",
                MAP,
                "--demonstrations",
                "demos.parquet",
                "--demonstrations-crs",
                crs,
                "--out",
                "out/dataset",
            ],
        );
        assert_input_error(&out, &["demonstrations_crs", says]);
        assert!(!ws.path().join("out").exists());
    }
}

#[test]
fn a_demonstration_needs_two_poses() {
    let ws = quickstart_workspace();
    write_demonstrations(
        &ws.path().join("demos.parquet"),
        &[demo("lonely", &[(1.5, 1.5)])],
    )
    .unwrap();
    let out = ingest(ws.path(), "demos.parquet");
    assert_input_error(&out, &["demos.parquet", "episode 'lonely'", "at least 2"]);
}

#[test]
fn a_failed_pipeline_writes_no_artifact() {
    let ws = quickstart_workspace();
    write_demonstrations(
        &ws.path().join("testdata/world/demonstrations.parquet"),
        &[demo("lonely", &[(1.5, 1.5)])],
    )
    .unwrap();
    let out = imitate(ws.path(), &["run", "pipelines/quickstart.yaml"]);
    assert_input_error(&out, &["demonstrations.parquet", "episode 'lonely'"]);
    assert!(!ws.path().join("out").exists());
}

#[test]
fn pipeline_mistakes_point_at_the_line() {
    let ws = quickstart_workspace();
    std::fs::write(
        ws.path().join("typo.yaml"),
        "schema: 1\nstages:\n  a:\n    uses: ingest\n    whith: {}\n",
    )
    .unwrap();
    let out = imitate(ws.path(), &["run", "typo.yaml"]);
    assert_input_error(&out, &["typo.yaml", "whith", "5"]);

    std::fs::write(
        ws.path().join("kind.yaml"),
        "schema: 1\nstages:\n  a:\n    uses: learchh\n",
    )
    .unwrap();
    let out = imitate(ws.path(), &["run", "kind.yaml"]);
    assert_input_error(
        &out,
        &["kind.yaml", "stage 'a'", "unknown stage kind 'learchh'"],
    );

    std::fs::write(
        ws.path().join("param.yaml"),
        "schema: 1\nstages:\n  a:\n    uses: learch\n    with: {roundz: 3}\n",
    )
    .unwrap();
    let out = imitate(ws.path(), &["run", "param.yaml"]);
    assert_input_error(
        &out,
        &[
            "param.yaml",
            "line 5 column 12",
            "unknown field `roundz`",
            "with: {roundz: 3}",
        ],
    );
}

/// A ZIP archive of files of two bytes each, named `names`.
fn zip_of(names: &[&str]) -> Vec<u8> {
    use std::io::Write;
    let mut archive = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for name in names {
        let stored = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored);
        archive.start_file(*name, stored).unwrap();
        archive.write_all(&[0, 1]).unwrap();
    }
    archive.finish().unwrap().into_inner()
}

#[test]
fn broken_ascii_grids_and_srtm_tiles_are_named() {
    let ws = quickstart_workspace();
    let demos = [demo("fine", &[(1.5, 1.5), (9.5, 9.5)])];
    write_demonstrations(&ws.path().join("demos.parquet"), &demos).unwrap();
    let header = "ncols 4\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 5\nNODATA_value -9999\n";
    for (name, bytes, says) in [
        (
            "short.asc",
            format!("{header}1 2 3 4\n5 6 7 8\n").into_bytes(),
            "holds 8 values; its header gives 4 × 3 = 12",
        ),
        (
            "void.asc",
            format!("{header}{}", "-9999 ".repeat(12)).into_bytes(),
            "every cell is nodata",
        ),
        (
            "huge.asc",
            "ncols 100000 nrows 100000 xllcorner 0 yllcorner 0 cellsize 1 1 2".into(),
            "more than its",
        ),
        (
            "N46E007.hgt",
            vec![0u8; 1000],
            "1000 bytes are not an SRTM tile",
        ),
        ("dem.hgt", vec![0u8; 2 * 1201 * 1201], "south-west corner"),
        (
            "N46E007.SRTMGL1.hgt.zip",
            vec![0u8; 1000],
            "is not a readable ZIP archive",
        ),
        (
            "tiles.zip",
            zip_of(&["L32/N46E007.hgt", "L32/N46E008.hgt"]),
            "holds 2 (L32/N46E007.hgt, L32/N46E008.hgt): unzip",
        ),
        (
            "N46E009.hgt.zip",
            zip_of(&["N46E009.hgt"]),
            "2 bytes are not",
        ),
    ] {
        std::fs::write(ws.path().join(name), bytes).unwrap();
        let out = imitate(
            ws.path(),
            &[
                "ingest",
                "--map",
                name,
                "--demonstrations",
                "demos.parquet",
                "--out",
                "out/dataset",
            ],
        );
        assert_input_error(&out, &[name, says]);
        assert!(!ws.path().join("out").exists());
    }
}
