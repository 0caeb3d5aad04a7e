//! ROS 2 navigation maps as Nav2's `map_server` reads and writes them: a YAML file
//! (`image`, `resolution`, `origin: [x, y, yaw]`, `negate`, `occupied_thresh`,
//! `free_thresh`, `mode`) naming a greyscale image (PGM or PNG) whose top row is the
//! map's north edge.
//!
//! Reading follows `nav2_map_server`'s `loadMapFromFile`: a pixel's occupancy
//! probability is (255 − shade) / 255 (shade / 255 with `negate: 1`); `trinary` mode
//! gives 0 below `free_thresh`, 100 above `occupied_thresh` and unknown between;
//! `scale` mode the same ends with 99 · (p − free) / (occupied − free) between (and
//! transparent pixels unknown); `raw` the shade itself (unknown above 100). The map has
//! one layer, `occupancy` (0–100, unknown as NaN), as a logged `nav_msgs/OccupancyGrid`.
//!
//! Writing takes occupancy values 0–100 and writes them so that `scale` mode gives them
//! back: shade 255 · (1 − occupancy / 100), `free_thresh` 0.01, `occupied_thresh` 0.99.

use std::path::{Path, PathBuf};

use image::{ImageEncoder, ImageReader};
use serde::Deserialize;

use super::fs::{write_atomic, write_bytes_atomic};
use crate::error::{Error, Result, read_input};
use crate::grid::{GeoRef, Layer, Map};

/// `free_thresh` and `occupied_thresh` of the maps written here.
const WRITTEN_THRESHOLDS: (f64, f64) = (0.01, 0.99);

#[derive(Debug, Deserialize)]
struct MapYaml {
    image: PathBuf,
    resolution: f64,
    origin: Vec<f64>,
    #[serde(default)]
    negate: u8,
    /// map_server's defaults where a file leaves them out.
    #[serde(default = "default_occupied")]
    occupied_thresh: f64,
    #[serde(default = "default_free")]
    free_thresh: f64,
    #[serde(default = "default_mode")]
    mode: String,
}

fn default_occupied() -> f64 {
    0.65
}

fn default_free() -> f64 {
    0.25
}

fn default_mode() -> String {
    "trinary".into()
}

/// Reads the map whose YAML is at `path`, named `name`.
pub fn read_nav2_map(path: &Path, name: &str) -> Result<Map> {
    let text = String::from_utf8(read_input(path)?)
        .map_err(|_| Error::input(path, "is not UTF-8 text"))?;
    let yaml: MapYaml = serde_saphyr::from_str(&text)
        .map_err(|e| Error::input(path, format!("is not a Nav2 map YAML: {e}")))?;
    let [x, y, yaw] = yaml.origin[..] else {
        return Err(Error::input(path, "origin must be [x, y, yaw]"));
    };
    if yaw.abs() > 1e-9 {
        return Err(Error::input(
            path,
            format!("origin is rotated by {yaw} rad; only axis-aligned maps are supported"),
        ));
    }
    if !(0.0..=1.0).contains(&yaml.free_thresh)
        || !(0.0..=1.0).contains(&yaml.occupied_thresh)
        || yaml.free_thresh >= yaml.occupied_thresh
    {
        return Err(Error::input(
            path,
            format!(
                "free_thresh {} and occupied_thresh {} must lie in [0, 1], free below occupied",
                yaml.free_thresh, yaml.occupied_thresh
            ),
        ));
    }
    let image_path = path.parent().unwrap_or(Path::new(".")).join(&yaml.image);
    let picture = ImageReader::open(&image_path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| Error::input(&image_path, format!("cannot be opened: {e}")))?
        .decode()
        .map_err(|e| Error::input(&image_path, format!("is not a readable image: {e}")))?
        .to_luma_alpha8();
    let (width, height) = picture.dimensions();
    let geo = GeoRef {
        width,
        height,
        resolution: yaml.resolution,
        resolution_y: None,
        origin: [x, y],
        frame: "map".into(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    };
    geo.validate().map_err(|e| Error::input(path, e))?;
    let (free, occupied) = (yaml.free_thresh, yaml.occupied_thresh);
    let occupancy = |shade: u8, alpha: u8| -> f32 {
        let shade = f64::from(shade);
        let p = if yaml.negate != 0 {
            shade / 255.0
        } else {
            (255.0 - shade) / 255.0
        };
        match yaml.mode.as_str() {
            "raw" if shade <= 100.0 => shade as f32,
            "raw" => f32::NAN,
            _ if p > occupied => 100.0,
            _ if p < free => 0.0,
            "scale" if alpha == 255 => (99.0 * (p - free) / (occupied - free)).round() as f32,
            _ => f32::NAN,
        }
    };
    if !matches!(yaml.mode.as_str(), "trinary" | "scale" | "raw") {
        return Err(Error::input(
            path,
            format!("mode '{}' is not trinary, scale or raw", yaml.mode),
        ));
    }
    let mut values = vec![0f32; geo.cell_count()];
    for (col, image_row, pixel) in picture.enumerate_pixels() {
        let row = height - 1 - image_row;
        values[(row * width + col) as usize] = occupancy(pixel[0], pixel[1]);
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("occupancy", values)],
    })
}

/// Writes `occupancy` (0–100 per cell of `geo`, row 0 at the origin) as `<stem>.yaml`
/// and `<stem>.pgm` beside it, to be read back in `scale` mode.
pub fn write_nav2_map(yaml_path: &Path, geo: &GeoRef, occupancy: &[i8]) -> Result<()> {
    let [x, y] = geo.origin;
    let pgm_path = yaml_path.with_extension("pgm");
    let (width, height) = (geo.width, geo.height);
    let mut shades = Vec::with_capacity(occupancy.len());
    for image_row in 0..height {
        let row = height - 1 - image_row;
        for col in 0..width {
            let value = f64::from(occupancy[(row * width + col) as usize].clamp(0, 100));
            shades.push((255.0 * (1.0 - value / 100.0)).round() as u8);
        }
    }
    write_atomic(&pgm_path, |out| {
        image::codecs::pnm::PnmEncoder::new(out)
            .with_subtype(image::codecs::pnm::PnmSubtype::Graymap(
                image::codecs::pnm::SampleEncoding::Binary,
            ))
            .write_image(&shades, width, height, image::ExtendedColorType::L8)
            .map_err(|e| Error::Failed(format!("writing {}: {e}", pgm_path.display())))
    })?;
    let (free, occupied) = WRITTEN_THRESHOLDS;
    let yaml = format!(
        "image: {}\nmode: scale\nresolution: {}\norigin: [{x}, {y}, 0.0]\nnegate: 0\n\
         occupied_thresh: {occupied}\nfree_thresh: {free}\n",
        pgm_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        geo.resolution
    );
    write_bytes_atomic(yaml_path, yaml.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_maps_read_back_and_map_server_modes_are_followed() {
        let dir = tempfile::tempdir().unwrap();
        let geo = GeoRef {
            origin: [-3.0, 2.5],
            resolution: 0.05,
            ..GeoRef::unit(4, 3)
        };
        let occupancy: Vec<i8> = vec![0, 10, 50, 100, 20, 30, 40, 60, 70, 80, 90, 99];
        let yaml = dir.path().join("floor.yaml");
        write_nav2_map(&yaml, &geo, &occupancy).unwrap();
        let map = read_nav2_map(&yaml, "floor").unwrap();
        assert_eq!((map.geo.width, map.geo.height), (4, 3));
        assert_eq!(map.geo.origin, [-3.0, 2.5]);
        // Each value back within the PGM's 1/255 steps; row 0 (south) first.
        for (got, want) in map.layers[0].values.iter().zip(&occupancy) {
            assert!((got - f32::from(*want)).abs() <= 1.0, "{got} vs {want}");
        }
        // The same image read in trinary mode: free, occupied or unknown.
        let text = std::fs::read_to_string(&yaml)
            .unwrap()
            .replace("mode: scale", "mode: trinary")
            .replace("occupied_thresh: 0.99", "occupied_thresh: 0.65")
            .replace("free_thresh: 0.01", "free_thresh: 0.25");
        std::fs::write(&yaml, text).unwrap();
        let map = read_nav2_map(&yaml, "floor").unwrap();
        let v = &map.layers[0].values;
        assert_eq!((v[0], v[1], v[3]), (0.0, 0.0, 100.0));
        assert!(v[2].is_nan(), "50 % is unknown in trinary mode");
        std::fs::write(
            &yaml,
            "image: floor.pgm\nresolution: 0.05\norigin: [0, 0, 0.3]\n",
        )
        .unwrap();
        let err = read_nav2_map(&yaml, "floor").unwrap_err().to_string();
        assert!(err.contains("rotated"), "{err}");
    }
}
