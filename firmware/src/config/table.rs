//! What the parameter table ([`super::params`]) is made into: the generator of [`Config`], its
//! defaults and checks and [`PARAMS`]; the description of one parameter ([`ParamInfo`]); how a
//! field's type crosses the wire and is handed to a host as a number ([`ParamValue`]).

use super::{Config, ConfigError, PlannerKind, StageBudgets};
use fixed_point::{BinaryAngle, Meters};

/// How people write a parameter's value (`lives --set`, `lives params`), and what
/// [`ParamInfo::get`] hands out for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// A [`PlannerKind`]: its index in [`PlannerKind::ALL`].
    Planner,
    /// Metres, as decimals; a [`Meters`]: its Q16.16 bits.
    Metres,
    /// A utility weight, as decimals; a [`super::Weight`]: its Q16.16 bits.
    Weight,
    /// Seconds, as decimals; a time in microseconds.
    Seconds,
    /// Degrees, as decimals; a [`BinaryAngle`]: its bits.
    Degrees,
    /// A whole number.
    Count,
    /// `true` or `false`: 1 or 0.
    Flag,
    /// The [`StageBudgets`] (no single number).
    Budgets,
}

impl Unit {
    /// The unit as `lives params` prints it.
    pub const fn symbol(self) -> &'static str {
        match self {
            Unit::Planner => "planner",
            Unit::Metres => "m",
            Unit::Weight => "utility",
            Unit::Seconds => "s",
            Unit::Degrees => "°",
            Unit::Count => "count",
            Unit::Flag => "bool",
            Unit::Budgets => "work units",
        }
    }
}

/// One row of the parameter table, for a host to list, set and check generically.
#[derive(Clone, Copy, Debug)]
pub struct ParamInfo {
    /// The field of [`Config`] (and of `ConfigMsg`, at this row's index in [`super::PARAMS`]).
    pub field: &'static str,
    /// How people write its value.
    pub unit: Unit,
    /// One line saying what it does.
    pub summary: &'static str,
    /// The range [`Config::validate`] holds it to, as its error says (`None`: any value of its type).
    pub allowed: Option<&'static str>,
    /// The name `lives --set` knows it by (`None`: not settable there).
    pub set_name: Option<&'static str>,
    /// Its type on the wire (the wire column of `docs/params.md`).
    pub wire: &'static str,
    /// The value in `config` as a number (see [`Unit`]); `None` for the budgets.
    pub get: fn(&Config) -> Option<i64>,
    /// Sets it from a number (see [`Unit`]); `false`, and nothing changed, when its type cannot
    /// hold `raw`.
    pub set: fn(&mut Config, i64) -> bool,
    /// The least and largest number its type holds.
    pub raw_range: (i64, i64),
}

/// A type a parameter may have: how it crosses the wire, and the number [`ParamInfo`] gives it as.
pub trait ParamValue: Copy + Sized {
    /// Its form in `ConfigMsg` (postcard-encoded as such).
    type Wire;
    /// Its wire type, as `docs/params.md` writes it.
    const WIRE: &'static str;
    /// The least and largest number [`ParamValue::to_raw`] gives (none by default).
    const RAW_RANGE: (i64, i64) = (0, 0);
    /// The wire form (lossless).
    fn to_wire(self) -> Self::Wire;
    /// Back from the wire form (lossless).
    fn from_wire(w: Self::Wire) -> Self;
    /// As one number (`None`, the default: it is not one number).
    fn to_raw(self) -> Option<i64> {
        None
    }
    /// From one number (`None`: out of the type's range, or not one number).
    fn from_raw(_raw: i64) -> Option<Self> {
        None
    }
}

/// Types whose wire form is an integer, which is also the number [`ParamInfo`] hands out:
/// `type => wire type, its words, to the wire, from the wire`.
macro_rules! integer_values {
    ($($t:ty => $wire:ty, $text:literal, $to:expr, $from:expr;)*) => {$(
        impl ParamValue for $t {
            type Wire = $wire;
            const WIRE: &'static str = $text;
            const RAW_RANGE: (i64, i64) =
                (<$wire>::MIN as i64, if <$wire>::MAX as u128 > i64::MAX as u128 { i64::MAX } else { <$wire>::MAX as i64 });
            fn to_wire(self) -> $wire {
                ($to)(self)
            }
            fn from_wire(w: $wire) -> $t {
                ($from)(w)
            }
            fn to_raw(self) -> Option<i64> {
                i64::try_from(self.to_wire()).ok()
            }
            fn from_raw(raw: i64) -> Option<$t> {
                <$wire>::try_from(raw).ok().map(Self::from_wire)
            }
        }
    )*};
}

integer_values! {
    u8 => u8, "`u8`", |v| v, |w| w;
    u16 => u16, "`u16`", |v| v, |w| w;
    u64 => u64, "`u64`", |v| v, |w| w;
    // Metres and weights: their Q16.16 bits.
    Meters => i32, "Q16", Meters::to_bits, Meters::from_bits;
    BinaryAngle => i32, "angle", |v: BinaryAngle| v.0, BinaryAngle;
}

impl ParamValue for bool {
    type Wire = bool;
    const WIRE: &'static str = "`bool`";
    const RAW_RANGE: (i64, i64) = (0, 1);
    fn to_wire(self) -> bool {
        self
    }
    fn from_wire(w: bool) -> bool {
        w
    }
    fn to_raw(self) -> Option<i64> {
        Some(self as i64)
    }
    fn from_raw(raw: i64) -> Option<bool> {
        [false, true].get(usize::try_from(raw).ok()?).copied()
    }
}

impl ParamValue for PlannerKind {
    type Wire = PlannerKind;
    const WIRE: &'static str = "enum (`PlannerKind::ALL`'s order)";
    const RAW_RANGE: (i64, i64) = (0, PlannerKind::ALL.len() as i64 - 1);
    fn to_wire(self) -> PlannerKind {
        self
    }
    fn from_wire(w: PlannerKind) -> PlannerKind {
        w
    }
    fn to_raw(self) -> Option<i64> {
        PlannerKind::ALL.iter().position(|&k| k == self).map(|i| i as i64)
    }
    fn from_raw(raw: i64) -> Option<PlannerKind> {
        usize::try_from(raw).ok().and_then(|i| PlannerKind::ALL.get(i).copied())
    }
}

/// The budgets cross as they are (five `u32`s); they are not one number.
impl ParamValue for StageBudgets {
    type Wire = StageBudgets;
    const WIRE: &'static str = "5 × `u32`";
    fn to_wire(self) -> StageBudgets {
        self
    }
    fn from_wire(w: StageBudgets) -> StageBudgets {
        w
    }
}

/// `v` in (0, `max`].
pub(super) fn positive(v: Meters, max: Meters) -> bool {
    Meters::ZERO < v && v <= max
}

/// `v` in [`min`, `max`].
pub(super) fn within(v: Meters, min: Meters, max: Meters) -> bool {
    min <= v && v <= max
}

/// `Ok` if `ok`, else the error for `field`.
pub(super) fn check(ok: bool, field: &'static str, allowed: &'static str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError { field, allowed })
    }
}

/// `Some(x)`, or `None` without an `x`.
macro_rules! some {
    () => {
        None
    };
    ($x:expr) => {
        Some($x)
    };
}
pub(super) use some;

/// Reads the rows of [`super::params`] (their grammar is written here, once) and calls `$gen!`
/// with each row as `field: Type => { [docs] default, Unit, "summary", [check => "allowed"],
/// ["set name"] }`, so that a generator matches the parts it uses and passes over the rest.
macro_rules! config_rows {
    ($gen:ident; $(
        $(#[$doc:meta])*
        $field:ident : $ty:ty = $default:expr, $unit:ident, $summary:literal
        $(, check $ok:expr => $allowed:literal)?
        $(, set $set:literal)?;
    )*) => {
        $gen! { $($field: $ty => { [$(#[$doc])*] $default, $unit, $summary, [$($ok => $allowed)?], [$($set)?] })* }
    };
}
pub(crate) use config_rows;

/// Generates [`Config`], [`Config::DEFAULT`], [`Config::validate`] and [`PARAMS`] from the rows of
/// [`super::params`] (as [`config_rows`] gives them).
macro_rules! define_config {
    ($($field:ident : $ty:ty => {
        [$(#[$doc:meta])*] $default:expr, $unit:ident, $summary:literal, [$($ok:expr => $allowed:literal)?], [$($set:literal)?]
    })*) => {
        /// The controller's configuration. Distances in metres ([`Meters`], Q16.16), angles as
        /// [`BinaryAngle`], times in microseconds. Written once, in the table of
        /// `firmware/src/config/params.rs`.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct Config {
            $($(#[$doc])* pub $field: $ty,)*
        }

        impl Config {
            /// The defaults, as a `const` so a `static` can hold them.
            pub const DEFAULT: Config = Config { $($field: $default,)* };

            /// Checks every field against its range (written on each field) and returns the first
            /// one outside it, in wire order. Fields without a range take any value of their type:
            /// the planner, the flags, the counts and caps (`min_frontier_cells`,
            /// `nonmap_block_cap`, `nonmap_view_cap`), the times and the budgets.
            /// `Config::DEFAULT` passes.
            pub fn validate(&self) -> Result<(), ConfigError> {
                $($({
                    let ok: fn($ty, &Config) -> bool = $ok;
                    super::table::check(ok(self.$field, self), stringify!($field), $allowed)?;
                })?)*
                Ok(())
            }
        }

        /// Every parameter, in wire order (the rows of `firmware/src/config/params.rs`).
        pub const PARAMS: &[ParamInfo] = &[$(ParamInfo {
            field: stringify!($field),
            unit: Unit::$unit,
            summary: $summary,
            allowed: super::table::some!($($allowed)?),
            set_name: super::table::some!($($set)?),
            wire: <$ty as ParamValue>::WIRE,
            get: |c| ParamValue::to_raw(c.$field),
            set: |c, raw| match ParamValue::from_raw(raw) {
                Some(v) => {
                    c.$field = v;
                    true
                }
                None => false,
            },
            raw_range: <$ty as ParamValue>::RAW_RANGE,
        }),*];
    };
}
pub(super) use define_config;
