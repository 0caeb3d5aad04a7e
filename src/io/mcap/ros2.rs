//! The ROS 2 and Foxglove message types the tool reads and writes, between decoded
//! [`Value`]s and our maps and poses: grids (`nav_msgs/msg/OccupancyGrid`,
//! `grid_map_msgs/msg/GridMap`, `foxglove.Grid`) and poses (`nav_msgs/msg/Odometry`,
//! `geometry_msgs/msg/PoseStamped`, `PoseWithCovarianceStamped`, `nav_msgs/msg/Path`,
//! `foxglove.PoseInFrame`, `foxglove.PosesInFrame`), and `tf2_msgs/msg/TFMessage`.

use std::borrow::Cow;
use std::sync::Arc;

use super::value::Value;
use crate::grid::{GeoRef, Layer, Map};

/// Schema texts as rosbag2 stores them: the type, then its dependencies.
pub mod schemas {
    const HEADER: &str = "\
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";
    const VECTOR3: &str = "\
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
";
    const POSE: &str = "\
================================================================================
MSG: geometry_msgs/Pose
Point position
Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
";

    pub fn odometry() -> String {
        format!(
            "std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
================================================================================
MSG: geometry_msgs/PoseWithCovariance
Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/TwistWithCovariance
Twist twist
float64[36] covariance
================================================================================
MSG: geometry_msgs/Twist
Vector3 linear
Vector3 angular
{VECTOR3}{HEADER}{POSE}"
        )
    }

    pub fn pose_stamped() -> String {
        format!("std_msgs/Header header\ngeometry_msgs/Pose pose\n{HEADER}{POSE}")
    }

    pub fn path() -> String {
        format!(
            "std_msgs/Header header
geometry_msgs/PoseStamped[] poses
================================================================================
MSG: geometry_msgs/PoseStamped
std_msgs/Header header
Pose pose
{HEADER}{POSE}"
        )
    }

    pub fn occupancy_grid() -> String {
        format!(
            "std_msgs/Header header
MapMetaData info
int8[] data
================================================================================
MSG: nav_msgs/MapMetaData
builtin_interfaces/Time map_load_time
float32 resolution
uint32 width
uint32 height
geometry_msgs/Pose origin
{HEADER}{POSE}"
        )
    }

    pub fn tf_message() -> String {
        format!(
            "geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
Transform transform
================================================================================
MSG: geometry_msgs/Transform
Vector3 translation
Quaternion rotation
{VECTOR3}{HEADER}{POSE}"
        )
    }

    pub fn grid_map() -> String {
        format!(
            "std_msgs/Header header
grid_map_msgs/GridMapInfo info
string[] layers
string[] basic_layers
std_msgs/Float32MultiArray[] data
uint16 outer_start_index
uint16 inner_start_index
================================================================================
MSG: grid_map_msgs/GridMapInfo
float64 resolution
float64 length_x
float64 length_y
geometry_msgs/Pose pose
================================================================================
MSG: std_msgs/Float32MultiArray
MultiArrayLayout layout
float32[] data
================================================================================
MSG: std_msgs/MultiArrayLayout
MultiArrayDimension[] dim
uint32 data_offset
================================================================================
MSG: std_msgs/MultiArrayDimension
string label
uint32 size
uint32 stride
{HEADER}{POSE}"
        )
    }
}

/// Builds struct values field by field.
pub fn record(fields: Vec<(&str, Value)>) -> Value {
    let (names, values): (Vec<Arc<str>>, Vec<Value>) =
        fields.into_iter().map(|(k, v)| (Arc::from(k), v)).unzip();
    Value::Struct {
        names: names.into(),
        values,
    }
}

fn time(ns: u64) -> Value {
    record(vec![
        ("sec", Value::Int((ns / 1_000_000_000) as i64)),
        ("nanosec", Value::Uint(ns % 1_000_000_000)),
    ])
}

pub fn header(ns: u64, frame: &str) -> Value {
    record(vec![
        ("stamp", time(ns)),
        ("frame_id", Value::String(frame.to_string())),
    ])
}

fn xyz(x: f64, y: f64, z: f64) -> Value {
    record(vec![
        ("x", Value::Float64(x)),
        ("y", Value::Float64(y)),
        ("z", Value::Float64(z)),
    ])
}

/// A rotation of `yaw` about z, as a quaternion.
fn rotation(yaw: f64) -> Value {
    record(vec![
        ("x", Value::Float64(0.0)),
        ("y", Value::Float64(0.0)),
        ("z", Value::Float64((yaw / 2.0).sin())),
        ("w", Value::Float64((yaw / 2.0).cos())),
    ])
}

/// A planar pose: position (x, y, 0) and a rotation of `yaw` about z.
pub fn pose(x: f64, y: f64, yaw: f64) -> Value {
    record(vec![
        ("position", xyz(x, y, 0.0)),
        ("orientation", rotation(yaw)),
    ])
}

pub fn pose_stamped(ns: u64, frame: &str, x: f64, y: f64, yaw: f64) -> Value {
    record(vec![
        ("header", header(ns, frame)),
        ("pose", pose(x, y, yaw)),
    ])
}

/// A `nav_msgs/msg/Path` through `points` (x, y), each pose heading to the next.
pub fn path(ns: u64, frame: &str, points: &[(f64, f64)]) -> Value {
    let poses = points
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| {
            let (nx, ny) = points.get(i + 1).copied().unwrap_or((x, y));
            let heading = if (nx, ny) == (x, y) && i > 0 {
                let (px, py) = points[i - 1];
                (y - py).atan2(x - px)
            } else {
                (ny - y).atan2(nx - x)
            };
            pose_stamped(ns, frame, x, y, heading)
        })
        .collect();
    record(vec![
        ("header", header(ns, frame)),
        ("poses", Value::List(poses)),
    ])
}

pub fn odometry(ns: u64, frame: &str, child: &str, x: f64, y: f64, yaw: f64) -> Value {
    let zero3 = || xyz(0.0, 0.0, 0.0);
    record(vec![
        ("header", header(ns, frame)),
        ("child_frame_id", Value::String(child.to_string())),
        (
            "pose",
            record(vec![
                ("pose", pose(x, y, yaw)),
                ("covariance", Value::Float64s(vec![0.0; 36])),
            ]),
        ),
        (
            "twist",
            record(vec![
                (
                    "twist",
                    record(vec![("linear", zero3()), ("angular", zero3())]),
                ),
                ("covariance", Value::Float64s(vec![0.0; 36])),
            ]),
        ),
    ])
}

/// A `tf2_msgs/msg/TFMessage` of one planar transform: `child`'s pose in `parent`.
pub fn tf_message(ns: u64, parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> Value {
    let transform = record(vec![
        ("header", header(ns, parent)),
        ("child_frame_id", Value::String(child.to_string())),
        (
            "transform",
            record(vec![
                ("translation", xyz(x, y, 0.0)),
                ("rotation", rotation(yaw)),
            ]),
        ),
    ]);
    record(vec![("transforms", Value::List(vec![transform]))])
}

/// An occupancy grid of `values` (row 0 south, as our maps), −1 for unknown.
pub fn occupancy_grid(ns: u64, geo: &GeoRef, values: Vec<i8>) -> Value {
    record(vec![
        ("header", header(ns, &geo.frame)),
        (
            "info",
            record(vec![
                ("map_load_time", time(ns)),
                ("resolution", Value::Float32(geo.resolution as f32)),
                ("width", Value::Uint(geo.width.into())),
                ("height", Value::Uint(geo.height.into())),
                ("origin", pose(geo.origin[0], geo.origin[1], 0.0)),
            ]),
        ),
        ("data", Value::Int8s(values)),
    ])
}

/// A `grid_map_msgs/msg/GridMap` of every layer of `map`. grid_map indexes cells from the
/// (+x, +y) corner, its first index running along −x, stored column-major: exactly our
/// row-major south-west-first order reversed.
pub fn grid_map(ns: u64, map: &Map) -> Value {
    let geo = &map.geo;
    let (length_x, length_y) = (
        f64::from(geo.width) * geo.resolution,
        f64::from(geo.height) * geo.resolution,
    );
    let dimension = |label: &str, size: u32, stride: u32| {
        record(vec![
            ("label", Value::String(label.to_string())),
            ("size", Value::Uint(size.into())),
            ("stride", Value::Uint(stride.into())),
        ])
    };
    let data = map
        .layers
        .iter()
        .map(|layer| {
            record(vec![
                (
                    "layout",
                    record(vec![
                        (
                            "dim",
                            Value::List(vec![
                                dimension("column_index", geo.height, geo.width * geo.height),
                                dimension("row_index", geo.width, geo.width),
                            ]),
                        ),
                        ("data_offset", Value::Uint(0)),
                    ]),
                ),
                (
                    "data",
                    Value::Float32s(layer.values.iter().rev().copied().collect()),
                ),
            ])
        })
        .collect();
    let names = || {
        Value::List(
            map.layers
                .iter()
                .map(|l| Value::String(l.name.clone()))
                .collect(),
        )
    };
    record(vec![
        ("header", header(ns, &geo.frame)),
        (
            "info",
            record(vec![
                ("resolution", Value::Float64(geo.resolution)),
                ("length_x", Value::Float64(length_x)),
                ("length_y", Value::Float64(length_y)),
                (
                    "pose",
                    pose(
                        geo.origin[0] + length_x / 2.0,
                        geo.origin[1] + length_y / 2.0,
                        0.0,
                    ),
                ),
            ]),
        ),
        ("layers", names()),
        ("basic_layers", Value::List(Vec::new())),
        ("data", Value::List(data)),
        ("outer_start_index", Value::Uint(0)),
        ("inner_start_index", Value::Uint(0)),
    ])
}

/// A pose read from a message: when, in which frame, where.
#[derive(Debug, Clone, PartialEq)]
pub struct StampedPose {
    /// Nanoseconds: the header stamp, or the log time where the stamp is zero.
    pub time: u64,
    pub frame: String,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

fn field<'a>(value: &'a Value, path: &str) -> Result<&'a Value, String> {
    value
        .path(path)
        .ok_or_else(|| format!("has no field {path}"))
}

fn number(value: &Value, path: &str) -> Result<f64, String> {
    field(value, path)?
        .as_f64()
        .ok_or_else(|| format!("field {path} is not a number"))
}

fn text<'a>(value: &'a Value, path: &str) -> Result<&'a str, String> {
    field(value, path)?
        .as_str()
        .ok_or_else(|| format!("field {path} is not a string"))
}

/// Yaw of a quaternion (rotation about z of its planar part).
fn yaw_of(q: &Value) -> Result<f64, String> {
    let (x, y, z, w) = (
        number(q, "x")?,
        number(q, "y")?,
        number(q, "z")?,
        number(q, "w")?,
    );
    Ok((2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)))
}

/// Header stamp in nanoseconds (ROS 2's or ROS 1's `std_msgs/Header`, or Foxglove's
/// `timestamp`).
fn stamp(value: &Value) -> Result<u64, String> {
    let (sec, nanos) = if let Some(stamp) = value.path("header.stamp") {
        match stamp.get("secs") {
            Some(_) => (number(stamp, "secs")?, number(stamp, "nsecs")?),
            None => (number(stamp, "sec")?, number(stamp, "nanosec")?),
        }
    } else if let Some(stamp) = value.get("timestamp") {
        // Foxglove: protobuf's Timestamp (seconds, nanos), or JSON's (sec, nsec).
        match (stamp.get("seconds"), stamp.get("sec")) {
            (Some(_), _) => (number(stamp, "seconds")?, number(stamp, "nanos")?),
            _ => (number(stamp, "sec")?, number(stamp, "nsec")?),
        }
    } else {
        return Ok(0);
    };
    if !(0.0..1.8e10).contains(&sec) || !(0.0..1e9).contains(&nanos) {
        return Err(format!("stamp of {sec} s and {nanos} ns is not a time"));
    }
    Ok(sec as u64 * 1_000_000_000 + nanos as u64)
}

fn planar(pose: &Value, time: u64, frame: &str) -> Result<StampedPose, String> {
    Ok(StampedPose {
        time,
        frame: frame.to_string(),
        x: number(pose, "position.x")?,
        y: number(pose, "position.y")?,
        yaw: yaw_of(field(pose, "orientation")?)?,
    })
}

/// The name ingest knows a message type by: ROS 1's `pkg/Name` becomes ROS 2's
/// `pkg/msg/Name` (the types ingest reads have the same fields in both, but for the
/// stamp), and ROS 1's `tf/tfMessage` is `tf2_msgs/msg/TFMessage`.
pub fn canonical_type(name: &str) -> Cow<'_, str> {
    match name.split_once('/') {
        _ if name == "tf/tfMessage" => Cow::Borrowed("tf2_msgs/msg/TFMessage"),
        Some((package, message)) if !message.contains('/') => {
            Cow::Owned(format!("{package}/msg/{message}"))
        }
        _ => Cow::Borrowed(name),
    }
}

/// The pose types ingest understands, by schema name.
pub const POSE_TYPES: [&str; 6] = [
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "nav_msgs/msg/Path",
    "foxglove.PoseInFrame",
    "foxglove.PosesInFrame",
];

/// The poses a message of type `schema` carries (one, or a whole path).
pub fn poses(schema: &str, message: &Value, log_time: u64) -> Result<Vec<StampedPose>, String> {
    let or_log_time = |t: u64| if t == 0 { log_time } else { t };
    match schema {
        "nav_msgs/msg/Odometry" | "geometry_msgs/msg/PoseWithCovarianceStamped" => {
            let t = or_log_time(stamp(message)?);
            Ok(vec![planar(
                field(message, "pose.pose")?,
                t,
                text(message, "header.frame_id")?,
            )?])
        }
        "geometry_msgs/msg/PoseStamped" => {
            let t = or_log_time(stamp(message)?);
            Ok(vec![planar(
                field(message, "pose")?,
                t,
                text(message, "header.frame_id")?,
            )?])
        }
        "nav_msgs/msg/Path" => {
            let frame = text(message, "header.frame_id")?;
            let items = field(message, "poses")?
                .as_list()
                .ok_or("field poses is not a list")?;
            items
                .iter()
                .enumerate()
                .map(|(i, item)| {
                    let t = or_log_time(stamp(item)?);
                    let own = text(item, "header.frame_id").unwrap_or("");
                    planar(
                        field(item, "pose")?,
                        t,
                        if own.is_empty() { frame } else { own },
                    )
                    .map_err(|e| format!("poses[{i}]: {e}"))
                })
                .collect()
        }
        "foxglove.PoseInFrame" => {
            let t = or_log_time(stamp(message)?);
            Ok(vec![planar(
                field(message, "pose")?,
                t,
                text(message, "frame_id")?,
            )?])
        }
        "foxglove.PosesInFrame" => {
            let t = or_log_time(stamp(message)?);
            let frame = text(message, "frame_id")?;
            field(message, "poses")?
                .as_list()
                .ok_or("field poses is not a list")?
                .iter()
                .map(|item| planar(item, t, frame))
                .collect()
        }
        other => Err(format!(
            "type {other} carries no pose ingest understands ({})",
            POSE_TYPES.join(", ")
        )),
    }
}

/// The grid types ingest understands, by schema name.
pub const GRID_TYPES: [&str; 3] = [
    "nav_msgs/msg/OccupancyGrid",
    "grid_map_msgs/msg/GridMap",
    "foxglove.Grid",
];

/// The map a grid message carries, named `name`.
pub fn grid(schema: &str, message: &Value, name: &str) -> Result<Map, String> {
    match schema {
        "nav_msgs/msg/OccupancyGrid" => occupancy_map(message, name),
        "grid_map_msgs/msg/GridMap" => grid_map_map(message, name),
        "foxglove.Grid" => foxglove_grid_map(message, name),
        other => Err(format!(
            "type {other} is not a grid ingest understands ({})",
            GRID_TYPES.join(", ")
        )),
    }
}

fn size(value: &Value, path: &str) -> Result<u32, String> {
    field(value, path)?
        .as_u64()
        .and_then(|v| u32::try_from(v).ok())
        .ok_or_else(|| format!("field {path} is not a size"))
}

/// Maps must be axis-aligned: our rasters have no rotation.
fn unrotated(pose: &Value, what: &str) -> Result<(), String> {
    let yaw = yaw_of(field(pose, "orientation")?)?;
    if yaw.abs() > 1e-6 {
        return Err(format!(
            "{what} is rotated by {:.4} rad; only axis-aligned grids are supported",
            yaw
        ));
    }
    Ok(())
}

fn checked_geo(geo: GeoRef) -> Result<GeoRef, String> {
    geo.validate()?;
    Ok(geo)
}

fn occupancy_map(message: &Value, name: &str) -> Result<Map, String> {
    let origin = field(message, "info.origin")?;
    unrotated(origin, "info.origin")?;
    let geo = checked_geo(GeoRef {
        width: size(message, "info.width")?,
        height: size(message, "info.height")?,
        resolution: number(message, "info.resolution")?,
        resolution_y: None,
        origin: [number(origin, "position.x")?, number(origin, "position.y")?],
        frame: text(message, "header.frame_id")?.to_string(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    })?;
    let data = field(message, "data")?;
    let values: Vec<f32> = match data {
        Value::Int8s(v) => v
            .iter()
            .map(|&x| if x < 0 { f32::NAN } else { f32::from(x) })
            .collect(),
        _ => return Err("field data is not an int8 array".into()),
    };
    check_cells(&geo, values.len(), "data")?;
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("occupancy", values)],
    })
}

fn check_cells(geo: &GeoRef, count: usize, what: &str) -> Result<(), String> {
    if count != geo.cell_count() {
        return Err(format!(
            "{what} holds {count} cells, {}×{} needs {}",
            geo.width,
            geo.height,
            geo.cell_count()
        ));
    }
    Ok(())
}

fn grid_map_map(message: &Value, name: &str) -> Result<Map, String> {
    let pose = field(message, "info.pose")?;
    unrotated(pose, "info.pose")?;
    let resolution = number(message, "info.resolution")?;
    let (length_x, length_y) = (
        number(message, "info.length_x")?,
        number(message, "info.length_y")?,
    );
    // grid_map sizes are lengths over resolution, rounded.
    let cells = |length: f64| -> Result<u32, String> {
        let n = (length / resolution).round();
        if n >= 1.0 && n <= f64::from(u32::MAX) {
            Ok(n as u32)
        } else {
            Err(format!(
                "length {length} at resolution {resolution} is not a size"
            ))
        }
    };
    let (width, height) = (cells(length_x)?, cells(length_y)?);
    let geo = checked_geo(GeoRef {
        width,
        height,
        resolution,
        resolution_y: None,
        origin: [
            number(pose, "position.x")? - f64::from(width) * resolution / 2.0,
            number(pose, "position.y")? - f64::from(height) * resolution / 2.0,
        ],
        frame: text(message, "header.frame_id")?.to_string(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    })?;
    let names = field(message, "layers")?
        .as_list()
        .ok_or("field layers is not a list")?;
    let arrays = field(message, "data")?
        .as_list()
        .ok_or("field data is not a list")?;
    if names.len() != arrays.len() {
        return Err(format!(
            "{} layers but {} data arrays",
            names.len(),
            arrays.len()
        ));
    }
    let outer = size(message, "outer_start_index")? as usize;
    let inner = size(message, "inner_start_index")? as usize;
    let (rows, cols) = (width as usize, height as usize); // grid_map: i along x, j along y
    let mut layers = Vec::with_capacity(names.len());
    for (layer_name, array) in names.iter().zip(arrays) {
        let layer_name = layer_name.as_str().ok_or("a layer name is not a string")?;
        let problem = |e: String| format!("layer {layer_name}: {e}");
        let Value::Float32s(data) = field(array, "data").map_err(problem)? else {
            return Err(problem("data is not a float32 array".into()));
        };
        check_cells(&geo, data.len(), "data").map_err(problem)?;
        let dims = field(array, "layout.dim")
            .map_err(problem)?
            .as_list()
            .unwrap_or(&[]);
        let column_major = match dims
            .first()
            .and_then(|d| d.get("label"))
            .and_then(Value::as_str)
        {
            Some("row_index") => false,
            _ => true, // grid_map writes "column_index" first: column-major storage
        };
        let offset = size(array, "layout.data_offset").map_err(problem)? as usize;
        if offset != 0 {
            return Err(problem(format!("data_offset {offset} is not supported")));
        }
        let mut values = vec![0f32; geo.cell_count()];
        for (index, value) in values.iter_mut().enumerate() {
            let (r, c) = (index / rows, index % rows); // our row (y) and column (x)
            // grid_map index (i, j) of our cell, then its place in the circular buffer.
            let (i, j) = (rows - 1 - c, cols - 1 - r);
            let (bi, bj) = ((i + outer) % rows, (j + inner) % cols);
            *value = if column_major {
                data[bj * rows + bi]
            } else {
                data[bi * cols + bj]
            };
        }
        layers.push(Layer::new(layer_name.to_string(), values));
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers,
    })
}

/// `foxglove.Grid`: cells row by row from the origin pose's corner, each `cell_stride`
/// bytes holding the `fields` (name, offset, numeric type) little endian.
fn foxglove_grid_map(message: &Value, name: &str) -> Result<Map, String> {
    let pose = field(message, "pose")?;
    unrotated(pose, "pose")?;
    let resolution_x = number(message, "cell_size.x")?;
    let resolution_y = number(message, "cell_size.y")?;
    if (resolution_x - resolution_y).abs() > 1e-9 * resolution_x.abs() {
        return Err(format!(
            "cells of {resolution_x}×{resolution_y} are not square"
        ));
    }
    let width = size(message, "column_count")?;
    let Value::Uint8s(data) = field(message, "data")? else {
        return Err("field data is not bytes".into());
    };
    let row_stride = size(message, "row_stride")? as usize;
    let cell_stride = size(message, "cell_stride")? as usize;
    if row_stride == 0 || cell_stride == 0 {
        return Err("row_stride and cell_stride must be positive".into());
    }
    let height = u32::try_from(data.len() / row_stride).map_err(|_| "too many rows")?;
    let geo = checked_geo(GeoRef {
        width,
        height,
        resolution: resolution_x,
        resolution_y: None,
        origin: [number(pose, "position.x")?, number(pose, "position.y")?],
        frame: text(message, "frame_id")?.to_string(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    })?;
    if (width as usize) * cell_stride > row_stride {
        return Err(format!(
            "{width} cells of {cell_stride} bytes overflow a row of {row_stride}"
        ));
    }
    let fields = field(message, "fields")?
        .as_list()
        .ok_or("field fields is not a list")?;
    let mut layers = Vec::with_capacity(fields.len());
    for f in fields {
        let layer_name = text(f, "name")?;
        let offset = size(f, "offset")? as usize;
        // foxglove.NumericType: 1 UINT8, 2 INT8, 3 UINT16, 4 INT16, 5 UINT32, 6 INT32,
        // 7 FLOAT32, 8 FLOAT64.
        let numeric = size(f, "type")?;
        let width_bytes = match numeric {
            1 | 2 => 1,
            3 | 4 => 2,
            5..=7 => 4,
            8 => 8,
            other => return Err(format!("field {layer_name}: unknown numeric type {other}")),
        };
        if offset + width_bytes > cell_stride {
            return Err(format!(
                "field {layer_name} does not fit in a cell of {cell_stride} bytes"
            ));
        }
        let read = |b: &[u8]| -> f32 {
            match numeric {
                1 => f32::from(b[0]),
                2 => f32::from(b[0] as i8),
                3 => f32::from(u16::from_le_bytes([b[0], b[1]])),
                4 => f32::from(i16::from_le_bytes([b[0], b[1]])),
                5 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                6 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                7 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                _ => f64::from_le_bytes(b[..8].try_into().expect("8 bytes")) as f32,
            }
        };
        let values = (0..geo.cell_count())
            .map(|index| {
                let (r, c) = (index / width as usize, index % width as usize);
                let at = r * row_stride + c * cell_stride + offset;
                read(&data[at..at + width_bytes])
            })
            .collect();
        layers.push(Layer::new(layer_name.to_string(), values));
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers,
    })
}

/// One transform of a `tf2_msgs/msg/TFMessage`: `child` expressed in `parent`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTransform {
    pub time: u64,
    pub parent: String,
    pub child: String,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

/// The transforms of a `tf2_msgs/msg/TFMessage`.
pub fn transforms(message: &Value, log_time: u64) -> Result<Vec<FrameTransform>, String> {
    let items = field(message, "transforms")?
        .as_list()
        .ok_or("field transforms is not a list")?;
    items
        .iter()
        .map(|item| {
            let t = stamp(item)?;
            let translation = field(item, "transform.translation")?;
            Ok(FrameTransform {
                time: if t == 0 { log_time } else { t },
                parent: text(item, "header.frame_id")?
                    .trim_start_matches('/')
                    .to_string(),
                child: text(item, "child_frame_id")?
                    .trim_start_matches('/')
                    .to_string(),
                x: number(translation, "x")?,
                y: number(translation, "y")?,
                yaw: yaw_of(field(item, "transform.rotation")?)?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::{cdr, ros2msg};
    use super::*;

    fn round_trip(schema_name: &str, text: &str, value: &Value) -> Value {
        let schema = ros2msg::parse(schema_name, text).unwrap();
        cdr::decode(&schema, &cdr::encode(&schema, value).unwrap()).unwrap()
    }

    fn sample_map() -> Map {
        let geo = GeoRef::square(5, 3, 0.5, [10.0, -2.0], "map");
        let layer = |k: f32| Layer::new(format!("l{k}"), (0..15).map(|i| i as f32 * k).collect());
        Map {
            name: "m".into(),
            geo,
            layers: vec![layer(1.0), layer(-2.0)],
        }
    }

    #[test]
    fn grid_map_round_trips_with_grid_map_conventions() {
        let map = sample_map();
        let value = round_trip(
            "grid_map_msgs/msg/GridMap",
            &schemas::grid_map(),
            &grid_map(7, &map),
        );
        // grid_map's cell (0, 0) is the (+x, +y) corner: our last cell.
        let data = value.path("data").unwrap().as_list().unwrap()[0]
            .get("data")
            .unwrap();
        assert_eq!(data.item(0), Some(Value::Float32(14.0)));
        let back = grid("grid_map_msgs/msg/GridMap", &value, "m").unwrap();
        assert_eq!(back, map);
    }

    #[test]
    fn grid_map_circular_buffer_start_indices_are_undone() {
        let map = sample_map();
        let mut value = grid_map(0, &map);
        // Shift the storage by (outer 2, inner 1) as grid_map's circular buffer does.
        let Value::Struct { values, names } = &mut value else {
            panic!()
        };
        let at = |n: &str| names.iter().position(|x| &**x == n).unwrap();
        let (rows, cols) = (5usize, 3usize);
        let Value::List(arrays) = &mut values[at("data")] else {
            panic!()
        };
        for array in arrays.iter_mut() {
            let Value::Struct { values, .. } = array else {
                panic!()
            };
            let Value::Float32s(data) = &mut values[1] else {
                panic!()
            };
            let logical = data.clone();
            for i in 0..rows {
                for j in 0..cols {
                    data[((j + 1) % cols) * rows + (i + 2) % rows] = logical[j * rows + i];
                }
            }
        }
        values[at("outer_start_index")] = Value::Uint(2);
        values[at("inner_start_index")] = Value::Uint(1);
        assert_eq!(grid("grid_map_msgs/msg/GridMap", &value, "m").unwrap(), map);
    }

    #[test]
    fn occupancy_grids_keep_rows_and_turn_unknown_into_nodata() {
        let geo = sample_map().geo;
        let cells: Vec<i8> = (0..15)
            .map(|i| if i == 3 { -1 } else { i as i8 * 7 })
            .collect();
        let value = round_trip(
            "nav_msgs/msg/OccupancyGrid",
            &schemas::occupancy_grid(),
            &occupancy_grid(1, &geo, cells),
        );
        let map = grid("nav_msgs/msg/OccupancyGrid", &value, "m").unwrap();
        assert_eq!(map.geo, geo);
        assert!(map.layers[0].values[3].is_nan());
        assert_eq!(map.layers[0].values[14], 98.0);
    }

    #[test]
    fn odometry_poses_carry_stamp_frame_and_yaw() {
        let value = round_trip(
            "nav_msgs/msg/Odometry",
            &schemas::odometry(),
            &odometry(1_500_000_000, "map", "base_link", 1.0, 2.0, 0.75),
        );
        let poses = poses("nav_msgs/msg/Odometry", &value, 99).unwrap();
        assert_eq!(poses.len(), 1);
        let p = &poses[0];
        assert_eq!(
            (p.time, p.frame.as_str(), p.x, p.y),
            (1_500_000_000, "map", 1.0, 2.0)
        );
        assert!((p.yaw - 0.75).abs() < 1e-12);
        let err = poses_of_unknown();
        assert!(err.contains("nav_msgs/msg/Odometry"), "{err}");
    }

    fn poses_of_unknown() -> String {
        poses("std_msgs/msg/String", &Value::Null, 0).unwrap_err()
    }

    #[test]
    fn rotated_grids_are_refused() {
        let geo = sample_map().geo;
        let mut value = occupancy_grid(1, &geo, vec![0; 15]);
        let Value::Struct { values, .. } = &mut value else {
            panic!()
        };
        let Value::Struct { values: info, .. } = &mut values[1] else {
            panic!()
        };
        info[4] = pose(10.0, -2.0, 0.3);
        let err = grid("nav_msgs/msg/OccupancyGrid", &value, "m").unwrap_err();
        assert!(err.contains("rotated"), "{err}");
    }
}
