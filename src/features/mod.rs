//! Per-cell features of a map. This first set is the raw layers plus a constant bias;
//! the feature operators (blur, slope, distance transforms, ...) are their own work.

use serde::{Deserialize, Serialize};

use crate::grid::{FeatureStack, Map};

/// Which features to compute; stored with every stack it made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureSpec {
    /// Layers taken as they are, in this order; `None` takes every layer of the map.
    pub layers: Option<Vec<String>>,
    /// Append a constant 1 feature so that a linear cost has an intercept.
    pub bias: bool,
}

pub const BIAS: &str = "bias";

/// Builds the feature stack of one map; the error names a missing layer.
pub fn compute(map: &Map, spec: &FeatureSpec) -> Result<FeatureStack, String> {
    let names: Vec<String> = spec.layers.clone().unwrap_or_else(|| map.layer_names());
    if names.is_empty() && !spec.bias {
        return Err("the feature spec selects no features".into());
    }
    let layers = names
        .iter()
        .map(|name| {
            map.layer(name).ok_or_else(|| {
                format!(
                    "map '{}' has no layer '{name}' (it has: {})",
                    map.name,
                    map.layer_names().join(", ")
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some((layer, i)) = layers
        .iter()
        .find_map(|l| l.values.iter().position(|v| !v.is_finite()).map(|i| (l, i)))
    {
        let cell = map.geo.cell_at(i);
        return Err(format!(
            "layer '{}' of map '{}' is {} at {cell}",
            layer.name, map.name, layer.values[i]
        ));
    }
    let n = map.geo.cell_count();
    let dim = names.len() + usize::from(spec.bias);
    let mut data = Vec::with_capacity(n * dim);
    for layer in &layers {
        data.extend_from_slice(&layer.values);
    }
    if spec.bias {
        data.resize(n * dim, 1.0);
    }
    let mut feature_names = names;
    if spec.bias {
        feature_names.push(BIAS.into());
    }
    Ok(FeatureStack {
        geo: map.geo.clone(),
        names: feature_names,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{GeoRef, Layer};

    fn map() -> Map {
        Map {
            name: "m".into(),
            geo: GeoRef {
                width: 2,
                height: 1,
                resolution: 1.0,
                origin: [0.0, 0.0],
                frame: "map".into(),
            },
            layers: vec![
                Layer {
                    name: "a".into(),
                    values: vec![1.0, 2.0],
                },
                Layer {
                    name: "b".into(),
                    values: vec![3.0, 4.0],
                },
            ],
        }
    }

    #[test]
    fn raw_layers_and_bias() {
        let spec = FeatureSpec {
            layers: Some(vec!["b".into()]),
            bias: true,
        };
        let stack = compute(&map(), &spec).unwrap();
        assert_eq!(stack.names, ["b", "bias"]);
        assert_eq!(stack.data, [3.0, 4.0, 1.0, 1.0]);
        let all = compute(
            &map(),
            &FeatureSpec {
                layers: None,
                bias: false,
            },
        )
        .unwrap();
        assert_eq!(all.names, ["a", "b"]);
    }

    #[test]
    fn missing_layers_and_non_finite_values_are_errors() {
        let spec = FeatureSpec {
            layers: Some(vec!["c".into()]),
            bias: true,
        };
        assert!(compute(&map(), &spec).unwrap_err().contains("no layer 'c'"));
        let mut bad = map();
        bad.layers[0].values[1] = f32::NAN;
        let err = compute(
            &bad,
            &FeatureSpec {
                layers: None,
                bias: true,
            },
        )
        .unwrap_err();
        assert!(err.contains("layer 'a'") && err.contains("col 1"), "{err}");
    }
}
