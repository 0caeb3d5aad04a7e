//! Planar frame transforms from `/tf` and `/tf_static`: each child frame's pose in its
//! parent over time, looked up at any time by linear interpolation (shortest-way yaw),
//! chained through the tree to relate any two connected frames.

use std::collections::HashMap;

use super::ros2::FrameTransform;

/// A rigid planar transform: rotate by `yaw`, then translate by (x, y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planar {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

impl Planar {
    pub const IDENTITY: Planar = Planar {
        x: 0.0,
        y: 0.0,
        yaw: 0.0,
    };

    /// `self ∘ other`: apply `other` first.
    pub fn then_in(&self, other: &Planar) -> Planar {
        let (s, c) = self.yaw.sin_cos();
        Planar {
            x: self.x + c * other.x - s * other.y,
            y: self.y + s * other.x + c * other.y,
            yaw: wrap(self.yaw + other.yaw),
        }
    }

    pub fn inverse(&self) -> Planar {
        let (s, c) = self.yaw.sin_cos();
        Planar {
            x: -(c * self.x + s * self.y),
            y: s * self.x - c * self.y,
            yaw: wrap(-self.yaw),
        }
    }
}

fn wrap(angle: f64) -> f64 {
    let wrapped = (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
    wrapped - std::f64::consts::PI
}

struct Edge {
    parent: String,
    /// Time-sorted samples; one sample for static transforms.
    samples: Vec<(u64, Planar)>,
    is_static: bool,
}

/// Every transform of a log, by child frame.
#[derive(Default)]
pub struct FrameTree {
    edges: HashMap<String, Edge>,
}

impl FrameTree {
    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }

    pub fn add(&mut self, transform: FrameTransform, is_static: bool) -> Result<(), String> {
        let edge = self
            .edges
            .entry(transform.child.clone())
            .or_insert_with(|| Edge {
                parent: transform.parent.clone(),
                samples: Vec::new(),
                is_static,
            });
        if edge.parent != transform.parent {
            return Err(format!(
                "frame '{}' has two parents, '{}' and '{}'",
                transform.child, edge.parent, transform.parent
            ));
        }
        let planar = Planar {
            x: transform.x,
            y: transform.y,
            yaw: transform.yaw,
        };
        if is_static {
            edge.samples = vec![(transform.time, planar)];
            edge.is_static = true;
        } else {
            edge.samples.push((transform.time, planar));
        }
        Ok(())
    }

    /// Sorts samples by time; call once after the last `add`.
    pub fn finish(&mut self) {
        for edge in self.edges.values_mut() {
            edge.samples.sort_by_key(|s| s.0);
        }
    }

    /// `frame`'s pose in its root frame at `time`, and that root's name.
    fn to_root(&self, frame: &str, time: u64, tolerance: u64) -> Result<(Planar, String), String> {
        let mut pose = Planar::IDENTITY;
        let mut current = frame.to_string();
        let mut hops = 0;
        while let Some(edge) = self.edges.get(&current) {
            let step = if edge.is_static {
                edge.samples[0].1
            } else {
                interpolate(&edge.samples, time, tolerance)
                    .map_err(|e| format!("transform {} -> {}: {e}", edge.parent, current))?
            };
            pose = step.then_in(&pose);
            current = edge.parent.clone();
            hops += 1;
            if hops > self.edges.len() {
                return Err(format!("the /tf frames around '{frame}' form a cycle"));
            }
        }
        Ok((pose, current))
    }

    /// The transform taking coordinates in `from` to coordinates in `to` at `time`.
    pub fn lookup(
        &self,
        from: &str,
        to: &str,
        time: u64,
        tolerance: u64,
    ) -> Result<Planar, String> {
        let (from_root, root_a) = self.to_root(from, time, tolerance)?;
        let (to_root, root_b) = self.to_root(to, time, tolerance)?;
        if root_a != root_b {
            return Err(format!(
                "no /tf or /tf_static transforms connect frame '{from}' (tree of '{root_a}') \
                 to frame '{to}' (tree of '{root_b}')"
            ));
        }
        Ok(to_root.inverse().then_in(&from_root))
    }
}

fn interpolate(samples: &[(u64, Planar)], time: u64, tolerance: u64) -> Result<Planar, String> {
    let after = samples.partition_point(|s| s.0 < time);
    let seconds = |ns: u64| ns as f64 * 1e-9;
    if after == samples.len() {
        let (last, pose) = samples[samples.len() - 1];
        return if time - last <= tolerance {
            Ok(pose)
        } else {
            Err(format!(
                "needed at {:.3} s, the last is at {:.3} s",
                seconds(time),
                seconds(last)
            ))
        };
    }
    let (t1, p1) = samples[after];
    if after == 0 {
        return if t1 - time <= tolerance {
            Ok(p1)
        } else {
            Err(format!(
                "needed at {:.3} s, the first is at {:.3} s",
                seconds(time),
                seconds(t1)
            ))
        };
    }
    let (t0, p0) = samples[after - 1];
    let w = if t1 == t0 {
        1.0
    } else {
        (time - t0) as f64 / (t1 - t0) as f64
    };
    Ok(Planar {
        x: p0.x + w * (p1.x - p0.x),
        y: p0.y + w * (p1.y - p0.y),
        yaw: wrap(p0.yaw + w * wrap(p1.yaw - p0.yaw)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(time: u64, parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> FrameTransform {
        FrameTransform {
            time,
            parent: parent.into(),
            child: child.into(),
            x,
            y,
            yaw,
        }
    }

    #[test]
    fn chains_static_and_interpolated_transforms() {
        let mut tree = FrameTree::default();
        // map -> odom static: odom is map shifted by (10, 0) and turned a quarter.
        tree.add(
            tf(0, "map", "odom", 10.0, 0.0, std::f64::consts::FRAC_PI_2),
            true,
        )
        .unwrap();
        tree.add(tf(0, "odom", "base", 0.0, 0.0, 0.0), false)
            .unwrap();
        tree.add(tf(2_000, "odom", "base", 2.0, 0.0, 0.0), false)
            .unwrap();
        tree.finish();
        // base at t=1000 is at (1, 0) in odom, which is (10, 1) in map.
        let t = tree.lookup("base", "map", 1_000, 0).unwrap();
        assert!(
            (t.x - 10.0).abs() < 1e-12 && (t.y - 1.0).abs() < 1e-12,
            "{t:?}"
        );
        // And the other way round.
        let back = tree.lookup("map", "base", 1_000, 0).unwrap();
        let id = back.then_in(&t);
        assert!(id.x.abs() < 1e-12 && id.y.abs() < 1e-12 && id.yaw.abs() < 1e-12);
        // Outside the samples beyond the tolerance: an error naming the edge.
        let err = tree.lookup("base", "map", 5_000, 100).unwrap_err();
        assert!(err.contains("odom -> base"), "{err}");
        let err = tree.lookup("base", "elsewhere", 1_000, 0).unwrap_err();
        assert!(err.contains("elsewhere"), "{err}");
    }

    #[test]
    fn yaw_interpolates_the_short_way_round() {
        let samples = [
            (
                0,
                Planar {
                    x: 0.0,
                    y: 0.0,
                    yaw: 3.0,
                },
            ),
            (
                10,
                Planar {
                    x: 0.0,
                    y: 0.0,
                    yaw: -3.0,
                },
            ),
        ];
        let mid = interpolate(&samples, 5, 0).unwrap();
        assert!(
            (mid.yaw.abs() - std::f64::consts::PI).abs() < 1e-9,
            "{mid:?}"
        );
    }
}
