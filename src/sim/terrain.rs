//! A seeded synthetic terrain world: maps with elevation, vegetation, water and road
//! layers, a hidden "true" cost of those layers, and a teacher whose demonstrations are
//! optimal paths under the true cost. LEARCH should recover a cost whose plans match.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::grid::{Cell, Demonstration, GeoRef, Grid, Layer, Map, Pose};
use crate::plan::shortest_path;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldConfig {
    pub seed: u64,
    pub maps: usize,
    pub width: u32,
    pub height: u32,
    /// Metres per cell.
    pub resolution: f64,
    pub demonstrations_per_map: usize,
    /// The teacher records a pose every this many cells of its path (plus the goal).
    pub pose_every: usize,
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            seed: 7,
            maps: 4,
            width: 64,
            height: 64,
            resolution: 1.0,
            demonstrations_per_map: 16,
            pose_every: 1,
        }
    }
}

/// The hidden cost: exp(offset + Σ weight · layer).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrueCost {
    pub offset: f64,
    pub weights: Vec<(String, f64)>,
}

impl Default for TrueCost {
    fn default() -> Self {
        TrueCost {
            offset: 0.0,
            weights: vec![
                ("elevation".into(), 0.02),
                ("vegetation".into(), 2.0),
                ("water".into(), 3.5),
                ("road".into(), -1.2),
            ],
        }
    }
}

impl TrueCost {
    pub fn costmap(&self, map: &Map) -> Grid<f32> {
        let mut log_cost = vec![self.offset; map.geo.cell_count()];
        for (name, w) in &self.weights {
            let layer = map.layer(name).expect("synthetic maps carry every layer");
            for (s, &v) in log_cost.iter_mut().zip(&layer.values) {
                *s += w * f64::from(v);
            }
        }
        Grid::from_vec(
            map.geo.clone(),
            log_cost.iter().map(|s| s.exp() as f32).collect(),
        )
    }
}

pub struct SyntheticWorld {
    pub maps: Vec<Map>,
    pub truth: Vec<Grid<f32>>,
    pub true_cost: TrueCost,
    pub demonstrations: Vec<Demonstration>,
}

pub fn generate_world(config: &WorldConfig) -> Result<SyntheticWorld, String> {
    if config.width < 16 || config.height < 16 {
        return Err("synthetic maps need at least 16x16 cells".into());
    }
    if config.pose_every == 0 {
        return Err("pose_every must be at least 1".into());
    }
    let true_cost = TrueCost::default();
    let mut world = SyntheticWorld {
        maps: Vec::new(),
        truth: Vec::new(),
        true_cost: true_cost.clone(),
        demonstrations: Vec::new(),
    };
    for m in 0..config.maps {
        // One RNG stream per map, so adding maps does not change the earlier ones.
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed.wrapping_mul(1_000_003) + m as u64);
        let map = terrain(&format!("terrain-{m:03}"), config, &mut rng);
        let truth = true_cost.costmap(&map);
        for d in 0..config.demonstrations_per_map {
            let episode = format!("{}-demo-{d:03}", map.name);
            world.demonstrations.push(teacher_demonstration(
                &episode, &map, &truth, config, &mut rng,
            )?);
        }
        world.maps.push(map);
        world.truth.push(truth);
    }
    Ok(world)
}

fn terrain(name: &str, config: &WorldConfig, rng: &mut ChaCha8Rng) -> Map {
    let (w, h) = (config.width as usize, config.height as usize);
    let geo = GeoRef::square(
        config.width,
        config.height,
        config.resolution,
        [0.0, 0.0],
        "map",
    );
    let height_field = fractal_noise(w, h, rng);
    let mut vegetation = fractal_noise(w, h, rng);
    let mut water: Vec<f32> = height_field.iter().map(|&e| f32::from(e < 0.3)).collect();
    let elevation: Vec<f32> = height_field.iter().map(|&e| 30.0 * e).collect();
    let mut road = vec![0.0f32; w * h];
    for _ in 0..2 {
        draw_road(&geo, &mut road, rng);
    }
    for i in 0..w * h {
        if road[i] > 0.0 {
            water[i] = 0.0; // bridges
        }
        if road[i] > 0.0 || water[i] > 0.0 {
            vegetation[i] = 0.0;
        }
    }
    let layer = |name: &str, values: Vec<f32>| Layer::new(name, values);
    Map {
        name: name.into(),
        geo,
        layers: vec![
            layer("elevation", elevation),
            layer("vegetation", vegetation),
            layer("water", water),
            layer("road", road),
        ],
    }
}

/// Value noise over three octaves, rescaled to [0, 1].
fn fractal_noise(w: usize, h: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    let mut out = vec![0.0f64; w * h];
    for (spacing, amplitude) in [(24.0, 1.0), (12.0, 0.5), (6.0, 0.25)] {
        let gw = (w as f64 / spacing).ceil() as usize + 2;
        let gh = (h as f64 / spacing).ceil() as usize + 2;
        let lattice: Vec<f64> = (0..gw * gh).map(|_| rng.random::<f64>()).collect();
        for r in 0..h {
            let fy = r as f64 / spacing;
            let (y0, ty) = (fy.floor() as usize, smooth(fy.fract()));
            for c in 0..w {
                let fx = c as f64 / spacing;
                let (x0, tx) = (fx.floor() as usize, smooth(fx.fract()));
                let at = |x: usize, y: usize| lattice[y * gw + x];
                let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
                let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
                out[r * w + c] += amplitude * (top * (1.0 - ty) + bottom * ty);
            }
        }
    }
    let lo = out.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = out.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    out.iter()
        .map(|v| ((v - lo) / (hi - lo).max(1e-12)) as f32)
        .collect()
}

fn smooth(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// A two-cell-wide road through random waypoints from one map edge to the opposite one.
fn draw_road(geo: &GeoRef, road: &mut [f32], rng: &mut ChaCha8Rng) {
    let (w, h) = (geo.width, geo.height);
    let horizontal = rng.random_bool(0.5);
    let waypoints: Vec<(f64, f64)> = (0..5)
        .map(|k| {
            let along = k as f64 / 4.0;
            let across = rng.random_range(0.15..0.85);
            let (fx, fy) = if horizontal {
                (along, across)
            } else {
                (across, along)
            };
            (
                (fx * f64::from(w - 1) + 0.5) * geo.resolution,
                (fy * f64::from(h - 1) + 0.5) * geo.resolution,
            )
        })
        .collect();
    let cells = crate::grid::rasterize_polyline(geo, &waypoints).expect("waypoints lie on the map");
    for cell in cells {
        for (dr, dc) in [(0, 0), (0, 1), (1, 0)] {
            let (r, c) = (cell.row + dr, cell.col + dc);
            if r < h && c < w {
                road[(r * w + c) as usize] = 1.0;
            }
        }
    }
}

fn teacher_demonstration(
    episode: &str,
    map: &Map,
    truth: &Grid<f32>,
    config: &WorldConfig,
    rng: &mut ChaCha8Rng,
) -> Result<Demonstration, String> {
    let geo = &map.geo;
    let water = &map
        .layer("water")
        .expect("synthetic maps have water")
        .values;
    let min_separation = 0.5 * f64::from(geo.width.min(geo.height));
    let random_dry_cell = |rng: &mut ChaCha8Rng| loop {
        let cell = Cell::new(
            rng.random_range(0..geo.height),
            rng.random_range(0..geo.width),
        );
        if water[geo.index(cell)] == 0.0 {
            return cell;
        }
    };
    let (start, goal) = loop {
        let (a, b) = (random_dry_cell(rng), random_dry_cell(rng));
        if (a.distance_squared(b) as f64).sqrt() >= min_separation {
            break (a, b);
        }
    };
    let route = shortest_path(truth, start, goal)
        .ok_or_else(|| format!("{episode}: the teacher found no path"))?;
    let mut picked: Vec<usize> = (0..route.cells.len()).step_by(config.pose_every).collect();
    if picked.last() != Some(&(route.cells.len() - 1)) {
        picked.push(route.cells.len() - 1);
    }
    let mut poses = Vec::with_capacity(picked.len());
    let mut t = 0.0;
    for (k, &i) in picked.iter().enumerate() {
        let (cx, cy) = geo.center_of(route.cells[i]);
        // Jitter within the cell: real poses are not at cell centres.
        let jitter = 0.3 * geo.resolution;
        let x = cx + rng.random_range(-jitter..jitter);
        let y = cy + rng.random_range(-jitter..jitter);
        if let Some(prev) = poses.last() {
            let Pose { x: px, y: py, .. } = *prev;
            t += ((x - px).powi(2) + (y - py).powi(2)).sqrt(); // 1 m/s
        }
        let next = picked.get(k + 1).map(|&j| geo.center_of(route.cells[j]));
        let yaw = next.map_or_else(
            || poses.last().and_then(|p: &Pose| p.yaw),
            |(nx, ny)| Some((ny - cy).atan2(nx - cx)),
        );
        poses.push(Pose { t, x, y, yaw });
    }
    Ok(Demonstration {
        episode: episode.into(),
        map: map.name.clone(),
        poses,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worlds_are_reproducible_and_sensible() {
        let config = WorldConfig {
            maps: 1,
            width: 32,
            height: 32,
            demonstrations_per_map: 3,
            ..WorldConfig::default()
        };
        let a = generate_world(&config).unwrap();
        let b = generate_world(&config).unwrap();
        assert_eq!(a.maps, b.maps);
        assert_eq!(a.demonstrations, b.demonstrations);
        let map = &a.maps[0];
        assert_eq!(
            map.layer_names(),
            ["elevation", "vegetation", "water", "road"]
        );
        assert!(map.layer("road").unwrap().values.iter().any(|&v| v > 0.0));
        for demo in &a.demonstrations {
            let path = crate::grid::rasterize(&map.geo, &demo.xy()).unwrap();
            assert!(path.len() >= 16);
            assert!(demo.poses.windows(2).all(|p| p[0].t < p[1].t));
        }
    }
}
