//! Maps: a georeference and named f32 layers (elevation, vegetation, class, ...).

use super::GeoRef;

#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    /// One value per cell, row by row.
    pub values: Vec<f32>,
    pub kind: LayerKind,
}

/// What a layer's values mean, where the file says so.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LayerKind {
    /// Measurements, or nothing said: whether the values look like classes is read
    /// from the values themselves ([`classes_of`]).
    #[default]
    Values,
    /// Class codes, as the file declares them: a palette (colour-mapped) GeoTIFF,
    /// the way land-cover products (NLCD, CORINE, ESA WorldCover) are shipped.
    Classes,
}

/// A layer whose data cells hold from 2 to this many distinct integers looks like
/// classes (land cover, slope classes, masks). Past it, integer layers are far more
/// often quantised measurements (8-bit imagery, DEMs in whole metres).
pub const MAX_CLASSES: usize = 32;

/// The most classes a layer declared as classes ([`LayerKind::Classes`]) is read with:
/// CORINE's 44 and ESA CCI's 37 fit; past it, one indicator per class would make a
/// feature stack of hundreds of planes, so the layer is read as values.
pub const MAX_DECLARED_CLASSES: usize = 64;

impl Layer {
    /// A layer of values ([`LayerKind::Values`]).
    pub fn new(name: impl Into<String>, values: Vec<f32>) -> Self {
        Layer {
            name: name.into(),
            values,
            kind: LayerKind::Values,
        }
    }

    /// The same layer, declared as class codes.
    pub fn declared_classes(self) -> Self {
        Layer {
            kind: LayerKind::Classes,
            ..self
        }
    }

    /// The layer's classes in ascending order, if it holds classes: declared ones of 2
    /// to [`MAX_DECLARED_CLASSES`] integer codes, otherwise as [`classes_of`] finds.
    pub fn classes(&self) -> Option<Vec<f32>> {
        let most = match self.kind {
            LayerKind::Values => MAX_CLASSES,
            LayerKind::Classes => MAX_DECLARED_CLASSES,
        };
        distinct_integers(&self.values, most)
    }
}

/// The classes of a layer whose values look like classes: from 2 to [`MAX_CLASSES`]
/// distinct integers, in ascending order; `None` for any other.
pub fn classes_of(values: &[f32]) -> Option<Vec<f32>> {
    distinct_integers(values, MAX_CLASSES)
}

/// The distinct non-NaN values in ascending order, if they are from 2 to `most`
/// integers.
pub fn distinct_integers(values: &[f32], most: usize) -> Option<Vec<f32>> {
    let mut classes: Vec<f32> = Vec::new();
    for &v in values.iter().filter(|v| !v.is_nan()) {
        if classes.contains(&v) {
            continue;
        }
        if v.fract() != 0.0 || classes.len() == most {
            return None;
        }
        classes.push(v);
    }
    classes.sort_by(f32::total_cmp);
    (classes.len() >= 2).then_some(classes)
}

#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    pub name: String,
    pub geo: GeoRef,
    pub layers: Vec<Layer>,
}

impl Map {
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layer_index(name).map(|i| &self.layers[i])
    }

    /// The layer named `name`; failing that, `bandN` names the Nth layer, so that a
    /// spec written for a raster's numbered bands still works once its bands carry
    /// descriptions (GeoTIFF layers are named by them).
    pub fn layer_index(&self, name: &str) -> Option<usize> {
        self.layers.iter().position(|l| l.name == name).or_else(|| {
            let digits = name.strip_prefix("band")?;
            if digits.starts_with('0') || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            let n: usize = digits.parse().ok()?;
            (1..=self.layers.len()).contains(&n).then(|| n - 1)
        })
    }

    pub fn layer_names(&self) -> Vec<String> {
        self.layers.iter().map(|l| l.name.clone()).collect()
    }
}

/// Map names become file names inside artifacts (`maps/NAME.parquet`), so a name read
/// from data must be a plain file name: not empty, at most 200 bytes, no slash or backslash,
/// no leading '.', no control characters.
pub fn check_map_name(name: &str) -> Result<(), String> {
    let plain = !name.is_empty()
        && name.len() <= 200
        && !name.starts_with('.')
        && !name.contains(['/', '\\'])
        && !name.chars().any(char::is_control);
    if plain {
        Ok(())
    } else {
        Err(format!(
            "the map name {name:?} cannot be a file name (map names are plain file names: \
             no '/', '\\', leading '.' or control characters, at most 200 bytes)"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_of_few_integers_look_like_classes() {
        assert_eq!(classes_of(&[7.0, 3.0, f32::NAN, 3.0]), Some(vec![3.0, 7.0]));
        // Not classes: fractions, a constant, more than MAX_CLASSES values.
        assert_eq!(classes_of(&[0.5, 1.0]), None);
        assert_eq!(classes_of(&[4.0, 4.0, f32::NAN]), None);
        let many: Vec<f32> = (0..=MAX_CLASSES).map(|i| i as f32).collect();
        assert_eq!(classes_of(&many), None);
        assert_eq!(classes_of(&many[..MAX_CLASSES]).unwrap().len(), MAX_CLASSES);
        // Declared classes may hold up to MAX_DECLARED_CLASSES codes, never fractions.
        let layer = |n: usize| Layer::new("c", (0..n).map(|i| i as f32).collect());
        assert_eq!(layer(44).classes(), None);
        assert_eq!(layer(44).declared_classes().classes().unwrap().len(), 44);
        assert_eq!(
            layer(MAX_DECLARED_CLASSES + 1).declared_classes().classes(),
            None
        );
        let fractions = Layer::new("f", vec![0.5, 1.0]).declared_classes();
        assert_eq!(fractions.classes(), None);
    }

    #[test]
    fn numbered_bands_name_layers_that_carry_descriptions() {
        let layer = |name: &str| Layer::new(name, vec![0.0]);
        let map = Map {
            name: "m".into(),
            geo: GeoRef::square(1, 1, 1.0, [0.0, 0.0], "map"),
            layers: vec![layer("elevation"), layer("nir"), layer("band1")],
        };
        assert_eq!(map.layer_index("nir"), Some(1));
        assert_eq!(map.layer_index("band2"), Some(1));
        // A layer's own name comes first.
        assert_eq!(map.layer_index("band1"), Some(2));
        for absent in ["band0", "band4", "band", "band+1", "band02", "red"] {
            assert_eq!(map.layer_index(absent), None, "{absent}");
        }
    }

    #[test]
    fn map_names_are_plain_file_names() {
        for good in ["terrain-000", "Gebiet Süd", "a.b"] {
            check_map_name(good).unwrap();
        }
        let long = "x".repeat(201);
        for bad in [
            "",
            "..",
            "../../../evil",
            "a/b",
            "a\\b",
            ".hidden",
            "a\nb",
            &long,
        ] {
            assert!(check_map_name(bad).is_err(), "{bad:?} passed");
        }
    }
}
