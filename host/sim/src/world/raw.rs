//! The file format as serde sees it: every table and key of a world file, with its span.

use serde::Deserialize;
use toml::Spanned;

/// A point or a size, `[x, y]`: exactly two numbers (serde's `[f64; 2]` would ignore extra
/// elements of a TOML array).
#[derive(Clone, Copy)]
pub(super) struct Xy(pub(super) [f64; 2]);

impl<'de> Deserialize<'de> for Xy {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<f64>::deserialize(d)?;
        match v[..] {
            [x, y] => Ok(Xy([x, y])),
            _ => Err(serde::de::Error::custom(format!("expected two numbers [x, y], found {}", v.len()))),
        }
    }
}

impl std::ops::Deref for Xy {
    type Target = [f64; 2];
    fn deref(&self) -> &[f64; 2] {
        &self.0
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawWorld {
    pub(super) name: Option<String>,
    pub(super) time_limit_s: Spanned<f64>,
    pub(super) start: Spanned<RawStart>,
    #[serde(default)]
    pub(super) walls: Vec<Spanned<RawWall>>,
    #[serde(default)]
    pub(super) obstacles: Vec<Spanned<RawObstacle>>,
    #[serde(default)]
    pub(super) targets: Vec<Spanned<RawTarget>>,
    #[serde(default)]
    pub(super) people: Vec<Spanned<RawPerson>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawStart {
    pub(super) position: Xy,
    pub(super) yaw_rad: Option<f64>,
    pub(super) yaw_deg: Option<f64>,
    pub(super) jitter_m: Option<f64>,
    pub(super) jitter_yaw_rad: Option<f64>,
    pub(super) jitter_yaw_deg: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawWall {
    pub(super) points: Vec<Xy>,
    #[serde(default)]
    pub(super) closed: bool,
    pub(super) material: Option<Spanned<String>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum RawKind {
    Furniture,
    Clutter,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRect {
    pub(super) center: Xy,
    pub(super) size: Xy,
    pub(super) yaw_rad: Option<f64>,
    pub(super) yaw_deg: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCircle {
    pub(super) center: Xy,
    pub(super) radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawObstacle {
    pub(super) kind: RawKind,
    pub(super) label: Option<String>,
    pub(super) material: Option<Spanned<String>>,
    pub(super) rect: Option<Spanned<RawRect>>,
    pub(super) circle: Option<Spanned<RawCircle>>,
    pub(super) polygon: Option<Spanned<Vec<Xy>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTarget {
    pub(super) name: Option<String>,
    pub(super) rect: Option<Spanned<RawRect>>,
    pub(super) circle: Option<Spanned<RawCircle>>,
    pub(super) polygon: Option<Spanned<Vec<Xy>>>,
    pub(super) candidates: Option<Spanned<Vec<Xy>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPerson {
    pub(super) path: Vec<Xy>,
    pub(super) speed_mps: f64,
    pub(super) radius_m: Option<f64>,
}
