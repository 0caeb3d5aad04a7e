//! `imitate testdata world`: writes a synthetic world (maps, demonstrations, true costs).

use std::path::PathBuf;

use clap::Subcommand;

use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::mcap::frames::Planar;
use crate::io::mcap::writer::{DemonstrationLog, write_demonstration_log};
use crate::io::tables::{write_costmap, write_demonstrations, write_map};
use crate::sim::{WorldConfig, generate_world};

#[derive(Debug, Subcommand)]
pub enum TestdataCommand {
    /// A terrain world with a hidden true cost and teacher demonstrations.
    World {
        /// Folder to write: maps/, demonstrations.parquet, logs/ (the same as MCAP),
        /// truth/, world.json.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        #[arg(long, default_value_t = WorldConfig::default().seed)]
        seed: u64,
        #[arg(long, default_value_t = WorldConfig::default().maps)]
        maps: usize,
        #[arg(long, default_value_t = WorldConfig::default().width)]
        width: u32,
        #[arg(long, default_value_t = WorldConfig::default().height)]
        height: u32,
        /// Metres per cell.
        #[arg(long, default_value_t = WorldConfig::default().resolution)]
        resolution: f64,
        #[arg(long, default_value_t = WorldConfig::default().demonstrations_per_map)]
        demonstrations_per_map: usize,
        /// Record a pose every this many cells of the teacher's path.
        #[arg(long, default_value_t = WorldConfig::default().pose_every)]
        pose_every: usize,
    },
}

pub fn run(command: TestdataCommand) -> Result<()> {
    let TestdataCommand::World {
        out,
        seed,
        maps,
        width,
        height,
        resolution,
        demonstrations_per_map,
        pose_every,
    } = command;
    let config = WorldConfig {
        seed,
        maps,
        width,
        height,
        resolution,
        demonstrations_per_map,
        pose_every,
    };
    if !(resolution.is_finite() && resolution > 0.0) {
        return Err(Error::Usage(
            "--resolution must be a positive number".into(),
        ));
    }
    let world = generate_world(&config).map_err(Error::Usage)?;
    for (map, truth) in world.maps.iter().zip(&world.truth) {
        write_map(&out.join(format!("maps/{}.parquet", map.name)), map)?;
        write_costmap(
            &out.join(format!("truth/{}.parquet", map.name)),
            &map.name,
            truth,
        )?;
    }
    write_demonstrations(&out.join("demonstrations.parquet"), &world.demonstrations)?;
    // The same world as robot logs: one per map, odometry in its own frame with a
    // /tf_static to the map, a goal message starting each episode.
    let layout = DemonstrationLog {
        start_ns: 1_700_000_000_000_000_000,
        gap_ns: 5_000_000_000,
        odom_frame: "odom".into(),
        map_to_odom: Planar {
            x: 3.0,
            y: -2.0,
            yaw: 0.25,
        },
    };
    for map in &world.maps {
        let demos: Vec<_> = world
            .demonstrations
            .iter()
            .filter(|d| d.map == map.name)
            .collect();
        write_demonstration_log(
            &out.join(format!("logs/{}.mcap", map.name)),
            map,
            &demos,
            &layout,
        )?;
    }
    let description = serde_json::json!({
        "generator": format!("imitate {} testdata world", env!("CARGO_PKG_VERSION")),
        "config": config,
        "true_cost": {
            "form": "exp(offset + sum(weight * layer))",
            "offset": world.true_cost.offset,
            "weights": world.true_cost.weights.iter().cloned().collect::<std::collections::BTreeMap<_, _>>(),
        },
    });
    write_bytes_atomic(&out.join("world.json"), &to_json_bytes(&description))?;
    eprintln!(
        "testdata: {} maps of {}x{} cells, {} demonstrations in {}",
        world.maps.len(),
        width,
        height,
        world.demonstrations.len(),
        out.display()
    );
    Ok(())
}
