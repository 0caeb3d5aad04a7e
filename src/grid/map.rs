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
        self.layers.iter().find(|l| l.name == name)
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
