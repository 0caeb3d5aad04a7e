//! `track`: the seed's lane-keeping circuit. A kinematic bicycle at a fixed speed on a
//! closed track, steered at 5 Hz with a command in [−1, 1] (times the largest steering
//! angle) and a little actuation noise. Leaving the lane (|lateral offset| > half the
//! width) is a fall: the car is put back on the centre line, facing along it, and drives
//! on. The teacher is pure pursuit of a point on the centre line a fixed distance ahead.
//!
//! The learner sees the lateral offset, the heading error and the centre line's
//! curvature at three distances ahead; the teacher sees the track itself.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Centre-line samples per metre.
const SAMPLES_PER_METRE: f64 = 2.0;
/// Integration steps per control step.
const SUBSTEPS: usize = 8;
/// Curvature preview distances (metres ahead along the centre line).
pub const PREVIEW: [f64; 3] = [3.0, 8.0, 15.0];
/// What the learner observes, in this order.
pub const OBSERVATION_NAMES: [&str; 5] = [
    "lateral_offset",
    "heading_error",
    "curvature_3m",
    "curvature_8m",
    "curvature_15m",
];

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackConfig {
    /// Mean radius of the circuit (m).
    pub radius: f64,
    pub speed: f64,
    /// Control period (s): 5 Hz.
    pub period: f64,
    pub wheelbase: f64,
    /// Steering angle at command 1 (rad).
    pub max_steer: f64,
    pub half_width: f64,
    /// Standard deviation of the noise added to the executed command.
    pub actuation_noise: f64,
    /// The teacher's pure-pursuit look-ahead (m).
    pub lookahead: f64,
}

impl Default for TrackConfig {
    fn default() -> Self {
        TrackConfig {
            radius: 40.0,
            speed: 10.0,
            period: 0.2,
            wheelbase: 2.7,
            max_steer: 0.5,
            half_width: 2.0,
            actuation_noise: 0.05,
            lookahead: 8.0,
        }
    }
}

/// The centre line, sampled evenly by arc length.
pub struct Track {
    pub config: TrackConfig,
    xs: Vec<f64>,
    ys: Vec<f64>,
    headings: Vec<f64>,
    curvatures: Vec<f64>,
    spacing: f64,
}

fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    a - two_pi * ((a + std::f64::consts::PI) / two_pi).floor()
}

impl Track {
    /// A closed circuit r(θ) = R (1 + 0.25 cos 2θ + 0.08 sin 3θ): two long bends, two
    /// tight ones and an S, so the steering the teacher needs varies along a lap.
    pub fn new(config: TrackConfig) -> Self {
        let dense = 20_000;
        let point = |t: f64| {
            let r = config.radius * (1.0 + 0.25 * (2.0 * t).cos() + 0.08 * (3.0 * t).sin());
            (r * t.cos(), r * t.sin())
        };
        // Arc length along a dense polygon, then even resampling.
        let mut lengths = vec![0.0];
        let mut previous = point(0.0);
        for k in 1..=dense {
            let p = point(std::f64::consts::TAU * k as f64 / dense as f64);
            let step = ((p.0 - previous.0).powi(2) + (p.1 - previous.1).powi(2)).sqrt();
            lengths.push(lengths[k - 1] + step);
            previous = p;
        }
        let total = lengths[dense];
        let samples = (total * SAMPLES_PER_METRE).round() as usize;
        let spacing = total / samples as f64;
        let (mut xs, mut ys) = (Vec::with_capacity(samples), Vec::with_capacity(samples));
        let mut k = 0;
        for i in 0..samples {
            let s = i as f64 * spacing;
            while lengths[k + 1] < s {
                k += 1;
            }
            let f = (s - lengths[k]) / (lengths[k + 1] - lengths[k]);
            let t = std::f64::consts::TAU * (k as f64 + f) / dense as f64;
            let (x, y) = point(t);
            xs.push(x);
            ys.push(y);
        }
        let n = samples;
        let headings: Vec<f64> = (0..n)
            .map(|i| {
                let j = (i + 1) % n;
                let h = (i + n - 1) % n;
                (ys[j] - ys[h]).atan2(xs[j] - xs[h])
            })
            .collect();
        let curvatures = (0..n)
            .map(|i| {
                wrap_angle(headings[(i + 1) % n] - headings[(i + n - 1) % n]) / (2.0 * spacing)
            })
            .collect();
        Track {
            config,
            xs,
            ys,
            headings,
            curvatures,
            spacing,
        }
    }

    pub fn length(&self) -> f64 {
        self.xs.len() as f64 * self.spacing
    }

    /// Control steps that certainly cover `laps` laps: three times the nominal count.
    pub fn step_cap(&self, laps: f64) -> usize {
        let c = &self.config;
        (3.0 * laps * self.length() / (c.speed * c.period)).ceil() as usize
    }

    /// Falls per lap of a driver over `laps` laps from the start line, with the
    /// actuation noise drawn from `seed`. A driver that does not finish them within
    /// `step_cap` is charged a fall for every lap it misses.
    pub fn falls_per_lap(&self, laps: usize, seed: u64, drive: impl Fn(&TrackSim) -> f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut sim = TrackSim::new(self, 0.0);
        let cap = self.step_cap(laps as f64);
        let mut steps = 0;
        while sim.laps() < laps as f64 && steps < cap {
            let u = drive(&sim);
            sim.step(u, &mut rng);
            steps += 1;
        }
        let missing = (laps as f64 - sim.laps()).max(0.0).ceil();
        (sim.falls as f64 + missing) / laps.max(1) as f64
    }

    /// Falls per lap of a driver that also sees the step index (a non-stationary
    /// policy), over `laps` separate one-lap episodes from the start line, each counting
    /// steps from 0. An unfinished lap counts as a fall.
    pub fn lap_falls_per_lap(
        &self,
        laps: usize,
        seed: u64,
        drive: impl Fn(usize, &TrackSim) -> f64,
    ) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut total = 0.0;
        for _ in 0..laps {
            let mut sim = TrackSim::new(self, 0.0);
            let mut t = 0;
            while sim.laps() < 1.0 && t < self.step_cap(1.0) {
                let u = drive(t, &sim);
                sim.step(u, &mut rng);
                t += 1;
            }
            total += sim.falls as f64 + if sim.laps() < 1.0 { 1.0 } else { 0.0 };
        }
        total / laps.max(1) as f64
    }

    /// Control steps of one lap at the nominal speed: the horizon of forward training.
    pub fn lap_steps(&self) -> usize {
        let c = &self.config;
        (self.length() / (c.speed * c.period)).ceil() as usize
    }

    fn sample(&self, s: f64) -> usize {
        let n = self.xs.len();
        ((s / self.spacing).round() as i64).rem_euclid(n as i64) as usize
    }

    /// The sample nearest to (x, y), searching around the `hint` sample.
    fn nearest(&self, x: f64, y: f64, hint: usize) -> usize {
        let n = self.xs.len() as i64;
        let reach = (8.0 * SAMPLES_PER_METRE * self.config.speed * self.config.period) as i64;
        (-reach..=reach)
            .map(|d| (hint as i64 + d).rem_euclid(n) as usize)
            .min_by(|&a, &b| {
                let da = (self.xs[a] - x).powi(2) + (self.ys[a] - y).powi(2);
                let db = (self.xs[b] - x).powi(2) + (self.ys[b] - y).powi(2);
                da.total_cmp(&db).then(a.cmp(&b))
            })
            .expect("a non-empty search")
    }
}

/// The car on the track.
#[derive(Debug, Clone, Copy)]
pub struct CarState {
    x: f64,
    y: f64,
    heading: f64,
    /// The nearest centre-line sample.
    index: usize,
}

/// One simulated run: the car, the laps driven and the falls.
pub struct TrackSim<'a> {
    pub track: &'a Track,
    car: CarState,
    /// Arc length driven along the centre line (m).
    pub progress: f64,
    pub falls: usize,
}

impl<'a> TrackSim<'a> {
    /// The car on the centre line at `start` metres along it, facing along it.
    pub fn new(track: &'a Track, start: f64) -> Self {
        let index = track.sample(start);
        TrackSim {
            track,
            car: CarState {
                x: track.xs[index],
                y: track.ys[index],
                heading: track.headings[index],
                index,
            },
            progress: 0.0,
            falls: 0,
        }
    }

    pub fn laps(&self) -> f64 {
        self.progress / self.track.length()
    }

    /// Signed distance from the centre line (left positive) and heading error.
    fn errors(&self) -> (f64, f64) {
        let t = self.track;
        let i = self.car.index;
        let (dx, dy) = (self.car.x - t.xs[i], self.car.y - t.ys[i]);
        let h = t.headings[i];
        let lateral = -h.sin() * dx + h.cos() * dy;
        (lateral, wrap_angle(self.car.heading - h))
    }

    /// What the learner sees (`OBSERVATION_NAMES`).
    pub fn observation(&self) -> [f64; 5] {
        let (lateral, heading) = self.errors();
        let t = self.track;
        let here = self.car.index as f64 * t.spacing;
        let curvature = |ahead: f64| t.curvatures[t.sample(here + ahead)];
        [
            lateral,
            heading,
            curvature(PREVIEW[0]),
            curvature(PREVIEW[1]),
            curvature(PREVIEW[2]),
        ]
    }

    /// The teacher's command: pure pursuit of the centre-line point `lookahead` ahead.
    pub fn teacher(&self) -> f64 {
        let t = self.track;
        let c = &t.config;
        let target = t.sample(self.car.index as f64 * t.spacing + c.lookahead);
        let (dx, dy) = (t.xs[target] - self.car.x, t.ys[target] - self.car.y);
        let alpha = wrap_angle(dy.atan2(dx) - self.car.heading);
        let distance = (dx * dx + dy * dy).sqrt().max(1e-6);
        let steer = (2.0 * c.wheelbase * alpha.sin() / distance).atan();
        (steer / c.max_steer).clamp(-1.0, 1.0)
    }

    /// Executes `command` (clamped to [−1, 1], plus actuation noise) for one control
    /// period. Returns whether the car left the lane (and was put back).
    pub fn step(&mut self, command: f64, rng: &mut ChaCha8Rng) -> bool {
        let t = self.track;
        let c = &t.config;
        let executed =
            (command.clamp(-1.0, 1.0) + c.actuation_noise * gaussian(rng)).clamp(-1.0, 1.0);
        let steer = executed * c.max_steer;
        let dt = c.period / SUBSTEPS as f64;
        for _ in 0..SUBSTEPS {
            self.car.x += c.speed * self.car.heading.cos() * dt;
            self.car.y += c.speed * self.car.heading.sin() * dt;
            self.car.heading += c.speed / c.wheelbase * steer.tan() * dt;
        }
        let before = self.car.index;
        self.car.index = t.nearest(self.car.x, self.car.y, before);
        let n = t.xs.len() as i64;
        let moved = (self.car.index as i64 - before as i64 + n / 2).rem_euclid(n) - n / 2;
        self.progress += moved as f64 * t.spacing;
        let (lateral, _) = self.errors();
        if lateral.abs() > c.half_width {
            self.falls += 1;
            let i = self.car.index;
            self.car = CarState {
                x: t.xs[i],
                y: t.ys[i],
                heading: t.headings[i],
                index: i,
            };
            return true;
        }
        false
    }
}

/// A standard normal draw (Box–Muller), from the seeded generator.
pub fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_track_closes_and_its_curvature_turns_once_around() {
        let track = Track::new(TrackConfig::default());
        let total_turn: f64 = track.curvatures.iter().sum::<f64>() * track.spacing;
        assert!(
            (total_turn - std::f64::consts::TAU).abs() < 1e-2,
            "{total_turn}"
        );
        let (first, last) = (0, track.xs.len() - 1);
        let gap = ((track.xs[first] - track.xs[last]).powi(2)
            + (track.ys[first] - track.ys[last]).powi(2))
        .sqrt();
        assert!((gap - track.spacing).abs() < 0.05 * track.spacing, "{gap}");
    }

    #[test]
    fn the_teacher_drives_laps_without_falling() {
        let track = Track::new(TrackConfig::default());
        let mut sim = TrackSim::new(&track, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        while sim.laps() < 3.0 {
            let u = sim.teacher();
            sim.step(u, &mut rng);
        }
        assert_eq!(sim.falls, 0);
        assert!(sim.observation()[0].abs() < 1.0);
    }

    #[test]
    fn driving_straight_falls_and_is_put_back_on_the_centre_line() {
        let track = Track::new(TrackConfig::default());
        let mut sim = TrackSim::new(&track, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut fell = false;
        for _ in 0..200 {
            fell |= sim.step(0.0, &mut rng);
        }
        assert!(fell && sim.falls > 0);
        assert!(sim.observation()[0].abs() <= track.config.half_width);
    }
}
