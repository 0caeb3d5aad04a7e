//! Feature banks: named, documented lists of operators chosen by the layers a map has,
//! so that a user who only names the layers gets features a learner can work with.
//! Every length is in cells or metres per axis (never degrees), and every name is the
//! same on every map, so a cost learned on one map applies to another.

use serde::{Deserialize, Serialize};

use super::{Op, Side};
use crate::grid::{MAX_DECLARED_CLASSES, Map};

/// Which bank (`imitate features --bank`, or `bank:` in a spec). Every bank adds an
/// indicator per class on the dataset's class layers of 4 to 32 integer codes (land
/// cover).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Bank {
    /// Overhead imagery: per band multi-scale blurs, gradient (edges), local spread
    /// (texture), relief, contrast with the neighbourhood at the blurs' scales,
    /// quantile indicators and the distances to the brightest and the darkest decile;
    /// normalised differences of every pair of bands and the brightness (with its
    /// gradient, its roughness over windows of 3 to 31 cells, its quantile indicators
    /// and the distances to its brightest and darkest decile), when there are several.
    Imagery,
    /// Elevation: slope and aspect in degrees, roughness over windows of 3 to 31 cells, relief
    /// (cell minus its neighbourhood: hollows and ridges) at several scales, curvature
    /// (Laplacian), a blur and quantile indicators.
    Elevation,
    /// On layers named like elevation (a word of the name, or of a GeoTIFF band's
    /// description, is elevation, elev, dem, dtm, dsm, height, altitude, z,
    /// topography, bathymetry or topobathy), and on a map's only band (a DEM or a
    /// panchromatic image): the elevation bank's operators and the imagery's per-band
    /// ones. The imagery bank on the others.
    Auto,
}

/// Layer names that say "elevation": a word of the name (a band description such as
/// "Elevation (m)" or "DEM_1m") is one of these.
fn is_elevation_name(name: &str) -> bool {
    const WORDS: [&str; 11] = [
        "elevation",
        "elev",
        "dem",
        "dtm",
        "dsm",
        "height",
        "altitude",
        "z",
        "topography",
        "bathymetry",
        "topobathy",
    ];
    name.to_ascii_lowercase()
        .split(|c: char| !c.is_ascii_alphanumeric())
        .any(|word| WORDS.contains(&word) || word.starts_with("elevation"))
}

/// Bands beyond these are left out of the pairwise indices (a hyperspectral cube
/// would otherwise make thousands).
const MAX_PAIRED_BANDS: usize = 8;

/// The quantiles of each band (and of the brightness) the imagery bank marks, and the
/// ones whose brighter and darker cells it measures distances to: margins around
/// roofs, sand or peaks, and shores of water, shadow or valleys (a cost that the
/// bank's per-cell features cannot state; BENCHMARKS.md, "A shore teacher").
const QUANTILES: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 0.9];
const BRIGHTEST: f64 = 0.9;
const DARKEST: f64 = 0.1;

/// Where the bank's distances stop growing, in cells. Near a region, a distance says
/// "on its margin"; far from it, only where on the map a cell lies, a code that
/// boosted trees fit to the training paths and that misleads on held-out ones
/// (BENCHMARKS.md, "Distances capped at 8 cells").
const DISTANCE_CAP_CELLS: f64 = 8.0;

/// The scales (σ in cells) of each band's blurs, and of its contrast with its
/// neighbourhood.
const IMAGERY_CELLS: [f64; 3] = [1.0, 3.0, 8.0];

/// The windows (cells) of the roughness of elevation, of a map's only band and of the
/// brightness of multi-band imagery: rough ground over a window of any width from 3
/// to 31 cells is within a step of one of them. Spreads over a few fixed windows do
/// not state a spread over another, nor can the trees build one from them
/// (BENCHMARKS.md, "A texture teacher").
const TEXTURE_WINDOWS: [usize; 7] = [3, 5, 7, 11, 15, 21, 31];

fn imagery(layers: &[&str]) -> Vec<Op> {
    let mut ops = Vec::new();
    for &l in layers {
        let layer = l.to_string();
        ops.push(Op::Normalize {
            layer: layer.clone(),
        });
        ops.push(Op::Blur {
            layer: layer.clone(),
            sigmas: Vec::new(),
            cells: IMAGERY_CELLS.to_vec(),
        });
        ops.push(Op::Gradient {
            layer: layer.clone(),
        });
        ops.push(Op::Roughness {
            layer: layer.clone(),
            windows: vec![3, 9],
        });
        ops.push(Op::Relief {
            layer: layer.clone(),
            cells: vec![4.0],
        });
        ops.push(Op::Contrast {
            layer: layer.clone(),
            cells: IMAGERY_CELLS.to_vec(),
        });
        ops.push(Op::Quantile {
            layer: layer.clone(),
            quantiles: QUANTILES.to_vec(),
        });
        ops.push(Op::QuantileDistance {
            layer: layer.clone(),
            q: BRIGHTEST,
            side: Side::Above,
            max: None,
            max_cells: Some(DISTANCE_CAP_CELLS),
        });
        ops.push(Op::QuantileDistance {
            layer,
            q: DARKEST,
            side: Side::Below,
            max: None,
            max_cells: Some(DISTANCE_CAP_CELLS),
        });
    }
    let paired = &layers[..layers.len().min(MAX_PAIRED_BANDS)];
    for (i, a) in paired.iter().enumerate() {
        for b in &paired[i + 1..] {
            ops.push(Op::NormalizedDifference {
                a: a.to_string(),
                b: b.to_string(),
            });
        }
    }
    if layers.len() > 1 {
        ops.push(Op::Brightness {
            layers: layers.iter().map(|l| l.to_string()).collect(),
            quantiles: QUANTILES.to_vec(),
            distance_above: Some(BRIGHTEST),
            distance_below: Some(DARKEST),
            distance_max_cells: Some(DISTANCE_CAP_CELLS),
            gradient: true,
            roughness: TEXTURE_WINDOWS.to_vec(),
        });
    }
    ops
}

fn elevation(layers: &[&str]) -> Vec<Op> {
    let mut ops = Vec::new();
    for &l in layers {
        let layer = l.to_string();
        ops.push(Op::Normalize {
            layer: layer.clone(),
        });
        ops.push(Op::Slope {
            layer: layer.clone(),
        });
        ops.push(Op::Aspect {
            layer: layer.clone(),
        });
        ops.push(Op::Roughness {
            layer: layer.clone(),
            windows: TEXTURE_WINDOWS.to_vec(),
        });
        ops.push(Op::Relief {
            layer: layer.clone(),
            cells: vec![2.0, 6.0, 16.0],
        });
        ops.push(Op::Laplacian {
            layer: layer.clone(),
        });
        ops.push(Op::Quantile {
            layer,
            quantiles: vec![0.25, 0.5, 0.75],
        });
    }
    ops
}

/// Class layers (land cover) with at least this many classes get an indicator per
/// class (`one_hot`): a cost per class in no order of the codes takes the trees many
/// splits on the codes alone. On three classes the indicators planned worse, on
/// masks they add nothing (BENCHMARKS.md, "Per-class indicators in the bank").
pub const MIN_INDICATED_CLASSES: usize = 4;

impl Bank {
    /// The operators this bank computes on `map` (layers with no data at all are left
    /// out), given the class layers of its dataset ([`super::DatasetLayers`]): the
    /// same names on every map of the dataset.
    pub fn ops(self, map: &Map, class_layers: &[(String, Vec<f32>)]) -> Vec<Op> {
        let layers: Vec<&str> = map
            .layers
            .iter()
            .filter(|l| l.values.iter().any(|v| !v.is_nan()))
            .map(|l| l.name.as_str())
            .collect();
        let mut ops = match self {
            Bank::Imagery => imagery(&layers),
            Bank::Elevation => elevation(&layers),
            Bank::Auto => {
                let (mut heights, mut others): (Vec<&str>, Vec<&str>) =
                    layers.iter().partition(|l| is_elevation_name(l));
                if heights.is_empty() && others.len() == 1 {
                    // One band: a DEM or a panchromatic image.
                    heights = std::mem::take(&mut others);
                }
                let mut ops: Vec<Op> = heights
                    .iter()
                    .flat_map(|&h| elevation_and_imagery(h))
                    .collect();
                ops.extend(imagery(&others));
                ops
            }
        };
        ops.extend(
            indicated(class_layers)
                .filter(|(name, _)| layers.contains(&name.as_str()))
                .map(|(name, classes)| Op::OneHot {
                    layer: name.clone(),
                    classes: classes.clone(),
                }),
        );
        ops
    }
}

/// The class layers that get an indicator per class.
fn indicated(class_layers: &[(String, Vec<f32>)]) -> impl Iterator<Item = &(String, Vec<f32>)> {
    class_layers
        .iter()
        .filter(|(_, classes)| classes.len() >= MIN_INDICATED_CLASSES)
}

/// Both banks' operators on one layer, the imagery's blurs and quantiles once, with
/// the elevation bank's roughness and relief in place of the imagery's: the bank
/// `auto` gives a DEM. Measured on real DEMs, the elevation bank alone plans worse
/// (BENCHMARKS.md): it has no distance to the highest ground.
fn elevation_and_imagery(layer: &str) -> Vec<Op> {
    let mut ops: Vec<Op> = imagery(&[layer])
        .into_iter()
        .filter(|op| {
            !matches!(
                op,
                Op::Gradient { .. } | Op::Roughness { .. } | Op::Relief { .. }
            )
        })
        .collect();
    ops.extend(elevation(&[layer]).into_iter().filter(|op| {
        matches!(
            op,
            Op::Slope { .. }
                | Op::Aspect { .. }
                | Op::Laplacian { .. }
                | Op::Roughness { .. }
                | Op::Relief { .. }
        )
    }));
    ops
}

impl Bank {
    /// One message per layer of a dataset ([`super::DatasetLayers`]) that the bank
    /// reads as values though it may hold classes, with the operator that reads it
    /// as classes, its classes written out: class layers of fewer than
    /// [`MIN_INDICATED_CLASSES`] classes (masks, slope classes), and layers of more
    /// than [`crate::grid::MAX_CLASSES`] integer codes that no map declares classes (a
    /// land cover that lost its colour table), and layers declared classes that hold
    /// too many codes to read as classes. Layers that `ops` already reads as classes get
    /// none.
    pub fn class_layer_hints(self, dataset: &super::DatasetLayers, ops: &[Op]) -> Vec<String> {
        let covered = |name: &str| {
            ops.iter().any(|op| {
                matches!(op, Op::Classes { layer, .. } | Op::OneHot { layer, .. } if layer == name)
            })
        };
        let list = |classes: &[f32]| {
            classes
                .iter()
                .map(super::format_number)
                .collect::<Vec<_>>()
                .join(",")
        };
        let few = dataset
            .classes
            .iter()
            .filter(|(_, classes)| classes.len() < MIN_INDICATED_CLASSES)
            .filter(|(name, _)| !covered(name))
            .map(|(name, classes)| {
                format!(
                    "layer '{name}' holds {} integer classes; the bank '{}' reads them as \
                     values. For an indicator, share and distance per class add --op \
                     '{{\"op\":\"classes\",\"layer\":\"{name}\",\"classes\":[{}],\"shares\":[4]}}'",
                    classes.len(),
                    self.name(),
                    list(classes)
                )
            });
        let many = dataset
            .undeclared_codes
            .iter()
            .filter(|(name, _)| !covered(name))
            .map(|(name, codes)| {
                format!(
                    "layer '{name}' holds {} integer codes; the bank '{}' reads them as \
                     values (a layer is read as classes past {} codes only where its \
                     file declares them, as a palette GeoTIFF's colour table does). If \
                     they are classes (a land cover), add --op \
                     '{{\"op\":\"one_hot\",\"layer\":\"{name}\",\"classes\":[{}]}}'",
                    codes.len(),
                    self.name(),
                    crate::grid::MAX_CLASSES,
                    list(codes)
                )
            });
        let declared = dataset
            .declared_as_values
            .iter()
            .filter(|(name, _)| !covered(name))
            .map(|(name, codes)| {
                let held = match codes {
                    Some(n) => format!("{n} codes, more than the {MAX_DECLARED_CLASSES} read as classes"),
                    None => "values that are not integer codes".to_string(),
                };
                format!(
                    "layer '{name}' is declared classes by its file (a colour table, category \
                     names or an attribute table) but holds {held}; the bank '{}' reads it as \
                     values, which ranks the classes by their codes. Reclassify it into at \
                     most {MAX_DECLARED_CLASSES} classes, or add an indicator for each class \
                     that matters: --op '{{\"op\":\"one_hot\",\"layer\":\"{name}\",\"classes\":[<codes>]}}'",
                    self.name(),
                )
            });
        few.chain(many).chain(declared).collect()
    }

    fn name(self) -> &'static str {
        match self {
            Bank::Imagery => "imagery",
            Bank::Elevation => "elevation",
            Bank::Auto => "auto",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{DatasetLayers, FeatureSpec, compute, compute_in_dataset};
    use crate::grid::{GeoRef, Layer};

    fn map(layers: &[&str]) -> Map {
        let geo = GeoRef::square(24, 20, 10.0, [0.0, 0.0], "map");
        Map {
            name: "m".into(),
            layers: layers
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    Layer::new(
                        name.to_string(),
                        (0..geo.cell_count())
                            .map(|i| ((i * (k + 3)) % 17) as f32 + 1.0)
                            .collect(),
                    )
                })
                .collect(),
            geo,
        }
    }

    fn names(map: &Map, bank: Bank) -> Vec<String> {
        let spec = FeatureSpec {
            layers: None,
            ops: Vec::new(),
            bias: true,
            nodata_fill: 0.0,
            bank: Some(bank),
        };
        let stack = compute(map, &spec).unwrap();
        assert!(stack.data.iter().all(|v| v.is_finite()));
        stack.names
    }

    #[test]
    fn imagery_bank_indexes_pairs_of_bands() {
        let n = names(&map(&["band1", "band2", "band3"]), Bank::Imagery);
        for expected in [
            "band1/robust",
            "band2/blur_3c",
            "band3/roughness_9c",
            "band2/gradient",
            "band1/relief_4c",
            "band1/contrast_1c",
            "band3/contrast_8c",
            "band2/above_q90",
            "band3/distance_to_above_q90_m",
            "band1/distance_to_below_q10_m",
            "nd(band1,band3)",
            "nd(band2,band3)",
            "brightness",
            "brightness/gradient",
            "brightness/roughness_5c",
            "brightness/roughness_31c",
            "brightness/above_q25",
            "brightness/distance_to_above_q90_m",
            "brightness/distance_to_below_q10_m",
            "bias",
        ] {
            assert!(n.iter().any(|x| x == expected), "{expected} in {n:?}");
        }
        assert!(!n.iter().any(|x| x.contains("slope")));
        // Each band's own texture at two windows; the brightness's at every one.
        assert!(!n.iter().any(|x| x == "band1/roughness_5c"), "{n:?}");
    }

    #[test]
    fn auto_takes_elevation_by_name_and_both_for_one_band() {
        let n = names(&map(&["elevation", "red", "nir"]), Bank::Auto);
        assert!(n.contains(&"elevation/slope_deg".to_string()));
        assert!(n.contains(&"nd(red,nir)".to_string()));
        assert!(!n.iter().any(|x| x.starts_with("nd(elevation")));
        let one = names(&map(&["band1"]), Bank::Auto);
        for expected in [
            "band1/slope_deg",
            "band1/aspect_deg",
            "band1/roughness_5c",
            "band1/roughness_31c",
            "band1/relief_16c",
            "band1/blur_8c",
            "band1/contrast_3c",
            "band1/above_q10",
            "band1/distance_to_below_q10_m",
        ] {
            assert!(one.iter().any(|x| x == expected), "{expected} in {one:?}");
        }
        let unique: std::collections::BTreeSet<_> = one.iter().collect();
        assert_eq!(unique.len(), one.len(), "no feature twice");
        // Slope is the band's gradient in degrees: not both.
        assert!(!one.iter().any(|x| x.ends_with("/gradient")), "{one:?}");
        // A map's only band gets the same whether or not its name says elevation, and
        // so does an elevation band beside imagery.
        let dem = names(&map(&["DEM (m)"]), Bank::Auto);
        assert_eq!(
            dem,
            one.iter()
                .map(|n| n.replace("band1", "DEM (m)"))
                .collect::<Vec<_>>()
        );
        assert!(n.contains(&"elevation/distance_to_above_q90_m".to_string()));
    }

    #[test]
    fn class_layers_get_a_hint_naming_the_operator_and_their_classes() {
        let mut a = map(&["landcover", "red"]);
        a.layers[0]
            .values
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| {
                *v = [10.0, 20.0][i % 2];
            });
        // Red holds fractions: not classes.
        a.layers[1].values.iter_mut().for_each(|v| *v += 0.5);
        let mut b = a.clone();
        b.layers[0].values[0] = 80.0;
        let dataset = DatasetLayers::of(&[a, b]);
        let hints = Bank::Auto.class_layer_hints(&dataset, &[]);
        assert_eq!(hints.len(), 1, "{hints:?}");
        assert!(
            hints[0].contains("layer 'landcover' holds 3 integer classes"),
            "{}",
            hints[0]
        );
        assert!(hints[0].contains(r#""classes":[10,20,80]"#), "{}", hints[0]);
        // The hint's operator is one a spec accepts.
        let json = hints[0]
            .split_once("--op '")
            .and_then(|(_, rest)| rest.strip_suffix('\''))
            .unwrap();
        let op: Op = serde_json::from_str(json).unwrap();
        assert!(matches!(op, Op::Classes { .. }), "{op:?}");
        // Once a spec has it, no hint.
        assert!(Bank::Auto.class_layer_hints(&dataset, &[op]).is_empty());
    }

    #[test]
    fn many_codes_are_classes_where_any_map_declares_them_and_a_hint_where_none_does() {
        let codes: Vec<f32> = (1..=40).map(|c| c as f32).collect();
        let undeclared = class_map(&codes);
        let dataset = DatasetLayers::of(std::slice::from_ref(&undeclared));
        assert!(dataset.classes.iter().all(|(name, _)| name != "landcover"));
        assert_eq!(
            dataset.undeclared_codes,
            vec![("landcover".to_string(), codes.clone())]
        );
        let hints = Bank::Auto.class_layer_hints(&dataset, &[]);
        assert_eq!(hints.len(), 1, "{hints:?}");
        assert!(hints[0].contains("holds 40 integer codes"), "{}", hints[0]);
        let mut declared = undeclared.clone();
        declared.layers[0] = declared.layers[0].clone().declared_classes();
        let dataset = DatasetLayers::of(std::slice::from_ref(&declared));
        assert!(dataset.undeclared_codes.is_empty());
        assert!(Bank::Auto.class_layer_hints(&dataset, &[]).is_empty());
        let ops = Bank::Auto.ops(&declared, &dataset.classes);
        assert!(ops.iter().any(
            |op| matches!(op, Op::OneHot { layer, classes } if layer == "landcover" && *classes == codes)
        ));
        // Declared, but with more codes than are read as classes: values, with a hint.
        let fine: Vec<f32> = (1..=70).map(|c| c as f32).collect();
        let mut too_many = class_map(&fine);
        too_many.layers[0] = too_many.layers[0].clone().declared_classes();
        let dataset = DatasetLayers::of(std::slice::from_ref(&too_many));
        assert_eq!(
            dataset.declared_as_values,
            [("landcover".to_string(), Some(70))]
        );
        let hints = Bank::Auto.class_layer_hints(&dataset, &[]);
        assert_eq!(hints.len(), 1, "{hints:?}");
        assert!(
            hints[0].contains("declared classes") && hints[0].contains("holds 70 codes"),
            "{}",
            hints[0]
        );
        // One map declaring the layer declares it for the dataset: a tile whose colour
        // table was dropped holds the same land cover.
        let dataset = DatasetLayers::of(&[undeclared, declared]);
        assert!(
            dataset
                .classes
                .contains(&("landcover".to_string(), codes.clone()))
        );
        assert!(dataset.undeclared_codes.is_empty());
    }

    /// A map whose first layer holds `classes` in turn, cell by cell, and whose
    /// second holds fractions.
    fn class_map(classes: &[f32]) -> Map {
        let mut m = map(&["landcover", "red"]);
        m.layers[1].values.iter_mut().for_each(|v| *v += 0.5);
        m.layers[0]
            .values
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = classes[i % classes.len()]);
        m
    }

    #[test]
    fn layers_of_many_classes_get_an_indicator_per_class_of_the_whole_dataset() {
        // Map b lacks class 90: it still gets its (empty) indicator, so both stacks
        // have the same features.
        let a = class_map(&[11.0, 21.0, 41.0, 90.0]);
        let b = class_map(&[11.0, 21.0, 41.0, 82.0]);
        let dataset = DatasetLayers::of(&[a.clone(), b.clone()]);
        let spec = FeatureSpec {
            layers: None,
            ops: Vec::new(),
            bias: false,
            nodata_fill: 0.0,
            bank: Some(Bank::Auto),
        };
        let stack_a = compute_in_dataset(&a, &spec, &dataset).unwrap();
        let stack_b = compute_in_dataset(&b, &spec, &dataset).unwrap();
        assert_eq!(stack_a.names, stack_b.names);
        let indicators: Vec<&str> = stack_b
            .names
            .iter()
            .map(String::as_str)
            .filter(|n| n.starts_with("landcover/class_"))
            .collect();
        assert_eq!(
            indicators,
            [
                "landcover/class_11",
                "landcover/class_21",
                "landcover/class_41",
                "landcover/class_82",
                "landcover/class_90"
            ]
        );
        let plane = |stack: &crate::features::FeatureStack, name: &str| {
            let k = stack.names.iter().position(|n| n == name).unwrap();
            stack.plane(k).to_vec()
        };
        assert!(
            plane(&stack_b, "landcover/class_90")
                .iter()
                .all(|&v| v == 0.0)
        );
        let class_82 = plane(&stack_b, "landcover/class_82");
        for (i, v) in class_82.iter().enumerate() {
            assert_eq!(*v, if i % 4 == 3 { 1.0 } else { 0.0 }, "cell {i}");
        }
        // The bank reads these classes itself: no hint.
        assert!(Bank::Auto.class_layer_hints(&dataset, &[]).is_empty());
        // A spec's own class operator on the layer replaces the bank's indicators.
        let mut own = spec.clone();
        own.ops.push(Op::Classes {
            layer: "landcover".into(),
            classes: vec![11.0, 90.0],
            shares: vec![4.0],
        });
        let stack = compute_in_dataset(&a, &own, &dataset).unwrap();
        assert!(
            stack
                .names
                .iter()
                .any(|n| n == "landcover/class_90/share_4c")
        );
        assert!(!stack.names.iter().any(|n| n == "landcover/class_21"));
    }

    #[test]
    fn layers_of_few_classes_and_mixed_layers_get_no_indicators() {
        let few = class_map(&[1.0, 2.0, 3.0]);
        let ops = Bank::Auto.ops(&few, &DatasetLayers::of(std::slice::from_ref(&few)).classes);
        assert!(
            !ops.iter().any(|op| matches!(op, Op::OneHot { .. })),
            "{ops:?}"
        );
        // Classes on one map, fractions on another: not a class layer.
        let a = class_map(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        let mut b = a.clone();
        b.layers[0].values[0] = 0.5;
        let dataset = DatasetLayers::of(&[a.clone(), b]);
        assert!(dataset.classes.iter().all(|(name, _)| name != "landcover"));
        let ops = Bank::Auto.ops(&a, &dataset.classes);
        assert!(
            !ops.iter().any(|op| matches!(op, Op::OneHot { .. })),
            "{ops:?}"
        );
    }

    #[test]
    fn bank_distances_stop_at_eight_cells() {
        // One bright cell in a corner of a 24 × 20 map of 10 m cells: the far corner
        // lies 300 m from it, but the bank's distances say no more than 80 m.
        let mut m = map(&["band1", "band2"]);
        for layer in &mut m.layers {
            layer.values.fill(1.0);
            layer.values[0] = 5.0;
        }
        let spec = FeatureSpec {
            layers: None,
            ops: Vec::new(),
            bias: false,
            nodata_fill: 0.0,
            bank: Some(Bank::Imagery),
        };
        let stack = compute(&m, &spec).unwrap();
        for name in [
            "band1/distance_to_above_q90_m",
            "brightness/distance_to_above_q90_m",
        ] {
            let k = stack.names.iter().position(|n| n == name).unwrap();
            let plane = stack.plane(k);
            assert_eq!(plane[0], 0.0, "{name}");
            assert_eq!(plane[1], 10.0, "{name}");
            let far = plane.iter().copied().fold(0.0f32, f32::max);
            assert_eq!(far, 10.0 * DISTANCE_CAP_CELLS as f32, "{name}");
        }
    }

    #[test]
    fn elevation_names_are_told_by_their_words() {
        for name in [
            "elevation",
            "Elevation (m)",
            "DEM_1m",
            "dtm",
            "z",
            "height",
            "elevation_ft",
            "Topobathy",
        ] {
            assert!(is_elevation_name(name), "{name}");
        }
        for name in [
            "band1",
            "red",
            "nir",
            "zone",
            "demand",
            "Near infrared",
            "blue",
        ] {
            assert!(!is_elevation_name(name), "{name}");
        }
    }
}
