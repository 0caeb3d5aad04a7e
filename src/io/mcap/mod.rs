//! MCAP logs (ROS 2, Foxglove): streaming reader, schema-driven decoders (ROS 2 CDR,
//! JSON, protobuf), inspection and a writer for the logs the tool produces itself.

pub mod cdr;
pub mod decode;
pub mod episodes;
pub mod foxglove;
pub mod frames;
pub mod inspect;
pub mod reader;
pub mod ros2;
pub mod ros2idl;
pub mod ros2msg;
pub mod value;
pub mod writer;

pub use decode::{Decoders, MessageDecoder};
pub use reader::{ChannelInfo, Event, scan};
pub use value::Value;
