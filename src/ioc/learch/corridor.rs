//! Demonstrations as their demonstrators meant them: a recorded track wanders around
//! the route the robot was driven along (GNSS and odometry noise, a driver's
//! weaving), and LEARCH, asked to make every wobble optimal, learns the dear ground it
//! brushes as cheap. Each round instead takes the cheapest path under the current cost
//! through a corridor of cells around the track (Silver, Bagnell and Stentz, "Learning
//! from demonstration for autonomous navigation in complex unstructured terrain",
//! IJRR 2010: the example replaced by the best path within a corridor around it).
//! Cells of the corridor off the track cost [`OFF_TRACK_PREMIUM`] more: the path
//! leaves the track where the cost learned so far finds it clearly dear, not for a
//! small saving the early rounds' cost, still wrong, may offer.

use serde::{Deserialize, Serialize};

use super::super::ExampleEvaluation;
use super::GridMethod;
use crate::grid::{Cell, CellPath, GeoRef, Grid};
use crate::plan::{Moves, dijkstra};

/// The corridor a run asks for: a width in cells (0: the demonstrations as they are),
/// or `auto`, chosen from how the demonstrations fit ([`choose_corridor`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corridor {
    Auto,
    Cells(u32),
}

impl std::str::FromStr for Corridor {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "auto" => Ok(Corridor::Auto),
            _ => text
                .parse()
                .map(Corridor::Cells)
                .map_err(|_| format!("'{text}' is neither 'auto' nor a number of cells")),
        }
    }
}

impl std::fmt::Display for Corridor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Corridor::Auto => f.write_str("auto"),
            Corridor::Cells(cells) => write!(f, "{cells}"),
        }
    }
}

/// In YAML and JSON as the command line has it: `auto` or a number.
impl Serialize for Corridor {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            Corridor::Auto => serializer.serialize_str("auto"),
            Corridor::Cells(cells) => serializer.serialize_u32(*cells),
        }
    }
}

impl<'de> Deserialize<'de> for Corridor {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Given {
            Cells(u32),
            Word(String),
        }
        match Given::deserialize(deserializer)? {
            Given::Cells(cells) => Ok(Corridor::Cells(cells)),
            Given::Word(word) => word.parse().map_err(serde::de::Error::custom),
        }
    }
}

/// How much more a corridor's cells off the track cost than the learned cost says,
/// as a share. In a hard corridor (0) near-equal paths beside the track, on a cost
/// still wrong in the early rounds, take the demonstration's place as readily as the
/// track; a small premium settles them for the track and leaves it only where the
/// detour is clearly dear. On 21 runs with tracks wandering by half a cell (13 real
/// rasters) a corridor of 1 cell planned at 1.086 hard, 1.054 at 0.05, 1.058 at 0.1,
/// 1.072 at 0.15 and 1.095 at 0.25; at a cell's wander (10 runs) 1.228 hard, 1.235 at
/// 0.05 and 1.261 at 0.1. BENCHMARKS.md, "A corridor that prefers the track".
pub const OFF_TRACK_PREMIUM: f32 = 0.05;

/// The corridor `auto` retrains with when the demonstrations wander. Two cells, priced
/// by their distance from the track, gain at a cell's wander (1.235 -> 1.202) and lose
/// at half a cell's (1.062 -> 1.069), which `auto` cannot tell apart. BENCHMARKS.md,
/// "A corridor of 2 cells priced by its distance from the track: not kept".
pub const AUTO_CORRIDOR_CELLS: u32 = 1;

/// `auto` retrains with a corridor when fewer than this share of the training plans,
/// on the cost learned from the demonstrations as they are, are as long (in cells) as
/// their demonstrations. A learner fits exact tracks so that most plans retrace them
/// (0.38–1.00 of them in 52 runs on 18 real rasters, 0.36–1.00 in 168 teacher-bench
/// pairs: two at 16 of 45 on a Web Mercator image, where a corridor cost 1.026 -> 1.076
/// and 1.049 -> 1.061); a track that wanders by half a cell or more holds detours no cost
/// makes optimal, and plans shorten most of them (0.00–0.49 in 41 runs, 36 below this,
/// none between 0.34 and 0.40). Low on purpose: a corridor costs an exact track more
/// than a missed one gains. BENCHMARKS.md, "Choosing the corridor" and "Five rasters
/// from localtileserver's wheel".
pub const AUTO_CORRIDOR_BELOW: f64 = 0.35;

/// What a run used as its corridor and why (`corridor` in metrics.json).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CorridorChoice {
    /// What the parameters asked for.
    pub requested: Corridor,
    /// The corridor the kept model was trained with, in cells.
    pub cells: u32,
    /// `auto`: the share of training plans as long as their demonstrations on the
    /// cost learned without a corridor, and the share below which it retrains.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plans_as_long: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub retrains_below: Option<f64>,
}

/// The share of `evaluations` whose plan has at least as many cells as the
/// demonstration (0 for none).
pub fn plans_as_long(evaluations: &[ExampleEvaluation]) -> f64 {
    let long = evaluations
        .iter()
        .filter(|e| e.planned_cells >= e.demonstrated_cells)
        .count();
    long as f64 / evaluations.len().max(1) as f64
}

/// Trains as `requested` asks: `train(cells)` trains with a corridor of that many
/// cells. `auto` trains without one and, where the model's plans on the training
/// examples (`training_plans`) shorten most demonstrations, trains again with
/// [`AUTO_CORRIDOR_CELLS`] and keeps that model; a method that takes no corridor
/// (MaxEnt, whose visitation already spreads over the paths near a track) trains once.
pub fn choose_corridor<T, E>(
    requested: Corridor,
    method: GridMethod,
    mut train: impl FnMut(u32) -> Result<T, E>,
    training_plans: impl Fn(&T) -> &[ExampleEvaluation],
) -> Result<(T, CorridorChoice), E> {
    let cells = match requested {
        Corridor::Cells(cells) => cells,
        Corridor::Auto => 0,
    };
    let trained = train(cells)?;
    let mut choice = CorridorChoice {
        requested,
        cells,
        plans_as_long: None,
        retrains_below: None,
    };
    if requested != Corridor::Auto || method == GridMethod::Maxent {
        return Ok((trained, choice));
    }
    let share = plans_as_long(training_plans(&trained));
    choice.plans_as_long = Some(share);
    choice.retrains_below = Some(AUTO_CORRIDOR_BELOW);
    if share >= AUTO_CORRIDOR_BELOW {
        return Ok((trained, choice));
    }
    choice.cells = AUTO_CORRIDOR_CELLS;
    Ok((train(AUTO_CORRIDOR_CELLS)?, choice))
}

/// The cheapest path under `costs` between the ends of `track` through the cells
/// within `radius` cells of one of its cells (round on the grid: a cell whose offset
/// (dr, dc) from a track cell has dr² + dc² ≤ (radius + ½)²), those off the track
/// priced [`OFF_TRACK_PREMIUM`] dearer. `None` when `radius` is 0 or no such path
/// exists (the track crosses blocked cells only).
pub(super) fn corridor_path(costs: &Grid<f32>, track: &[Cell], radius: u32) -> Option<CellPath> {
    corridor_path_priced(costs, track, radius, OFF_TRACK_PREMIUM)
}

/// [`corridor_path`] with the cells off the track priced `premium` dearer.
fn corridor_path_priced(
    costs: &Grid<f32>,
    track: &[Cell],
    radius: u32,
    premium: f32,
) -> Option<CellPath> {
    let (first, last) = (track.first()?, track.last()?);
    if radius == 0 {
        return None;
    }
    let geo = &costs.geo;
    let r = radius as i64;
    let (mut r0, mut r1, mut c0, mut c1) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
    for cell in track {
        let (row, col) = (i64::from(cell.row), i64::from(cell.col));
        (r0, r1, c0, c1) = (r0.min(row), r1.max(row), c0.min(col), c1.max(col));
    }
    let (r0, c0) = ((r0 - r).max(0), (c0 - r).max(0));
    let r1 = (r1 + r).min(i64::from(geo.height) - 1);
    let c1 = (c1 + r).min(i64::from(geo.width) - 1);
    let (w, h) = ((c1 - c0 + 1) as usize, (r1 - r0 + 1) as usize);
    let mut values = vec![f32::INFINITY; w * h];
    let reach = (radius as f64 + 0.5).powi(2);
    let local_index = |row: i64, col: i64| (row - r0) as usize * w + (col - c0) as usize;
    for cell in track {
        let (row, col) = (i64::from(cell.row), i64::from(cell.col));
        for dr in -r..=r {
            for dc in -r..=r {
                let (rr, cc) = (row + dr, col + dc);
                if ((dr * dr + dc * dc) as f64) > reach || rr < r0 || rr > r1 || cc < c0 || cc > c1
                {
                    continue;
                }
                let off_track = costs.get(Cell::new(rr as u32, cc as u32)) * (1.0 + premium);
                values[local_index(rr, cc)] = off_track;
            }
        }
    }
    for cell in track {
        values[local_index(i64::from(cell.row), i64::from(cell.col))] = costs.get(*cell);
    }
    let [sx, sy] = geo.cell_size();
    let window = GeoRef {
        width: w as u32,
        height: h as u32,
        origin: [
            geo.origin[0] + c0 as f64 * sx,
            geo.origin[1] + r0 as f64 * sy,
        ],
        ..geo.clone()
    };
    let local = |cell: &Cell| Cell::new(cell.row - r0 as u32, cell.col - c0 as u32);
    let route = dijkstra(
        &Grid::from_vec(window, values),
        local(first),
        local(last),
        Moves::default(),
    )?;
    Some(
        route
            .cells
            .into_iter()
            .map(|cell| Cell::new(cell.row + r0 as u32, cell.col + c0 as u32))
            .collect(),
    )
}

/// A drawn route as its demonstrator meant it under `costs`: through its vertices
/// (`waypoints`, indices into `track`) in order, each stretch between two of them the
/// cheapest path through a corridor around their straight line, as wide as a quarter of
/// the stretch (at least `radius`, at least 1 cell). A person clicking a route puts its
/// vertices on it and draws straight lines between them that cut its bends: the
/// vertices are what the drawing says, and unlike a track's cells the line between
/// them earns no preference (on ten runs of five real rasters with a vertex every 20
/// cells, 1.124 against 1.176 with the track's 5 %; BENCHMARKS.md, "Routes drawn by
/// hand"). `None` where a stretch has no path.
pub(super) fn waypoint_path(
    costs: &Grid<f32>,
    track: &[Cell],
    waypoints: &[usize],
    radius: u32,
) -> Option<CellPath> {
    let mut path = vec![track[*waypoints.first()?]];
    for pair in waypoints.windows(2) {
        let stretch = &track[pair[0]..=pair[1]];
        let width = radius.max(stretch.len().div_ceil(4) as u32).max(1);
        let part = corridor_path_priced(costs, stretch, width, 0.0)?;
        path.extend(&part[1..]);
    }
    Some(path)
}

/// The indices in `path` of the cells of `vertices` (a drawn route's vertices, in order):
/// each the path's cell nearest it at or after the previous one's, the first and last
/// cells of the path included. Empty where the vertices are no sparser than one per
/// [`SPARSE_VERTEX_CELLS`] cells: a logged track, whose poses are the path.
pub fn waypoints_of(path: &[Cell], vertices: &[Cell]) -> Vec<usize> {
    if path.len() < 2 || vertices.len() < 2 {
        return Vec::new();
    }
    let spacing = (path.len() - 1) as f64 / (vertices.len() - 1) as f64;
    if spacing < SPARSE_VERTEX_CELLS {
        return Vec::new();
    }
    let mut indices = vec![0];
    for vertex in &vertices[1..vertices.len() - 1] {
        let from = *indices.last().expect("the first index");
        let nearest = (from..path.len())
            .min_by_key(|&i| (path[i].chebyshev(*vertex), i))
            .expect("a cell at or after the last");
        if nearest != from {
            indices.push(nearest);
        }
    }
    if *indices.last().expect("the first index") != path.len() - 1 {
        indices.push(path.len() - 1);
    }
    indices
}

/// Vertices at least this many path cells apart on average are a drawn route's, not
/// a logged track's poses (a walker's 1 Hz GPS fix on 10 m cells is 0.14 cells apart).
pub const SPARSE_VERTEX_CELLS: f64 = 2.5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::path_cost;

    fn costs(width: u32, height: u32, cost: impl Fn(u32, u32) -> f32) -> Grid<f32> {
        let geo = GeoRef::square(width, height, 1.0, [0.0, 0.0], "map");
        let values = (0..height)
            .flat_map(|r| (0..width).map(move |c| (r, c)))
            .map(|(r, c)| cost(r, c))
            .collect();
        Grid::from_vec(geo, values)
    }

    #[test]
    fn a_wobbling_track_becomes_the_cheap_road_it_wobbles_around() {
        // A cheap road along row 5 of dear ground; the track weaves a cell to either
        // side of it every few columns.
        let grid = costs(41, 11, |r, _| if r == 5 { 1.0 } else { 5.0 });
        let track: Vec<Cell> = (0..41)
            .map(|c| Cell::new([5, 6, 5, 4][c as usize % 4], c))
            .collect();
        let road = corridor_path(&grid, &track, 1).unwrap();
        assert!(road.iter().all(|cell| cell.row == 5), "{road:?}");
        assert_eq!((road[0], road[road.len() - 1]), (track[0], track[40]));
        assert!(path_cost(&grid, &road) < path_cost(&grid, &track));
    }

    #[test]
    fn a_drawn_route_follows_the_cheap_road_between_its_vertices() {
        // A cheap road bending from row 2 up to row 12 and back; the route is drawn with
        // vertices on the road every 20 columns, its straight lines cutting the bends.
        let road = |c: u32| 2 + (10.0 * (std::f64::consts::PI * f64::from(c) / 40.0).sin()) as u32;
        let grid = costs(41, 15, |r, c| if r == road(c) { 1.0 } else { 8.0 });
        let vertices: Vec<Cell> = (0..=40)
            .step_by(20)
            .map(|c| Cell::new(road(c), c))
            .collect();
        let centre = |cell: &Cell| (f64::from(cell.col) + 0.5, f64::from(cell.row) + 0.5);
        let xy: Vec<(f64, f64)> = vertices.iter().map(centre).collect();
        let drawn = crate::grid::rasterize(&grid.geo, &xy).unwrap();
        let waypoints = waypoints_of(&drawn, &vertices);
        assert_eq!(waypoints.len(), vertices.len());
        assert!(
            waypoints
                .iter()
                .zip(&vertices)
                .all(|(&i, v)| drawn[i] == *v)
        );
        let meant = waypoint_path(&grid, &drawn, &waypoints, 0).unwrap();
        assert!(
            meant.iter().all(|cell| cell.row == road(cell.col)),
            "{meant:?}"
        );
        let off_road = drawn.iter().filter(|cell| cell.row != road(cell.col));
        assert!(off_road.count() > 10, "{drawn:?}");
        // A logged track's poses are its path: no waypoints.
        assert!(waypoints_of(&drawn, &drawn).is_empty());
    }

    #[test]
    fn the_path_keeps_to_the_corridor() {
        // The road lies 3 rows off the track: a corridor of 1 cell cannot reach it, one
        // of 3 can.
        let grid = costs(30, 12, |r, _| if r == 8 { 1.0 } else { 5.0 });
        let track: Vec<Cell> = (0..30).map(|c| Cell::new(5, c)).collect();
        let near = corridor_path(&grid, &track, 1).unwrap();
        assert!(
            near.iter().all(|cell| (4..=6).contains(&cell.row)),
            "{near:?}"
        );
        let wide = corridor_path(&grid, &track, 3).unwrap();
        assert!(
            wide.iter().filter(|cell| cell.row == 8).count() >= 24,
            "{wide:?}"
        );
        assert!(wide.iter().all(|cell| (2..=8).contains(&cell.row)));
        assert_eq!(corridor_path(&grid, &track, 0), None);
    }

    #[test]
    fn the_path_leaves_the_track_only_for_a_saving_above_the_premium() {
        // Row 6 beside the track on row 5 is a little cheaper (less than the premium):
        // the track stands. Cheaper by more than the premium: the path takes it.
        let track: Vec<Cell> = (0..30).map(|c| Cell::new(5, c)).collect();
        let slightly = 1.0 - OFF_TRACK_PREMIUM / 2.0;
        let grid = costs(30, 12, |r, _| if r == 6 { slightly } else { 1.0 });
        assert_eq!(corridor_path(&grid, &track, 1).unwrap(), track);
        let clearly = 1.0 - 2.0 * OFF_TRACK_PREMIUM;
        let grid = costs(30, 12, |r, _| if r == 6 { clearly } else { 1.0 });
        let beside = corridor_path(&grid, &track, 1).unwrap();
        assert!(beside.iter().filter(|cell| cell.row == 6).count() >= 26);
    }

    #[test]
    fn the_corridor_reads_as_written_on_the_command_line_and_in_yaml() {
        assert_eq!("auto".parse::<Corridor>(), Ok(Corridor::Auto));
        assert_eq!("2".parse::<Corridor>(), Ok(Corridor::Cells(2)));
        assert!("wide".parse::<Corridor>().unwrap_err().contains("'wide'"));
        assert!("-1".parse::<Corridor>().is_err());
        for corridor in [Corridor::Auto, Corridor::Cells(0), Corridor::Cells(3)] {
            let json = serde_json::to_string(&corridor).unwrap();
            assert_eq!(serde_json::from_str::<Corridor>(&json).unwrap(), corridor);
            assert_eq!(corridor.to_string().parse::<Corridor>(), Ok(corridor));
        }
        assert_eq!(serde_json::to_string(&Corridor::Cells(1)).unwrap(), "1");
        assert_eq!(serde_json::to_string(&Corridor::Auto).unwrap(), "\"auto\"");
        assert!(serde_json::from_str::<Corridor>("\"narrow\"").is_err());
    }

    /// Plans of `planned` cells for demonstrations of 10 cells.
    fn plans(planned: &[usize]) -> Vec<ExampleEvaluation> {
        planned
            .iter()
            .map(|&planned_cells| ExampleEvaluation {
                example: "e".into(),
                map: "m".into(),
                planned_cells,
                demonstrated_cells: 10,
                within_radius: 1.0,
                reference_cost_ratio: None,
                planned: Vec::new(),
            })
            .collect()
    }

    /// `choose_corridor` with a trainer whose plans have `planned` cells without a
    /// corridor (and 10 with one): the corridors it trained with, and its choice.
    fn chosen(requested: Corridor, planned: &[usize]) -> (Vec<u32>, CorridorChoice) {
        let mut trained = Vec::new();
        let (kept, choice) = choose_corridor(
            requested,
            GridMethod::Learch,
            |cells| {
                trained.push(cells);
                Ok::<_, ()>(plans(if cells == 0 { planned } else { &[10] }))
            },
            |plans| plans,
        )
        .unwrap();
        assert_eq!(
            kept.len(),
            if choice.cells == 0 { planned.len() } else { 1 }
        );
        (trained, choice)
    }

    #[test]
    fn auto_retrains_with_a_corridor_where_plans_shorten_most_demonstrations() {
        // Two of ten plans as long as their demonstrations: the tracks wander.
        let (trained, choice) = chosen(Corridor::Auto, &[10, 11, 9, 9, 8, 9, 9, 8, 9, 9]);
        assert_eq!(trained, [0, AUTO_CORRIDOR_CELLS]);
        assert_eq!(choice.cells, AUTO_CORRIDOR_CELLS);
        assert_eq!(choice.plans_as_long, Some(0.2));
        assert_eq!(choice.retrains_below, Some(AUTO_CORRIDOR_BELOW));
        // Seven of ten: the demonstrations are fitted as they are.
        let (trained, choice) = chosen(Corridor::Auto, &[10, 10, 12, 10, 10, 9, 10, 9, 11, 9]);
        assert_eq!((trained, choice.cells), (vec![0], 0));
        assert_eq!(choice.plans_as_long, Some(0.7));
    }

    #[test]
    fn auto_keeps_exact_paths_at_the_lowest_share_measured_on_them() {
        // 16 of 45 plans as long: exact teacher paths on a Web Mercator image, where a
        // corridor cost 1.026 -> 1.076. 15 of 45: the highest share of wandering tracks
        // that retrained (BENCHMARKS.md, "Five rasters from localtileserver's wheel").
        let as_long_of_45 = |long: usize| [vec![10; long], vec![9; 45 - long]].concat();
        assert_eq!(chosen(Corridor::Auto, &as_long_of_45(16)).1.cells, 0);
        assert_eq!(
            chosen(Corridor::Auto, &as_long_of_45(15)).1.cells,
            AUTO_CORRIDOR_CELLS
        );
    }

    #[test]
    fn a_corridor_given_in_cells_trains_once_with_it() {
        for cells in [0, 2] {
            let (trained, choice) = chosen(Corridor::Cells(cells), &[9, 9, 9]);
            assert_eq!(trained, [cells]);
            assert_eq!(choice.cells, cells);
            assert_eq!((choice.plans_as_long, choice.retrains_below), (None, None));
        }
        assert_eq!(plans_as_long(&[]), 0.0);
    }

    #[test]
    fn a_corridor_at_the_map_edge_is_clipped() {
        let grid = costs(10, 3, |_, _| 1.0);
        let track: Vec<Cell> = (0..10).map(|c| Cell::new(0, c)).collect();
        let path = corridor_path(&grid, &track, 2).unwrap();
        assert_eq!(path.len(), 10);
        assert!(path.iter().all(|cell| cell.row < 3));
    }
}
