//! Reading and writing files: Parquet tables, PNG images, atomic writes.

pub mod demo_tables;
pub mod fs;
pub mod geotiff;
pub mod gpx;
pub mod leftovers;
pub mod mcap;
pub mod mdp_tables;
pub mod movingai;
pub mod nav2;
pub mod parquet_check;
pub mod png;
pub mod tables;
