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
