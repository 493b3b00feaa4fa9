//! `lives map`: prior maps in the ROS map_server format (`.yaml` + `.pgm`/`.png`; issue 32,
//! docs/map-files.md): write a world's true map, or check a map file.

use super::common::{load_world, say};
use clap::Subcommand;
use host::io::map_file::{export, PriorMap};
use host::sim::Scenario;
use std::path::PathBuf;
use std::process::ExitCode;

/// Prior maps in the ROS map_server format (a `.yaml` naming a `.pgm` or `.png` image;
/// docs/map-files.md).
#[derive(Subcommand)]
pub enum MapCmd {
    /// Write the true map of a world (its walls and static obstacles at 0.1 m; the floor reached
    /// from the start free, the rest unknown) as OUT.yaml and OUT.pgm beside it.
    Export {
        /// A built-in world (apartment, office, hallway), `random` (with --seed), or a world file (.toml).
        world: String,
        /// The map file to write (.yaml); the image goes beside it with the extension .pgm.
        out: PathBuf,
        /// easy or hard (built-in and random worlds).
        #[arg(long, default_value = "easy")]
        scenario: Scenario,
        /// The seed of `random` (which building it generates).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Read a map file and its image and print the map's size, resolution, origin and cells;
    /// check that it fits the controller's grid (51.2 m square at 0.1 m). Bad input exits with
    /// status 2 and an error naming the file.
    Check {
        /// The map_server map file (.yaml).
        file: PathBuf,
        /// The grid's lower-left corner X,Y in metres (default: the grid centred on the map's
        /// known cells, as a search centres it on a world).
        #[arg(long, value_name = "X,Y")]
        grid_origin: Option<String>,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
}

fn parse_xy(s: &str) -> Result<[f64; 2], String> {
    host::overrides::finite_numbers(s).ok_or_else(|| format!("--grid-origin {s}: expected two finite numbers X,Y in metres"))
}

pub fn run(cmd: MapCmd) -> Result<ExitCode, String> {
    match cmd {
        MapCmd::Export { world, out, scenario, seed } => {
            let (name, w, _) = load_world(&world, scenario, seed)?;
            let map = export::true_map(&w, &out.display().to_string());
            let pgm = export::write(
                &map,
                &out,
                &format!("lives map export: the true map of world {name} ({scenario}), {} m/cell", map.resolution_m),
            )?;
            let n = map.counts();
            say!(
                "wrote {} and {}: {} x {} cells at {} m, origin ({}, {}); {} occupied, {} free, {} unknown",
                out.display(),
                pgm.display(),
                map.width,
                map.height,
                map.resolution_m,
                map.origin[0],
                map.origin[1],
                n.occupied,
                n.free,
                n.unknown
            );
            Ok(ExitCode::SUCCESS)
        }
        MapCmd::Check { file, grid_origin, json } => {
            let map = PriorMap::load(&file).map_err(|e| e.to_string())?;
            let origin = match grid_origin {
                Some(s) => parse_xy(&s)?,
                None => map.centred_grid_origin(),
            };
            map.to_controller_grid(origin).map_err(|e| e.to_string())?;
            let n = map.counts();
            let side = firmware::capacity::GRID_CELLS as f64 / firmware::capacity::CELLS_PER_METER as f64;
            if json {
                let v = serde_json::json!({
                    "file": map.file,
                    "width": map.width,
                    "height": map.height,
                    "resolution_m": map.resolution_m,
                    "origin": map.origin,
                    "size_m": [map.width as f64 * map.resolution_m, map.height as f64 * map.resolution_m],
                    "known_bounds_m": map.known_bounds(),
                    "cells": n,
                    "grid_origin": origin,
                    "grid_size_m": side,
                });
                say!("{v}");
            } else {
                say!(
                    "{}: {} x {} cells at {} m ({:.1} x {:.1} m), origin ({}, {}){}; {} occupied, {} free, {} unknown; fits the controller's grid ({side:.1} m square from ({}, {}))",
                    map.file,
                    map.width,
                    map.height,
                    map.resolution_m,
                    map.width as f64 * map.resolution_m,
                    map.height as f64 * map.resolution_m,
                    map.origin[0],
                    map.origin[1],
                    if map.origin[2] == 0.0 { String::new() } else { format!(" turned {:.2}°", map.origin[2].sin().atan2(map.origin[2].cos()).to_degrees()) },
                    n.occupied,
                    n.free,
                    n.unknown,
                    origin[0],
                    origin[1]
                );
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}
