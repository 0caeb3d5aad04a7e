//! Planners on in-memory costmaps. They never touch files.

mod dijkstra;

pub use dijkstra::{Route, edge_cost, path_cost, shortest_path};
