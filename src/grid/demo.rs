//! Demonstrations: what an expert did, as ordered poses in a map's frame.

/// A timed pose in the map frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub yaw: Option<f64>,
}

/// One episode: an expert driving from its first pose (start) to its last (goal) on a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Demonstration {
    pub episode: String,
    pub map: String,
    pub poses: Vec<Pose>,
}

impl Demonstration {
    pub fn xy(&self) -> Vec<(f64, f64)> {
        self.poses.iter().map(|p| (p.x, p.y)).collect()
    }
}
