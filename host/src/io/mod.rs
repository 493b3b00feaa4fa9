//! Real data in and out: recorded logs and bags replayed through the controller (`replay`), real
//! sensors (`sensors`: the VLP-16), run recordings for Foxglove (`record`), CARMEN logs written
//! as ROS 2 bags (`export_bag`), and the one rule that turns a metric range into the wire's
//! millimetres for every source (`range`).

pub mod export_bag;
pub mod map_file;
pub mod range;
pub mod record;
pub mod replay;
pub mod sensors;
