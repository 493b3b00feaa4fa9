//! The configuration on the wire: [`ConfigMsg`], made from the parameter table
//! (`firmware/src/config/params.rs`) like [`Config`] itself, so the two cannot drift apart.
//!
//! Each field crosses in its type's wire form ([`ParamValue::Wire`]): metres and weights as
//! Q16.16 bits (`i32`), angles as binary-angle bits (`i32`), times in microseconds (`u64`), counts
//! and flags as they are, the planner as [`crate::config::PlannerKind`], the budgets as five `u32`s. The rows'
//! order is the wire order; the golden frames (`protocol/golden.rs`) pin the bytes.

use crate::config::{config_params, Config, ParamValue, PlannerKind, StageBudgets, Weight};
use fixed_point::{BinaryAngle, Meters};
use serde::{Deserialize, Serialize};

/// Per-stage work budgets on the wire: [`StageBudgets`] itself, five `u32`s in its field order.
pub type BudgetsMsg = StageBudgets;

/// Generates [`ConfigMsg`] and its conversions from the rows of the parameter table: each field's
/// name and type (the rest of the row is not on the wire).
macro_rules! define_config_msg {
    ($($field:ident : $ty:ty => $rest:tt)*) => {
        /// The controller's whole configuration (mirrors [`Config`] field by field, in its order).
        /// Metres and weights as Q16.16 bits, angles as binary angles, times in microseconds.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub struct ConfigMsg {
            $(#[doc = concat!("[`Config::", stringify!($field), "`].")] pub $field: <$ty as ParamValue>::Wire,)*
        }

        impl ConfigMsg {
            /// The fields' names ([`Config`]'s), in wire order: [`super::ErrorCode::ConfigInvalid`] names a
            /// field by its index here.
            pub const FIELDS: [&'static str; [$(stringify!($field)),*].len()] = [$(stringify!($field)),*];

            /// The wire form of `c` (lossless).
            pub fn from_config(c: &Config) -> Self {
                Self { $($field: ParamValue::to_wire(c.$field),)* }
            }

            /// The core's configuration (lossless).
            pub fn config(&self) -> Config {
                Config { $($field: <$ty as ParamValue>::from_wire(self.$field),)* }
            }
        }
    };
}

config_params!(define_config_msg);

impl ConfigMsg {
    /// The index of the field called `name` in [`ConfigMsg::FIELDS`].
    pub fn field_index(name: &str) -> Option<u8> {
        Self::FIELDS.iter().position(|&f| f == name).map(|i| i as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_configuration_crosses_losslessly() {
        let c = Config::DEFAULT;
        assert_eq!(ConfigMsg::from_config(&c).config(), c);
        let mut c2 = Config {
            planner: PlannerKind::Nearest,
            origin_x_m: Config::mm(-12_345),
            camera_fov: BinaryAngle::from_degrees(60),
            w_nonmap_per_point: Config::weight_milli(-2_500),
            look_around_here: true,
            scan_matching: true,
            ..Config::DEFAULT
        };
        c2.budgets.plan_ops = 1;
        assert_eq!(ConfigMsg::from_config(&c2).config(), c2);
    }
}
