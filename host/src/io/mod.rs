//! Real data in and out: recorded logs and bags replayed through the controller (`replay`), real
//! sensors (`sensors`: the VLP-16), run recordings for Foxglove (`record`), CARMEN logs written
//! as ROS 2 bags (`export_bag`), prior maps (`map_file`) and classifier blobs (`model_file`).
//! The one rule that turns a metric range into the wire's millimetres for every source is the
//! run loop's (`crate::run::range`).

pub mod export_bag;
pub mod map_file;
pub mod model_file;
pub mod record;
pub mod replay;
pub mod sensors;
