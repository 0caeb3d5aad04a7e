//! Per-cell features of a map: operators composed per layer, computed plane by plane
//! in parallel. Each output plane is written once, in place, so memory stays close to
//! the size of the output stack (plus a few temporary planes per worker thread).

mod bank;
mod kernels;
mod scale;

pub use bank::Bank;
pub use scale::{is_distance, scale_in_cells};

pub use kernels::{
    aspect, distance_transform, gaussian_blur, gaussian_blur_by_row, gaussian_blur_of_data,
    gradient, laplacian, local_std, local_std_by_row, robust_normalize,
};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::grid::{
    FeatureStack, Layer, LayerKind, MAX_CLASSES, MAX_DECLARED_CLASSES, Map, distinct_integers,
};

/// What to compute; stored with every stack it made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureSpec {
    /// Layers taken as they are, in this order; `None` takes every layer of the map
    /// (when `ops` is empty) or none (when it is not).
    #[serde(default)]
    pub layers: Option<Vec<String>>,
    /// Operators on layers, after the plain layers, in this order.
    #[serde(default)]
    pub ops: Vec<Op>,
    /// Append a constant 1 feature so that a linear cost has an intercept.
    pub bias: bool,
    /// NaN cells of a layer (no data) read as this value, and the layer gets an extra
    /// `<layer>/nodata` indicator feature.
    #[serde(default)]
    pub nodata_fill: f32,
    /// A named list of operators chosen by the layers a map has (`features/bank`),
    /// computed before `layers` and `ops`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bank: Option<Bank>,
}

/// One operator. Lengths are in metres (using the map's resolution) unless named in cells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Op {
    /// (x − median) / interquartile range.
    Normalize { layer: String },
    /// Gaussian blur at each standard deviation: `sigmas` in metres, `cells` in cells
    /// (names that do not depend on the map's resolution).
    Blur {
        layer: String,
        #[serde(default)]
        sigmas: Vec<f64>,
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        cells: Vec<f64>,
    },
    /// Gradient magnitude, layer units per metre.
    Gradient { layer: String },
    /// Slope in degrees, atan |∇z|, for an elevation layer in metres.
    Slope { layer: String },
    /// Local standard deviation over square windows of this many cells (odd).
    Roughness { layer: String, windows: Vec<usize> },
    /// The 5-point Laplacian per square metre.
    Laplacian { layer: String },
    /// An indicator per class value.
    OneHot { layer: String, classes: Vec<f32> },
    /// Euclidean distance (metres) to the nearest cell equal to `class`, above `above`
    /// or below `below`; capped at `max` metres and at `max_cells` cells (of the
    /// longer side), by default at the map's diagonal.
    Distance {
        layer: String,
        #[serde(default)]
        class: Option<f32>,
        #[serde(default)]
        above: Option<f32>,
        #[serde(default)]
        below: Option<f32>,
        #[serde(default)]
        max: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_cells: Option<f64>,
    },
    /// An indicator per threshold: 1 where the layer is above it.
    Threshold { layer: String, above: Vec<f32> },
    /// The product of two features computed before it (by name).
    Product { a: String, b: String },
    /// (a − b) / (a + b), 0 where a + b is 0: vegetation- and water-like indices of
    /// multi-band imagery.
    NormalizedDifference { a: String, b: String },
    /// The mean of the layers; and, as for one layer, an indicator per quantile of it
    /// on this map and the distances (metres) to the nearest cell above quantile
    /// `distance_above` (the brightest parts of multi-band imagery: roofs, sand, snow)
    /// and below quantile `distance_below` (the darkest: water, shadow, dense forest),
    /// capped at `distance_max_cells` cells (of the longer side; by default at the
    /// map's diagonal).
    Brightness {
        layers: Vec<String>,
        #[serde(default)]
        quantiles: Vec<f64>,
        #[serde(default)]
        distance_above: Option<f64>,
        #[serde(default)]
        distance_below: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        distance_max_cells: Option<f64>,
        /// Also the mean's gradient magnitude per metre (`brightness/gradient`): edges
        /// in every band at once, which no band's own gradient states.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        gradient: bool,
        /// Also the mean's local standard deviation over square windows of this many
        /// cells (odd; `brightness/roughness_<w>c`): texture in every band at once.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        roughness: Vec<usize>,
    },
    /// The layer minus its Gaussian blur at each σ in cells: above (ridges, bright
    /// spots) or below (hollows, dark spots) its neighbourhood.
    Relief { layer: String, cells: Vec<f64> },
    /// The normalised difference of the layer and its Gaussian blur at each σ in cells,
    /// (x − m) / (x + m), 0 where x + m is 0: the cell's contrast with its
    /// neighbourhood, the same under any scaling of the layer (illumination, gain).
    Contrast { layer: String, cells: Vec<f64> },
    /// Direction of steepest descent in degrees clockwise from north (0–360; 0 where
    /// flat), for an elevation layer in metres.
    Aspect { layer: String },
    /// An indicator per quantile of the layer's values on this map: 1 where above it.
    Quantile { layer: String, quantiles: Vec<f64> },
    /// Euclidean distance (metres) to the nearest cell above (or, with `side: below`,
    /// below) the layer's quantile `q` on this map, capped at `max` metres and at
    /// `max_cells` cells (of the longer side), by default at the map's diagonal.
    QuantileDistance {
        layer: String,
        q: f64,
        #[serde(default)]
        side: Side,
        #[serde(default)]
        max: Option<f64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_cells: Option<f64>,
    },
    /// A class layer (land cover): per class, an indicator, its share of the
    /// neighbourhood at each σ in `shares` (cells: a Gaussian over the indicator), and
    /// the distance in metres to its nearest cell (capped at the map's diagonal).
    Classes {
        layer: String,
        classes: Vec<f32>,
        #[serde(default)]
        shares: Vec<f64>,
    },
}

/// Which side of a threshold a distance measures to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    #[default]
    Above,
    Below,
}

pub const BIAS: &str = "bias";

/// How one output plane is made.
#[derive(Debug, Clone)]
enum Plane {
    Copy(usize),
    Nodata(usize),
    Normalize(usize),
    /// σ in cells along x and y, for every row or one pair for them all (where the
    /// cells' ground size changes with latitude).
    Blur(usize, Vec<[f64; 2]>),
    Gradient(usize, bool),
    /// Windows of `[columns, rows]` cells (odd), for every row or one pair for them all.
    Roughness(usize, Vec<[usize; 2]>),
    Laplacian(usize),
    Equals(usize, f32),
    Above(usize, f32),
    Distance(usize, Target, f64),
    Product(usize, usize),
    NormalizedDifference(usize, usize),
    Brightness(Vec<usize>),
    /// σ in cells along x and y, as `Blur`.
    Relief(usize, Vec<[f64; 2]>),
    /// σ in cells along x and y, as `Blur`.
    Contrast(usize, Vec<[f64; 2]>),
    /// The share of class `c` around each cell: a Gaussian of σ cells (along x and y,
    /// as `Blur`) over its indicator.
    Share(usize, f32, Vec<[f64; 2]>),
    Aspect(usize),
    Bias,
}

#[derive(Debug, Clone, Copy)]
enum Target {
    Equals(f32),
    Above(f32),
    Below(f32),
}

impl Target {
    /// The target beyond the threshold `t` on `side`.
    fn beyond(side: Side, t: f32) -> Self {
        match side {
            Side::Above => Target::Above(t),
            Side::Below => Target::Below(t),
        }
    }

    /// Whether a cell's value is in the target (NaN never is).
    fn holds(self, v: f32) -> bool {
        match self {
            Target::Equals(c) => v == c,
            Target::Above(t) => v > t,
            Target::Below(t) => v < t,
        }
    }
}

/// "above" or "below", as feature names spell it.
fn side_name(side: Side) -> &'static str {
    match side {
        Side::Above => "above",
        Side::Below => "below",
    }
}

/// The value below which a share `q` of the layer's data cells lie (index ⌊q(n − 1)⌋
/// of the sorted non-NaN values; 0 when there are none).
fn quantile_of(values: &[f32], q: f64) -> f32 {
    let mut data: Vec<f32> = values.iter().copied().filter(|v| !v.is_nan()).collect();
    if data.is_empty() {
        return 0.0;
    }
    let k = ((q.clamp(0.0, 1.0) * (data.len() - 1) as f64).floor()) as usize;
    *data.select_nth_unstable_by(k, f32::total_cmp).1
}

/// A quantile as a name: 0.75 → "q75", 0.125 → "q12.5".
fn quantile_name(q: f64) -> String {
    format!("q{}", format_number((q * 1000.0).round() / 10.0))
}

/// Shortest decimal form of a parameter for a feature name ("2", "0.3", "2.5").
fn format_number(v: impl std::fmt::Display) -> String {
    let s = v.to_string();
    s.strip_suffix(".0").map(String::from).unwrap_or(s)
}

/// What a spec asks of one map: the output planes with their names, the layers (by
/// index) that hold no-data cells, and inputs derived from the layers, which planes
/// read as inputs numbered after the map's layers.
struct Layout {
    names: Vec<String>,
    planes: Vec<Plane>,
    nodata: Vec<usize>,
    derived: Vec<Vec<f32>>,
}

/// The mean of `layers` per cell, NaN where any of them has no data.
fn mean_of(map: &Map, layers: &[usize]) -> Vec<f32> {
    let scale = 1.0 / layers.len() as f32;
    (0..map.geo.cell_count())
        .map(|cell| {
            scale
                * layers
                    .iter()
                    .map(|&i| map.layers[i].values[cell])
                    .sum::<f32>()
        })
        .collect()
}

/// Turns the spec into named planes over the given layers; errors name what is wrong.
fn plan(map: &Map, spec: &FeatureSpec, dataset: &DatasetLayers) -> Result<Layout, String> {
    let mut out = LayoutBuilder {
        map,
        used: Vec::new(),
        layout: Layout {
            names: Vec::new(),
            planes: Vec::new(),
            nodata: Vec::new(),
            derived: Vec::new(),
        },
    };
    // A layer the spec gives its own class operator keeps that one (the bank's
    // indicators would repeat its names).
    let own_classes = |name: &str| {
        spec.ops.iter().any(|op| {
            matches!(op, Op::Classes { layer, .. } | Op::OneHot { layer, .. } if layer == name)
        })
    };
    let bank_ops: Vec<Op> = spec
        .bank
        .map(|b| b.ops(map, &dataset.classes))
        .unwrap_or_default()
        .into_iter()
        .filter(|op| !matches!(op, Op::OneHot { layer, .. } if own_classes(layer)))
        .collect();
    let plain = match (&spec.layers, spec.ops.is_empty() && spec.bank.is_none()) {
        (Some(layers), _) => layers.clone(),
        (None, true) => map.layer_names(),
        (None, false) => Vec::new(),
    };
    for name in &plain {
        let i = out.layer(name)?;
        out.push(name.clone(), Plane::Copy(i))?;
    }
    let [metres_x, metres_y] = map.geo.cell_metres();
    let diagonal_metres =
        (f64::from(map.geo.width) * metres_x).hypot(f64::from(map.geo.height) * metres_y);
    // A distance's cap in metres: the tightest of `max` metres, `max_cells` cells of
    // the longer side and the map's diagonal.
    let distance_cap = |what: &str, max: Option<f64>, max_cells: Option<f64>| {
        for (field, v) in [("max", max), ("max_cells", max_cells)] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(format!("{what}: `{field}` {v} is not a positive length"));
            }
        }
        let cells = max_cells.map_or(f64::INFINITY, |k| k * metres_x.max(metres_y));
        Ok(diagonal_metres.min(max.unwrap_or(f64::INFINITY)).min(cells))
    };
    for op in bank_ops.iter().chain(&spec.ops) {
        match op {
            Op::Normalize { layer: l } => {
                let i = out.layer(l)?;
                out.push(format!("{l}/robust"), Plane::Normalize(i))?;
            }
            Op::Blur {
                layer: l,
                sigmas,
                cells,
            } => {
                let i = out.layer(l)?;
                for &k in cells {
                    if !(k.is_finite() && k > 0.0) {
                        return Err(format!(
                            "blur of '{l}': sigma {k} must be a positive number of cells"
                        ));
                    }
                    out.push(
                        format!("{l}/blur_{}c", format_number(k)),
                        Plane::Blur(i, ground_sigmas(map, k)),
                    )?;
                }
                for &sigma in sigmas {
                    if !(sigma.is_finite() && sigma > 0.0) {
                        return Err(format!(
                            "blur of '{l}': sigma {sigma} must be a positive number of metres"
                        ));
                    }
                    out.push(
                        format!("{l}/blur_{}m", format_number(sigma)),
                        Plane::Blur(i, metric_sigmas(map, sigma)),
                    )?;
                }
            }
            Op::Gradient { layer: l } => {
                let i = out.layer(l)?;
                out.push(format!("{l}/gradient"), Plane::Gradient(i, false))?;
            }
            Op::Slope { layer: l } => {
                let i = out.layer(l)?;
                out.push(format!("{l}/slope_deg"), Plane::Gradient(i, true))?;
            }
            Op::Roughness { layer: l, windows } => {
                let i = out.layer(l)?;
                for &w in windows {
                    check_window(l, w)?;
                    out.push(
                        format!("{l}/roughness_{w}c"),
                        Plane::Roughness(i, ground_windows(map, w)),
                    )?;
                }
            }
            Op::Laplacian { layer: l } => {
                let i = out.layer(l)?;
                out.push(format!("{l}/laplacian"), Plane::Laplacian(i))?;
            }
            Op::OneHot { layer: l, classes } => {
                let i = out.layer(l)?;
                for &c in classes {
                    out.push(
                        format!("{l}/class_{}", format_number(c)),
                        Plane::Equals(i, c),
                    )?;
                }
            }
            Op::Threshold { layer: l, above } => {
                let i = out.layer(l)?;
                for &t in above {
                    out.push(
                        format!("{l}/above_{}", format_number(t)),
                        Plane::Above(i, t),
                    )?;
                }
            }
            Op::Distance {
                layer: l,
                class,
                above,
                below,
                max,
                max_cells,
            } => {
                let i = out.layer(l)?;
                let (target, label) = match (class, above, below) {
                    (Some(c), None, None) => {
                        (Target::Equals(*c), format!("class_{}", format_number(c)))
                    }
                    (None, Some(t), None) => {
                        (Target::Above(*t), format!("above_{}", format_number(t)))
                    }
                    (None, None, Some(t)) => {
                        (Target::Below(*t), format!("below_{}", format_number(t)))
                    }
                    _ => {
                        return Err(format!(
                            "distance on '{l}': give exactly one of `class`, `above` and `below`"
                        ));
                    }
                };
                let cap = distance_cap(&format!("distance on '{l}'"), *max, *max_cells)?;
                out.push(
                    format!("{l}/distance_to_{label}_m"),
                    Plane::Distance(i, target, cap),
                )?;
            }
            Op::Product { a, b } => {
                let find = |n: &str| {
                    let names = &out.layout.names;
                    names.iter().position(|x| x == n).ok_or_else(|| {
                        format!(
                            "product: no feature '{n}' before it (features so far: {})",
                            names.join(", ")
                        )
                    })
                };
                let (ia, ib) = (find(a)?, find(b)?);
                let planes = &out.layout.planes;
                if matches!(planes[ia], Plane::Product(..))
                    || matches!(planes[ib], Plane::Product(..))
                {
                    return Err(format!(
                        "product of '{a}' and '{b}': products of products are not supported"
                    ));
                }
                out.push(format!("{a}*{b}"), Plane::Product(ia, ib))?;
            }
            Op::NormalizedDifference { a, b } => {
                let (ia, ib) = (out.layer(a)?, out.layer(b)?);
                out.push(format!("nd({a},{b})"), Plane::NormalizedDifference(ia, ib))?;
            }
            Op::Brightness {
                layers,
                quantiles,
                distance_above,
                distance_below,
                distance_max_cells,
                gradient,
                roughness,
            } => {
                if layers.is_empty() {
                    return Err("brightness: name at least one layer".into());
                }
                let cap = distance_cap("brightness", None, *distance_max_cells)?;
                let indices = layers
                    .iter()
                    .map(|l| out.layer(l))
                    .collect::<Result<Vec<_>, _>>()?;
                out.push("brightness".into(), Plane::Brightness(indices.clone()))?;
                let distances = [
                    (Side::Above, *distance_above),
                    (Side::Below, *distance_below),
                ];
                if quantiles.is_empty()
                    && distances.iter().all(|(_, q)| q.is_none())
                    && !*gradient
                    && roughness.is_empty()
                {
                    continue;
                }
                // The mean (NaN where a layer has no data) as an input of its own,
                // after the map's layers, for the gradient, indicators and distances.
                let source = map.layers.len() + out.layout.derived.len();
                let mean = mean_of(map, &indices);
                let values = &mean;
                if *gradient {
                    out.push("brightness/gradient".into(), Plane::Gradient(source, false))?;
                }
                for &w in roughness {
                    check_window("brightness", w)?;
                    out.push(
                        format!("brightness/roughness_{w}c"),
                        Plane::Roughness(source, ground_windows(map, w)),
                    )?;
                }
                for &q in quantiles.iter().chain(distance_above).chain(distance_below) {
                    if !(0.0..=1.0).contains(&q) {
                        return Err(format!("brightness: quantile {q} is not within 0 to 1"));
                    }
                }
                for &q in quantiles {
                    out.push(
                        format!("brightness/above_{}", quantile_name(q)),
                        Plane::Above(source, quantile_of(values, q)),
                    )?;
                }
                for (side, q) in distances {
                    let Some(q) = q else { continue };
                    out.push(
                        format!(
                            "brightness/distance_to_{}_{}_m",
                            side_name(side),
                            quantile_name(q)
                        ),
                        Plane::Distance(source, Target::beyond(side, quantile_of(values, q)), cap),
                    )?;
                }
                out.layout.derived.push(mean);
            }
            Op::Relief { layer: l, cells } | Op::Contrast { layer: l, cells } => {
                let i = out.layer(l)?;
                let what = if matches!(op, Op::Relief { .. }) {
                    "relief"
                } else {
                    "contrast"
                };
                for &k in cells {
                    if !(k.is_finite() && k > 0.0) {
                        return Err(format!(
                            "{what} of '{l}': sigma {k} must be a positive number of cells"
                        ));
                    }
                    out.push(
                        format!("{l}/{what}_{}c", format_number(k)),
                        if what == "relief" {
                            Plane::Relief(i, ground_sigmas(map, k))
                        } else {
                            Plane::Contrast(i, ground_sigmas(map, k))
                        },
                    )?;
                }
            }
            Op::Classes {
                layer: l,
                classes,
                shares,
            } => {
                let i = out.layer(l)?;
                for &k in shares {
                    if !(k.is_finite() && k > 0.0) {
                        return Err(format!(
                            "classes of '{l}': share sigma {k} must be a positive number of cells"
                        ));
                    }
                }
                for &c in classes {
                    let class = format!("{l}/class_{}", format_number(c));
                    out.push(class.clone(), Plane::Equals(i, c))?;
                    for &k in shares {
                        out.push(
                            format!("{class}/share_{}c", format_number(k)),
                            Plane::Share(i, c, ground_sigmas(map, k)),
                        )?;
                    }
                    out.push(
                        format!("{l}/distance_to_class_{}_m", format_number(c)),
                        Plane::Distance(i, Target::Equals(c), diagonal_metres),
                    )?;
                }
            }
            Op::Aspect { layer: l } => {
                let i = out.layer(l)?;
                out.push(format!("{l}/aspect_deg"), Plane::Aspect(i))?;
            }
            Op::Quantile {
                layer: l,
                quantiles,
            } => {
                let i = out.layer(l)?;
                for &q in quantiles {
                    if !(0.0..=1.0).contains(&q) {
                        return Err(format!("quantile of '{l}': {q} is not within 0 to 1"));
                    }
                    let t = quantile_of(&map.layers[i].values, q);
                    out.push(
                        format!("{l}/above_{}", quantile_name(q)),
                        Plane::Above(i, t),
                    )?;
                }
            }
            Op::QuantileDistance {
                layer: l,
                q,
                side,
                max,
                max_cells,
            } => {
                let i = out.layer(l)?;
                let cap = distance_cap(&format!("distance of '{l}'"), *max, *max_cells)?;
                if !(0.0..=1.0).contains(q) {
                    return Err(format!(
                        "distance of '{l}': quantile {q} is not within 0 to 1"
                    ));
                }
                let t = quantile_of(&map.layers[i].values, *q);
                out.push(
                    format!(
                        "{l}/distance_to_{}_{}_m",
                        side_name(*side),
                        quantile_name(*q)
                    ),
                    Plane::Distance(i, Target::beyond(*side, t), cap),
                )?;
            }
        }
    }
    // Layers with no data get an indicator.
    for i in out.used.clone() {
        let values = &map.layers[i].values;
        if let Some(j) = values.iter().position(|v| v.is_infinite()) {
            return Err(format!(
                "layer '{}' of map '{}' is {} at {}",
                map.layers[i].name,
                map.name,
                values[j],
                map.geo.cell_at(j)
            ));
        }
        if dataset.nodata.contains(&map.layers[i].name) || values.iter().any(|v| v.is_nan()) {
            out.layout.nodata.push(i);
            out.push(format!("{}/nodata", map.layers[i].name), Plane::Nodata(i))?;
        }
    }
    if spec.bias {
        out.push(BIAS.into(), Plane::Bias)?;
    }
    if out.layout.names.is_empty() {
        return Err("the feature spec selects no features".into());
    }
    Ok(out.layout)
}

/// A `Layout` as `plan` builds it, and the map's layers it has read so far.
struct LayoutBuilder<'a> {
    map: &'a Map,
    used: Vec<usize>,
    layout: Layout,
}

impl LayoutBuilder<'_> {
    /// The index of the map's layer `name`, noted as read.
    fn layer(&mut self, name: &str) -> Result<usize, String> {
        let map = self.map;
        let i = map.layer_index(name).ok_or_else(|| {
            format!(
                "map '{}' has no layer '{name}' (it has: {})",
                map.name,
                map.layer_names().join(", ")
            )
        })?;
        if !self.used.contains(&i) {
            self.used.push(i);
        }
        Ok(i)
    }

    /// Adds the output plane `name`; a name asked for twice is an error.
    fn push(&mut self, name: String, plane: Plane) -> Result<(), String> {
        if self.layout.names.contains(&name) {
            return Err(format!("feature '{name}' is asked for twice"));
        }
        self.layout.names.push(name);
        self.layout.planes.push(plane);
        Ok(())
    }
}

/// A roughness window must be an odd number of cells, so that it centres on its cell.
fn check_window(layer: &str, window: usize) -> Result<(), String> {
    if window.is_multiple_of(2) {
        return Err(format!(
            "roughness of '{layer}': window {window} must be an odd number of cells"
        ));
    }
    Ok(())
}

/// Builds the feature stack of one map; the error names what is missing or invalid.
/// A map on its own is its own dataset ([`DatasetLayers::of`]).
pub fn compute(map: &Map, spec: &FeatureSpec) -> Result<FeatureStack, String> {
    compute_in_dataset(map, spec, &DatasetLayers::of(std::slice::from_ref(map)))
}

/// What the features of each map take from every map of its dataset, so that all the
/// stacks of a dataset have the same features.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DatasetLayers {
    /// The layers that hold no-data (NaN) cells in any map: each gets its
    /// `<layer>/nodata` indicator on every map.
    pub nodata: Vec<String>,
    /// The layers that hold classes on every map that has them, by name, with the
    /// classes of all those maps in ascending order: 2 to [`MAX_DECLARED_CLASSES`]
    /// integer codes where any map declares the layer classes, else 2 to
    /// [`MAX_CLASSES`] ([`Layer::classes`]).
    pub classes: Vec<(String, Vec<f32>)>,
    /// Layers of more than [`MAX_CLASSES`] and at most [`MAX_DECLARED_CLASSES`]
    /// integer codes that no map declares classes, with their codes: read as values,
    /// though they may be a land cover whose colour table was lost (a hint says so).
    pub undeclared_codes: Vec<(String, Vec<f32>)>,
    /// Layers that a map declares classes but that hold more than
    /// [`MAX_DECLARED_CLASSES`] codes (`Some` with how many) or values that are not
    /// integers (`None`): read as values, with a hint (a finely divided vegetation map
    /// such as LANDFIRE's has hundreds).
    pub declared_as_values: Vec<(String, Option<usize>)>,
}

impl DatasetLayers {
    pub fn of(maps: &[Map]) -> Self {
        let mut nodata: Vec<String> = maps
            .iter()
            .flat_map(|m| m.layers.iter())
            .filter(|l| l.values.iter().any(|v| v.is_nan()))
            .map(|l| l.name.clone())
            .collect();
        nodata.sort();
        nodata.dedup();
        // A layer that one map declares classes is classes on every map (a tile whose
        // colour table a tool dropped still holds the same land cover).
        let declared: std::collections::BTreeSet<&str> = maps
            .iter()
            .flat_map(|m| &m.layers)
            .filter(|l| l.kind == LayerKind::Classes)
            .map(|l| l.name.as_str())
            .collect();
        let classes = gathered(maps, |layer| {
            let most = if declared.contains(layer.name.as_str()) {
                MAX_DECLARED_CLASSES
            } else {
                MAX_CLASSES
            };
            distinct_integers(&layer.values, most)
        });
        let undeclared_codes = gathered(maps, |layer| {
            (!declared.contains(layer.name.as_str()))
                .then(|| distinct_integers(&layer.values, MAX_DECLARED_CLASSES))
                .flatten()
        })
        .into_iter()
        .filter(|(_, codes)| (MAX_CLASSES + 1..=MAX_DECLARED_CLASSES).contains(&codes.len()))
        .collect();
        let declared_as_values = declared
            .iter()
            .filter(|name| !classes.iter().any(|(c, _)| c == *name))
            .map(|&name| {
                let values = maps
                    .iter()
                    .filter_map(|m| m.layer(name))
                    .flat_map(|l| &l.values)
                    .filter(|v| !v.is_nan());
                let mut codes = std::collections::BTreeSet::new();
                let mut integers = true;
                for v in values {
                    integers &= v.fract() == 0.0;
                    codes.insert(v.to_bits());
                }
                (name.to_string(), integers.then_some(codes.len()))
            })
            .collect();
        DatasetLayers {
            nodata,
            classes,
            undeclared_codes,
            declared_as_values,
        }
    }
}

/// Per layer name, in order, the union of the values `of_layer` finds on every map that
/// has the layer, ascending; a name is left out where it finds none on some map.
fn gathered(
    maps: &[Map],
    of_layer: impl Fn(&Layer) -> Option<Vec<f32>>,
) -> Vec<(String, Vec<f32>)> {
    let mut union: std::collections::BTreeMap<&str, Option<Vec<f32>>> = Default::default();
    for layer in maps.iter().flat_map(|m| &m.layers) {
        let entry = union
            .entry(layer.name.as_str())
            .or_insert_with(|| Some(Vec::new()));
        match (entry.as_mut(), of_layer(layer)) {
            (Some(all), Some(these)) => all.extend(these),
            _ => *entry = None,
        }
    }
    union
        .into_iter()
        .filter_map(|(name, values)| {
            let mut values = values?;
            values.sort_by(f32::total_cmp);
            values.dedup();
            Some((name.to_string(), values))
        })
        .collect()
}

/// A Gaussian's σ of `metres` on the ground in cells along x and y, row by row where
/// the cells' ground size changes with latitude (one pair elsewhere). Toward a pole
/// the cells narrow and σ spans ever more of them; it stops at the raster's side,
/// beyond which a blur is nearly the whole row's mean.
fn metric_sigmas(map: &Map, metres: f64) -> Vec<[f64; 2]> {
    per_row_and_axis(map, |cell| [metres / cell[0], metres / cell[1]])
}

/// The cells' mean side √(dx·dy) on the ground at the middle row: the unit of every
/// length an operator counts in cells.
pub fn mean_cell_side(map: &Map) -> f64 {
    let [x, y] = map.geo.cell_metres();
    (x * y).sqrt()
}

/// A Gaussian's σ of `cells` cells in cells along x and y, row by row as
/// [`metric_sigmas`]: a cell-counted length is `cells` mean sides ([`mean_cell_side`])
/// on the ground, so that the bank's neighbourhoods are round on the ground where the
/// cells are not square (a DEM in degrees away from the equator) and keep their ground
/// size toward the poles; on square cells it is `cells` rows and columns exactly.
fn ground_sigmas(map: &Map, cells: f64) -> Vec<[f64; 2]> {
    if has_square_cells(map) {
        return vec![[cells; 2]];
    }
    let mean = mean_cell_side(map);
    per_row_and_axis(map, |cell| {
        [cells * (mean / cell[0]), cells * (mean / cell[1])]
    })
}

/// A square window of `window` cells (odd) as `[columns, rows]` (odd) for every row,
/// on the ground as [`ground_sigmas`] takes a σ: its side of `window` mean sides spans
/// the odd count of cells nearest to it along each axis, at most twice the raster's
/// side.
pub fn ground_windows(map: &Map, window: usize) -> Vec<[usize; 2]> {
    if has_square_cells(map) {
        return vec![[window; 2]];
    }
    let mean = mean_cell_side(map);
    let sides = [map.geo.width, map.geo.height].map(|s| s as usize);
    map.geo
        .cell_metres_by_row()
        .iter()
        .map(|cell| {
            [0, 1].map(|axis| {
                let span = window as f64 * (mean / cell[axis]);
                let half = ((span - 1.0) / 2.0).round().max(0.0) as usize;
                2 * half.min(sides[axis]) + 1
            })
        })
        .collect()
}

/// Whether every cell is the same square on the ground.
fn has_square_cells(map: &Map) -> bool {
    !map.geo.varies_by_row() && map.geo.is_square()
}

/// `sigma(cell)` (cells along x and y, from a cell's ground size) for every row where
/// the cells' ground size changes with latitude, capped at the raster's sides there,
/// and one pair elsewhere.
fn per_row_and_axis(map: &Map, sigma: impl Fn([f64; 2]) -> [f64; 2]) -> Vec<[f64; 2]> {
    let sides = [map.geo.width, map.geo.height].map(f64::from);
    let varies = map.geo.varies_by_row();
    map.geo
        .cell_metres_by_row()
        .iter()
        .map(|&cell| {
            let mut s = sigma(cell);
            if varies {
                s = [s[0].min(sides[0]), s[1].min(sides[1])];
            }
            s
        })
        .collect()
}

/// [`compute`] for one map of a dataset: a `<layer>/nodata` indicator for each of the
/// dataset's no-data layers the spec uses, whether or not this map has no-data cells
/// in it, and the bank's class features from the dataset's classes.
pub fn compute_in_dataset(
    map: &Map,
    spec: &FeatureSpec,
    dataset: &DatasetLayers,
) -> Result<FeatureStack, String> {
    let Layout {
        names,
        planes,
        nodata,
        derived,
    } = plan(map, spec, dataset)?;
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    // Derivatives, distances and blurs in metres use each row's own cell size (it
    // varies with latitude in degrees and Web Mercator).
    let by_row = map.geo.cell_metres_by_row();
    let n = w * h;
    // Layers with no data, filled; the others are read in place.
    let filled: Vec<(usize, Vec<f32>)> = nodata
        .iter()
        .map(|&i| {
            let values = map.layers[i]
                .values
                .iter()
                .map(|&v| if v.is_nan() { spec.nodata_fill } else { v })
                .collect();
            (i, values)
        })
        .collect();
    let input = |i: usize| -> &[f32] {
        if let Some(values) = i.checked_sub(map.layers.len()).map(|k| &derived[k]) {
            return values;
        }
        filled
            .iter()
            .find(|(j, _)| *j == i)
            .map_or(&map.layers[i].values, |(_, v)| v)
    };
    // Derivatives read the layers with their gaps, which they step around.
    let unfilled = |i: usize| -> &[f32] {
        match i.checked_sub(map.layers.len()) {
            Some(k) => &derived[k],
            None => &map.layers[i].values,
        }
    };
    let mut data = vec![0.0f32; n * names.len()];
    // Everything but products, in parallel, each plane written in place.
    data.par_chunks_mut(n)
        .zip(planes.par_iter())
        .for_each(|(out, plane)| match *plane {
            Plane::Copy(i) => out.copy_from_slice(input(i)),
            Plane::Nodata(i) => {
                for (o, v) in out.iter_mut().zip(&map.layers[i].values) {
                    *o = f32::from(u8::from(v.is_nan()));
                }
            }
            Plane::Normalize(i) => robust_normalize(input(i), out),
            Plane::Blur(i, ref sigma_cells) => {
                gaussian_blur_of_data(unfilled(i), w, h, sigma_cells, spec.nodata_fill, out)
            }
            Plane::Gradient(i, degrees) => gradient(unfilled(i), w, h, &by_row, degrees, out),
            Plane::Roughness(i, ref windows) => local_std_by_row(unfilled(i), w, h, windows, out),
            Plane::Laplacian(i) => laplacian(unfilled(i), w, h, &by_row, out),
            Plane::Equals(i, c) => {
                for (o, &v) in out.iter_mut().zip(input(i)) {
                    *o = f32::from(u8::from(v == c));
                }
            }
            Plane::Above(i, t) => {
                for (o, &v) in out.iter_mut().zip(input(i)) {
                    *o = f32::from(u8::from(v > t));
                }
            }
            Plane::Distance(i, target, cap) => {
                // A void is no target, whatever the fill value says.
                let mask: Vec<bool> = unfilled(i).iter().map(|&v| target.holds(v)).collect();
                distance_transform(&mask, w, h, &by_row, cap, out);
            }
            Plane::NormalizedDifference(a, b) => {
                for ((o, &x), &y) in out.iter_mut().zip(input(a)).zip(input(b)) {
                    *o = normalized_difference(x, y);
                }
            }
            Plane::Brightness(ref layers) => {
                out.fill(0.0);
                for &i in layers {
                    for (o, &v) in out.iter_mut().zip(input(i)) {
                        *o += v;
                    }
                }
                let scale = 1.0 / layers.len() as f32;
                out.iter_mut().for_each(|o| *o *= scale);
            }
            // A cell against the mean of the data around it; 0 on a cell without data.
            Plane::Relief(i, ref sigma_cells) => {
                gaussian_blur_of_data(unfilled(i), w, h, sigma_cells, 0.0, out);
                for (o, &v) in out.iter_mut().zip(unfilled(i)) {
                    *o = if v.is_nan() { 0.0 } else { v - *o };
                }
            }
            Plane::Contrast(i, ref sigma_cells) => {
                gaussian_blur_of_data(unfilled(i), w, h, sigma_cells, 0.0, out);
                for (o, &v) in out.iter_mut().zip(unfilled(i)) {
                    *o = if v.is_nan() {
                        0.0
                    } else {
                        normalized_difference(v, *o)
                    };
                }
            }
            Plane::Share(i, c, ref sigma_cells) => {
                let indicator: Vec<f32> = input(i)
                    .iter()
                    .map(|&v| f32::from(u8::from(v == c)))
                    .collect();
                gaussian_blur_by_row(&indicator, w, h, sigma_cells, out);
            }
            Plane::Aspect(i) => aspect(unfilled(i), w, h, &by_row, out),
            Plane::Bias => out.fill(1.0),
            Plane::Product(..) => {}
        });
    // Products read planes made above.
    for (k, plane) in planes.iter().enumerate() {
        if let Plane::Product(a, b) = *plane {
            for cell in 0..n {
                data[k * n + cell] = data[a * n + cell] * data[b * n + cell];
            }
        }
    }
    Ok(FeatureStack {
        geo: map.geo.clone(),
        names,
        data,
    })
}

/// (x − y) / (x + y), 0 where x + y is 0.
fn normalized_difference(x: f32, y: f32) -> f32 {
    let sum = x + y;
    if sum == 0.0 { 0.0 } else { (x - y) / sum }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{GeoRef, Layer};

    fn map() -> Map {
        Map {
            name: "m".into(),
            geo: GeoRef::unit(2, 1),
            layers: vec![
                Layer::new("a", vec![1.0, 2.0]),
                Layer::new("b", vec![3.0, 4.0]),
            ],
        }
    }

    fn spec(layers: Option<Vec<&str>>, ops: Vec<Op>) -> FeatureSpec {
        FeatureSpec {
            layers: layers.map(|l| l.into_iter().map(String::from).collect()),
            ops,
            bias: true,
            nodata_fill: 0.0,
            bank: None,
        }
    }

    #[test]
    fn raw_layers_and_bias() {
        let stack = compute(&map(), &spec(Some(vec!["b"]), vec![])).unwrap();
        assert_eq!(stack.names, ["b", "bias"]);
        assert_eq!(stack.data, [3.0, 4.0, 1.0, 1.0]);
        let mut all = spec(None, vec![]);
        all.bias = false;
        assert_eq!(compute(&map(), &all).unwrap().names, ["a", "b"]);
    }

    #[test]
    fn operators_name_their_planes() {
        let ops = vec![
            Op::Threshold {
                layer: "a".into(),
                above: vec![1.5],
            },
            Op::OneHot {
                layer: "b".into(),
                classes: vec![4.0],
            },
            Op::Distance {
                layer: "b".into(),
                class: Some(4.0),
                above: None,
                below: None,
                max: None,
                max_cells: None,
            },
            Op::Distance {
                layer: "a".into(),
                class: None,
                above: None,
                below: Some(1.5),
                max: None,
                max_cells: None,
            },
            Op::Product {
                a: "a".into(),
                b: "b/class_4".into(),
            },
        ];
        let stack = compute(&map(), &spec(Some(vec!["a"]), ops)).unwrap();
        assert_eq!(
            stack.names,
            [
                "a",
                "a/above_1.5",
                "b/class_4",
                "b/distance_to_class_4_m",
                "a/distance_to_below_1.5_m",
                "a*b/class_4",
                "bias"
            ]
        );
        assert_eq!(stack.plane(1), [0.0, 1.0]);
        assert_eq!(stack.plane(2), [0.0, 1.0]);
        assert_eq!(stack.plane(3), [1.0, 0.0]);
        assert_eq!(stack.plane(4), [0.0, 1.0]);
        assert_eq!(stack.plane(5), [0.0, 2.0]);
        let two = Op::Distance {
            layer: "a".into(),
            class: None,
            above: Some(1.0),
            below: Some(1.0),
            max: None,
            max_cells: None,
        };
        let err = compute(&map(), &spec(None, vec![two])).unwrap_err();
        assert!(err.contains("exactly one"), "{err}");
    }

    #[test]
    fn classes_have_indicators_shares_and_distances() {
        // b = [3, 4] on two 1 m cells.
        let op = Op::Classes {
            layer: "b".into(),
            classes: vec![4.0, 5.0],
            shares: vec![1.0],
        };
        let stack = compute(&map(), &spec(Some(vec![]), vec![op])).unwrap();
        assert_eq!(
            stack.names,
            [
                "b/class_4",
                "b/class_4/share_1c",
                "b/distance_to_class_4_m",
                "b/class_5",
                "b/class_5/share_1c",
                "b/distance_to_class_5_m",
                "bias"
            ]
        );
        assert_eq!(stack.plane(0), [0.0, 1.0]);
        // The share is the blurred indicator: some of class 4 beside it, most on it.
        let share = stack.plane(1);
        assert!(
            share[0] > 0.0 && share[0] < 0.5 && share[1] > 0.5,
            "{share:?}"
        );
        assert_eq!(stack.plane(2), [1.0, 0.0]);
        // A class no cell holds: no share, and the distance capped at the diagonal.
        assert_eq!(stack.plane(3), [0.0, 0.0]);
        assert_eq!(stack.plane(4), [0.0, 0.0]);
        let diagonal = 2f32.hypot(1.0);
        assert!(stack.plane(5).iter().all(|&d| (d - diagonal).abs() < 1e-5));
        let bad = Op::Classes {
            layer: "b".into(),
            classes: vec![4.0],
            shares: vec![0.0],
        };
        let err = compute(&map(), &spec(None, vec![bad])).unwrap_err();
        assert!(err.contains("positive"), "{err}");
    }

    #[test]
    fn contrast_is_the_normalised_difference_with_the_blur_whatever_the_scale() {
        let op = |cells| Op::Contrast {
            layer: "a".into(),
            cells,
        };
        let stack = compute(&map(), &spec(Some(vec![]), vec![op(vec![1.0])])).unwrap();
        assert_eq!(stack.names, ["a/contrast_1c", "bias"]);
        let mut blur = [0.0f32; 2];
        gaussian_blur(&map().layers[0].values, 2, 1, [1.0; 2], &mut blur);
        let expected = [
            (1.0 - blur[0]) / (1.0 + blur[0]),
            (2.0 - blur[1]) / (2.0 + blur[1]),
        ];
        assert_eq!(stack.plane(0), expected);
        assert!(expected[0] < 0.0 && expected[1] > 0.0, "{expected:?}");
        // Scaling the layer (a brighter scene, another sensor gain) changes nothing;
        // where the cell and its neighbourhood sum to 0 the contrast is 0.
        let mut scaled = map();
        scaled.layers[0].values = vec![3.0, 6.0];
        let again = compute(&scaled, &spec(Some(vec![]), vec![op(vec![1.0])])).unwrap();
        for (a, b) in again.plane(0).iter().zip(stack.plane(0)) {
            assert!((a - b).abs() < 1e-6, "{a} against {b}");
        }
        let mut zero = map();
        zero.layers[0].values = vec![0.0, 0.0];
        let flat = compute(&zero, &spec(Some(vec![]), vec![op(vec![1.0])])).unwrap();
        assert_eq!(flat.plane(0), [0.0, 0.0]);
        let err = compute(&map(), &spec(Some(vec![]), vec![op(vec![-2.0])])).unwrap_err();
        assert!(
            err.contains("contrast of 'a'") && err.contains("positive"),
            "{err}"
        );
    }

    #[test]
    fn quantile_distances_reach_either_side() {
        // a = [1, 2]: the quantile 0 is 1, and the quantile 1 is 2.
        let op = |q, side| Op::QuantileDistance {
            layer: "a".into(),
            q,
            side,
            max: None,
            max_cells: None,
        };
        let ops = vec![op(0.0, Side::Above), op(1.0, Side::Below)];
        let stack = compute(&map(), &spec(Some(vec![]), ops)).unwrap();
        assert_eq!(
            stack.names,
            [
                "a/distance_to_above_q0_m",
                "a/distance_to_below_q100_m",
                "bias"
            ]
        );
        assert_eq!(stack.plane(0), [1.0, 0.0]);
        assert_eq!(stack.plane(1), [0.0, 1.0]);
    }

    #[test]
    fn metric_neighbourhoods_of_a_raster_in_degrees_follow_each_rows_latitude() {
        // 10° cells from the equator to 80° N, the westmost column the target: five
        // columns east of it lie five of that row's cells away on the ground, and a
        // blur of 2000 km reaches further across the narrow northern cells.
        let (w, h) = (20, 9);
        let geo = GeoRef {
            degrees: true,
            ..GeoRef::square(w, h, 10.0, [0.0, -5.0], "EPSG:4326")
        };
        let values = (0..w * h)
            .map(|i| f32::from(u8::from(i % w == 0)))
            .collect();
        let map = Map {
            name: "world".into(),
            geo: geo.clone(),
            layers: vec![Layer::new("a", values)],
        };
        let ops = vec![
            Op::Distance {
                layer: "a".into(),
                class: None,
                above: Some(0.5),
                below: None,
                max: None,
                max_cells: None,
            },
            Op::Blur {
                layer: "a".into(),
                sigmas: vec![2e6],
                cells: vec![],
            },
        ];
        let stack = compute(&map, &spec(Some(vec![]), ops)).unwrap();
        let by_row = geo.cell_metres_by_row();
        let (distance, blur) = (stack.plane(0), stack.plane(1));
        for (row, [east, _]) in by_row.iter().enumerate() {
            let found = f64::from(distance[row * w as usize + 5]);
            assert!(
                (found / (5.0 * east) - 1.0).abs() < 1e-6,
                "row {row}: {found}"
            );
        }
        let reach = |row: usize| blur[row * w as usize + 3] / blur[row * w as usize];
        assert!(reach(8) > 2.0 * reach(0), "{} {}", reach(8), reach(0));
    }

    /// A blur of σ 2 cells, the roughness over 3 cells and the relief at σ 2 cells of
    /// `layer`.
    fn neighbourhood_ops(layer: &str) -> Vec<Op> {
        vec![
            Op::Blur {
                layer: layer.into(),
                sigmas: vec![],
                cells: vec![2.0],
            },
            Op::Roughness {
                layer: layer.into(),
                windows: vec![3],
            },
            Op::Relief {
                layer: layer.into(),
                cells: vec![2.0],
            },
        ]
    }

    #[test]
    fn neighbourhoods_counted_in_cells_are_round_on_the_ground() {
        // Cells of 20 × 10 m: the mean side is √200 m, so a blur of 2 cells is σ √2
        // columns and 2√2 rows, and a roughness window of 3 cells (42.4 m) spans 3
        // columns (60 m; 1 or 5 would be further off) and 5 rows (50 m).
        let (w, h) = (9usize, 12usize);
        let geo = GeoRef {
            resolution_y: Some(10.0),
            ..GeoRef::square(w as u32, h as u32, 20.0, [0.0, 0.0], "EPSG:32633")
        };
        let values: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32).collect();
        let map = Map {
            name: "m".into(),
            geo,
            layers: vec![Layer::new("a", values.clone())],
        };
        let stack = compute(&map, &spec(Some(vec![]), neighbourhood_ops("a"))).unwrap();
        assert_eq!(ground_windows(&map, 3), [[3, 5]]);
        let root2 = 2f64.sqrt();
        let mut expected = vec![0.0; w * h];
        gaussian_blur(&values, w, h, [root2, 2.0 * root2], &mut expected);
        let close = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5);
        assert!(close(stack.plane(0), &expected));
        let relief: Vec<f32> = values.iter().zip(&expected).map(|(v, b)| v - b).collect();
        assert!(close(stack.plane(2), &relief));
        local_std_by_row(&values, w, h, &[[3, 5]], &mut expected);
        assert_eq!(stack.plane(1), expected);
        // On square cells a count of cells is that many rows and columns, to the bit.
        let square = Map {
            geo: GeoRef::square(w as u32, h as u32, 0.1, [0.0, 0.0], "EPSG:32633"),
            ..map
        };
        assert_eq!(ground_sigmas(&square, 3.0), [[3.0, 3.0]]);
        assert_eq!(ground_windows(&square, 7), [[7, 7]]);
    }

    #[test]
    fn neighbourhoods_counted_in_cells_keep_their_ground_size_toward_the_poles() {
        // 5° cells from the equator to 80° N: the mean side is the middle row's (40° N,
        // 427 × 555 km: 487 km), and a window of 3 of them spans about 1460 km
        // east-west in every row, 3 columns on the equator and ever more northward,
        // and 3 rows (1665 km) in each.
        let (w, h) = (40u32, 17u32);
        let geo = GeoRef {
            degrees: true,
            ..GeoRef::square(w, h, 5.0, [0.0, -2.5], "EPSG:4326")
        };
        let map = Map {
            name: "world".into(),
            geo: geo.clone(),
            layers: vec![Layer::new("a", vec![0.0; (w * h) as usize])],
        };
        let windows = ground_windows(&map, 3);
        let sigmas = ground_sigmas(&map, 3.0);
        let mean = mean_cell_side(&map);
        for (row, [east, north]) in geo.cell_metres_by_row().iter().enumerate() {
            let [columns, rows] = windows[row];
            assert_eq!(rows, 3, "row {row}");
            assert!(
                (columns as f64 - 3.0 * mean / east).abs() <= 1.0,
                "row {row}: {columns} columns of {east} m for {} m",
                3.0 * mean
            );
            let [sx, sy] = sigmas[row];
            assert!((sx * east / (3.0 * mean) - 1.0).abs() < 1e-12);
            assert!((sy * north / (3.0 * mean) - 1.0).abs() < 1e-12);
        }
        assert!(windows[0][0] < windows[16][0] / 3, "{windows:?}");
    }

    #[test]
    fn distances_stop_at_the_tightest_of_their_caps() {
        // One row of 12 cells, 2 m wide and 1 m tall; the target is the first cell.
        let mut m = map();
        m.geo.width = 12;
        m.geo.resolution = 2.0;
        m.geo.resolution_y = Some(1.0);
        m.layers = vec![Layer::new("a", (0..12).map(|x| x as f32).collect())];
        let distance = |max, max_cells| Op::Distance {
            layer: "a".into(),
            class: None,
            above: None,
            below: Some(0.5),
            max,
            max_cells,
        };
        // The quantile 0.1 is 1: the first cell is below it.
        let quantile = |max, max_cells| Op::QuantileDistance {
            layer: "a".into(),
            q: 0.1,
            side: Side::Below,
            max,
            max_cells,
        };
        let brightness = |distance_max_cells| Op::Brightness {
            layers: vec!["a".into()],
            quantiles: vec![],
            distance_above: None,
            distance_below: Some(0.1),
            distance_max_cells,
            gradient: false,
            roughness: vec![],
        };
        let ramp = |cap: f32| -> Vec<f32> { (0..12).map(|x| (2.0 * x as f32).min(cap)).collect() };
        // Uncapped, the distance runs to 22 m; 3 cells of the longer (2 m) side stop
        // it at 6 m, and the tighter of 3 cells and 5 m at 5 m.
        for (max, max_cells, cap) in [
            (None, None, f32::INFINITY),
            (None, Some(3.0), 6.0),
            (Some(5.0), Some(3.0), 5.0),
            (Some(9.0), Some(3.0), 6.0),
        ] {
            for op in [distance(max, max_cells), quantile(max, max_cells)] {
                let stack = compute(&m, &spec(Some(vec![]), vec![op])).unwrap();
                assert_eq!(stack.plane(0), ramp(cap), "{max:?} {max_cells:?}");
            }
        }
        let stack = compute(&m, &spec(Some(vec![]), vec![brightness(Some(3.0))])).unwrap();
        assert_eq!(stack.names[1], "brightness/distance_to_below_q10_m");
        assert_eq!(stack.plane(1), ramp(6.0));
        for op in [
            distance(None, Some(0.0)),
            quantile(Some(-1.0), None),
            brightness(Some(f64::NAN)),
        ] {
            let err = compute(&m, &spec(Some(vec![]), vec![op])).unwrap_err();
            assert!(err.contains("is not a positive length"), "{err}");
        }
    }

    #[test]
    fn brightness_has_quantile_indicators_and_distances_to_its_brightest_and_darkest_cells() {
        // Brightness [2, 3]: its median (index ⌊0.5·1⌋ of the sorted values) is 2, and
        // its quantile 1 is 3.
        let op = |distance_above, distance_below| Op::Brightness {
            layers: vec!["a".into(), "b".into()],
            quantiles: vec![0.5],
            distance_above,
            distance_below,
            distance_max_cells: None,
            gradient: false,
            roughness: vec![],
        };
        let both = op(Some(0.5), Some(1.0));
        let stack = compute(&map(), &spec(Some(vec![]), vec![both])).unwrap();
        assert_eq!(
            stack.names,
            [
                "brightness",
                "brightness/above_q50",
                "brightness/distance_to_above_q50_m",
                "brightness/distance_to_below_q100_m",
                "bias"
            ]
        );
        assert_eq!(stack.plane(0), [2.0, 3.0]);
        assert_eq!(stack.plane(1), [0.0, 1.0]);
        assert_eq!(stack.plane(2), [1.0, 0.0]);
        assert_eq!(stack.plane(3), [0.0, 1.0]);
        // A cell without data in any layer is neither above nor a target, and the
        // quantiles are of the cells with data.
        let mut m = map();
        m.layers[1].values[1] = f32::NAN;
        let stack = compute(&m, &spec(Some(vec![]), vec![op(None, None)])).unwrap();
        assert_eq!(stack.plane(1), [0.0, 0.0]);
        let bad = Op::Brightness {
            layers: vec!["a".into()],
            quantiles: vec![],
            distance_above: None,
            distance_below: Some(1.5),
            distance_max_cells: None,
            gradient: false,
            roughness: vec![],
        };
        let err = compute(&map(), &spec(Some(vec![]), vec![bad])).unwrap_err();
        assert!(err.contains("quantile 1.5"), "{err}");
    }

    #[test]
    fn brightness_gradient_is_the_means_slope_stepping_around_gaps() {
        // Brightness [2, 3] on 1 m cells: one-sided differences give 1 per metre at
        // both cells.
        let op = Op::Brightness {
            layers: vec!["a".into(), "b".into()],
            quantiles: vec![],
            distance_above: None,
            distance_below: None,
            distance_max_cells: None,
            gradient: true,
            roughness: vec![],
        };
        let stack = compute(&map(), &spec(Some(vec![]), vec![op.clone()])).unwrap();
        assert_eq!(stack.names, ["brightness", "brightness/gradient", "bias"]);
        assert_eq!(stack.plane(1), [1.0, 1.0]);
        // Without data in a layer at one cell, neither cell has a neighbour to differ
        // from: no cliff to the fill value.
        let mut m = map();
        m.layers[1].values[1] = f32::NAN;
        let stack = compute(&m, &spec(Some(vec![]), vec![op])).unwrap();
        assert_eq!(stack.plane(1), [0.0, 0.0]);
    }

    #[test]
    fn brightness_roughness_is_the_means_local_spread() {
        let op = |roughness: Vec<usize>| Op::Brightness {
            layers: vec!["a".into(), "b".into()],
            quantiles: vec![],
            distance_above: None,
            distance_below: None,
            distance_max_cells: None,
            gradient: false,
            roughness,
        };
        let stack = compute(&map(), &spec(Some(vec![]), vec![op(vec![3])])).unwrap();
        assert_eq!(
            stack.names,
            ["brightness", "brightness/roughness_3c", "bias"]
        );
        let mut expected = [0.0; 2];
        local_std(stack.plane(0), 2, 1, 3, &mut expected);
        assert_eq!(stack.plane(1), expected);
        assert!(expected.iter().all(|&v| v > 0.0), "{expected:?}");
        let err = compute(&map(), &spec(Some(vec![]), vec![op(vec![4])])).unwrap_err();
        assert!(
            err.contains("'brightness'") && err.contains("window 4"),
            "{err}"
        );
    }

    #[test]
    fn nodata_becomes_an_indicator_and_a_fill_value() {
        let mut m = map();
        m.layers[0].values[1] = f32::NAN;
        let mut s = spec(Some(vec!["a"]), vec![]);
        s.nodata_fill = -1.0;
        let stack = compute(&m, &s).unwrap();
        assert_eq!(stack.names, ["a", "a/nodata", "bias"]);
        assert_eq!(stack.data, [1.0, -1.0, 0.0, 1.0, 1.0, 1.0]);
    }

    #[test]
    fn neighbourhood_operators_leave_voids_out_and_voids_keep_the_fill() {
        // Two flat bands, 9 × 7 cells, with a void in one: a neighbourhood reads the
        // data around it, not the fill; the cell's own value is the fill.
        let (w, h) = (9, 7);
        let mut m = map();
        m.geo.width = w as u32;
        m.geo.height = h as u32;
        m.layers = vec![
            Layer::new("a", vec![10.0; w * h]),
            Layer::new("b", (0..w * h).map(|i| (i % w) as f32).collect()),
        ];
        let whole = m.clone();
        for cell in [3 * w + 4, 3 * w + 5] {
            m.layers[0].values[cell] = f32::NAN;
        }
        let mut ops = neighbourhood_ops("a");
        ops.extend([
            Op::Laplacian { layer: "a".into() },
            Op::QuantileDistance {
                layer: "a".into(),
                q: 0.1,
                side: Side::Below,
                max: None,
                max_cells: None,
            },
            Op::Brightness {
                layers: vec!["a".into(), "b".into()],
                quantiles: vec![],
                distance_above: None,
                distance_below: None,
                distance_max_cells: None,
                gradient: false,
                roughness: vec![5],
            },
        ]);
        let stack = compute(&m, &spec(Some(vec!["a"]), ops.clone())).unwrap();
        let plane = |name: &str| stack.plane(stack.names.iter().position(|n| n == name).unwrap());
        let void = |cell: usize| m.layers[0].values[cell].is_nan();
        assert_eq!(plane("a")[3 * w + 4], 0.0);
        for (cell, v) in plane("a/blur_2c").iter().enumerate() {
            let expected = if void(cell) { 0.0 } else { 10.0 };
            assert!((v - expected).abs() < 1e-4, "cell {cell}: {v}");
        }
        for flat in ["a/roughness_3c", "a/relief_2c", "a/laplacian"] {
            assert!(plane(flat).iter().all(|v| v.abs() < 1e-4), "{flat}");
        }
        // Nothing is below the data's lowest decile, and the void, read as 0, is not.
        let distance = plane("a/distance_to_below_q10_m");
        assert!(distance.iter().all(|&d| d == distance[0] && d > 9.0));
        // The brightness's spread is that of the data in each window: where a window
        // misses the void (the last row), what it is without the void.
        let without_void = compute(&whole, &spec(Some(vec!["a"]), ops)).unwrap();
        let name = "brightness/roughness_5c";
        let k = stack.names.iter().position(|n| n == name).unwrap();
        assert!(
            plane(name)
                .iter()
                .enumerate()
                .all(|(cell, &v)| void(cell) || v > 0.0)
        );
        assert_eq!(
            stack.plane(k)[(h - 1) * w..],
            without_void.plane(k)[(h - 1) * w..]
        );
    }

    #[test]
    fn mistakes_are_named() {
        let err = compute(&map(), &spec(Some(vec!["c"]), vec![])).unwrap_err();
        assert!(err.contains("no layer 'c'"), "{err}");
        let mut bad = map();
        bad.layers[0].values[1] = f32::INFINITY;
        let err = compute(&bad, &spec(None, vec![])).unwrap_err();
        assert!(err.contains("layer 'a'") && err.contains("col 1"), "{err}");
        let ops = vec![Op::Roughness {
            layer: "a".into(),
            windows: vec![4],
        }];
        assert!(
            compute(&map(), &spec(None, ops))
                .unwrap_err()
                .contains("odd")
        );
        let ops = vec![Op::Product {
            a: "a".into(),
            b: "zz".into(),
        }];
        assert!(
            compute(&map(), &spec(Some(vec!["a"]), ops))
                .unwrap_err()
                .contains("no feature 'zz'")
        );
    }

    #[test]
    fn specs_read_from_yaml() {
        let yaml = "bias: true\nops:\n  - {op: blur, layer: a, sigmas: [1, 2.5]}\n  - {op: distance, layer: b, above: 3}\n  - {op: quantile_distance, layer: a, q: 0.1, side: below}\n";
        let s: FeatureSpec = serde_saphyr::from_str(yaml).unwrap();
        let stack = compute(&map(), &s).unwrap();
        assert_eq!(
            stack.names,
            [
                "a/blur_1m",
                "a/blur_2.5m",
                "b/distance_to_above_3_m",
                "a/distance_to_below_q10_m",
                "bias"
            ]
        );
        // The brightness's indicators and distance are optional.
        let yaml = "bias: false\nops:\n  - {op: brightness, layers: [a, b]}\n  - {op: brightness, layers: [a], quantiles: [0.9], distance_above: 0.9}\n";
        let s: FeatureSpec = serde_saphyr::from_str(yaml).unwrap();
        assert_eq!(
            s.ops[0],
            Op::Brightness {
                layers: vec!["a".into(), "b".into()],
                quantiles: Vec::new(),
                distance_above: None,
                distance_below: None,
                distance_max_cells: None,
                gradient: false,
                roughness: vec![],
            }
        );
        assert_eq!(
            s.ops[1],
            Op::Brightness {
                layers: vec!["a".into()],
                quantiles: vec![0.9],
                distance_above: Some(0.9),
                distance_below: None,
                distance_max_cells: None,
                gradient: false,
                roughness: vec![],
            }
        );
    }
}
