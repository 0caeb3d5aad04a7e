//! Maps: a georeference and named f32 layers (elevation, vegetation, class, ...).

use super::GeoRef;

#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    /// One value per cell, row by row.
    pub values: Vec<f32>,
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
    fn numbered_bands_name_layers_that_carry_descriptions() {
        let layer = |name: &str| Layer {
            name: name.into(),
            values: vec![0.0],
        };
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
